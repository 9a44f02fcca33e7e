"""``mjchar bench``: run the controller x scenario matrix, the performance section, and write the
table, ``results.json``, plots (and videos); exit status 1 when an expected survivor fell."""

from __future__ import annotations

import argparse

from . import command_parser
from .argtypes import integer


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``bench`` subcommand to ``mjchar``'s subparsers (rows and scenarios from the
    controller registry)."""
    from mjchar.controllers.core.scenarios import registry as scenarios

    from ..bench.matrix import bench_specs, matrix

    controllers = tuple(matrix())
    p = command_parser(
        sub, "bench",
        description="Run the controllers (rows) in the scenarios that make sense for them, print "
                    "a table (survival, push survival per direction, distance, speed, tracking "
                    "error, root force, step cost over mj_step) and write results.json, "
                    "table.md and PNG plots into --out. Exit status 1 when a controller "
                    "expected to stand or walk fell (see docs/bench.md). Run times are for "
                    f"{REFERENCE} with nothing else running: --quick {QUICK_TIME}, the full "
                    f"run {FULL_TIME}.")
    p.add_argument("--quick", action="store_true",
                   help=f"the same rows, cheaper: short durations, push curves measured up to "
                        f"their first rate below 90 %%, 2 seeds, quick performance runs "
                        f"({QUICK_TIME} on {REFERENCE}; without it {FULL_TIME})")
    p.add_argument("--jobs", type=integer("jobs", minimum=1), metavar="N",
                   help="worker processes running the cells (default: one per core); the "
                        "results do not depend on it")
    p.add_argument("--controllers", nargs="+", choices=controllers, metavar="C",
                   help="controllers to run (default all): " + ", ".join(controllers))
    p.add_argument("--scenarios", nargs="+", choices=scenarios.names(), metavar="S",
                   help="scenarios to run (default: each controller's bench scenarios): "
                        + ", ".join(scenarios.names()))
    p.add_argument("--out", default="bench_out", metavar="DIR",
                   help="output folder (default bench_out)")
    p.add_argument("--seeds", type=integer("seeds", minimum=1), metavar="N",
                   help="seeds 0..N-1 for the seeded scenarios (default 3, --quick 2)")
    p.add_argument("--videos", action="store_true",
                   help="one MP4 per controller and scenario (first run) and a PNG still of "
                        "each, plus still.png (needs the video extra; MUJOCO_GL=egl is set)")
    p.add_argument("--fps", type=float, default=30.0, help="video frame rate (default 30)")
    p.add_argument("--no-perf", action="store_true", help="skip the performance section")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
    p.add_argument("--trajectories", metavar="DIR",
                   help="folder with saved trajectories samcon*.npz / cmaes*.npz for the replay "
                        "rows (default assets/trajectories)")
    for spec in bench_specs().values():
        if spec.kind == "replay":
            p.add_argument(f"--{_trajectory_option(spec.name)}", metavar="FILE.npz",
                           dest=_trajectory_dest(spec.name),
                           help=f"saved trajectory for the {spec.name} row ({spec.label})")
    p.add_argument("--skeletons", action="store_true",
                   help="add the skeletons section: static balance, pushes, SIMBICON, IPM, "
                        "hand-of-god and SAMCON on every rig of the zoo (mjchar.bvh.bundled.zoo: "
                        "the shared walks on CMU, Mixamo, LAFAN1, Unreal, game-studio, SMPL, "
                        "Blender and Xsens conventions, and the bundled humanoid at 1.5 m / 50 kg "
                        "and 1.95 m / 100 kg); rigs and models are written to OUT/skeletons")
    p.add_argument("--skeletons-only", action="store_true",
                   help="run the skeletons section alone (no matrix, performance or gait)")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.set_defaults(func=main)


#: the machine the stated run times are for (mjchar.bench.config.REFERENCE_STEPS_PER_S)
REFERENCE = "a 2-core machine where one core does 30,000 bare mj_step/s of the bundled humanoid"
#: what --quick and the full run take there (measured: docs/bench.md)
QUICK_TIME = "about 5 minutes"
FULL_TIME = "about 35 minutes (estimated)"


def _trajectory_option(name: str) -> str:
    """``samcon_replay`` -> ``samcon-trajectory`` (the option naming a replay row's file)."""
    return name.split("_")[0] + "-trajectory"


def _trajectory_dest(name: str) -> str:
    return _trajectory_option(name).replace("-", "_")


def main(args: argparse.Namespace) -> int:
    """Run the bench; print the table and where the outputs are; return the exit status."""
    import math
    import os
    import sys
    from dataclasses import replace
    from pathlib import Path

    if args.videos:  # the OpenGL backend is chosen when MuJoCo is first imported
        os.environ.setdefault("MUJOCO_GL", "egl")

    from .. import bench as B

    if not (math.isfinite(args.fps) and args.fps > 0):
        raise B.BenchError(f"--fps must be positive, got {args.fps}")
    config = B.quick_config(args.seeds) if args.quick else B.full_config(args.seeds)
    config = replace(config, fps=args.fps)
    trajectories = B.find_trajectories(args.trajectories)
    if args.trajectories and not Path(args.trajectories).is_dir():
        raise B.BenchError(f"--trajectories {args.trajectories}: no such folder")
    for name, spec in B.bench_specs().items():
        path = getattr(args, _trajectory_dest(name), None) if spec.kind == "replay" else None
        if path:
            if not Path(path).is_file():
                raise B.BenchError(f"trajectory file {path} not found")
            from mjchar.controllers.sampling.trajectory import load_trajectory

            load_trajectory(path)  # a file the user named must be readable: an error, not a row
            trajectories[name] = Path(path)
    skeletons = None
    if args.skeletons or args.skeletons_only:
        from ..bench.skeletons import SkeletonConfig

        skeletons = SkeletonConfig.quick() if args.quick else SkeletonConfig()
    if args.skeletons_only and (args.controllers or args.scenarios or args.videos):
        raise B.BenchError("--skeletons-only runs no matrix: --controllers, --scenarios and "
                           "--videos do not apply")
    doc = B.run_bench(config, controllers=args.controllers, scenarios=args.scenarios,
                      out_dir=args.out, videos=args.videos, performance=not args.no_perf,
                      plots=not args.no_plots, trajectories=trajectories,
                      progress=not args.quiet, command=["mjchar", *sys.argv[1:]],
                      skeletons=skeletons, matrix=not args.skeletons_only, jobs=args.jobs)
    if doc["skeletons"] is not None:
        from ..bench.skeletons import skeletons_markdown

        print(skeletons_markdown(doc["skeletons"]))
        print()
    if not args.skeletons_only:
        print(B.format_table(doc["table"]))
    if doc["performance"]:
        print()
        print(B.format_performance(doc["performance"]))
    print()
    for e in doc["expectations"]:
        if e["status"] != "skipped" or "not available" in e["detail"]:
            print(f"expect {e['controller']} / {e['scenario']} survives: "
                  f"{e['status'].upper()} ({e['detail']})")
    out = Path(args.out)
    print(f"\nwrote {out / 'results.json'}, {out / 'table.md'}"
          + "".join(f", {out / p}" for p in doc["plots"])
          + (f", {len(doc['videos'])} video(s) in {out / 'videos'}" if doc["videos"] else ""))
    slow = sorted(doc["timings"]["cells_cpu"].items(), key=lambda kv: -kv[1])[:3]
    print(f"wall time {doc['wall_s']:.0f} s (matrix {doc['timings']['matrix_s']:.0f} s"
          + (f", performance {doc['timings']['performance_s']:.0f} s"
             if "performance_s" in doc["timings"] else "")
          + "; costliest cells: " + ", ".join(f"{k} {v:.0f} CPU s" for k, v in slow) + ")")
    t = doc["timings"]
    n = t["normalised"]
    print(f"CPU time {t['cpu_s']:.0f} s on {t['jobs']} job(s); bare mj_step "
          f"{n['bare_steps_per_s']:,.0f} steps/s per core: on the reference machine "
          f"({n['reference_steps_per_s']:,} steps/s per core) wall {n['wall_s']:.0f} s, CPU / "
          f"{n['reference_cores']} cores {n['cpu_per_core_s']:.0f} s")
    status = B.exit_status(doc)
    if status:
        print("FAILED: a controller expected to survive fell (see above)", file=sys.stderr)
    return status
