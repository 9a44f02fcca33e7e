"""The fenced code blocks of the project's Markdown files, for the tests that run them."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

_FENCE = re.compile(r"^```(\w*)[^\n]*\n(.*?)^```\s*$", re.M | re.S)


@dataclass(frozen=True)
class Block:
    file: str  # relative to the project root
    line: int  # of the opening fence
    lang: str
    code: str
    section: str  # the heading above the block

    @property
    def where(self) -> str:
        return f"{self.file}:{self.line}"


def blocks(relpath: str) -> list[Block]:
    """Every fenced block of a Markdown file, with its language and the heading above it."""
    text = (ROOT / relpath).read_text()
    out = []
    for m in _FENCE.finditer(text):
        before = text[:m.start()]
        headings = re.findall(r"^#+ (.+)$", before, re.M)
        out.append(Block(relpath, before.count("\n") + 1, m.group(1).lower(), m.group(2),
                         headings[-1] if headings else ""))
    return out


def markdown_files() -> list[str]:
    """README.md and every page under docs/."""
    return ["README.md", *sorted(p.relative_to(ROOT).as_posix()
                                 for p in (ROOT / "docs").rglob("*.md"))]
