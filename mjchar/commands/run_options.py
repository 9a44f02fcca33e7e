"""Which options of ``mjchar run`` apply where, and the ranges they accept.

The options come from three places, each declared once: the controllers' factory options
(``--speed``, ``--gait``, ``--param``...), declared with their flags and ranges by the controller
registry (:data:`~mjchar.controllers.core.registry.FACTORY_OPTIONS`; a controller registers which
it takes), the run's own (``--motion``, ``--timestep``, ``--render``...) and the scenarios'
options, declared by the scenario registry (``--push``, ``--duration``, ``--seed``...). A new
controller or scenario option gets its flag with no edit here.

Every option is parsed with the default ``None`` so that an option the user typed can be told
from one left alone. :func:`check_applicable` then refuses, in one line (exit status 2), any
typed option that the chosen controller and scenario would not use; :func:`check_ranges`
refuses values outside what the run supports (durations, time steps, frame rates, push forces
relative to the body's weight; walking speeds are checked by the run builder against the
controller's registered limits; the time-step and duration bounds are
:mod:`mjchar.controllers.core.limits`'). Nothing is ever silently ignored.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from mjchar.bvh.errors import MjcharError

#: push forces (``--push``, ``--max-force``) above this many body weights are refused
MAX_PUSH_BODY_WEIGHTS = 10.0
#: frame rates of videos and BVH exports
MAX_FPS = 1000.0
#: a squat deeper than this fraction of the standing height is refused
MAX_SQUAT_FRACTION = 0.4
#: the push time when ``--push-time`` is not given (s), as the scenarios default it
DEFAULT_PUSH_TIME = 1.0

Applies = Callable[[object, object], bool]  # (ControllerSpec, ScenarioSpec) -> used?


@dataclass(frozen=True)
class CliOption:
    """One option of ``mjchar run``: its flag and where it is used.

    Attributes:
        dest: the argparse attribute.
        flag: as typed (``--speed``).
        applies: ``applies(controller_spec, scenario_spec)``: the option is used there.
        where: where it is used, for the error message.
        scenario: the option is a scenario's (passed to its procedure).
    """

    dest: str
    flag: str
    applies: Applies
    where: Callable[[], str]
    scenario: bool = False


def _controller_option(name: str, moving_only: bool = False) -> Applies:
    """Used by controllers whose factory takes ``name`` (only where they move, if so)."""
    return lambda c, s: name in c.options and (not moving_only or s.moving)


def _follows_clip(c, s) -> bool:
    from mjchar.controllers.core.builder import follows_clip

    return follows_clip(c, s)


def _not_protocol(c, s) -> bool:
    return not s.protocol


def _not_protocol_or_replay(c, s) -> bool:
    return not s.protocol and c.kind != "replay"


def names_with(option: str) -> str:
    """The registered controllers whose factory takes ``option``, for messages and help."""
    from mjchar.controllers import registry

    names = [s.name for s in registry.specs() if option in s.options]
    return ", ".join(names) if names else "no registered controller"


def _names_with(option: str) -> Callable[[], str]:
    return lambda: names_with(option)


def _moving_of(option: str) -> Callable[[], str]:
    def where() -> str:
        from mjchar.controllers.core.scenarios import registry

        moving = ", ".join(s.name for s in registry.specs() if s.moving)
        return f"the moving scenarios ({moving}) of {names_with(option)}"
    return where


def _scenarios_with(name: str) -> Callable[[], str]:
    def where() -> str:
        from mjchar.controllers.core.scenarios import registry

        names = [s.name for s in registry.specs() if s.option(name) is not None]
        return (f"the {', '.join(names[:-1])} and {names[-1]} scenarios" if len(names) > 1
                else f"the {names[0]} scenario")
    return where


def _text(text: str) -> Callable[[], str]:
    return lambda: text


_CLIP = _text("runs with a reference clip: track, and walk for the trackers (not walkers, "
              "replays)")


def _keeps_own(step: str) -> Callable[[], str]:
    """Where an option that a trajectory brings itself applies (its ``step``: time, control)."""
    return _text(f"every run but push-search and replays (a trajectory keeps its own {step} step)")


def _one_run(verb: str = "") -> Callable[[], str]:
    """Where an option about one run's picture applies (``verb``: how to get it for one push)."""
    hint = f": {verb} one with --scenario push" if verb else ""
    return _text(f"every scenario but push-search (hundreds of runs{hint})")


