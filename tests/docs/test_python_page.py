"""docs/python.md is executable: every ```python block runs as printed, in page order and in one
namespace (a block may use what an earlier one made), and at least one builds a simulation from
objects with no YAML and advances it in steps."""

from __future__ import annotations

import pytest

from doc_blocks import blocks

PAGE = "python.md"


def test_the_page_builds_from_objects_and_advances_in_steps():
    code = [b.text for b in blocks(PAGE) if b.lang == "python"]
    assert any("Builder(" in c and ".build()" in c and ("advance_to(" in c or ".step(" in c)
               and "load(" not in c and "yaml" not in c.lower() for c in code)


def test_every_python_block_runs_as_printed(capsys):
    namespace: dict = {"__name__": "python_page"}
    page = [b for b in blocks(PAGE) if b.lang == "python"]
    assert len(page) >= 5
    for b in page:
        try:
            exec(compile(b.text, f"docs/{PAGE}:{b.line}", "exec"), namespace)
        except Exception as e:       # noqa: BLE001 - the page's line, then the error
            pytest.fail(f"docs/{PAGE}: the python block at line {b.line} failed: {type(e).__name__}: {e}",
                        pytrace=True)
