"""Benchmark: BVH parsing and forward kinematics, mjchar's ``bvh`` against the ``bvhio`` package.

Same files, same run, same machine; every figure is the best of several repeats (the minimum is
the least noisy estimate on a shared machine). Files: the shared clips in ../shared/data/bvh
(when present) and a generated 10,000-frame CMU-style file (31 joints, 96 channels).

Times are CPU time of the benchmarking thread (``time.thread_time``): on a machine shared with
other jobs, wall-clock minima are skewed by preemption (a 13 ms call is rarely left alone, a 1 ms
call often is), CPU time is not; on an idle machine the two agree.

What is timed:
  parse  bvh.load(path) -> Motion (channels parsed, Euler angles turned into quaternions)
         vs bvhio.readAsBvh(path) (its lowest-level reader: per-joint keyframes as quaternion
         poses). bvhio.readAsHierarchy (the world-space joint tree bvhio needs for FK) is
         reported as well.
  FK     bvh.forward_kinematics(motion) (all frames, all joints)
         vs bvhio: hierarchy.loadPose(frame) then joint.PositionWorld for every joint and frame
         (the hierarchy loaded beforehand, not timed).
The two FK results are compared (bvhio computes in float32 via PyGLM).

Usage: python3 benchmarks/bench_bvh.py [--frames 10000] [--no-docs] [--quick]
Prints a table and rewrites the table section of docs/bvh.md.
"""

from __future__ import annotations

import argparse
import gc
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

CLOCK = time.thread_time  # CPU time of this thread (see the module docstring)
ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from bvh_variants import SHARED_BVH, big_motion  # noqa: E402

from mjchar import bvh  # noqa: E402

DOCS = ROOT / "docs" / "bvh.md"
BEGIN, END = "<!-- bench:begin -->", "<!-- bench:end -->"
SHARED = ["walk60.bvh", "idle.bvh", "walk_forward.bvh", "walk_and_turn_right.bvh"]


def best_time(fn, min_repeats: int = 5, budget: float = 1.0, max_repeats: int = 500) -> float:
    """Best CPU time (s) of ``fn()`` over at least ``min_repeats`` runs and about ``budget``
    seconds (a single run when one call exceeds the budget); garbage collection is off while
    timing, as in :mod:`timeit`."""
    times: list[float] = []
    start = time.perf_counter()
    gc.collect()
    gc.disable()
    try:
        while len(times) < max_repeats:
            t0 = CLOCK()
            fn()
            times.append(CLOCK() - t0)
            spent = time.perf_counter() - start
            if times[0] > budget or (len(times) >= min_repeats and spent > budget):
                break
    finally:
        gc.enable()
    return min(times)


def paired_best(ours, theirs, budget: float, min_rounds: int = 3, inner: int = 5,
                max_rounds: int = 300) -> tuple[float, float]:
    """Best CPU times (s) of ``ours()`` and ``theirs()``, measured in alternating rounds (one
    ``theirs``, then ``inner`` ``ours``) so both see the same machine load; at least
    ``min_rounds`` rounds and about ``budget`` seconds. Garbage collection is off while timing."""
    ta: list[float] = []
    tb: list[float] = []
    start = time.perf_counter()
    gc.collect()
    gc.disable()
    try:
        for r in range(max_rounds):
            t0 = CLOCK()
            theirs()
            tb.append(CLOCK() - t0)
            for _ in range(inner):
                t0 = CLOCK()
                ours()
                ta.append(CLOCK() - t0)
            if r + 1 >= min_rounds and time.perf_counter() - start > budget:
                break
    finally:
        gc.enable()
    return min(ta), min(tb)


def bvhio_fk(hierarchy, n_frames: int) -> tuple[list[str], np.ndarray]:
    """World positions ``(F, J, 3)`` of every joint with bvhio, in its layout order."""
    layout = [j for j, _, _ in hierarchy.layout()]
    out = np.empty((n_frames, len(layout), 3))
    for f in range(n_frames):
        hierarchy.loadPose(f)
        for k, joint in enumerate(layout):
            p = joint.PositionWorld
            out[f, k] = (p.x, p.y, p.z)
    return [j.Name for j in layout], out