#: the run's own options (neither a controller's nor a scenario's)
RUN_OPTIONS: tuple[CliOption, ...] = (
    CliOption("motion", "--motion", _follows_clip, _CLIP),
    CliOption("loop", "--loop", _follows_clip, _CLIP),
    CliOption("floor", "--floor", _follows_clip, _CLIP),
    CliOption("timestep", "--timestep", _not_protocol_or_replay, _keeps_own("time")),
    CliOption("control_dt", "--control-dt", _not_protocol_or_replay, _keeps_own("control")),
    CliOption("render", "--render", _not_protocol, _one_run("film")),
    CliOption("view", "--view", _not_protocol, _one_run("watch")),
    CliOption("export_bvh", "--export-bvh", _not_protocol, _one_run()),
)
#: options that only refine another one: (dest, needs, flag of needs)
REFINES = (("fps", "render", "--render"), ("export_fps", "export_bvh", "--export-bvh"))


def factory_options():
    """The declared factory options that have a flag (the positional FILE aside)."""
    from mjchar.controllers.core.registry import FACTORY_OPTIONS

    return tuple(o for o in FACTORY_OPTIONS.values() if o.kind != "file")


def options() -> tuple[CliOption, ...]:
    """Every option of ``mjchar run`` that applies somewhere only: one per declared factory
    option, the run's own, then one per registered scenario option."""
    from mjchar.controllers.core.scenarios import registry

    factory = tuple(
        CliOption(o.dest, o.flag, _controller_option(o.name, o.moving_only),
                  _moving_of(o.name) if o.moving_only else _names_with(o.name))
        for o in factory_options())
    return factory + RUN_OPTIONS + tuple(
        CliOption(o.name, o.flag, (lambda c, s, n=o.name: s.option(n) is not None),
                  _scenarios_with(o.name), scenario=True)
        for o in registry.options())


def check_applicable(args: argparse.Namespace, cspec, sspec) -> None:
    """One-line :class:`MjcharError` for the first typed option the controller in the
    scenario does not use."""
    for opt in options():
        if getattr(args, opt.dest, None) not in (None, False) and not opt.applies(cspec, sspec):
            raise MjcharError(f"{opt.flag} does not apply to {cspec.name} in the {sspec.name} "
                              f"scenario; it is used by {opt.where()}")
    for dest, needs, flag in REFINES:
        if getattr(args, dest, None) is not None and getattr(args, needs, None) is None:
            raise MjcharError(f"--{dest.replace('_', '-')} needs {flag}")
    if sspec.moving and sspec.option("force") is not None and getattr(args, "force", None) is None:
        for name in ("direction", "push_time", "push_duration"):
            if getattr(args, name, None) is not None:
                flag = sspec.option(name).flag
                raise MjcharError(f"{flag} in the {sspec.name} scenario needs --push N (one "
                                  "push while moving)")


def _bad(flag: str, value, what: str) -> MjcharError:
    return MjcharError(f"{flag} {value:g} is out of range: {what}")


