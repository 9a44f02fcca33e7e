"""BVH parsing and forward kinematics: mjchar's ``bvh`` against the ``bvhio`` package (the
table of docs/bvh.md; the bench's ``bvh`` part is :func:`bvh_parse_speed`).

    python -m mjchar.perf.bvh                  # measure and print
    python -m mjchar.perf.bvh --quick --write  # shorter budgets; update docs/bvh.md

Same files, same run: the shared clips in ``../shared/data/bvh`` (when present) and a long
CMU-style file (:func:`long_cmu_style_motion`). Every figure is the best of repeated runs on
the thread CPU clock (``thread_s`` of :func:`mjchar.perf.timing.timed`): on a machine shared
with other jobs, wall-clock minima are skewed by preemption (a 13 ms call is rarely left alone,
a 1 ms call often is), CPU time is not; on an idle machine the two agree. Ours and bvhio's take
turns (one bvhio call, then several of ours, per round) with garbage collection off.

What is timed:
  parse  ``bvh.load(path)`` -> Motion (channels parsed, Euler angles turned into quaternions)
         vs ``bvhio.readAsBvh(path)`` (its lowest-level reader: per-joint keyframes as
         quaternion poses); ``bvh.read_channels`` alone and ``bvhio.readAsHierarchy`` (the
         world-space joint tree bvhio needs for FK, once) are reported as well.
  FK     ``bvh.forward_kinematics(motion)`` (all frames, all joints)
         vs bvhio: ``hierarchy.loadPose(frame)`` then ``joint.PositionWorld`` for every joint
         and frame (the hierarchy loaded beforehand, not timed).
The two FK results are compared (bvhio computes in float32 via PyGLM).
"""

from __future__ import annotations

import math
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from mjchar import bvh

from .errors import PerfError, PerfUnavailable, positive_int
from .report import SHARED_BVH, entry_parser, machine_line, publish
from .timing import rounds, timed

__all__ = ["SHARED_CLIPS", "bvh_parse_speed", "long_cmu_style_motion", "bvhio_fk",
           "compare_file", "table", "main"]

#: the shared clips measured when present
SHARED_CLIPS = ("walk60.bvh", "idle.bvh", "walk_forward.bvh", "walk_and_turn_right.bvh")
CLOCK = "thread_s"


def _bvhio():
    try:
        import bvhio
    except ImportError:
        raise PerfUnavailable("bvhio is not installed (pip install 'mjchar[bench]')") from None
    return bvhio


def _bvhio_version() -> str | None:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("bvhio")
    except PackageNotFoundError:
        return None


def _paired_best(ours, theirs, budget: float, min_rounds: int = 3,
                 inner: int = 3) -> tuple[float, float]:
    """Best thread-CPU seconds of ``ours()`` and ``theirs()``, taking turns (one ``theirs``,
    then ``inner`` ``ours`` per round), at least ``min_rounds`` rounds and about ``budget`` s."""
    runs = rounds({"theirs": theirs, "ours": ours}, repeats=min_rounds, budget_s=budget,
                  max_rounds=300, calls={"ours": inner}, gc_off=True)
    return runs["ours"].best(CLOCK).thread_s, runs["theirs"].best(CLOCK).thread_s


def bvh_parse_speed(paths: Sequence[str | Path], *, budget: float = 1.0) -> dict:
    """Parse time of ``bvh.load`` (channels to quaternion ``Motion``) against
    ``bvhio.readAsBvh`` (bvhio's lowest-level reader) on each file, best of alternating rounds
    within about ``budget`` s per file, thread CPU time.

    Returns:
        ``{"bvhio_version", "budget_s", "files": [{"file", "frames", "joints", "bvh_load_ms",
        "bvhio_ms", "speedup"}]}`` (speedup = bvhio time / bvh time).
    Raises:
        PerfUnavailable: ``bvhio`` is not installed (``pip install 'mjchar[bench]'``).
    """
    bvhio = _bvhio()
    if not (math.isfinite(budget) and budget > 0):
        raise PerfError(f"budget must be positive seconds, got {budget}")
    rows = []
    for p in paths:
        p = Path(p)
        motion = bvh.load(p)
        ours, theirs = _paired_best(lambda p=p: bvh.load(p),
                                    lambda p=p: bvhio.readAsBvh(str(p)), budget)
        rows.append({"file": p.name, "frames": int(motion.n_frames),
                     "joints": int(motion.skeleton.n_joints), "bvh_load_ms": ours * 1e3,
                     "bvhio_ms": theirs * 1e3, "speedup": theirs / ours})
    return {"bvhio_version": _bvhio_version(), "budget_s": float(budget), "files": rows}


def long_cmu_style_motion(n_frames: int = 10_000) -> bvh.Motion:
    """A long CMU-style motion: the bundled walk as a CMU exporter writes it (CMU joint names,
    zero-length ``LHipJoint``/``RHipJoint`` helpers, ``Zrotation Yrotation Xrotation`` on every
    joint, inches, Y-up; the rig zoo's recipe), its frames repeated to ``n_frames``."""
    from mjchar.bvh.bundled.assets import motion_path
    from mjchar.bvh.bundled.zoo import CONVENTIONS, all_channels, insert_zero_length_joint, rename
    from mjchar.bvh.rigs.units import transform_motion

    n_frames = positive_int(n_frames, "n_frames")
    m = rename(bvh.load(motion_path("walk")), CONVENTIONS["cmu"])
    for side in ("Left", "Right"):
        m = insert_zero_length_joint(m, f"{side}UpLeg", f"{side[0]}HipJoint")
    m = all_channels(transform_motion(m, scale=1.0 / 0.0254), "ZYX")
    return m[np.arange(n_frames) % m.n_frames]


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


