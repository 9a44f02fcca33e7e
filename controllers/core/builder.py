"""The run builder: one description of a run, one way to build and execute it.

``mjchar run``, ``mjchar gait``, ``mjchar bench``, the push protocol's workers and the Python
API all describe a run as a :class:`RunSpec` (controller, scenario, model, clip, options) and
build it here, so a run described the same way gives the same result everywhere::

    from mjchar.controllers import run

    result = run("simbicon", "walk", speed=1.2, gait="natural", duration=20.0)
    result = run("hand_of_god", motion="walk")            # the bundled walk, tracked
    rates = run("static_balance", "push-search", max_force=200.0, phases=2, seeds=1)

What the builder does that a caller would otherwise have to remember:

- the scenario defaults to the controller's own, and must be one it runs;
- the physics time step is the controller's (its registered step, a replay's trajectory
  step), unless ``timestep`` is given (:func:`~mjchar.controllers.core.registry.make_controller`);
- a clip is loaded only where the scenario follows one (``motion``: a bundled clip's name such
  as ``"walk"``, a BVH path or a Motion; default the bundled walk), looped into a seamless cycle
  with ``loop``, placed on the floor the controller's way (``floor``);
- trackers follow that clip, or hold the standing pose when there is none; walkers that can
  also stand (IPM) stand still in scenarios that do not move (speed 0), and walk at their own
  speed unless given one; speeds are checked against the controller's measured range on this
  body.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from mjchar.bvh.errors import MjcharError

from . import registry
from .character import Character
from .limits import control_dt_problem, timestep_problem
from .scenarios import registry as scenario_registry
from .scenarios.registry import Run
from .scenarios.shared import standing_pose


class RunError(MjcharError):
    """A run described impossibly (a scenario the controller does not run, an unknown option,
    a speed outside the controller's range)."""


@dataclass(frozen=True)
class RunSpec:
    """A run, described (picklable: protocols send it to worker processes).

    Attributes:
        controller: a registered controller name.
        scenario: a registered scenario it runs (``None``: its default scenario).
        model: ``None`` (the bundled humanoid), an MJCF path or an ``MjModel``.
        motion: the clip followed where the scenario follows one: ``None`` (the controller's
            own clip when it has one, a learned policy's: :meth:`with_own_clip`; else the
            bundled walk), a bundled clip's name (``"walk"``, ``"idle"``), a BVH path, a
            ``Motion``, or a ``ReferenceMotion`` already prepared for the model (used as it
            is: ``loop``, ``floor`` and conditioning do not apply).
        loop: follow a seamless cycle cut from the clip, repeated for as long as the run lasts.
        floor: how the clip is placed on the floor (default: the controller's way).
        timestep: physics time step in s (``None``: the controller's).
        control_dt: seconds between control steps (``None``: every physics step).
        seed: the run's seed, passed to scenarios that randomise (``None``: their default).
        options: the controller factory's options (``speed``, ``gait``, ``params``...).
        scenario_options: the scenario procedure's options (``duration``, ``force``...).
    """

    controller: str
    scenario: str | None = None
    model: Any = None
    motion: Any = None
    loop: bool = False
    floor: str | None = None
    timestep: float | None = None
    control_dt: float | None = None
    seed: int | None = None
    options: Mapping[str, Any] = field(default_factory=dict)
    scenario_options: Mapping[str, Any] = field(default_factory=dict)

    @property
    def controller_spec(self) -> registry.ControllerSpec:
        return registry.get(self.controller)

    @property
    def scenario_spec(self) -> scenario_registry.ScenarioSpec:
        return scenario_registry.get(self.scenario or self.controller_spec.default_scenario)

    def check(self) -> RunSpec:
        """A one-line :class:`RunError` for what cannot run; returns self."""
        cspec, sspec = self.controller_spec, self.scenario_spec
        if not sspec.suits(cspec):
            raise RunError(f"{cspec.name} does not run the {sspec.name} scenario; it runs "
                           f"{', '.join(scenarios_of(cspec))}")
        if "params" not in cspec.options:  # (with params, its factory checks its tunables)
            for key in self.options:
                if key not in cspec.options:
                    valid = ", ".join(cspec.options) or "none"
                    raise RunError(f"{cspec.name} takes no option {key!r}; its options: "
                                   f"{valid}")
        for key, value in self.options.items():
            declared = registry.FACTORY_OPTIONS.get(key)
            problem = declared.problem(value) if declared is not None else None
            if problem:
                raise RunError(f"{key} {value:g} is out of range: {problem}")
        for what, problem in (
                ("timestep", self.timestep is not None and timestep_problem(self.timestep)),
                ("control_dt", self.control_dt is not None
                 and control_dt_problem(self.control_dt, self.timestep))):
            if problem:
                raise RunError(f"{what} {problem}")
        try:
            scenario_registry.check_options(sspec, self.scenario_options)
        except MjcharError as e:
            raise RunError(str(e)) from None
        if "seed" in self.scenario_options:
            raise RunError("give the seed as RunSpec.seed (the run's seed)")
        return self

    def follows_clip(self) -> bool:
        """Whether this run loads a clip (:func:`follows_clip`)."""
        return follows_clip(self.controller_spec, self.scenario_spec)

    def build(self, *, frame_callback: Callable | None = None, progress=None,
              info=None) -> Run:
        """The character, its clip and the controller, ready for the scenario's procedure;
        ``progress`` (a :class:`~mjchar.progress.Progress`) shows the clip's
        preparation and then the run's simulated time; ``info``: the model's role map when it
        is an ``MjModel`` that does not carry one (default: read from the model)."""
        spec = self.with_own_clip().check()
        check_model_file(spec.model)
        character = Character(spec.model, info=info, timestep=spec.timestep)
        reference = (load_reference(spec, character, progress) if spec.follows_clip()
                     else None)
        controller = spec.make_controller(character, reference)
        return Run(character, controller, reference, spec, frame_callback, spec.control_dt,
                   spec.seed, progress)

    def with_own_clip(self) -> RunSpec:
        """With no ``motion``, a controller made for one clip (``ControllerSpec.own_clip``: a
        learned policy) follows that clip, looped as it was made; otherwise (or when the
        scenario follows no clip) the same spec."""
        own = self.controller_spec.own_clip
        if self.motion is not None or own is None or not self.follows_clip():
            return self
        motion, loop = own(self.options)
        return replace(self, motion=motion, loop=bool(loop))

    def make_controller(self, character: Character, reference=None, *, target=None):
        """A fresh controller on ``character`` (its time step applied): trackers follow
        ``reference``, or hold ``target`` (default: the standing pose) without one."""
        cspec, sspec = self.controller_spec, self.scenario_spec
        options = dict(self.options)
        if "speed" in cspec.options:
            if not sspec.moving and "stand" in cspec.abilities:
                options["speed"] = 0.0  # a walker that can stand stands still here
            elif "speed" in options and not callable(options["speed"]):
                check_speed(cspec, options["speed"], character)  # (a profile: Python only)
        if reference is None and target is None and cspec.kind in ("pd", "balance"):
            target = standing_pose(character)
        return registry.make_controller(cspec.name, character,
                                        reference if reference is not None else target,
                                        **options)

    def execute(self, *, frame_callback: Callable | None = None):
        """Build and run it: the scenario's result (a Result, or a protocol's rates)."""
        return execute(self.build(frame_callback=frame_callback))

    def with_options(self, **scenario_options) -> RunSpec:
        """The same run with more scenario options."""
        return replace(self, scenario_options={**self.scenario_options, **scenario_options})


def execute(run: Run):
    """Run a built :class:`Run` through its scenario's procedure (:meth:`Run.execute`)."""
    return run.execute()


def follows_clip(cspec, sspec) -> bool:
    """Whether a run of controller ``cspec`` in scenario ``sspec`` loads a clip: the scenario
    follows one and the controller tracks (walkers walk alone; replays bring their own
    reference)."""
    return "track" in cspec.abilities and (
        sspec.reference == "required"
        or (sspec.reference == "trackers" and "walk" not in cspec.abilities))


def scenarios_of(cspec) -> list[str]:
    """The scenarios a controller runs, its default first."""
    return [cspec.default_scenario] + [s for s in cspec.scenarios()
                                       if s != cspec.default_scenario]


def check_speed(spec, speed: float, character: Character | None = None) -> None:
    """One-line :class:`RunError` when ``speed`` is outside the controller's registered
    ``speed`` limits (none registered: any speed) on ``character``'s body (the limits scale
    with its leg length when the controller registers ``speed_leg_length``)."""
    reg = spec.limit("speed")
    if reg is None:
        return
    leg = character.poses.leg_length() if character is not None and spec.speed_leg_length else None
    lim = spec.limit("speed", leg)
    if lim[0] <= speed <= lim[1]:
        return
    what = f"{spec.name} walks at {lim[0]:g} to {lim[1]:g} m/s"
    if lim != reg:
        what += (f" on this body (leg length {leg:.3g} m; {reg[0]:g} to {reg[1]:g} m/s on the "
                 f"body the range was measured on, leg length {spec.speed_leg_length:g} m)")
    raise RunError(f"--speed {speed:g} is out of range: {what}")


def motion_source(motion) -> Path | Any:
    """A clip given by name, path or Motion: a bundled clip's name (``"walk"``) is its bundled
    file, unless a file of that name exists; ``None`` is the bundled walk."""
    from mjchar.bvh.bundled.assets import BUNDLED_MOTION_NAMES, motion_path

    if motion is None:
        return motion_path("walk")
    if isinstance(motion, str | os.PathLike):
        if (isinstance(motion, str) and motion in BUNDLED_MOTION_NAMES
                and not Path(motion).exists()):
            return motion_path(motion)
        return Path(motion)
    return motion


def check_model_file(model) -> None:
    """A one-line :class:`RunError` when ``model`` is a path to a file that is not an MJCF model
    (a BVH clip given as the model, or any other file), before MuJoCo's parser sees it; other
    values (``None``, an ``MjModel``, a missing file) are left to the Character."""
    if not isinstance(model, str | os.PathLike) or not os.path.isfile(model):
        return
    path = os.fspath(model)
    try:
        with open(path, "rb") as fh:
            head = fh.read(4096).decode("utf-8-sig", errors="replace").lstrip()
    except OSError as e:
        raise RunError(f"{path}: cannot read the model: {e.strerror or e}") from None
    stem = os.path.splitext(path)[0]
    if path.lower().endswith(".bvh") or head[:9].upper() == "HIERARCHY":
        raise RunError(f"{path} is a BVH clip, not an MJCF model: convert it (mjchar convert "
                       f"{path} -o {stem}.xml) and pass --model {stem}.xml")
    if "<mujoco" not in head:
        raise RunError(f"{path} is not an MJCF model (no <mujoco> element at its start): give "
                       f"a model written by mjchar convert (or the bundled one: no --model)")


def load_reference(spec: RunSpec, character: Character, progress=None, condition: bool = True):
    """The clip of ``spec`` as a ReferenceMotion in ``character``'s model (a clip on another
    skeleton: a one-line :class:`RunError` naming it and the fix).

    With ``condition`` (the default) the clip is conditioned first
    (:func:`mjchar.bvh.reference.conditioning.condition`: glitch frames repaired or refused,
    feet on the floor, stance-foot skating removed); when that changed it, the reference
    carries ``conditioning`` (what was done) and ``raw_reference`` (the raw clip's
    ReferenceMotion), so runs report their error against both."""
    from mjchar.bvh.editing.clips import leading_jumps, make_cyclic
    from mjchar.bvh.errors import ReferenceMotionError
    from mjchar.bvh.io import load
    from mjchar.bvh.reference.conditioning import ConditioningError
    from mjchar.bvh.reference.conditioning import condition as condition_clip
    from mjchar.bvh.reference.reference_motion import ReferenceMotion

    if isinstance(spec.motion, ReferenceMotion):  # prepared already: used as it is
        if spec.motion.model.nq != character.model.nq:
            raise RunError(f"the reference was prepared for a model with nq = "
                           f"{spec.motion.model.nq}, not this one ({character.model.nq})")
        return spec.motion
    source = motion_source(spec.motion)
    motion = load(source) if isinstance(source, Path) else source
    if motion.n_frames == 0:
        raise RunError(f"{source}: the clip has no frames (a skeleton without motion): give a "
                       f"clip to follow")
    motion = motion[leading_jumps(motion):]  # a zero pose written before the capture
    if spec.loop:
        motion = make_cyclic(motion)
    conditioned = None
    if condition:
        try:
            conditioned = condition_clip(motion, character.info, str(source))
        except ConditioningError as e:
            raise RunError(str(e)) from None
    try:
        counter = (progress.counter("preparing the clip", "frames")
                   if hasattr(progress, "counter") else None)
        kw = dict(info=character.info, floor=spec.floor or spec.controller_spec.floor,
                  cyclic=True if spec.loop else None)
        if conditioned is None or not conditioned.changed:
            return ReferenceMotion(character.model, motion, progress=counter, **kw)
        ref = ReferenceMotion(character.model, conditioned.motion, progress=counter, **kw)
        ref.conditioning = conditioned
        ref.raw_reference = ReferenceMotion(character.model, motion, **kw)
        return ref
    except ReferenceMotionError as e:
        if isinstance(source, Path) and "lacks" in str(e):
            raise RunError(f"{source}: {str(e).replace('CLIP', str(source))}") from None
        raise


def run(controller: str, scenario: str | None = None, *, model=None, motion=None,
        loop: bool = False, floor: str | None = None, timestep: float | None = None,
        control_dt: float | None = None, seed: int | None = None,
        frame_callback: Callable | None = None, **options):
    """Describe a run, build it and execute it (see the module docstring).

    ``options`` are routed by name: the controller's factory options (its
    ``ControllerSpec.options``: ``speed``, ``gait``, ``params``...) and the scenario's options
    (``duration``, ``force``, ``direction``...); an unknown name lists both.

    Returns:
        the scenario's result: a :class:`~mjchar.controllers.core.metrics.Result`, or for a
        protocol (``push-search``) its rates.
    """
    cspec = registry.get(controller)
    sspec = scenario_registry.get(scenario or cspec.default_scenario)
    factory, scen = {}, {}
    for key, value in options.items():
        if sspec.option(key) is not None and key != "seed":
            scen[key] = value
        elif key in cspec.options or "params" in cspec.options:  # (its factory checks params)
            factory[key] = value
        else:
            valid = sorted(set(cspec.options) | {o.name for o in sspec.options} - {"seed"})
            raise RunError(f"{key!r} is neither an option of {cspec.name} nor of the "
                           f"{sspec.name} scenario; valid: {', '.join(valid) or 'none'}")
    spec = RunSpec(controller, sspec.name, model, motion, loop, floor, timestep, control_dt,
                   seed, factory, scen)
    return spec.execute(frame_callback=frame_callback)
