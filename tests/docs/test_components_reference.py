"""docs/components.md is the generated component reference, never edited by hand.

The test regenerates it from the built-in registry (no third-party entry
points, so an installed plugin cannot change the expected text) and compares.
"""

import difflib
from pathlib import Path

from snakesim.framework.reference import component_reference, reference_markdown
from snakesim.framework.registry import build_registry

PAGE = Path(__file__).resolve().parents[2] / "docs" / "components.md"

REGENERATE = """docs/components.md is stale: a component, port, unit or parameter changed.
Regenerate it and commit the result:

    snakesim components --markdown > docs/components.md

(with no third-party snakesim plugins installed; otherwise their components are
listed too). Difference, committed -> generated:
"""


def test_components_md_is_current():
    expected = reference_markdown(component_reference(build_registry(load_entry_points=False)))
    actual = PAGE.read_text() if PAGE.exists() else ""
    if actual != expected:
        diff = "".join(difflib.unified_diff(actual.splitlines(True), expected.splitlines(True),
                                            "docs/components.md (committed)", "generated", n=1))
        raise AssertionError(REGENERATE + diff[:6000])
