"""What each line of the README's tour costs: the times the README states.

    python -m mjchar.perf.tour            # every line of the tour, in a scratch folder
    python -m mjchar.perf.tour --json T.json

Each line runs as a user types it (a fresh ``mjchar`` process, start-up included). Its cost is
the process's CPU seconds (user + system), scaled to the reference machine of the bench
(:data:`~mjchar.bench.config.REFERENCE_STEPS_PER_S` bare ``mj_step``/s per core) by the bare
step rate measured on this machine just before and after the line: CPU time, not wall time, so
that other jobs on the machine change the figure little. On the reference machine a line
takes about its reference CPU seconds of wall time; the MPC spreads its CPU over the cores
(``wall`` ~ CPU / cores). Each line's figure is compared with the time its README comment
states (:func:`stated_seconds`): it holds within 25 % of it (of a range's ends).
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import shlex
import subprocess
import sys
import tempfile
from pathlib import Path

from .report import ROOT, write_json
from .timing import timed

#: how far a measured time may be from the README's and still hold (the README's promise)
TOLERANCE = 0.25


def _tour_block(readme: Path) -> list[str]:
    text = readme.read_text()
    m = re.search(r"^## A tour[^\n]*\n.*?```bash\n(.*?)```", text, re.S | re.M)
    if not m:
        raise SystemExit("README.md has no '## A tour' section with a bash block")
    return [line for line in m.group(1).splitlines()
            if line.strip() and not line.lstrip().startswith("#")]


def tour_lines(readme: Path = ROOT / "README.md") -> list[str]:
    """The commands of the README's tour block (comments dropped)."""
    return [re.sub(r"\s+#.*$", "", line).strip() for line in _tour_block(readme)]


def stated_seconds(line: str) -> tuple[float, float] | None:
    """``(low, high)`` seconds a tour line's comment states (``# 2-3 s: ...`` -> ``(2, 3)``,
    ``# 1 s: ...`` -> ``(1, 1)``), ``None`` without one."""
    m = re.search(r"#\s*(\d+(?:\.\d+)?)(?:\s*-\s*(\d+(?:\.\d+)?))?\s*s\b", line)
    if not m:
        return None
    low = float(m.group(1))
    return low, float(m.group(2)) if m.group(2) else low


def holds(seconds: float, stated: tuple[float, float] | None,
          tolerance: float = TOLERANCE) -> bool | None:
    """Whether ``seconds`` is within ``tolerance`` of the stated time or range (``None``: no
    time stated)."""
    if stated is None:
        return None
    low, high = stated
    return low * (1.0 - tolerance) <= seconds <= high * (1.0 + tolerance)


def bare_rate() -> float:
    """Bare ``mj_step`` per CPU second of the bundled humanoid standing (C loop)."""
    from mjchar.controllers.core import scenarios as S
    from mjchar.controllers.core.character import Character

    from .physics import raw_step_rate

    ch = Character()
    return float(raw_step_rate(ch.model, S.standing_pose(ch), steps=3000,
                               repeats=3)["c_loop_steps_per_cpu_s"])


def measure(line: str, folder: Path) -> dict:
    """One line's wall and CPU seconds, its exit status, and the bare rate around it."""
    from mjchar.bench.config import REFERENCE_STEPS_PER_S

    before = bare_rate()
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}"
                                 f"{os.environ.get('PATH', '')}"}
    proc, timing = timed(subprocess.run, shlex.split(line), cwd=folder, env=env,
                         capture_output=True, text=True)
    wall = timing.wall_s
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    after = bare_rate()
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    rate = (before + after) / 2
    return {"line": line, "status": proc.returncode, "wall_s": wall, "cpu_s": cpu,
            "bare_steps_per_cpu_s": rate, "load": os.getloadavg()[0],
            "reference_cpu_s": cpu * rate / REFERENCE_STEPS_PER_S,
            "error": proc.stderr.strip().splitlines()[-1] if proc.returncode else None}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m mjchar.perf.tour", description=__doc__)
    p.add_argument("--json", metavar="OUT.json", help="also write the rows as JSON")
    args = p.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for text in _tour_block(ROOT / "README.md"):
            line = re.sub(r"\s+#.*$", "", text).strip()
            row = measure(line, Path(tmp))
            row["stated_s"] = stated_seconds(text)
            row["holds"] = holds(row["reference_cpu_s"], row["stated_s"])
            rows.append(row)
            said = ("" if row["stated_s"] is None else
                    f"README {_range(row['stated_s'])}, "
                    f"{'holds' if row['holds'] else 'OFF by more than 25 %'}; ")
            print(f"{row['reference_cpu_s']:6.1f} s  ({said}here: {row['cpu_s']:.1f} CPU s, "
                  f"{row['wall_s']:.1f} s wall, load {row['load']:.1f})  {line}"
                  + (f"  FAILED: {row['error']}" if row["status"] else ""), flush=True)
    total = sum(r["reference_cpu_s"] for r in rows)
    off = [r for r in rows if r["holds"] is False]
    print(f"{total:6.1f} s  in all, on the reference machine; "
          f"{len(rows) - len(off)} of {len(rows)} lines within 25 % of the README's times")
    if args.json:
        write_json(args.json, rows)
    return 1 if any(r["status"] for r in rows) else 0


def _range(stated: tuple[float, float]) -> str:
    low, high = stated
    return f"{low:g} s" if low == high else f"{low:g}-{high:g} s"


if __name__ == "__main__":
    sys.exit(main())