def compare_file(path: Path, label: str, quick: bool, log=print) -> dict:
    """One row of the table: parse and FK times of ours and bvhio's on ``path`` (s)."""
    bvhio = _bvhio()
    log(f"[bvh] {label}: parsing ...")
    budget = 0.3 if quick else 1.5
    motion = bvh.load(path)
    row = {"file": label, "frames": motion.n_frames, "joints": motion.skeleton.n_joints,
           "channels": motion.skeleton.n_channels}
    big = motion.n_frames > 2000
    row["ours_parse"], row["bvhio_parse"] = _paired_best(
        lambda: bvh.load(path), lambda: bvhio.readAsBvh(path), budget=budget,
        min_rounds=2 if big else 10, inner=5)
    row["ours_channels"] = rounds({"channels": lambda: bvh.read_channels(path)}, repeats=5,
                                  budget_s=budget / 3, max_rounds=500,
                                  gc_off=True)["channels"].best(CLOCK).thread_s
    log(f"[bvh] {label}: bvhio hierarchy ...")
    hierarchy, t = timed(bvhio.readAsHierarchy, str(path))
    row["bvhio_hierarchy"] = t.thread_s
    log(f"[bvh] {label}: forward kinematics ...")
    result: dict = {}

    def run_bvhio_fk() -> None:
        result["names"], result["positions"] = bvhio_fk(hierarchy, motion.n_frames)

    row["ours_fk"], row["bvhio_fk"] = _paired_best(
        lambda: bvh.forward_kinematics(motion), run_bvhio_fk, budget=budget,
        min_rounds=1 if big else 5, inner=5)
    names, theirs = result["names"], result["positions"]
    ours = bvh.forward_kinematics(motion).positions[:, [motion.skeleton.index(n) for n in names]]
    extent = float(np.ptp(ours.reshape(-1, 3), axis=0).max())
    row["fk_diff"] = float(np.abs(ours - theirs).max()) / max(extent, 1e-12)
    return row


def _ms(s: float) -> str:
    return f"{s * 1e3:.2f}" if s < 10 else f"{s * 1e3:.0f}"


def table(rows: list[dict]) -> str:
    """The Markdown table and summary of docs/bvh.md."""
    head = ("| file | frames x joints (channels) | bvh.read_channels ms | bvh.load ms | "
            "bvhio.readAsBvh ms | parse speed-up | bvhio.readAsHierarchy ms | bvh FK ms | "
            "bvhio FK ms | FK speed-up | FK max diff / extent |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for r in rows:
        lines.append(
            f"| {r['file']} | {r['frames']} x {r['joints']} ({r['channels']}) | "
            f"{_ms(r['ours_channels'])} | {_ms(r['ours_parse'])} | {_ms(r['bvhio_parse'])} | "
            f"**{r['bvhio_parse'] / r['ours_parse']:.1f}x** | {_ms(r['bvhio_hierarchy'])} | "
            f"{_ms(r['ours_fk'])} | {_ms(r['bvhio_fk'])} | "
            f"**{r['bvhio_fk'] / r['ours_fk']:.0f}x** | {r['fk_diff']:.1e} |")
    parse = [r["bvhio_parse"] / r["ours_parse"] for r in rows]
    fk = [r["bvhio_fk"] / r["ours_fk"] for r in rows]
    small = [r["bvhio_parse"] / r["ours_parse"] for r in rows if r["frames"] <= 1000]
    summary = (f"Parse speed-up over bvhio.readAsBvh: {min(parse):.1f}x to {max(parse):.1f}x"
               + (f" (shared clips: median {np.median(small):.1f}x)" if small else "")
               + f"; FK speed-up {min(fk):.0f}x to {max(fk):.0f}x.")
    return (f"{chr(10).join(lines)}\n\n{summary}\n\nMeasured with `python -m mjchar.perf.bvh` "
            f"({machine_line(numpy=np.__version__, bvhio=_bvhio_version() or '?')}). Each "
            f"figure is the best CPU time of this thread (`time.thread_time`) of repeated runs, "
            f"ours and bvhio's measured in alternating rounds so that both see the same machine "
            f"load; bvhio.readAsHierarchy once. Speed-up = bvhio time / bvh time.")


def main(argv: list[str] | None = None) -> int:
    ap = entry_parser("bvh", __doc__)
    ap.add_argument("--frames", type=int, default=10_000, help="frames of the long CMU-style file")
    ap.add_argument("--quick", action="store_true", help="shorter timing budgets")
    ap.add_argument("--write", action="store_true", help="update docs/bvh.md")
    args = ap.parse_args(argv)
    try:
        _bvhio()
    except PerfUnavailable as e:
        print(f"error: {e}", file=sys.stderr)
        return 1

    def log(msg: str) -> None:
        print(msg, file=sys.stderr, flush=True)

    rows = []
    for name in SHARED_CLIPS:
        path = SHARED_BVH / name
        if path.is_file():
            rows.append(compare_file(path, name, args.quick, log))
        else:
            log(f"[bvh] {path} not found: skipped (no ../shared/data here)")
    with tempfile.TemporaryDirectory() as tmp:
        big = Path(tmp) / f"cmu_style_{args.frames}.bvh"
        log(f"[bvh] writing {big.name} ...")
        bvh.save(long_cmu_style_motion(args.frames), big)
        rows.append(compare_file(big, f"CMU-style, bundled walk repeated "
                                      f"({big.stat().st_size / 1e6:.1f} MB)", args.quick, log))
    text = table(rows)
    publish(text, "bvh.md", "bvh", args.write, said="[bvh] table written to")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
