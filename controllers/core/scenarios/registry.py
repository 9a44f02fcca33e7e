"""The scenario registry: every scenario is one module plus one :func:`register` call.

A :class:`ScenarioSpec` says what a scenario measures, which controllers it suits (by what they
can do: their ``abilities``), the options its procedure takes (each with its command-line flag),
its default duration, whether it follows a reference clip, and how ``mjchar bench`` runs it.
``mjchar run`` (its ``--scenario`` choices, flags and help), ``mjchar bench`` (its columns),
:func:`run_scenario` and the run builder (:mod:`mjchar.controllers.core.builder`) all read this
registry, so a new scenario touches no list anywhere else::

    from mjchar.controllers.core.scenarios.registry import ScenarioSpec, register
    from mjchar.controllers.core.scenarios.options import DURATION
    from mjchar.controllers.core.scenarios.shared import simulate, standing_pose

    def sway(run, *, duration=5.0):
        return simulate(run.character, run.controller, duration=duration, scenario="sway",
                        qpos=standing_pose(run.character), **run.simulate_options())

    register(ScenarioSpec(name="sway", measures="stand for a while", procedure=sway,
                          needs=("stand",), options=(DURATION,), default_duration=5.0))

A procedure is ``procedure(run, **options) -> Result`` (or, for a protocol of many runs such as
``push-search``, a result with ``to_dict()`` and ``summary()``), where ``run`` is a :class:`Run`:
the character, the controller, the reference clip (or ``None``), the frame callback and
control step, and, when the run was described with a
:class:`~mjchar.controllers.core.builder.RunSpec`, that description (a protocol rebuilds the run
from it for every trial).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from mjchar.bvh.errors import MjcharError

#: what a controller can do, which is what a scenario asks for (``ControllerSpec.abilities``):
#: ``stand`` holds the standing pose under its own control, ``track`` follows a reference clip,
#: ``walk`` walks from its own start state with no reference, ``replay`` plays a saved
#: trajectory (its own start state, time step and reference)
ABILITIES = ("stand", "track", "walk", "replay")
#: kinds of option value, which the command line parses and range-checks
OPTION_KINDS = ("seconds", "newtons", "degrees", "count", "seed", "switch", "metres", "number")
#: what a scenario does with a reference clip: ``none``; ``trackers`` (a clip is loaded for
#: controllers that track, walkers walk alone); ``required``
REFERENCE_MODES = ("none", "trackers", "required")


class ScenarioError(MjcharError):
    """A scenario was asked for something impossible (unknown name or option, missing
    reference), or a registration is inconsistent."""


@dataclass(frozen=True)
class Option:
    """One option of a scenario: a keyword of its procedure and the flag ``mjchar run`` gives it.

    Attributes:
        name: the procedure's keyword (``force``).
        flag: the command-line flag (``--push``).
        kind: one of :data:`OPTION_KINDS` (how the flag parses its value and which values it
            accepts: ``seconds`` > 0, ``newtons`` and ``metres`` >= 0, ``degrees`` finite or a
            direction name, ``count`` a whole number >= 1, ``seed`` a whole number >= 0,
            ``switch`` takes no value).
        help: one line for ``--help`` (what it does, its default).
        high: the largest value accepted (``None``: no bound beyond the kind's).
        metavar: the value's name in ``--help``.
    """

    name: str
    flag: str
    kind: str
    help: str
    high: float | None = None
    metavar: str | None = None

    def __post_init__(self) -> None:
        if self.kind not in OPTION_KINDS:
            raise ScenarioError(f"option {self.name!r}: kind must be one of "
                                f"{', '.join(OPTION_KINDS)}, got {self.kind!r}")
        if not self.flag.startswith("--"):
            raise ScenarioError(f"option {self.name!r}: the flag must start with --")


@dataclass(frozen=True)
class BenchRun:
    """One run of a bench cell: its label, its seed (``None``: none) and the procedure's options."""

    label: str
    seed: int | None = None
    options: Mapping[str, Any] = field(default_factory=dict)


def _one_run(settings: Mapping[str, Any], controller) -> list[BenchRun]:
    """The bench default: one run at the scenario's own defaults."""
    return [BenchRun("default")]


@dataclass(frozen=True)
class ScenarioSpec:
    """How to run one scenario and what it suits.

    Attributes:
        name: the registry key (``mjchar run --scenario NAME``, a bench column).
        measures: one line: what it does and measures (help texts, docs).
        procedure: ``procedure(run, **options)``, see the module docstring.
        needs: the abilities (:data:`ABILITIES`) a controller must have one of to run it.
        options: the :class:`Option` keywords the procedure takes.
        default_duration: simulated s when no ``duration`` is given (``None``: the clip's, or
            the procedure's own protocol).
        reference: what it does with a clip (:data:`REFERENCE_MODES`).
        moving: the controller moves (walks, tracks); elsewhere a walker that can also stand
            stands still (its speed command is 0).
        protocol: it runs the controller many times, rebuilding it from the run's description
            (so it needs a :class:`~mjchar.controllers.core.builder.RunSpec`).
        bench: ``bench(settings, controller_spec) -> [BenchRun]``: the runs of one bench cell,
            from the bench's settings (a mapping of its configuration: durations, seeds, forces).
        excludes: controller names it does not suit although their abilities would (with the
            reason in a comment where it is registered).
    """

    name: str
    measures: str
    procedure: Callable[..., Any]
    needs: tuple[str, ...]
    options: tuple[Option, ...] = ()
    default_duration: float | None = None
    reference: str = "none"
    moving: bool = False
    protocol: bool = False
    bench: Callable[[Mapping[str, Any], Any], list[BenchRun]] = _one_run
    excludes: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        def bad(what: str) -> ScenarioError:
            return ScenarioError(f"scenario spec {self.name!r}: {what}")

        if not self.name or not self.name.replace("-", "").replace("_", "").isalnum():
            raise bad("the name must be letters, digits, '-' and '_'")
        if not callable(self.procedure) or not callable(self.bench):
            raise bad("the procedure and bench must be callable")
        if not self.needs or any(a not in ABILITIES for a in self.needs):
            raise bad(f"needs must be among {', '.join(ABILITIES)}, got {self.needs}")
        if self.reference not in REFERENCE_MODES:
            raise bad(f"reference must be one of {', '.join(REFERENCE_MODES)}")
        names = [o.name for o in self.options]
        if len(set(names)) != len(names):
            raise bad(f"an option is listed twice: {names}")
        if self.default_duration is not None and not (
                math.isfinite(self.default_duration) and self.default_duration > 0):
            raise bad(f"the default duration must be positive seconds, got "
                      f"{self.default_duration}")

    def option(self, name: str) -> Option | None:
        """The :class:`Option` called ``name``, ``None`` when it takes no such option."""
        return next((o for o in self.options if o.name == name), None)

    def suits(self, controller) -> bool:
        """Whether ``controller`` (a :class:`~mjchar.controllers.core.registry.ControllerSpec`)
        can run this scenario: it has one of :attr:`needs` and is not excluded."""
        return (controller.name not in self.excludes
                and any(a in controller.abilities for a in self.needs))


_SPECS: dict[str, ScenarioSpec] = {}
_OPTIONS: dict[str, Option] = {}


def register(spec: ScenarioSpec) -> ScenarioSpec:
    """Add ``spec`` to the registry. A duplicate name, or an option whose name another
    scenario declares differently (one flag per name on the command line), raises
    :class:`ScenarioError`."""
    if spec.name in _SPECS:
        raise ScenarioError(f"a scenario named {spec.name!r} is already registered")
    for o in spec.options:
        known = _OPTIONS.get(o.name)
        if known is not None and known != o:
            raise ScenarioError(f"scenario {spec.name!r}: option {o.name!r} differs from the "
                                f"one already registered ({known.flag}, {known.kind})")
        clash = next((k for k in _OPTIONS.values() if k.flag == o.flag and k.name != o.name),
                     None)
        if clash is not None:
            raise ScenarioError(f"scenario {spec.name!r}: flag {o.flag} is option "
                                f"{clash.name!r} already")
    _SPECS[spec.name] = spec
    for o in spec.options:
        _OPTIONS[o.name] = o
    return spec


def unregister(name: str) -> None:
    """Remove a registration (for tests and interactive experiments)."""
    get(name)
    del _SPECS[name]
    used = {o.name for s in _SPECS.values() for o in s.options}
    for n in [n for n in _OPTIONS if n not in used]:
        del _OPTIONS[n]


def get(name: str) -> ScenarioSpec:
    """The spec of scenario ``name``; an unknown name lists the valid ones."""
    try:
        return _SPECS[name]
    except KeyError:
        raise ScenarioError(f"unknown scenario {name!r}; choose from {', '.join(_SPECS)}") \
            from None


def names() -> tuple[str, ...]:
    """Registered scenario names, in registration order."""
    return tuple(_SPECS)


def specs() -> tuple[ScenarioSpec, ...]:
    """Every registered spec, in registration order."""
    return tuple(_SPECS.values())


def options() -> tuple[Option, ...]:
    """Every option of every registered scenario, once each (registration order)."""
    return tuple(_OPTIONS.values())


@dataclass
class Run:
    """One run being executed: what a scenario's procedure works on.

    Attributes:
        character: the :class:`~mjchar.controllers.core.character.Character` (its time step
            already what the controller needs).
        controller: the controller (``reset``/``act``).
        reference: the reference clip (a ReferenceMotion) or ``None``.
        spec: the run's description (a :class:`~mjchar.controllers.core.builder.RunSpec`), when it
            was described rather than built by hand; protocols rebuild the run from it.
        frame_callback: called as ``frame_callback(character)`` after the reset and after every
            control step (video, BVH export, probes).
        control_dt: seconds between control steps (``None``: every physics step).
        seed: the run's seed (scenarios that randomise take it as their ``seed`` option).
        progress: a :class:`~mjchar.progress.Progress`: the simulation shows
            its simulated time on it (a bar on a terminal) and long protocols write their
            lines through it (any callable of one line will do for those); ``None``: quiet.
    """

    character: Any
    controller: Any
    reference: Any = None
    spec: Any = None
    frame_callback: Callable | None = None
    control_dt: float | None = None
    seed: int | None = None
    progress: Callable[[str], None] | None = None

    def execute(self):
        """Run it through its scenario's procedure (the scenario and its options are the
        description's, ``spec``): the scenario's result (a Result, or a protocol's rates)."""
        if self.spec is None:
            raise ScenarioError("a run built by hand has no scenario to execute: use "
                                "run_scenario(name, character, controller)")
        sspec = self.spec.scenario_spec
        options = dict(self.spec.scenario_options)
        if self.spec.seed is not None and sspec.option("seed") is not None:
            options["seed"] = self.spec.seed
        return sspec.procedure(self, **options)

    def simulate_options(self) -> dict:
        """The keywords of :func:`~mjchar.controllers.core.scenarios.shared.simulate` this
        run sets (frame callback, control step, progress bar)."""
        bar = self.progress if hasattr(self.progress, "start") else None
        return {"frame_callback": self.frame_callback, "control_dt": self.control_dt,
                "progress": bar}


def run_scenario(name: str, character, controller, *, reference=None, frame_callback=None,
                 control_dt: float | None = None, **options):
    """Run scenario ``name`` (:func:`names`) with a character and controller built by hand.

    Args:
        reference: the clip for scenarios that follow one.
        frame_callback, control_dt: see :class:`Run`.
        options: the scenario's options (its :attr:`ScenarioSpec.options`, e.g. ``duration``,
            ``force``); an unknown one lists the valid ones.

    A protocol of many runs (``push-search``) rebuilds the controller for every trial and needs
    the run described: use :func:`mjchar.controllers.core.builder.run` for it.
    """
    spec = get(name)
    check_options(spec, options)
    if spec.protocol:
        raise ScenarioError(f"{name} runs the controller many times and rebuilds it for each "
                            "run: describe the run with mjchar.controllers.run(...) (or "
                            "RunSpec) instead of a built controller")
    run = Run(character, controller, reference, None, frame_callback, control_dt)
    return spec.procedure(run, **options)


def check_options(spec: ScenarioSpec, options: Mapping[str, Any]) -> None:
    """A :class:`ScenarioError` naming the first option ``spec`` does not take."""
    for key in options:
        if spec.option(key) is None:
            valid = ", ".join(o.name for o in spec.options) or "none"
            raise ScenarioError(f"the {spec.name} scenario takes no option {key!r}; its "
                                f"options: {valid}")
