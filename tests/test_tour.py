"""The README's tour takes the times it states: each line's CPU seconds on the reference
machine (``python -m mjchar.perf.tour``: CPU time scaled by the bare step rate measured around
the line) within 25 % of its comment, and the whole tour within 25 % of its heading."""

from __future__ import annotations

import re

import pytest
from markdown_blocks import ROOT

from mjchar.perf.tour import measure, tour_lines

pytestmark = pytest.mark.claims

README = ROOT / "README.md"


def _stated() -> tuple[float, list[tuple[str, float]]]:
    """The heading's seconds and ``(line, stated seconds)`` of every tour line."""
    text = README.read_text()
    heading = float(re.search(r"^## A tour in (\d+) seconds", text, re.M).group(1))
    block = re.search(r"^## A tour.*?```bash\n(.*?)```", text, re.S | re.M).group(1)
    stated = [float(re.search(r"#\s*(\d+(?:\.\d+)?) s\b", line).group(1))
              for line in block.splitlines() if line.strip()]
    lines = tour_lines(README)
    assert len(lines) == len(stated), "every tour line states its time"
    return heading, list(zip(lines, stated, strict=True))


def test_the_tour_takes_the_times_it_states(tmp_path):
    heading, lines = _stated()
    rows = [(line, stated, measure(line, tmp_path)) for line, stated in lines]
    failed = [f"{line}: {r['error']}" for line, _, r in rows if r["status"]]
    assert not failed, failed
    table = "\n".join(f"{r['reference_cpu_s']:6.2f} s (states {stated:g} s, load "
                      f"{r['load']:.1f})  {line}" for line, stated, r in rows)
    off = [line for line, stated, r in rows if abs(r["reference_cpu_s"] - stated) > 0.25 * stated]
    assert not off, f"off by more than 25 %: {off}\n{table}"
    total = sum(r["reference_cpu_s"] for _, _, r in rows)
    assert abs(total - heading) <= 0.25 * heading, f"the tour takes {total:.1f} s\n{table}"
