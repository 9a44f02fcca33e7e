"""``mjchar run CONTROLLER``: run a controller in a scenario and report its metrics.

The command line is turned into a :class:`~mjchar.controllers.core.builder.RunSpec` and built by
the run builder, as the bench and the Python API build theirs: the same run gives the same
numbers from every entry point. Scenario flags come from the scenario registry.
"""

from __future__ import annotations

import argparse
import math
import textwrap

from . import COMMANDS
from .argtypes import add_floor_argument, assignment, integer, non_negative, number, positive
from .run_options import (
    check_applicable,
    check_body,
    check_outputs,
    check_ranges,
    factory_options,
    names_with,
)
from .suggest import hint


def _direction(text: str) -> float:
    """Degrees, or a name of the scenarios' push directions (``back`` for ``backward``)."""
    from mjchar.controllers.core.scenarios.shared import DIRECTIONS  # (only when parsing)

    names = {**DIRECTIONS, "back": DIRECTIONS["backward"]}
    if text.lower() in names:
        return names[text.lower()]
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"direction must be degrees or one of {', '.join(names)}, got {text!r}"
        ) from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"direction must be finite, got {text!r}")
    return v


def _scenario_type(option):
    """The argparse type of a scenario option, by its kind."""
    what = option.flag.lstrip("-").replace("-", " ")
    return {"seconds": positive(what), "newtons": non_negative(what),
            "metres": non_negative(what), "degrees": _direction, "number": number(what),
            "count": integer(what, minimum=1), "seed": integer(what)}[option.kind]