def check_ranges(args: argparse.Namespace, cspec, sspec) -> None:
    """One-line :class:`MjcharError` for a value the run does not support (before anything is
    built). Scenario options are checked against their declared bounds."""
    from mjchar.controllers.core.limits import MAX_CONTROL_DT_S, MAX_TIMESTEP_S, MIN_TIMESTEP_S
    from mjchar.controllers.core.scenarios import registry

    for o in registry.options():
        value = getattr(args, o.name, None)
        if o.high is not None and value is not None and value > o.high:
            unit = {"seconds": " s", "metres": " m", "newtons": " N"}.get(o.kind, "")
            raise _bad(o.flag, value, f"at most {o.high:g}{unit}")
    for o in factory_options():
        value = getattr(args, o.dest, None)
        problem = o.problem(value) if value is not None else None
        if problem:
            raise _bad(o.flag, value, problem)
    if args.timestep is not None and args.timestep > MAX_TIMESTEP_S:
        raise _bad("--timestep", args.timestep, f"at most {MAX_TIMESTEP_S:g} s")
    if args.timestep is not None and args.timestep < MIN_TIMESTEP_S:
        raise _bad("--timestep", args.timestep, f"at least {MIN_TIMESTEP_S:g} s (a second of "
                                                f"simulation would take over 1e5 steps)")
    if args.control_dt is not None:
        dt = args.timestep or cspec.timestep
        if dt and args.control_dt < dt - 1e-12:
            raise _bad("--control-dt", args.control_dt,
                       f"shorter than the physics step {dt:g} s")
        if args.control_dt > MAX_CONTROL_DT_S:
            raise _bad("--control-dt", args.control_dt, f"at most {MAX_CONTROL_DT_S:g} s")
    for flag, value in (("--fps", args.fps), ("--export-fps", args.export_fps)):
        if value is not None and value > MAX_FPS:
            raise _bad(flag, value, f"at most {MAX_FPS:g} frames per second")
    max_force, tolerance = getattr(args, "max_force", None), getattr(args, "tolerance", None)
    if max_force is not None and tolerance is not None and tolerance > max_force:
        raise _bad("--tolerance", tolerance,
                   f"the grid step must not exceed --max-force {max_force:g} N")
    if sspec.option("push_time") is not None and getattr(args, "force", None) is not None:
        run = args.duration if args.duration is not None else sspec.default_duration
        push_time = DEFAULT_PUSH_TIME if args.push_time is None else args.push_time
        if run is not None and push_time >= run:
            raise _bad("--push-time", push_time,
                       f"the push must start within the {run:g} s run (see --duration)")


def check_body(args: argparse.Namespace, mass: float, height: float | None) -> None:
    """One-line :class:`MjcharError` for a push or squat too large for this body (its mass in
    kg, its standing height in m)."""
    limit = MAX_PUSH_BODY_WEIGHTS * mass * 9.81
    for flag, value in (("--push", getattr(args, "force", None)),
                        ("--max-force", getattr(args, "max_force", None))):
        if value is not None and value > limit:
            raise _bad(flag, value, f"at most {MAX_PUSH_BODY_WEIGHTS:g} body weights "
                                    f"({limit:.0f} N for this {mass:.1f} kg model)")
    if height is not None and args.squat is not None and args.squat > MAX_SQUAT_FRACTION * height:
        raise _bad("--squat", args.squat, f"at most {MAX_SQUAT_FRACTION:g} of the standing "
                                          f"height ({MAX_SQUAT_FRACTION * height:.2f} m)")


def check_outputs(args: argparse.Namespace) -> None:
    """``--render`` and ``--export-bvh``: writable paths of the right kind that are none of the
    run's inputs (the clip, the model, the trajectory), checked before the run."""
    from mjchar.bvh.io.files import check_output
    from mjchar.controllers.core.builder import motion_source

    inputs = [args.model, getattr(args, "trajectory", None)]
    if args.motion is not None:
        inputs.append(motion_source(args.motion))
    if args.render is not None:
        check_output(args.render, inputs=inputs, flag="--render", suffixes=(".mp4",))
    if args.export_bvh is not None:
        check_output(args.export_bvh, inputs=inputs, flag="--export-bvh", suffixes=(".bvh",))
        if args.render is not None and Path(args.render).resolve() == Path(
                args.export_bvh).resolve():
            raise MjcharError("--render and --export-bvh name the same file")
