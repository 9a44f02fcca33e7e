"""The controller registry: every controller is one module plus one :func:`register` call.

A :class:`ControllerSpec` says how to build a controller and what it can do: its
``abilities`` (which decide the scenarios it runs, :mod:`~mjchar.controllers.core.scenarios`),
the options its factory takes, its default physics time step, and the cells of ``mjchar bench``
it runs (and which of them it must survive). :func:`make_controller`, the run builder
(:mod:`~mjchar.controllers.core.builder`), the CLI's choices and help, the bench matrix and the
environments read this registry, so adding a controller touches no list anywhere else::

    from mjchar.controllers.core.registry import ControllerSpec, register

    register(ControllerSpec(
        name="my_balance", label="my balance controller", kind="balance",
        factory=lambda character, target=None, **options: MyBalance(**options),
        abilities=("stand",), default_scenario="stand",
        bench=("stand", "push-search"), expected=("stand",)))

The registration sits at the bottom of the controller's module; the subpackage's ``__init__``
imports its modules explicitly, and ``controllers/__init__`` imports the subpackages, which is
what fills the registry (no directory scanning, no entry points).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from mjchar.bvh.errors import MjcharError
from mjchar.bvh.reference.reference_motion import FLOOR_MODES

from .scenarios import registry as scenario_registry
from .scenarios.registry import ABILITIES

#: what a controller is, for the CLI and the bench: ``pd`` (the PD trackers: hold the standing
#: pose or follow the reference; hand-of-god wraps one), ``balance`` (balance controllers, on a
#: pose or a clip), ``walker`` (walks from its own start state, no reference), ``replay`` (plays
#: a saved trajectory)
KINDS = ("pd", "balance", "walker", "replay")
#: how the bench's push-search pushes a controller: from the standing pose on the pelvis, or
#: while walking at phases of the stride (needs the controller's FSM ``transitions``)
PUSH_MODES = ("standing", "walking")


class RegistryError(MjcharError):
    """An unknown controller name, a duplicate registration or an inconsistent spec."""


#: how a factory option's value is given on the command line: ``number`` (finite),
#: ``metres`` (>= 0), ``text``, ``pd`` (the name of a registered PD tracker), ``params``
#: (``NAME=VALUE``, repeatable), ``file`` (``mjchar run``'s positional FILE), ``squat`` (a depth
#: in metres >= 0 that the run turns into a squat profile)
OPTION_KINDS = ("number", "metres", "text", "pd", "params", "file", "squat")


@dataclass(frozen=True)
class FactoryOption:
    """A keyword option of controller factories, declared once: a controller lists the names
    it takes (:attr:`ControllerSpec.options`); ``mjchar run`` derives its flag, how the value
    parses, where it applies and its range from this declaration, and the run builder checks
    the same range for every entry point.

    Attributes:
        name: the factory keyword (``speed``).
        flag: the command-line flag (``--speed``), ``FILE`` for the positional argument.
        kind: one of :data:`OPTION_KINDS`.
        help: the ``--help`` line (what it does, its default).
        dest: the command line's attribute (default: the flag without dashes).
        low, high: the values accepted (``None``: no bound beyond the kind's).
        moving_only: used only in the scenarios that move (walk, slopes).
        metavar: the value's name in ``--help``.
        unit: the value's unit, for messages (``degrees``).
    """

    name: str
    flag: str
    kind: str
    help: str = ""
    dest: str = ""
    low: float | None = None
    high: float | None = None
    moving_only: bool = False
    metavar: str | None = None
    unit: str = ""

    def __post_init__(self) -> None:
        if self.kind not in OPTION_KINDS:
            raise RegistryError(f"option {self.name!r}: kind must be one of "
                                f"{', '.join(OPTION_KINDS)}, got {self.kind!r}")
        if not (self.flag.startswith("--") or self.flag == "FILE"):
            raise RegistryError(f"option {self.name!r}: the flag must start with -- (or be "
                                "FILE)")
        if not self.dest:
            object.__setattr__(self, "dest", "trajectory" if self.flag == "FILE"
                               else self.flag[2:].replace("-", "_"))

    def problem(self, value) -> str | None:
        """What is wrong with ``value`` (``None``: it is in range; only numbers are ranged)."""
        if not isinstance(value, int | float) or isinstance(value, bool):
            return None
        unit = f" {self.unit}" if self.unit else ""
        if self.low is not None and self.high is not None and self.low == -self.high:
            if abs(value) > self.high:
                return f"give {self.unit or 'values'} within +-{self.high:g}"
        elif self.high is not None and value > self.high:
            return f"at most {self.high:g}{unit}"
        elif self.low is not None and value < self.low:
            return f"at least {self.low:g}{unit}"
        return None


_DECLARED = (
    FactoryOption("speed", "--speed", "number", metavar="M/S", moving_only=True,
                  help="walk and slopes, controllers taking a speed (ipm, simbicon): desired "
                       "forward speed (default: the controller's own, ipm 1.0, simbicon its "
                       "gait's; ipm: 0 stops and stands; each controller's range is checked)"),
    FactoryOption("heading", "--heading", "number", metavar="DEG", low=-360.0, high=360.0,
                  unit="degrees",
                  help="ipm: desired heading in degrees (world yaw, 0 = +X, counter-clockwise)"),
    FactoryOption("gait", "--gait", "text", metavar="NAME",
                  help="simbicon: gait parameter set (default walk)"),
    FactoryOption("params", "--param", "params", metavar="NAME=VALUE",
                  help="a tunable of the controller (repeatable; {controllers}): mpc's "
                       "MpcOptions (samples=96, horizon=0.5, update=cem), ipm's IPMParams "
                       "(timing.step_time=0.5), simbicon's Gait (torso_pitch=0.2); VALUE is read "
                       "as JSON, else as text; `mjchar params CONTROLLER` lists every NAME with "
                       "its type, unit, range and default; a wrong type, NaN or a value out of "
                       "range is an error naming it"),
    FactoryOption("calibration", "--calibration", "text", metavar="FILE|none",
                  help="ipm, simbicon (walk gait): the walker's calibration for the body: a "
                       "file made by mjchar calibrate, or none for the defaults (default: the "
                       "body's stored calibration, made first if missing; the bundled "
                       "humanoid's is the defaults)"),
    FactoryOption("height", "--squat", "squat", metavar="M",
                  help="static_balance: lower the COM target by M metres (1 s in, over 1.5 s), "
                       "hold 1 s and rise again"),
    FactoryOption("tracker", "--tracker", "pd", help="PD variant hand_of_god wraps (default spd)"),
    FactoryOption("trajectory", "FILE", "file"),
    FactoryOption("policy", "FILE", "file"),
)
#: every factory option a controller may take, by name (:func:`declare_option` adds one)
FACTORY_OPTIONS: dict[str, FactoryOption] = {o.name: o for o in _DECLARED}


def declare_option(option: FactoryOption) -> FactoryOption:
    """Declare a factory option (a name declared twice raises :class:`RegistryError`)."""
    if option.name in FACTORY_OPTIONS:
        raise RegistryError(f"an option named {option.name!r} is already declared")
    FACTORY_OPTIONS[option.name] = option
    return option


@dataclass(frozen=True)
class ControllerSpec:
    """How to build one controller and what it supports.

    Attributes:
        name: the registry key (``mjchar run NAME``, a bench row).
        label: a short readable description (help texts, the bench table).
        kind: one of :data:`KINDS`.
        factory: ``factory(character, target=None, **options) -> controller``; ``target`` is what
            trackers follow (a pose ``(nq,)`` or a ReferenceMotion), walkers ignore it; replays
            take ``trajectory=`` (a saved trajectory or its path).
        abilities: what it can do (:data:`~mjchar.controllers.core.scenarios.registry.ABILITIES`:
            ``stand``, ``track``, ``walk``, ``replay``); the scenarios it runs are those that ask
            for one of them (:meth:`scenarios`).
        default_scenario: the scenario ``mjchar run NAME`` runs when none is given.
        options: the factory keyword options the CLI may pass (e.g. ``speed``, ``gait``;
            ``params``: it takes its tunables as keywords, from ``mjchar run --param``).
        timestep: its physics time step in s (``None``: the model's own), applied by
            :func:`make_controller` unless the character's step was chosen.
        steps: recovers from pushes by stepping (a push then counts as survived with a step).
        push: how the bench's push-search pushes it (:data:`PUSH_MODES`).
        bench: the ``mjchar bench`` scenarios it runs by default (among :meth:`scenarios`).
        expected: bench scenarios it must survive (a fall makes ``mjchar bench`` exit 1).
        trajectory_prefixes: replays: saved-trajectory file names (``PREFIX*.npz``) it plays by
            default, looked for in the bundled trajectories.
        limits: ``(option, low, high)`` ranges of numeric options the controller supports
            (measured, e.g. IPM's walking speeds); ``mjchar run`` refuses values outside them.
        speed_leg_length: the leg length (m, :meth:`Character.leg_length`) of the body the
            ``speed`` limits were measured on; on a body of leg length ``L`` they scale by
            ``sqrt(L / speed_leg_length)`` (the same Froude speeds, as the walkers scale their
            gaits), rounded outward to 0.01 m/s. ``None``: the speed limits hold in m/s on
            every body.
        speed_every_body: ``(low, high)`` m/s measured on every body (e.g. every rig of the
            skeleton zoo); the scaled range is widened to include it.
        floor: how a reference clip it tracks is placed on the floor by default
            (``ReferenceMotion(floor=...)``): ``"contact"`` (stance feet on the floor) for
            controllers that only have joint torques, ``"clip"`` for one with a root force,
            which can follow the clip's floating stance feet as recorded (grounding the clip
            made hand-of-god's swing toes scuff and catch on 5 of 10 zoo rigs: 2.1 -> 5.8 cm on
            the Unreal rig).
        own_clip: a controller made for one clip (a learned policy): ``own_clip(options) ->
            (motion, loop)``, the clip a run follows when it names none, and its looping
            (:meth:`~mjchar.controllers.core.builder.RunSpec.with_own_clip`).
        tunables: with the ``params`` option, what ``--param`` takes:
            ``tunables(**options) -> [Tunable]`` (:class:`~mjchar.controllers.core.param_fields.
            Tunable`: name, declaration, default, meaning; ``mjchar params`` prints them;
            ``options`` such as ``gait`` choose which defaults are shown).
    """

    name: str
    label: str
    kind: str
    factory: Callable[..., object]
    abilities: tuple[str, ...]
    default_scenario: str
    options: tuple[str, ...] = ()
    timestep: float | None = None
    steps: bool = False
    push: str = "standing"
    bench: tuple[str, ...] = ()
    expected: tuple[str, ...] = ()
    trajectory_prefixes: tuple[str, ...] = ()
    limits: tuple[tuple[str, float, float], ...] = ()
    speed_leg_length: float | None = None
    speed_every_body: tuple[float, float] | None = None
    floor: str = "contact"
    tunables: Callable[..., list] | None = None
    own_clip: Callable[[Mapping], tuple] | None = None

    def scenarios(self) -> tuple[str, ...]:
        """The registered scenarios it runs (those asking for one of its :attr:`abilities`), in
        registration order."""
        return tuple(s.name for s in scenario_registry.specs() if s.suits(self))

    def runs(self, scenario: str) -> bool:
        """Whether it runs ``scenario`` (a registered scenario name)."""
        return scenario_registry.get(scenario).suits(self)

    def limit(self, option: str, leg_length: float | None = None) -> tuple[float, float] | None:
        """``(low, high)`` of ``option`` from :attr:`limits`, ``None`` when unlimited; the
        ``speed`` limits on a body of ``leg_length`` m (``None``: as registered), see
        :attr:`speed_leg_length` and :attr:`speed_every_body`."""
        for name, lo, hi in self.limits:
            if name == option:
                if option == "speed" and leg_length is not None and self.speed_leg_length:
                    k = math.sqrt(leg_length / self.speed_leg_length)
                    lo = math.floor(round(lo * k * 100.0, 6)) / 100.0
                    hi = math.ceil(round(hi * k * 100.0, 6)) / 100.0
                    if self.speed_every_body:
                        every = self.speed_every_body
                        lo, hi = min(lo, every[0]), max(hi, every[1])
                return lo, hi
        return None

    def __post_init__(self) -> None:
        def bad(what: str) -> RegistryError:
            return RegistryError(f"controller spec {self.name!r}: {what}")

        if not self.name or not self.name.replace("_", "").isalnum():
            raise bad("the name must be letters, digits and underscores")
        if self.kind not in KINDS:
            raise bad(f"kind must be one of {', '.join(KINDS)}, got {self.kind!r}")
        if not callable(self.factory):
            raise bad("the factory must be callable")
        if not self.abilities or any(a not in ABILITIES for a in self.abilities):
            raise bad(f"abilities must be among {', '.join(ABILITIES)}, got {self.abilities}")
        runs = self.scenarios()
        if self.default_scenario not in runs:
            raise bad(f"the default scenario {self.default_scenario!r} is not one it runs "
                      f"({', '.join(runs)})")
        if any(s not in runs for s in self.bench):
            raise bad(f"bench scenarios must be among the ones it runs ({', '.join(runs)}), "
                      f"got {self.bench}")
        if any(s not in self.bench for s in self.expected):
            raise bad(f"expected scenarios {self.expected} must be bench scenarios")
        if self.push not in PUSH_MODES:
            raise bad(f"push must be one of {', '.join(PUSH_MODES)}, got {self.push!r}")
        undeclared = [o for o in self.options if o not in FACTORY_OPTIONS]
        if undeclared:
            raise bad(f"options {', '.join(undeclared)} are not declared (declare_option); "
                      f"declared: {', '.join(FACTORY_OPTIONS)}")
        for lim in self.limits:
            if len(lim) != 3 or lim[0] not in self.options or not lim[1] <= lim[2]:
                raise bad(f"limits must be (option, low, high) of its own options, got {lim}")
        if self.floor not in FLOOR_MODES:
            raise bad(f"floor must be one of {', '.join(FLOOR_MODES)}, got {self.floor!r}")
        if self.speed_leg_length is not None and not self.speed_leg_length > 0:
            raise bad(f"speed_leg_length must be positive metres, got {self.speed_leg_length}")
        if self.speed_every_body is not None and (
                len(self.speed_every_body) != 2 or self.limit("speed") is None
                or not self.speed_every_body[0] <= self.speed_every_body[1]):
            raise bad(f"speed_every_body must be (low, high) m/s with speed limits, got "
                      f"{self.speed_every_body}")
        if self.timestep is not None and not self.timestep > 0:
            raise bad(f"the time step must be positive, got {self.timestep}")
        if ("params" in self.options) != (self.tunables is not None):
            raise bad("a controller taking params declares them (tunables=...), and only one "
                      "taking params does")


_SPECS: dict[str, ControllerSpec] = {}


def register(spec: ControllerSpec) -> ControllerSpec:
    """Add ``spec`` to the registry (a duplicate name raises :class:`RegistryError`)."""
    if spec.name in _SPECS:
        raise RegistryError(f"a controller named {spec.name!r} is already registered")
    _SPECS[spec.name] = spec
    return spec


def unregister(name: str) -> None:
    """Remove a registration (for tests and interactive experiments)."""
    get(name)
    del _SPECS[name]


def get(name: str) -> ControllerSpec:
    """The spec of controller ``name``; an unknown name lists the valid ones."""
    try:
        return _SPECS[name]
    except KeyError:
        raise RegistryError(f"unknown controller {name!r}; choose from "
                            f"{', '.join(_SPECS)}") from None


def names(kind: str | None = None) -> tuple[str, ...]:
    """Registered controller names in registration order (of one ``kind`` if given)."""
    return tuple(n for n, s in _SPECS.items() if kind is None or s.kind == kind)


def specs() -> tuple[ControllerSpec, ...]:
    """Every registered spec, in registration order."""
    return tuple(_SPECS.values())


def default_timestep(name: str) -> float | None:
    """Physics time step controller ``name`` runs at by default (``None``: the model's own)."""
    return get(name).timestep


def make_controller(name: str, character, target=None, **options):
    """Build controller ``name`` for ``character`` through its registered factory, and give the
    character the physics time step the controller needs.

    The time step becomes the controller's own (a replay's trajectory step), its registered
    :attr:`ControllerSpec.timestep` or the model's own, unless the character's step was chosen
    (``Character(timestep=...)`` or ``set_timestep``), which is kept: a caller never has to
    remember a controller's step, and an explicit choice is never overridden.

    Args:
        name: a registered controller (:func:`names`).
        character: the :class:`~mjchar.controllers.core.character.Character` it will run on
            (``None``: build only, nothing applied).
        target: what trackers follow (a pose ``(nq,)`` or a ReferenceMotion); balance
            controllers hold it when it is a pose; walkers ignore it.
        options: keyword options of the factory (e.g. ``gains``, ``tracker`` for hand-of-god,
            ``height`` for static balance, ``gait`` for SIMBICON, ``speed``/``heading`` for IPM).
    """
    spec = get(name)
    controller = spec.factory(character, target, **options)
    if character is not None and not character.timestep_chosen:
        dt = getattr(controller, "timestep", None) or spec.timestep or character.model_timestep
        character.set_timestep(dt, chosen=False)
    return controller