def _add_factory_option(p: argparse.ArgumentParser, o, registry) -> None:
    """The flag of a declared factory option (its parsing by kind)."""
    help_ = o.help.format(controllers=names_with(o.name))
    if o.kind == "params":
        p.add_argument(o.flag, dest=o.dest, type=assignment(o.flag), action="append",
                       metavar=o.metavar, help=help_)
    elif o.kind == "pd":
        p.add_argument(o.flag, dest=o.dest, choices=registry.names("pd"), help=help_)
    else:
        kind = {"number": number(o.name), "metres": non_negative(o.name),
                "squat": non_negative("squat depth"), "text": None}[o.kind]
        p.add_argument(o.flag, dest=o.dest, type=kind, metavar=o.metavar, help=help_)


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``run`` subcommand to ``mjchar``'s subparsers."""
    from mjchar.controllers import registry
    from mjchar.controllers.core.builder import scenarios_of
    from mjchar.controllers.core.scenarios import registry as scenarios

    intro = textwrap.fill(
        "Run a controller on the simulated humanoid in a scenario and print a summary (or one "
        "JSON object). PD trackers and hand_of_god follow the reference motion in track/walk and "
        "hold the standing pose otherwise. Default motion: the bundled walk; default model: the "
        "bundled humanoid.", 80)
    table = "\n".join(f"  {s.name:<15} {s.label} ({', '.join(scenarios_of(s))})"
                      for s in registry.specs())
    stable = "\n".join(f"  {s.name:<15} {s.measures}" for s in scenarios.specs())
    p = sub.add_parser(
        "run", help=COMMANDS["run"],
        description=f"{intro}\n\ncontrollers (scenarios, the default first):\n{table}\n\n"
                    f"scenarios:\n{stable}",
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("controller", choices=registry.names(), metavar="CONTROLLER",
                   help="one of: " + ", ".join(registry.names()))
    p.add_argument("trajectory", nargs="?", metavar="FILE",
                   help="replays: a trajectory saved by mjchar samcon / mjchar trajopt "
                        "(default for samcon_replay / cmaes_replay: the bundled one); any "
                        "other controller: a scenario's name, as --scenario "
                        "(`mjchar run mpc track`)")
    p.add_argument("--scenario", choices=scenarios.names(), metavar="S",
                   help="one of: " + ", ".join(scenarios.names())
                        + " (default: the controller's own, see above)")
    for o in factory_options():
        _add_factory_option(p, o, registry)
    p.add_argument("--motion", metavar="CLIP",
                   help="reference motion for track/walk and hand_of_god: a BVH file or a "
                        "bundled clip's name (walk, idle; default walk; policy: the clip "
                        "it was trained on, looped as trained)")
    p.add_argument("--loop", action="store_true", default=None,
                   help="track/walk: loop a seamless cycle cut from the motion (its root "
                        "advancing each cycle) for as long as --duration")
    p.add_argument("--model", metavar="FILE.xml",
                   help="converted model (default: the bundled humanoid)")
    add_floor_argument(p, default=None)
    for o in scenarios.options():
        if o.kind == "switch":
            p.add_argument(o.flag, dest=o.name, action="store_true", default=None, help=o.help)
        else:
            p.add_argument(o.flag, dest=o.name, type=_scenario_type(o), metavar=o.metavar,
                           help=o.help)
    p.add_argument("--timestep", type=positive("timestep"), metavar="S",
                   help="physics time step in seconds (default: the controller's, e.g. 1/2000 "
                        "for pd, 1/1000 for simbicon; the model's otherwise)")
    p.add_argument("--control-dt", type=positive("control dt"), metavar="S",
                   help="seconds between control steps (default: every physics step)")
    p.add_argument("--json", action="store_true", help="print exactly one JSON object")
    p.add_argument("--render", metavar="OUT.mp4",
                   help="write a video following the character (needs the video extra)")
    p.add_argument("--fps", type=positive("fps"), help="video frame rate (default 30)")
    p.add_argument("--view", action="store_true",
                   help="watch the run live in MuJoCo's viewer, in real time (needs a display; "
                        "closing the window ends the run)")
    p.add_argument("--export-bvh", metavar="OUT.bvh",
                   help="write the simulated motion as BVH on the skeleton the model was "
                        "converted from (its joint names, channel orders, units, up axis)")
    p.add_argument("--export-fps", type=positive("export fps"), metavar="FPS",
                   help="frame rate of --export-bvh (default: the source clip's; 60 for a "
                        "model converted from a bare skeleton)")
    p.epilog = ("An option the chosen controller and scenario do not use is an error (exit 2), "
                "as is a value outside what the controller supports.")
    p.set_defaults(func=main)


def _controller_options(spec, args: argparse.Namespace) -> dict:
    """The factory options ``spec`` takes, from the command line (the declared options' flags,
    then ``--param``, which refuses an option that has a flag of its own)."""
    from mjchar.bvh.errors import MjcharError
    from mjchar.controllers.core.registry import FACTORY_OPTIONS

    options = {}
    for o in FACTORY_OPTIONS.values():
        value = getattr(args, o.dest, None)
        if o.name not in spec.options or o.kind == "params" or value is None:
            continue
        if o.kind == "squat":  # a depth (0: no squat) becomes the squat's height profile
            if value:
                from mjchar.controllers.balance.static_balance import squat_profile

                options[o.name] = squat_profile(value)
        else:
            options[o.name] = value
    for name, value in args.param or ():
        declared = FACTORY_OPTIONS.get(name)
        if declared is not None and declared.kind != "params":
            raise MjcharError(f"--param {name}: give it as {declared.flag}")
        if name in options and options[name] != value:
            raise MjcharError(f"--param {name} is given twice with different values")
        options[name] = value
    return options


def _policy_clip(args: argparse.Namespace) -> None:
    """``mjchar run policy POLICY``: the policy, loaded once; with no ``--motion`` the builder
    runs it on its own clip, looped as it was trained (``RunSpec.with_own_clip``)."""
    from mjchar.controllers.learned import find_policy

    args.trajectory = find_policy(args.trajectory)


def _motion_label(motion, args: argparse.Namespace) -> str:
    """The clip a run followed, for its JSON: a name or path, or (a clip a policy file carries)
    the name the policy was trained on."""
    import os

    if motion is None:
        return "bundled walk"
    if isinstance(motion, str | os.PathLike):
        return str(motion)
    return f"{args.trajectory.meta['clip']['name']} (the copy in the policy file)"


def describe(args: argparse.Namespace):
    """The :class:`~mjchar.controllers.core.builder.RunSpec` of a ``mjchar run`` command line,
    with every typed option checked against the controller and scenario."""
    from mjchar.bvh.errors import MjcharError
    from mjchar.controllers import registry
    from mjchar.controllers.core.builder import RunSpec
    from mjchar.controllers.core.scenarios import registry as scenarios

    cspec = registry.get(args.controller)
    if (args.trajectory in scenarios.names() and cspec.kind != "replay"
            and args.scenario in (None, args.trajectory)):
        args.scenario, args.trajectory = args.trajectory, None  # `mjchar run mpc track`
    spec = RunSpec(cspec.name, args.scenario)
    sspec = spec.scenario_spec
    if not sspec.suits(cspec):
        spec.check()  # the builder's one-line refusal, naming the scenarios it runs
    takes_file = cspec.kind == "replay" or "policy" in cspec.options
    if args.trajectory is not None and not takes_file:
        meant = hint(args.trajectory, scenarios.names(), "--scenario ")
        raise MjcharError(f"unexpected argument {args.trajectory!r}{meant}: only the replays "
                          f"({', '.join(registry.names('replay'))}) and policy take a file")
    if "policy" in cspec.options:
        _policy_clip(args)
    if args.gait is not None and "gait" in cspec.options:
        from mjchar.controllers.walking.gaits import GAITS

        if args.gait not in GAITS:
            raise MjcharError(f"unknown gait {args.gait!r}{hint(args.gait, GAITS)}; choose from "
                              f"{', '.join(GAITS)}")
    check_applicable(args, cspec, sspec)
    check_ranges(args, cspec, sspec)
    check_outputs(args)
    scenario_options = {o.name: getattr(args, o.name) for o in sspec.options
                        if o.name != "seed" and getattr(args, o.name, None) is not None}
    return RunSpec(cspec.name, sspec.name, model=args.model, motion=args.motion,
                   loop=bool(args.loop), floor=args.floor, timestep=args.timestep,
                   control_dt=args.control_dt, seed=getattr(args, "seed", None),
                   options=_controller_options(cspec, args),
                   scenario_options=scenario_options).check()


def main(args: argparse.Namespace) -> int:
    """Describe, build and execute the run; print the result."""
    import json
    import os

    if args.render:  # the OpenGL backend is chosen when MuJoCo is first imported
        os.environ.setdefault("MUJOCO_GL", "egl")

    from mjchar.bvh.reference.export import MotionRecorder
    from mjchar.controllers.core.builder import execute
    from mjchar.controllers.core.scenarios.shared import chain_callbacks
    from mjchar.progress import Progress

    spec = describe(args)
    if args.view:
        from ..viewer import check_display

        check_display()  # before the clip is prepared
    # a bar on a terminal (the clip's preparation, then simulated time), a protocol's lines
    built = spec.build(progress=None if args.json else Progress())
    ch = built.character
    check_body(args, ch.dynamics.mass, ch.info.extra.get("height"))
    video = None
    if args.render:
        from ..render import VideoRecorder

        video = VideoRecorder(ch, args.render, fps=args.fps or 30.0)
    recorder = MotionRecorder() if args.export_bvh else None
    viewer = None
    if args.view:
        from ..viewer import LiveViewer

        viewer = LiveViewer(ch)
    built.frame_callback = chain_callbacks(video.capture if video else None, recorder, viewer)
    try:
        result = execute(built)
    except BaseException:
        if video is not None:
            video.close(keep=False)  # an existing video at the path stays as it was
        raise
    finally:
        if viewer is not None:
            viewer.close()
    if video is not None:
        video.close()
    exported = _export(args, recorder)
    if args.json:
        out = result.to_dict()
        if spec.controller_spec.kind == "replay":
            out["trajectory"] = str(_trajectory_path(args, spec.controller_spec))
        else:
            out["model"] = str(args.model) if args.model else "bundled humanoid"
        if built.reference is not None:
            out["motion"] = _motion_label(built.spec.motion, args)
        if video is not None:
            out["video"] = args.render
            out["video_frames"] = video.frames
        out.update(exported)
        print(json.dumps(out))
    else:
        print(result.summary())
        if video is not None:
            print(f"  video: {args.render} ({video.frames} frames)")
        _print_export(exported)
    return 0


def _trajectory_path(args: argparse.Namespace, spec):
    from mjchar.bvh.bundled.assets import find_trajectory

    return args.trajectory or find_trajectory(spec.trajectory_prefixes)


def _export(args: argparse.Namespace, recorder) -> dict:
    """``--export-bvh``: write the recording; the JSON keys describing what was written."""
    if recorder is None:
        return {}
    motion = recorder.save_bvh(args.export_bvh, fps=args.export_fps)
    return {"export_bvh": args.export_bvh, "export_frames": motion.n_frames,
            "export_fps": motion.fps}


def _print_export(exported: dict) -> None:
    if exported:
        print(f"  BVH: {exported['export_bvh']} ({exported['export_frames']} frames at "
              f"{exported['export_fps']:g} fps)")
