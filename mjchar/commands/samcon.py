"""``mjchar samcon MOTION.bvh -o OUTPUT``: reconstruct a clip with SAMCON and save the trajectory.

The saved file plays back with ``mjchar run replay OUTPUT`` (or
``mjchar.controllers.sampling.trajectory.replay(OUTPUT)``).
"""

from __future__ import annotations

import argparse
import math

from . import command_parser
from .argtypes import add_floor_argument, integer, non_negative, positive


def _weight(text: str) -> tuple[str, float]:
    from mjchar.controllers.sampling.tracking import CostWeights

    name, sep, value = text.partition("=")
    names = list(CostWeights.__dataclass_fields__)
    if not sep or name not in names:
        raise argparse.ArgumentTypeError(f"weight must be NAME=VALUE with NAME one of "
                                         f"{', '.join(names)}, got {text!r}")
    try:
        v = float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"weight {name} must be a number, got {value!r}") from None
    if not (math.isfinite(v) and v >= 0):
        raise argparse.ArgumentTypeError(f"weight {name} must be zero or positive, got {value!r}")
    return name, v


def add_executor_arguments(p: argparse.ArgumentParser) -> None:
    """The executor options (``--executor``, ``--threads``, ``--ray-address``, ...)."""
    from mjchar.controllers.sampling.executors import add_executor_arguments as add

    add(p)


def add_output_argument(p: argparse.ArgumentParser) -> None:
    """``-o/--output OUTPUT``: the trajectory file an optimiser's command writes."""
    p.add_argument("-o", "--output", required=True, metavar="OUTPUT",
                   help="trajectory file to write (.npz)")


def add_optimiser_arguments(p: argparse.ArgumentParser, statistics: str) -> None:
    """The options an optimiser's command ends with (``samcon``, ``trajopt``): ``--quiet``,
    ``--json`` (printing ``statistics`` and the replay's metrics), ``--floor`` and the
    executor's."""
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true",
                   help=f"print one JSON object ({statistics} and the replay's metrics)")
    add_floor_argument(p)
    add_executor_arguments(p)


def set_given(options, args: argparse.Namespace, names) -> None:
    """Set each ``(name, attr)`` of ``names``: ``options.attr`` to ``args.name`` where the
    command line gave it (not ``None``); the others keep the options' own values."""
    for name, attr in names:
        v = getattr(args, name)
        if v is not None:
            setattr(options, attr, v)


def load_reference(path: str, model, floor: str = "contact"):
    """``(character_model, ReferenceMotion)`` for a BVH clip on ``model`` (default: the bundled
    humanoid), placed on the floor per ``floor`` (see ``ReferenceMotion``); a clip the model
    cannot follow raises an ``MjcharError`` with the reason."""
    from mjchar import bvh
    from mjchar.bvh.reference.reference_motion import ReferenceMotion, ReferenceMotionError
    from mjchar.controllers.core.builder import check_model_file
    from mjchar.controllers.core.character import Character

    check_model_file(model)
    ch = Character(model)
    motion = bvh.load(path)
    try:
        ref = ReferenceMotion(ch.model, motion, info=ch.info, floor=floor)
    except ReferenceMotionError as e:
        reason = str(e).replace("CLIP", path)
        raise ReferenceMotionError(f"{path}: the model cannot follow this motion: {reason}") \
            from None
    return ch, ref


def check_output(args: argparse.Namespace) -> None:
    """Fail early (before a long optimisation) when ``-o`` cannot be written or would write
    over one of the inputs (the clip, the model)."""
    from mjchar.bvh.io.files import check_output as check

    check(args.output, inputs=[getattr(args, "motion", None), getattr(args, "model", None)],
          flag="-o")


