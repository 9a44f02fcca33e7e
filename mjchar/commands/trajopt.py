"""``mjchar trajopt``: CMA-ES trajectory optimisation of open-loop PD targets.

``mjchar trajopt MOTION.bvh -o OUTPUT`` tracks a clip; ``mjchar trajopt --task jump -o OUTPUT``
optimises a standing vertical jump. Both save a trajectory that ``mjchar run replay OUTPUT``
plays back.
"""

from __future__ import annotations

import argparse

from . import command_parser
from .argtypes import integer, non_negative, positive
from .samcon import (
    add_optimiser_arguments,
    add_output_argument,
    check_output,
    load_reference,
    set_given,
)

TASKS = ("track", "jump")


def register(sub: argparse._SubParsersAction) -> None:
    p = command_parser(
        sub, "trajopt",
        description="Optimise PD-target offsets at spline knots with CMA-ES over overlapping "
                    "windows (each generation simulated as one batch) and save the trajectory "
                    "for `mjchar run replay FILE`. Give a clip to track it, or --task jump.")
    p.add_argument("motion", nargs="?", metavar="MOTION.bvh",
                   help="clip to track (not with --task jump)")
    add_output_argument(p)
    p.add_argument("--task", choices=TASKS, default=None,
                   help="track (default with a motion) or jump (no motion)")
    p.add_argument("--model", metavar="FILE.xml", help="converted model (default: bundled)")
    p.add_argument("--duration", type=positive("duration"), metavar="S",
                   help="seconds to optimise (track: default the whole clip; jump: 2.2)")
    p.add_argument("--start", type=non_negative("start"), default=0.0, metavar="S",
                   help="clip time to start tracking from (default 0)")
    p.add_argument("--generations", type=integer("generations", 1), metavar="N",
                   help="CMA-ES generations per window (default 40; jump 60)")
    p.add_argument("--popsize", type=integer("popsize", 1), metavar="N",
                   help="CMA-ES population (default max(4 + 3 ln n, 2 x parallelism))")
    p.add_argument("--window", type=positive("window"), metavar="S",
                   help="seconds per optimisation window (default 0.5)")
    p.add_argument("--commit", type=positive("commit"), metavar="S",
                   help="seconds committed per window (default 0.2)")
    p.add_argument("--knot-dt", type=positive("knot dt"), metavar="S",
                   help="seconds between spline knots (default 0.1)")
    p.add_argument("--sigma", type=positive("sigma"), metavar="S",
                   help="initial CMA-ES step size in parameter units")
    p.add_argument("--clearance", type=positive("clearance"), default=0.10,
                   metavar="M", help="jump: required foot clearance in metres (default 0.10)")
    p.add_argument("--seed", type=integer("seed"), default=0, metavar="N")
    add_optimiser_arguments(p, "optimiser statistics")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    import json
    import sys

    from mjchar.bvh.errors import MjcharError
    from mjchar.controllers.sampling.executors import executor_from_args
    from mjchar.controllers.sampling.trajectory import replay
    from mjchar.controllers.sampling.trajopt import (
        JUMP_OPTIONS,
        TrajoptOptions,
        optimise_jump,
        track_clip,
    )

    task = args.task or ("track" if args.motion else None)
    if task is None:
        raise MjcharError("give a MOTION.bvh to track, or --task jump")
    if task == "jump" and args.motion:
        raise MjcharError("--task jump takes no motion file")
    if task == "track" and not args.motion:
        raise MjcharError("--task track needs a MOTION.bvh")
    check_output(args)
    ref = None
    if task == "track":
        _, ref = load_reference(args.motion, args.model, args.floor)
    else:
        from mjchar.controllers.core.builder import check_model_file

        check_model_file(args.model)
    o = TrajoptOptions(seed=args.seed, start=args.start)
    if task == "jump":
        o = TrajoptOptions(**dict(JUMP_OPTIONS, seed=args.seed))
    else:
        o.duration = args.duration
    set_given(o, args, (("generations", "generations"), ("popsize", "popsize"),
                        ("window", "window"), ("commit", "commit"), ("knot_dt", "knot_dt"),
                        ("sigma", "sigma0")))
    progress = not (args.quiet or args.json)
    ex = executor_from_args(args)
    try:
        if task == "jump":
            result = optimise_jump(model=args.model, duration=args.duration or 2.2, options=o,
                                   executor=ex, target_clearance=args.clearance,
                                   progress=progress)
        else:
            result = track_clip(ref, model=args.model, options=o, executor=ex,
                                source_motion=args.motion, progress=progress)
    finally:
        ex.close()
    result.trajectory.save(args.output)
    r = replay(result.trajectory, model=args.model,
               duration=result.trajectory.duration + (1.0 if task == "jump" else 0.0))
    if args.json:
        print(json.dumps({"output": args.output, "task": task,
                          "window_costs": result.window_costs,
                          "evaluations": result.evaluations, "wall_s": result.wall_s,
                          "replay": r.to_dict()}))
    else:
        print(f"CMA-ES {task}: {len(result.window_costs)} window(s), {result.evaluations} "
              f"rollouts in {result.wall_s:.1f} s", file=sys.stderr)
        print(f"wrote {args.output}")
        print(r.summary())
    return 0
