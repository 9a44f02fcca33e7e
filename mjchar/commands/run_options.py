"""Which options of ``mjchar run`` apply where, their defaults, and the ranges they accept.

Every option is parsed with the default ``None`` so that an option the user typed can be told
from one left alone. :func:`check_applicable` then refuses, in one line (exit status 2), any
typed option that the chosen controller and scenario would not use; :func:`fill_defaults` puts
the real defaults in; :func:`check_ranges` refuses values outside what the controller supports
(speeds from the controller's registered limits, headings, push forces relative to the body's
weight, durations, time steps, frame rates). Nothing is ever silently ignored.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from mjchar.bvh.errors import MjcharError

#: push forces (``--push``, ``--max-force``) above this many body weights are refused
MAX_PUSH_BODY_WEIGHTS = 10.0
#: longest run ``mjchar run`` accepts, simulated seconds
MAX_DURATION_S = 3600.0
#: largest physics time step accepted, s (explicit contact dynamics are unstable far above)
MAX_TIMESTEP_S = 0.01
#: headings are degrees in [-MAX_HEADING_DEG, MAX_HEADING_DEG]
MAX_HEADING_DEG = 360.0
#: frame rates of videos and BVH exports
MAX_FPS = 1000.0
#: push-search grid limits
MAX_PHASES, MAX_SEEDS = 64, 100
#: a squat deeper than this fraction of the standing height is refused
MAX_SQUAT_FRACTION = 0.4

Applies = Callable[[object, str], bool]  # (ControllerSpec, scenario) -> used?


def _scenarios(*names: str) -> Applies:
    return lambda spec, scenario: scenario in names


def _option(name: str, scenarios: tuple[str, ...] | None = None) -> Applies:
    """Used by controllers whose factory takes ``name`` (in ``scenarios`` when given)."""
    return lambda spec, scenario: (name in spec.options
                                   and (scenarios is None or scenario in scenarios))


def _not_replay(*but: str) -> Applies:
    return lambda spec, scenario: spec.kind != "replay" and scenario not in but


def _with_reference(spec, scenario: str) -> bool:
    """A reference clip is loaded: track, and walk for the trackers (walkers walk alone)."""
    return spec.kind != "replay" and (scenario == "track"
                                      or (scenario == "walk" and spec.kind != "walker"))


@dataclass(frozen=True)
class Option:
    """One option of ``mjchar run``: its flag, default and where it is used.

    Attributes:
        dest: the argparse attribute.
        flag: as typed (``--speed``).
        default: the value when not typed.
        applies: ``applies(spec, scenario)``: the option is used there.
        where: where it is used, for the error message (``{names}`` is filled with the
            controllers whose factory takes the option).
    """

    dest: str
    flag: str
    default: object
    applies: Applies
    where: str


OPTIONS: tuple[Option, ...] = (
    # not typed: the controller's own speed (its factory's default: IPM 1 m/s, SIMBICON its gait's)
    Option("speed", "--speed", None, _option("speed", ("walk",)),
           "the walk scenario of {names}"),
    Option("heading", "--heading", None, _option("heading"), "{names}"),
    Option("gait", "--gait", "walk", _option("gait"), "{names}"),
    Option("tracker", "--tracker", "spd", _option("tracker"), "{names}"),
    Option("squat", "--squat", None, _option("height"), "{names}"),
    Option("param", "--param", (), _option("params"), "{names}"),
    Option("motion", "--motion", None, _with_reference,
           "the track scenario, and the walk scenario of the trackers (not walkers, replays)"),
    Option("loop", "--loop", False, _with_reference,
           "runs with a reference clip (--motion): track, and walk for the trackers"),
    Option("floor", "--floor", None, _with_reference,
           "runs with a reference clip (--motion): track, and walk for the trackers"),
    Option("duration", "--duration", None, _scenarios("stand", "push", "random-push", "track",
                                                      "walk"),
           "every scenario but push-search (whose runs last the protocol's 5 s after the push)"),
    Option("push", "--push", None, _scenarios("push", "random-push", "track", "walk"),
           "the push, random-push, track and walk scenarios (push-search sweeps forces: "
           "--max-force)"),
    Option("direction", "--direction", 0.0, _scenarios("push", "track", "walk"),
           "the push, track and walk scenarios"),
    Option("push_duration", "--push-duration", 0.2,
           _scenarios("push", "push-search", "track", "walk"),
           "the push, push-search, track and walk scenarios"),
    Option("push_time", "--push-time", 1.0, _scenarios("push", "track", "walk"),
           "the push, track and walk scenarios"),
    Option("allow_steps", "--allow-steps", False, _scenarios("push"), "the push scenario"),
    Option("max_force", "--max-force", 500.0, _scenarios("push-search"),
           "the push-search scenario"),
    Option("tolerance", "--tolerance", 25.0, _scenarios("push-search"),
           "the push-search scenario"),
    Option("phases", "--phases", 4, _scenarios("push-search"), "the push-search scenario"),
    Option("seeds", "--seeds", 2, _scenarios("push-search"), "the push-search scenario"),
    Option("seed", "--seed", 0, _scenarios("random-push"),
           "the random-push scenario (push-search takes --seeds)"),
    Option("timestep", "--timestep", None, _not_replay("push-search"),
           "every run but push-search and replays (a trajectory keeps its own time step)"),
    Option("control_dt", "--control-dt", None, _not_replay("push-search"),
           "every run but push-search and replays (a trajectory keeps its own control step)"),
    Option("render", "--render", None, _scenarios("stand", "push", "random-push", "track",
                                                  "walk"),
           "every scenario but push-search (hundreds of runs: film one with --scenario push)"),
    Option("export_bvh", "--export-bvh", None, _scenarios("stand", "push", "random-push",
                                                          "track", "walk"),
           "every scenario but push-search (hundreds of runs)"),
)

#: options that only refine another one: (dest, needs, flag of needs)
REFINES = (("fps", "render", "--render"), ("export_fps", "export_bvh", "--export-bvh"))
#: in track and walk, the push's details need the push
PUSH_DETAILS = ("direction", "push_time", "push_duration")
REFINE_DEFAULTS = {"fps": 30.0, "export_fps": None}


def _names_with(option: str) -> str:
    from mjchar.controllers import registry

    names = [s.name for s in registry.specs() if option in s.options]
    return ", ".join(names) if names else "no registered controller"


def _where(opt: Option) -> str:
    key = {"squat": "height", "param": "params"}.get(opt.dest, opt.dest)
    return opt.where.format(names=_names_with(key))


def check_applicable(args: argparse.Namespace, spec, scenario: str) -> None:
    """One-line :class:`MjcharError` for the first typed option ``spec`` in ``scenario`` does not
    use."""
    for opt in OPTIONS:
        if getattr(args, opt.dest, None) is not None and not opt.applies(spec, scenario):
            raise MjcharError(f"{opt.flag} does not apply to {spec.name} in the {scenario} "
                              f"scenario; it is used by {_where(opt)}")
    for dest, needs, flag in REFINES:
        if getattr(args, dest, None) is not None and getattr(args, needs, None) is None:
            raise MjcharError(f"--{dest.replace('_', '-')} needs {flag}")
    if scenario in ("track", "walk") and getattr(args, "push", None) is None:
        for dest in PUSH_DETAILS:
            if getattr(args, dest, None) is not None:
                raise MjcharError(f"--{dest.replace('_', '-')} in the {scenario} scenario "
                                  "needs --push N (one push while moving)")


def fill_defaults(args: argparse.Namespace) -> None:
    """Replace the ``None`` of every option the user did not type by its default."""
    for opt in OPTIONS:
        if getattr(args, opt.dest, None) is None:
            setattr(args, opt.dest, opt.default)
    for dest, default in REFINE_DEFAULTS.items():
        if getattr(args, dest, None) is None:
            setattr(args, dest, default)


def _bad(flag: str, value, what: str) -> MjcharError:
    return MjcharError(f"{flag} {value:g} is out of range: {what}")


def check_speed(spec, speed: float, character=None) -> None:
    """One-line :class:`MjcharError` when ``speed`` is outside the controller's registered
    ``speed`` limits (none registered: any speed) on ``character``'s body (the limits scale
    with its leg length when the controller registers ``speed_leg_length``)."""
    reg = spec.limit("speed")
    if reg is None:
        return
    leg = character.leg_length() if character is not None and spec.speed_leg_length else None
    lim = spec.limit("speed", leg)
    if lim[0] <= speed <= lim[1]:
        return
    what = f"{spec.name} walks at {lim[0]:g} to {lim[1]:g} m/s"
    if lim != reg:
        what += (f" on this body (leg length {leg:.3g} m; {reg[0]:g} to {reg[1]:g} m/s on the "
                 f"body the range was measured on, leg length {spec.speed_leg_length:g} m)")
    raise _bad("--speed", speed, what)


def check_ranges(args: argparse.Namespace, spec, scenario: str, *, mass: float | None = None,
                 height: float | None = None, character=None,
                 default_duration: float | None = None) -> None:
    """One-line :class:`MjcharError` for a value the controller does not support.

    Args:
        mass: the model's mass in kg (push forces are checked against its weight).
        height: the model's standing height in m (squat depth).
        character: the model's :class:`Character` (walking speeds scale with its legs).
        default_duration: the scenario's run length when ``--duration`` is not given (a push
            must start within the run).
    """
    if "speed" in spec.options and scenario == "walk" and args.speed is not None:
        check_speed(spec, args.speed, character)
    if args.heading is not None and abs(args.heading) > MAX_HEADING_DEG:
        raise _bad("--heading", args.heading,
                   f"give degrees within +-{MAX_HEADING_DEG:g}")
    if args.duration is not None and args.duration > MAX_DURATION_S:
        raise _bad("--duration", args.duration, f"at most {MAX_DURATION_S:g} simulated s")
    if args.timestep is not None and args.timestep > MAX_TIMESTEP_S:
        raise _bad("--timestep", args.timestep, f"at most {MAX_TIMESTEP_S:g} s")
    if args.control_dt is not None:
        dt = args.timestep or spec.timestep
        if dt and args.control_dt < dt - 1e-12:
            raise _bad("--control-dt", args.control_dt,
                       f"shorter than the physics step {dt:g} s")
        if args.control_dt > 0.1:
            raise _bad("--control-dt", args.control_dt, "at most 0.1 s")
    for flag, value in (("--fps", args.fps), ("--export-fps", args.export_fps)):
        if value is not None and value > MAX_FPS:
            raise _bad(flag, value, f"at most {MAX_FPS:g} frames per second")
    if scenario == "push-search":
        if args.tolerance > args.max_force:
            raise _bad("--tolerance", args.tolerance,
                       f"the grid step must not exceed --max-force {args.max_force:g} N")
        if args.phases > MAX_PHASES:
            raise _bad("--phases", args.phases, f"at most {MAX_PHASES}")
        if args.seeds > MAX_SEEDS:
            raise _bad("--seeds", args.seeds, f"at most {MAX_SEEDS}")
    if scenario in ("push", "push-search") and args.push_duration > 5.0:
        raise _bad("--push-duration", args.push_duration, "at most 5 s")
    if scenario == "push" or (scenario in ("track", "walk") and args.push is not None):
        run = args.duration if args.duration is not None else default_duration
        if run is not None and args.push_time >= run:
            raise _bad("--push-time", args.push_time,
                       f"the push must start within the {run:g} s run (see --duration)")
    if mass is not None:
        limit = MAX_PUSH_BODY_WEIGHTS * mass * 9.81
        for flag, value in (("--push", args.push), ("--max-force", args.max_force)):
            if value is not None and value > limit:
                raise _bad(flag, value, f"at most {MAX_PUSH_BODY_WEIGHTS:g} body weights "
                                        f"({limit:.0f} N for this {mass:.1f} kg model)")
    if height is not None and args.squat is not None and args.squat > MAX_SQUAT_FRACTION * height:
        raise _bad("--squat", args.squat, f"at most {MAX_SQUAT_FRACTION:g} of the standing "
                                          f"height ({MAX_SQUAT_FRACTION * height:.2f} m)")


def check_export_path(path: str | None) -> None:
    """``--export-bvh``: a ``.bvh`` path in a folder that exists (checked before the run)."""
    if path is None:
        return
    p = Path(path)
    if p.suffix.lower() != ".bvh":
        raise MjcharError(f"--export-bvh writes BVH: give a .bvh path, got {path!r}")
    if not p.resolve().parent.is_dir():
        raise MjcharError(f"--export-bvh {path}: folder {p.resolve().parent} does not exist")