def register(sub: argparse._SubParsersAction) -> None:
    p = command_parser(
        sub, "samcon",
        description="SAMCON (Liu et al. 2010/2015): sample PD-target offsets slice by slice, "
                    "simulate them in batches, keep the best states and save the lowest-cost "
                    "path as a trajectory file that `mjchar run replay FILE` plays back.")
    p.add_argument("motion", metavar="MOTION.bvh", help="the clip to reconstruct")
    add_output_argument(p)
    p.add_argument("--model", metavar="FILE.xml", help="converted model (default: bundled)")
    p.add_argument("--samples", type=integer("samples", 1), default=1000, metavar="N",
                   help="samples per slice (default 1000)")
    p.add_argument("--saved", type=integer("saved", 1), default=200, metavar="N",
                   help="saved states per slice (default 200)")
    p.add_argument("--seed", type=integer("seed"), default=0, metavar="N")
    p.add_argument("--duration", type=positive("duration"), metavar="S",
                   help="seconds of the clip to reconstruct (default: all)")
    p.add_argument("--start", type=non_negative("start"), default=0.0, metavar="S",
                   help="clip time to start from (default 0)")
    p.add_argument("--slice", type=positive("slice"), default=None, metavar="S",
                   help="slice length in seconds (default 0.1)")
    p.add_argument("--distribution", choices=("uniform", "gaussian"), default=None,
                   help="offset distribution (default uniform)")
    p.add_argument("--width-scale", type=non_negative("width scale"), default=None,
                   metavar="F", help="factor on the per-joint sampling widths")
    p.add_argument("--window", type=integer("window", 1), default=None, metavar="N",
                   help="sliding window of slices scored together (2015; default 2)")
    p.add_argument("--iterations", type=integer("iterations", 1), default=None,
                   metavar="N", help="passes over the clip (default 2)")
    p.add_argument("--adapt", action=argparse.BooleanOptionalAction, default=True,
                   help="CMA-style per-slice update of the sampling distribution between "
                        "passes (2015; default on, --no-adapt for the 2010 scheme)")
    p.add_argument("--weight", type=_weight, action="append", default=[], metavar="NAME=V",
                   help="cost weight override, repeatable (pose, root, end_effector, balance, "
                        "com, joints, velocity, com_horizon), e.g. --weight root=20 for sharp "
                        "turns")
    add_optimiser_arguments(p, "SAMCON statistics")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    import json
    import sys

    from mjchar.controllers.sampling.executors import executor_from_args
    from mjchar.controllers.sampling.samcon import RECONSTRUCTION_OPTIONS, Samcon, SamconOptions
    from mjchar.controllers.sampling.tracking import CostWeights
    from mjchar.controllers.sampling.trajectory import replay

    check_output(args)
    _, ref = load_reference(args.motion, args.model, args.floor)
    o = SamconOptions(**dict(RECONSTRUCTION_OPTIONS, samples=args.samples,
                             saved=min(args.saved, args.samples), seed=args.seed,
                             duration=args.duration, start=args.start, adapt=args.adapt,
                             weights=CostWeights(**dict(args.weight))))
    set_given(o, args, (("slice", "slice_dt"), ("distribution", "distribution"),
                        ("width_scale", "width_scale"), ("window", "window"),
                        ("iterations", "iterations")))
    ex = executor_from_args(args)
    try:
        with Samcon(ref, model=args.model, options=o, executor=ex,
                    source_motion=args.motion) as s:
            result = s.run(progress=not (args.quiet or args.json))
    finally:
        ex.close()
    result.trajectory.save(args.output)
    r = replay(result.trajectory, model=args.model)
    if args.json:
        out = {"output": args.output, "total_cost": result.total_cost,
               "samples_simulated": result.samples_simulated, "wall_s": result.wall_s,
               "samples_per_s": result.samples_per_s, "replay": r.to_dict()}
        print(json.dumps(out))
    else:
        print(f"SAMCON {args.motion}: {len(result.slice_costs)} slices, total cost "
              f"{result.total_cost:.2f}, {result.samples_simulated} samples in "
              f"{result.wall_s:.1f} s ({result.samples_per_s:.0f}/s)", file=sys.stderr)
        print(f"wrote {args.output}")
        print(r.summary())
    return 0
