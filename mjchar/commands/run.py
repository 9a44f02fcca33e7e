"""``mjchar run CONTROLLER``: run a controller in a scenario and report its metrics."""

from __future__ import annotations

import argparse
import math
import textwrap

from .argtypes import add_floor_argument, assignment, integer, non_negative, number, positive
from .run_options import check_applicable, check_export_path, check_ranges, fill_defaults

DIRECTION_NAMES = {"forward": 0.0, "left": 90.0, "backward": 180.0, "back": 180.0,
                   "right": 270.0}


def _direction(text: str) -> float:
    if text.lower() in DIRECTION_NAMES:
        return DIRECTION_NAMES[text.lower()]
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"direction must be degrees or one of {', '.join(DIRECTION_NAMES)}, got {text!r}"
        ) from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"direction must be finite, got {text!r}")
    return v


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``run`` subcommand to ``mjchar``'s subparsers."""
    from mjchar.controllers import registry

    intro = textwrap.fill(
        "Run a controller on the simulated humanoid in a scenario and print a summary (or one "
        "JSON object). PD trackers and hand_of_god follow the reference motion in track/walk and "
        "hold the standing pose otherwise. Default motion: the bundled walk; default model: the "
        "bundled humanoid.", 80)
    table = "\n".join(f"  {s.name:<15} {s.label} ({_scenario_list(s)})" for s in registry.specs())
    p = sub.add_parser(
        "run", help="run a controller in a scenario (stand, push, track, ...) and report metrics",
        description=f"{intro}\n\ncontrollers (scenarios, the default first):\n{table}",
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("controller", choices=registry.names(), metavar="CONTROLLER",
                   help="one of: " + ", ".join(registry.names()))
    p.add_argument("trajectory", nargs="?", metavar="FILE",
                   help="replays only: a trajectory saved by mjchar samcon / mjchar trajopt "
                        "(default for samcon_replay / cmaes_replay: the bundled one)")
    p.add_argument("--speed", type=number("speed"), metavar="M/S",
                   help="walk scenario, controllers taking a speed (ipm, simbicon): desired "
                        "forward speed (default: the controller's own, ipm 1.0, simbicon its "
                        "gait's; ipm: 0 stops and stands; each controller's range is checked)")
    p.add_argument("--heading", type=number("heading"), metavar="DEG",
                   help="ipm: desired heading in degrees (world yaw, 0 = +X, counter-clockwise)")
    p.add_argument("--gait", metavar="NAME",
                   help="simbicon: gait parameter set (default walk)")
    p.add_argument("--param", type=assignment("--param"), action="append", metavar="NAME=VALUE",
                   help="a tunable of the controller (repeatable; "
                        f"{', '.join(s.name for s in registry.specs() if 'params' in s.options)}):"
                        " mpc's MpcOptions (samples=96, horizon=0.5, update=cem), ipm's "
                        "IPMParams (timing.step_time=0.5), simbicon's Gait (torso_pitch=0.2); "
                        "VALUE is read as JSON, else as text; an unknown NAME lists the valid "
                        "ones")
    p.add_argument("--scenario", choices=registry.SCENARIOS, metavar="S",
                   help="one of: " + ", ".join(registry.SCENARIOS)
                        + " (default: the controller's own, see above)")
    p.add_argument("--motion", metavar="FILE.bvh",
                   help="reference motion for track/walk and hand_of_god (default: bundled walk)")
    p.add_argument("--loop", action="store_true", default=None,
                   help="track/walk: loop a seamless cycle cut from the motion (its root "
                        "advancing each cycle) for as long as --duration")
    p.add_argument("--model", metavar="FILE.xml",
                   help="converted model (default: the bundled humanoid)")
    add_floor_argument(p, default=None)
    p.add_argument("--duration", type=positive("duration"), metavar="T",
                   help="simulated seconds (default: per scenario; the clip for track/walk)")
    p.add_argument("--push", type=non_negative("push"), metavar="N",
                   help="push force in newtons (push: required; random-push: default 10; "
                        "track/walk and replays: one push while moving, at --push-time)")
    p.add_argument("--direction", type=_direction, metavar="DEG",
                   help="push direction in degrees from the facing direction (0 forward, "
                        "90 left, 180 backward, 270 right) or a name; default forward")
    p.add_argument("--push-duration", type=positive("push duration"), metavar="S",
                   help="push length in seconds (default 0.2)")
    p.add_argument("--push-time", type=non_negative("push time"), metavar="S",
                   help="when the push starts in seconds (default 1)")
    p.add_argument("--max-force", type=positive("max force"), metavar="N",
                   help="push-search: the force grid's cap in newtons (default 500)")
    p.add_argument("--tolerance", type=positive("tolerance"), metavar="N",
                   help="push-search: the force grid's step in newtons (default 25)")
    p.add_argument("--phases", type=integer("phases", minimum=1), metavar="K",
                   help="push-search: phases of the stride (walkers) or moments (standing) "
                        "pushed at (default 4)")
    p.add_argument("--seeds", type=integer("seeds", minimum=1), metavar="S",
                   help="push-search: seeds 0..S-1 of the start perturbation (default 2)")
    p.add_argument("--allow-steps", action="store_true", default=None,
                   help="a push counts as survived even if a foot moved (stepping controllers)")
    p.add_argument("--squat", type=non_negative("squat depth"), metavar="M",
                   help="static_balance: lower the COM target by M metres (1 s in, over 1.5 s), "
                        "hold 1 s and rise again")
    p.add_argument("--tracker", choices=registry.names("pd"),
                   help="PD variant hand_of_god wraps (default spd)")
    p.add_argument("--timestep", type=positive("timestep"), metavar="S",
                   help="physics time step in seconds (default: 1/2000 for pd, the model's "
                        "otherwise)")
    p.add_argument("--control-dt", type=positive("control dt"), metavar="S",
                   help="seconds between control steps (default: every physics step)")
    p.add_argument("--seed", type=integer("seed"), metavar="N",
                   help="random seed (random-push directions; default 0)")
    p.add_argument("--json", action="store_true", help="print exactly one JSON object")
    p.add_argument("--render", metavar="OUT.mp4",
                   help="write a video following the character (needs the video extra)")
    p.add_argument("--fps", type=positive("fps"), help="video frame rate (default 30)")
    p.add_argument("--export-bvh", metavar="OUT.bvh",
                   help="write the simulated motion as BVH on the skeleton the model was "
                        "converted from (its joint names, channel orders, units, up axis)")
    p.add_argument("--export-fps", type=positive("export fps"), metavar="FPS",
                   help="frame rate of --export-bvh (default: the source clip's; 60 for a "
                        "model converted from a bare skeleton)")
    p.epilog = ("An option the chosen controller and scenario do not use is an error (exit 2), "
                "as is a value outside what the controller supports.")
    p.set_defaults(func=run)


def _scenario_list(spec) -> str:
    return ", ".join([spec.default_scenario]
                     + [s for s in spec.scenarios if s != spec.default_scenario])


#: factory options that have their own flag (``--param`` refuses them)
_FLAG_OF = {"speed": "--speed", "heading": "--heading", "gait": "--gait",
            "tracker": "--tracker", "height": "--squat", "progress": "(set by the command)"}


def _controller_options(spec, args: argparse.Namespace, scenario: str) -> dict:
    """The factory options ``spec`` takes, from the command line (one rule per option name)."""
    from mjchar.bvh.errors import MjcharError

    options = {}
    if "tracker" in spec.options:
        options["tracker"] = args.tracker
    if "height" in spec.options and args.squat:
        from mjchar.controllers.balance.static_balance import squat_profile

        options["height"] = squat_profile(args.squat)
    if "gait" in spec.options:
        options["gait"] = args.gait
    if "speed" in spec.options:  # walk: as typed, else the controller's own; elsewhere stand
        if scenario != "walk":
            options["speed"] = 0.0
        elif args.speed is not None:
            options["speed"] = args.speed
    if "heading" in spec.options:
        options["heading"] = args.heading
    for name, value in args.param or ():
        flag = _FLAG_OF.get(name)
        if flag is not None:
            raise MjcharError(f"--param {name}: give it as {flag}")
        if name in options and options[name] != value:
            raise MjcharError(f"--param {name} is given twice with different values")
        options[name] = value
    return options


def run(args: argparse.Namespace) -> int:
    """Build the character, reference and controller, run the scenario, print the result."""
    import json
    import os

    if args.render:  # the OpenGL backend is chosen when MuJoCo is first imported
        os.environ.setdefault("MUJOCO_GL", "egl")

    from mjchar import bvh
    from mjchar.bvh.errors import MjcharError
    from mjchar.controllers import registry
    from mjchar.controllers.core import scenarios as S
    from mjchar.controllers.core.character import Character
    from mjchar.controllers.core.recording import MotionRecorder, chain_callbacks

    spec = registry.get(args.controller)
    scenario = args.scenario or spec.default_scenario
    if scenario not in spec.scenarios:
        raise MjcharError(f"{spec.name} does not run the {scenario} scenario; it runs "
                          f"{_scenario_list(spec)}")
    if args.trajectory is not None and spec.kind != "replay":
        raise MjcharError(f"unexpected argument {args.trajectory!r}: only the replays "
                          f"({', '.join(registry.names('replay'))}) take a file")
    check_applicable(args, spec, scenario)
    fill_defaults(args)
    check_export_path(args.export_bvh)
    if args.render and not args.render.lower().endswith(".mp4"):
        raise MjcharError(f"--render writes MP4: give a .mp4 path, got {args.render!r}")
    if scenario == "push" and args.push is None:
        raise MjcharError("the push scenario needs --push NEWTONS")
    if spec.kind == "replay":
        check_ranges(args, spec, scenario)
        return _replay(args, spec)
    walker = spec.kind == "walker"

    character = Character(args.model)
    check_ranges(args, spec, scenario, mass=character.mass,
                 height=character.info.extra.get("height"),
                 character=character,
                 default_duration=S.DEFAULT_DURATIONS.get(scenario))
    if scenario == "push-search":
        return _push_search(args, spec)
    timestep = args.timestep or spec.timestep
    if timestep:
        character.set_timestep(timestep)

    reference = None
    if scenario == "track" or (scenario == "walk" and not walker):
        from mjchar.bvh.bundled.assets import motion_path
        from mjchar.bvh.reference.reference_motion import ReferenceMotion

        path = args.motion or motion_path("walk")
        motion = bvh.load(path)
        if args.loop:
            from mjchar.bvh.editing.clips import make_cyclic

            motion = make_cyclic(motion)
        reference = ReferenceMotion(character.model, motion, info=character.info,
                                    floor=args.floor or spec.floor,
                                    cyclic=True if args.loop else None)
    # trackers follow the reference in track/walk, and hold the standing pose otherwise
    target = reference if reference is not None else S.standing_pose(character)
    controller = registry.make_controller(spec.name, character, target,
                                          **_controller_options(spec, args, scenario))

    kw: dict = {"control_dt": args.control_dt}
    if args.duration is not None:
        kw["duration"] = args.duration
    video = None
    if args.render:
        from ..render import VideoRecorder

        video = VideoRecorder(character, args.render, fps=args.fps)
    recorder = MotionRecorder() if args.export_bvh else None
    kw["frame_callback"] = chain_callbacks(video.capture if video else None, recorder)
    try:
        if scenario == "push":
            result = S.push(character, controller, force=args.push, direction=args.direction,
                            push_duration=args.push_duration, push_time=args.push_time,
                            allow_steps=args.allow_steps, **kw)
        elif scenario == "random-push":
            result = S.random_push(character, controller, seed=args.seed,
                                   force=10.0 if args.push is None else args.push, **kw)
        else:
            if args.push is not None and scenario in ("track", "walk"):  # a push while moving
                kw["push"] = S.PushEvent(args.push, args.direction, args.push_time,
                                         args.push_duration)
            result = S.run_scenario(scenario, character, controller, reference=reference, **kw)
    finally:
        if video is not None:
            video.close()
    result.seed = args.seed
    exported = _export(args, recorder)
    if args.json:
        out = result.to_dict()
        out["model"] = str(args.model) if args.model else "bundled humanoid"
        if reference is not None:
            out["motion"] = str(args.motion) if args.motion else "bundled walk"
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


def _push_search(args: argparse.Namespace, spec) -> int:
    """``--scenario push-search``: survival rates over phases, seeds and a force grid
    (:mod:`mjchar.controllers.core.push_protocol`), every core busy."""
    import json
    import sys

    from mjchar.controllers.core.push_protocol import PushProtocol, survival_rates

    protocol = PushProtocol.grid(args.max_force, min(args.tolerance, args.max_force),
                                 phases=args.phases, seeds=tuple(range(args.seeds)),
                                 push_duration=args.push_duration)
    progress = None if args.json else (lambda msg: print(msg, file=sys.stderr, flush=True))
    options = _controller_options(spec, args, "push-search")
    rates = survival_rates(spec.name, protocol, model=args.model, options=options, processes=0,
                           progress=progress)
    if args.json:
        out = rates.to_dict()
        out["model"] = str(args.model) if args.model else "bundled humanoid"
        print(json.dumps(out))
    else:
        print(rates.summary())
    return 0


def _replay(args: argparse.Namespace, spec) -> int:
    """``mjchar run replay FILE`` (or a registered replay with its bundled trajectory): play a
    saved PD-target trajectory open-loop."""
    import json
    import sys

    from mjchar.bvh.errors import MjcharError
    from mjchar.controllers.core.recording import MotionRecorder, chain_callbacks
    from mjchar.controllers.sampling.trajectory import find_trajectory, load_trajectory, replay

    path = args.trajectory or find_trajectory(spec.trajectory_prefixes)
    if path is None:
        if not spec.trajectory_prefixes:
            raise MjcharError(f"{spec.name} needs the trajectory file: mjchar run {spec.name} "
                              "FILE")
        raise MjcharError(f"{spec.name}: no bundled trajectory "
                          f"{spec.trajectory_prefixes[0]}*.npz; give one: mjchar run "
                          f"{spec.name} FILE")
    trajectory = load_trajectory(path)
    video = None
    kw = {}
    if args.push is not None:  # a push during the replay
        from mjchar.controllers.core.scenarios import PushEvent

        kw["push"] = PushEvent(args.push, args.direction, args.push_time, args.push_duration)
    if args.render:
        from mjchar.controllers.core.character import Character

        from ..render import VideoRecorder

        # the recorder only reads the simulated state through the callback's character
        video = VideoRecorder(Character(args.model), args.render, fps=args.fps)
    recorder = MotionRecorder() if args.export_bvh else None
    try:
        result = replay(trajectory, model=args.model, duration=args.duration,
                        frame_callback=chain_callbacks(video.capture if video else None,
                                                       recorder), **kw)
    finally:
        if video is not None:
            video.close()
    exported = _export(args, recorder)
    if args.json:
        out = result.to_dict()
        out["trajectory"] = str(path)
        out.update(exported)
        print(json.dumps(out))
    else:
        print(result.summary(), file=sys.stdout)
        _print_export(exported)
    return 0