def bench_file(path: Path, label: str, quick: bool) -> dict:
    import bvhio

    print(f"[bench] {label}: parsing ...", flush=True)
    budget = 0.3 if quick else 1.5
    motion = bvh.load(path)
    row = {"file": label, "frames": motion.n_frames, "joints": motion.skeleton.n_joints,
           "channels": motion.skeleton.n_channels}
    big = motion.n_frames > 2000
    row["ours_parse"], row["bvhio_parse"] = paired_best(
        lambda: bvh.load(path), lambda: bvhio.readAsBvh(path), budget=budget,
        min_rounds=2 if big else 10)
    row["ours_channels"] = best_time(lambda: bvh.read_channels(path), budget=budget / 3)
    print(f"[bench] {label}: bvhio hierarchy ...", flush=True)
    t0 = CLOCK()
    hierarchy = bvhio.readAsHierarchy(str(path))
    row["bvhio_hierarchy"] = CLOCK() - t0
    print(f"[bench] {label}: forward kinematics ...", flush=True)
    result: dict = {}

    def run_bvhio_fk() -> None:
        result["names"], result["positions"] = bvhio_fk(hierarchy, motion.n_frames)

    row["ours_fk"], row["bvhio_fk"] = paired_best(
        lambda: bvh.forward_kinematics(motion), run_bvhio_fk, budget=budget,
        min_rounds=1 if big else 5)
    names, theirs = result["names"], result["positions"]
    ours = bvh.forward_kinematics(motion).positions[:, [motion.skeleton.index(n) for n in names]]
    extent = float(np.ptp(ours.reshape(-1, 3), axis=0).max())
    row["fk_diff"] = float(np.abs(ours - theirs).max()) / max(extent, 1e-12)
    return row


def fmt_ms(s: float) -> str:
    return f"{s * 1e3:.2f}" if s < 10 else f"{s * 1e3:.0f}"


def table(rows: list[dict]) -> str:
    head = ("| file | frames x joints (channels) | bvh.read_channels ms | bvh.load ms | "
            "bvhio.readAsBvh ms | parse speed-up | bvhio.readAsHierarchy ms | bvh FK ms | "
            "bvhio FK ms | FK speed-up | FK max diff / extent |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for r in rows:
        lines.append(
            f"| {r['file']} | {r['frames']} x {r['joints']} ({r['channels']}) | "
            f"{fmt_ms(r['ours_channels'])} | {fmt_ms(r['ours_parse'])} | "
            f"{fmt_ms(r['bvhio_parse'])} | "
            f"**{r['bvhio_parse'] / r['ours_parse']:.1f}x** | {fmt_ms(r['bvhio_hierarchy'])} | "
            f"{fmt_ms(r['ours_fk'])} | {fmt_ms(r['bvhio_fk'])} | "
            f"**{r['bvhio_fk'] / r['ours_fk']:.0f}x** | {r['fk_diff']:.1e} |")
    return "\n".join(lines)


def environment() -> str:
    from importlib.metadata import version

    import bvhio  # noqa: F401

    return (f"Python {platform.python_version()}, numpy {np.__version__}, bvhio "
            f"{version('bvhio')}, {platform.machine()} with {os.cpu_count()} cores (shared), "
            f"{time.strftime('%Y-%m-%d')}")


def update_docs(text: str) -> None:
    doc = DOCS.read_text() if DOCS.is_file() else f"# BVH\n\n{BEGIN}\n{END}\n"
    if BEGIN not in doc or END not in doc:
        doc += f"\n{BEGIN}\n{END}\n"
    before, rest = doc.split(BEGIN, 1)
    _, after = rest.split(END, 1)
    DOCS.write_text(f"{before}{BEGIN}\n{text}\n{END}{after}")
    print(f"[bench] table written to {DOCS.relative_to(ROOT)}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--frames", type=int, default=10_000, help="frames of the generated file")
    ap.add_argument("--no-docs", action="store_true", help="do not rewrite docs/bvh.md")
    ap.add_argument("--quick", action="store_true", help="shorter timing budgets")
    args = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in SHARED:
            path = SHARED_BVH / name
            if path.is_file():
                rows.append(bench_file(path, name, args.quick))
            else:
                print(f"[bench] {path} not found: skipped (no ../shared/data here)")
        big = Path(tmp) / f"generated_{args.frames}.bvh"
        print(f"[bench] writing {big.name} ...", flush=True)
        bvh.save(big_motion(args.frames), big)
        rows.append(bench_file(big, f"generated CMU-style ({big.stat().st_size / 1e6:.1f} MB)",
                               args.quick))
    out = table(rows)
    small = [r for r in rows if r["frames"] <= 1000]
    summary = (f"Parse speed-up over bvhio.readAsBvh: "
               f"{min(r['bvhio_parse'] / r['ours_parse'] for r in rows):.1f}x to "
               f"{max(r['bvhio_parse'] / r['ours_parse'] for r in rows):.1f}x"
               + (f" (shared clips: median "
                  f"{np.median([r['bvhio_parse'] / r['ours_parse'] for r in small]):.1f}x)"
                  if small else "")
               + f"; FK speed-up {min(r['bvhio_fk'] / r['ours_fk'] for r in rows):.0f}x to "
               f"{max(r['bvhio_fk'] / r['ours_fk'] for r in rows):.0f}x.")
    text = (f"{out}\n\n{summary}\n\nMeasured with `python3 benchmarks/bench_bvh.py` "
            f"({environment()}). Each figure is the best CPU time (`time.thread_time`) of repeated "
            f"runs, ours and bvhio's "
            f"measured in alternating rounds so that both see the same machine load; "
            f"bvhio.readAsHierarchy once. Speed-up = bvhio time / bvh time.")
    print()
    print(text)
    if not args.no_docs:
        update_docs(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
