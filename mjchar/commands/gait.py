"""``mjchar gait SOURCE``: gait statistics of a walker's run or a BVH clip, side by side with
reference clips, and the joint-angle curves over the normalised gait cycle
(mjchar.bvh.gait.analysis)."""

from __future__ import annotations

import argparse

from . import command_parser
from .argtypes import integer, non_negative, number, positive


def register(sub: argparse._SubParsersAction) -> None:
    from mjchar.controllers import registry
    from mjchar.controllers.core.limits import MAX_DURATION_S

    walkers = registry.names("walker")
    p = command_parser(
        sub, "gait",
        description="Measure speed, cadence, step length and width, stance and double support, "
                    "trunk lean, pelvis rotation, knee and hip flexion, foot clearance, stance "
                    "slip and COM excursion of a simulated walk or a BVH clip (see "
                    "docs/gait.md), print them beside reference clips, and optionally plot the "
                    "joint-angle curves over the normalised gait cycle.")
    p.add_argument("source", metavar="SOURCE",
                   help=f"a walker ({', '.join(walkers)}) to run, or a BVH clip to analyse")
    p.add_argument("--reference", action="append", default=[], metavar="CLIP.bvh",
                   help="a clip to compare with (repeatable)")
    p.add_argument("--model", metavar="FILE.xml",
                   help="walkers: the converted model (default: the bundled humanoid)")
    p.add_argument("--duration", type=positive("duration", high=MAX_DURATION_S), metavar="T",
                   help="walkers: simulated seconds (default 20, at most 3600)")
    p.add_argument("--from", dest="start", type=non_negative("from"), metavar="S",
                   help="start of the analysed window in s (default: 3 for runs, 0 for clips)")
    p.add_argument("--speed", type=number("speed"), metavar="M/S",
                   help="walkers taking a speed: the commanded speed")
    p.add_argument("--gait", metavar="NAME", help="simbicon: gait parameter set")
    p.add_argument("--seed", type=integer("seed"), metavar="N",
                   help="walkers: start from a seeded perturbation of the standing pose, as "
                        "the terrain walks do (default: the standing pose itself)")
    p.add_argument("--plot", metavar="OUT.png",
                   help="write the cycle curves (knee, hip flexion, trunk lean, pelvis "
                        "rotation) as a PNG (needs matplotlib: the bench extra)")
    p.add_argument("--filmstrip", metavar="OUT.png",
                   help="write side views over one stride of every walk (the source, then each "
                        "reference) as a PNG (needs matplotlib and OpenGL: MUJOCO_GL=egl)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=main)


def _walker_stats(args, spec):
    from mjchar.bvh.errors import MjcharError
    from mjchar.bvh.gait.analysis import analyse
    from mjchar.bvh.reference.export import MotionRecorder
    from mjchar.controllers.core.builder import RunSpec, execute
    from mjchar.progress import Progress

    options = {}
    for name, value in (("speed", args.speed), ("gait", args.gait)):
        if value is None:
            continue
        if name not in spec.options:
            raise MjcharError(f"--{name} does not apply to {spec.name}")
        options[name] = value
    duration = 20.0 if args.duration is None else args.duration
    start = 3.0 if args.start is None else args.start
    if start >= duration:
        raise MjcharError(f"--from {start:g} must be before the end of the {duration:g} s run")
    # from the standing pose, as `mjchar run` and the bench walk; with --seed from the
    # walker's own seeded start
    recorder = MotionRecorder()
    run = RunSpec(spec.name, "walk", model=args.model, seed=args.seed, options=options,
                  scenario_options={"duration": duration}).build(
        frame_callback=recorder, progress=None if args.json else Progress())
    result = execute(run)
    character = run.character
    label = " ".join([spec.name] + ([options["gait"]] if "gait" in options else [])
                     + ([f"{options['speed']:g} m/s"] if "speed" in options else []))
    stats = analyse(character.model, recorder.times, recorder.qpos, start=start,
                    end=result.fall_time_s, info=character.info, label=label)
    return (stats, character.model, recorder.times, recorder.qpos), result


def main(args: argparse.Namespace) -> int:
    import json
    import os

    from mjchar.bvh.errors import MjcharError
    from mjchar.bvh.gait.analysis import table
    from mjchar.controllers import registry

    result = None
    from mjchar.bvh.io.files import check_output

    inputs = [args.source, args.model, *args.reference]
    for flag, value in (("--plot", args.plot), ("--filmstrip", args.filmstrip)):
        if value:
            check_output(value, inputs=inputs, flag=flag, suffixes=(".png",))
    # the reference clips first: a bad one is an error before any simulation
    for path in args.reference:
        if not os.path.isfile(path):
            what = "a folder, not a clip" if os.path.isdir(path) else "no such file"
            raise MjcharError(f"--reference {path}: {what}")
    references = [_clip(path) for path in args.reference]
    if args.source.lower().endswith(".bvh"):
        for flag, value in (("--model", args.model), ("--duration", args.duration),
                            ("--speed", args.speed), ("--gait", args.gait),
                            ("--seed", args.seed)):
            if value is not None:
                raise MjcharError(f"{flag} applies to walkers, not to a clip")
        if not os.path.isfile(args.source):
            raise MjcharError(f"{args.source}: no such file")
        walk = _clip(args.source, start=args.start or 0.0)
    elif args.source in registry.names("walker"):
        walk, result = _walker_stats(args, registry.get(args.source))
    else:
        raise MjcharError(f"SOURCE must be a walker ({', '.join(registry.names('walker'))}) or "
                          f"a .bvh clip, got {args.source!r}")
    walks = [walk, *references]
    stats, refs = walk[0], [w[0] for w in walks[1:]]
    everything = [stats, *refs]
    if args.plot:
        from ..gait_plot import plot_cycles

        plot_cycles(everything, args.plot)
    if args.filmstrip:
        from ..gait_plot import plot_filmstrip

        plot_filmstrip(walks, args.filmstrip)
    if args.json:
        out = {"source": stats.to_dict(), "references": [r.to_dict() for r in refs]}
        if result is not None:
            out["run"] = result.to_dict()
        for key in ("plot", "filmstrip"):
            if getattr(args, key):
                out[key] = getattr(args, key)
        print(json.dumps(out))
        return 0
    if result is not None and result.fell:
        print(f"note: {args.source} fell at {result.fall_time_s:.2f} s; analysed up to the fall")
    print(table(everything))
    for key in ("plot", "filmstrip"):
        if getattr(args, key):
            print(f"{key}: {getattr(args, key)}")
    return 0


def _clip(path: str, start: float = 0.0):
    """``(stats, model, times, qpos)`` of a BVH clip analysed from ``start`` s."""
    import os

    from mjchar.bvh.gait.analysis import analyse, clip_walk

    model, info, times, qpos = clip_walk(path)
    label = os.path.splitext(os.path.basename(path))[0]
    return analyse(model, times, qpos, start=start, info=info, label=label), model, times, qpos
