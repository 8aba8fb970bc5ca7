"""Fenced code blocks of a Markdown page, in order, with their info strings."""

from __future__ import annotations

import re
import shlex
from dataclasses import dataclass
from pathlib import Path

DOCS = Path(__file__).resolve().parents[2] / "docs"

_FENCE = re.compile(r"^```([\w-]*)([^\n]*)\n(.*?)^```[ \t]*$", re.S | re.M)
_TITLE = re.compile(r'title="([^"]+)"')


@dataclass
class Block:
    lang: str
    title: str | None
    text: str
    line: int

    def commands(self) -> list[list[str]]:
        """The ``$ ...`` lines of a console block, split like a shell would."""
        return [shlex.split(ln[2:]) for ln in self.text.splitlines() if ln.startswith("$ ")]


def blocks(page: str) -> list[Block]:
    text = (DOCS / page).read_text()
    out = []
    for m in _FENCE.finditer(text):
        title = _TITLE.search(m.group(2))
        out.append(Block(m.group(1), title.group(1) if title else None, m.group(3),
                         text.count("\n", 0, m.start()) + 1))
    return out


def assembled_files(page: str) -> dict[str, str]:
    """The files a page prints: its ``title="FILE"`` blocks, a file printed in parts (several blocks with
    one title, in page order) joined by two blank lines, as top-level Python code is spaced."""
    parts: dict[str, list[str]] = {}
    for b in blocks(page):
        if b.title:
            parts.setdefault(b.title, []).append(b.text)
    return {title: "\n\n".join(texts) for title, texts in parts.items()}
