"""docs/plugins.md quotes the demo plugin; the quotes must match its files.

Each paragraph (run of non-blank lines) of a ```python``` block must appear,
line for line, in the plugin's component module or its tests; each line of
a ```toml``` block must appear in its pyproject.toml. Editing the plugin
without the guide (or the reverse) fails here.
"""

from pathlib import Path

import pytest

from doc_blocks import blocks

PLUGIN = Path(__file__).resolve().parents[2] / "tests" / "plugin_pkg"
SOURCES = [PLUGIN / "src" / "snakesim_demo_plugin" / "lowpass.py", PLUGIN / "tests" / "test_demo_lowpass.py"]


def _paragraphs(text: str) -> list[list[str]]:
    out, cur = [], []
    for line in text.splitlines():
        if line.strip():
            cur.append(line.rstrip())
        elif cur:
            out.append(cur)
            cur = []
    return out + ([cur] if cur else [])


def _contains(haystack: list[str], needle: list[str]) -> bool:
    n = len(needle)
    return any(haystack[i:i + n] == needle for i in range(len(haystack) - n + 1))


def test_python_quotes_match_the_plugin():
    sources = [[ln.rstrip() for ln in p.read_text().splitlines() if ln.strip()] for p in SOURCES]
    quoted = [b for b in blocks("plugins.md") if b.lang == "python"]
    assert quoted, "no python blocks in docs/plugins.md"
    for b in quoted:
        for para in _paragraphs(b.text):
            if not any(_contains(src, para) for src in sources):
                pytest.fail(f"docs/plugins.md:{b.line}: this quote is not in {', '.join(p.name for p in SOURCES)}:\n"
                            + "\n".join(para), pytrace=False)


def test_toml_quotes_match_the_plugin():
    lines = {ln.strip() for ln in (PLUGIN / "pyproject.toml").read_text().splitlines()}
    for b in blocks("plugins.md"):
        if b.lang == "toml":
            missing = [ln for ln in b.text.splitlines() if ln.strip() and ln.strip() not in lines]
            assert not missing, f"docs/plugins.md:{b.line}: not in pyproject.toml: {missing}"
