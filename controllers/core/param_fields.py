"""Parameters that carry their physical dimension and their valid values on their declaration.

A walker's parameter set is a frozen dataclass of groups (frozen dataclasses by concern); every
field of a group is declared through one of the helpers below, which stores a :class:`Spec` in
the field's metadata::

    @dataclass(frozen=True)
    class Swing:
        duration: float = time(0.5, gt=0)           # s, scales by sqrt(L / L_t), must be > 0
        heights: tuple[float, float, float] = length((0.04, 0.15, 0.02))   # m, x L / L_t
        blend: str = choice("smooth", ("quadratic", "smooth"))

    @dataclass(frozen=True)
    class Params:
        swing: Swing = field(default_factory=Swing)

From those declarations alone the set is carried to another body by dynamic similarity
(:func:`scaled`, factors from :func:`~mjchar.controllers.core.similarity.similarity_factors`),
checked (:func:`checked`: types, finite numbers, ranges, one line per bad value naming the
field and what it accepts) and overridden by dotted names (:func:`overridden`,
``{"swing.duration": 0.45}``). No list of field names is kept anywhere else.

Dimensions: ``length`` (m), ``time`` (s), ``speed`` (m/s), ``rate`` (1/s), ``per_length`` (1/m),
``torque_gain`` (N m/rad), ``damping_gain`` (N m s/rad), ``force`` (N), ``torque`` (N m), as
:mod:`~mjchar.controllers.core.similarity` scales them; ``acceleration`` (m/s^2, unchanged:
gravity is the same on every body) and ``none`` (angles, phases, scales, switches) stay.
"""

from __future__ import annotations

import difflib
import math
import numbers
from collections.abc import Iterator, Mapping
from dataclasses import Field, dataclass, field, fields, is_dataclass, replace

import numpy as np

from .similarity import similarity_factors

#: the metadata key of a field's :class:`Spec`
SPEC = "param"
#: dimensions that scale with the body (those :func:`similarity_factors` knows)
SCALED = tuple(similarity_factors(1.0, 1.0))
#: dimensions that stay: accelerations (Froude similarity keeps g) and pure numbers
UNSCALED = ("acceleration", "none")
#: what :meth:`Spec.coerce` returns for a value the field does not accept
REFUSED = object()


@dataclass(frozen=True)
class Spec:
    """What one parameter is: its dimension, unit and accepted values.

    Attributes:
        dimension: one of :data:`SCALED` or :data:`UNSCALED`.
        unit: shown in messages (``"s"``, ``"N m/rad"``; ``""`` for pure numbers).
        kind: ``"number"``, ``"flag"`` (a bool) or ``"choice"`` (one of ``choices``).
        size: 0 for one number, ``n`` for a tuple of ``n`` numbers (each checked).
        optional: ``None`` is accepted too.
        low, high: bounds (``None``: open); ``low_open`` / ``high_open``: strict.
    """

    dimension: str
    unit: str = ""
    kind: str = "number"
    size: int = 0
    optional: bool = False
    low: float | None = None
    low_open: bool = False
    high: float | None = None
    high_open: bool = False
    choices: tuple[str, ...] = ()

    def accepted(self) -> str:
        """What the field accepts, in words (``"a finite number > 0 (s)"``)."""
        if self.kind == "flag":
            return "true or false"
        if self.kind == "choice":
            return "one of " + ", ".join(repr(c) for c in self.choices)
        bounds = []
        if self.low is not None:
            bounds.append(f"{'>' if self.low_open else '>='} {self.low:g}")
        if self.high is not None:
            bounds.append(f"{'<' if self.high_open else '<='} {self.high:g}")
        what = "a finite number" if self.size == 0 else f"{self.size} finite numbers"
        if bounds:
            what += (" " if self.size == 0 else ", each ") + " and ".join(bounds)
        if self.unit:
            what += f" ({self.unit})"
        return what + (", or null" if self.optional else "")

    def coerce(self, value):
        """``value`` as stored (ints as floats, sequences as tuples of floats), or
        :data:`REFUSED` when the field does not accept it."""
        if value is None:
            return None if self.optional else REFUSED
        if self.kind == "flag":
            return value if isinstance(value, bool) else REFUSED
        if self.kind == "choice":
            return value if isinstance(value, str) and value in self.choices else REFUSED
        if self.size == 0:
            return self._number(value)
        if isinstance(value, str | bytes) or not hasattr(value, "__len__"):
            return REFUSED
        if len(value) != self.size:
            return REFUSED
        out = tuple(self._number(x) for x in value)
        return REFUSED if any(x is REFUSED for x in out) else out

    def _number(self, x):
        if isinstance(x, bool | np.bool_) or not isinstance(x, numbers.Real):
            return REFUSED
        try:
            x = float(x)
        except OverflowError:
            return REFUSED
        if not math.isfinite(x):
            return REFUSED
        if self.low is not None and (x < self.low or (self.low_open and x == self.low)):
            return REFUSED
        if self.high is not None and (x > self.high or (self.high_open and x == self.high)):
            return REFUSED
        return x


def _declare(dimension: str, unit: str):
    """A field helper for parameters of one dimension: ``helper(default, *, gt=, ge=, lt=,
    le=, size=, optional=, unit=)`` (``size`` from a tuple default unless given)."""

    def helper(default, *, gt: float | None = None, ge: float | None = None,
               lt: float | None = None, le: float | None = None, size: int | None = None,
               optional: bool = False, unit: str = unit) -> Field:
        if size is None:
            size = len(default) if isinstance(default, tuple) else 0
        spec = Spec(dimension, unit, size=size, optional=optional,
                    low=gt if gt is not None else ge, low_open=gt is not None,
                    high=lt if lt is not None else le, high_open=lt is not None)
        stored = spec.coerce(default)
        if stored is REFUSED or stored != default:
            raise ValueError(f"default {default!r} is not {spec.accepted()}")
        return field(default=default, metadata={SPEC: spec})

    helper.__name__ = helper.__qualname__ = dimension
    return helper


length = _declare("length", "m")
time = _declare("time", "s")
speed = _declare("speed", "m/s")
rate = _declare("rate", "1/s")
per_length = _declare("per_length", "1/m")
acceleration = _declare("acceleration", "m/s^2")
torque_gain = _declare("torque_gain", "N m/rad")
damping_gain = _declare("damping_gain", "N m s/rad")
force = _declare("force", "N")
torque = _declare("torque", "N m")
#: pure numbers: angles (rad), phases (of the nominal step), scales and fractions
angle = _declare("none", "rad")
phase = _declare("none", "step phase")
number = _declare("none", "")


def flag(default: bool) -> Field:
    """A switch (``True`` / ``False``)."""
    return field(default=default, metadata={SPEC: Spec("none", kind="flag")})


def choice(default: str, choices: tuple[str, ...]) -> Field:
    """One of ``choices`` (text)."""
    return field(default=default, metadata={SPEC: Spec("none", kind="choice", choices=choices)})


# -- parameter sets: a frozen dataclass of groups ------------------------------------------------
def spec_of(f: Field) -> Spec:
    """The :class:`Spec` a field was declared with (``TypeError`` for a plain field)."""
    spec = f.metadata.get(SPEC)
    if not isinstance(spec, Spec):
        raise TypeError(f"field {f.name} was not declared with a dimension (length(...), ...)")
    if spec.dimension not in SCALED + UNSCALED:
        raise TypeError(f"field {f.name}: unknown dimension {spec.dimension!r}")
    return spec


def group_types(cls) -> dict[str, type]:
    """``{group name: group dataclass}`` of a parameter set class (every field a group)."""
    out = {}
    for f in fields(cls):
        kind = f.default_factory
        if not (isinstance(kind, type) and is_dataclass(kind)):
            raise TypeError(f"{cls.__name__}.{f.name} is not a group (default_factory=<dataclass>)")
        out[f.name] = kind
    return out


def leaves(cls) -> Iterator[tuple[str, str, Spec]]:
    """``(group, field, spec)`` for every parameter of a parameter set class, in declaration
    order (checks that every field has a dimension)."""
    for g, kind in group_types(cls).items():
        for f in fields(kind):
            yield g, f.name, spec_of(f)


def names(cls) -> list[str]:
    """Every parameter's dotted name (``"timing.step_time"``), in declaration order."""
    return [f"{g}.{n}" for g, n, _ in leaves(cls)]


def flat(params) -> dict[str, object]:
    """``{dotted name: value}`` of a parameter set."""
    return {f"{g}.{n}": getattr(getattr(params, g), n) for g, n, _ in leaves(type(params))}


def checked(params, error: type[Exception], what: str) -> dict[str, object]:
    """The groups of ``params`` whose values needed converting (ints to floats, lists to
    tuples), converted, as ``{group name: new group}``; raises ``error`` (one line: ``{what}
    timing.step_time must be a finite number > 0 (s), got -1``) for a value a field does not
    accept or a group of the wrong type."""
    out = {}
    for g, kind in group_types(type(params)).items():
        group = getattr(params, g)
        if type(group) is not kind:
            raise error(f"{what} group {g} must be a {kind.__name__}, got {group!r}")
        changes = {}
        for f in fields(kind):
            spec, value = spec_of(f), getattr(group, f.name)
            stored = spec.coerce(value)
            if stored is REFUSED:
                raise error(f"{what} {g}.{f.name} must be {spec.accepted()}, got {value!r}")
            if not _same(stored, value):
                changes[f.name] = stored
        if changes:
            out[g] = replace(group, **changes)
    return out


def _same(stored, value) -> bool:
    """Whether ``value`` is already stored as ``stored`` (same types, tuples of floats)."""
    if type(stored) is not type(value) or stored != value:
        return False
    return not isinstance(value, tuple) or all(type(x) is float for x in value)


def scaled(params, factors: Mapping[str, float]):
    """``params`` with every dimensional value multiplied by its dimension's factor (``None``
    and unscaled dimensions left as they are; tuples element by element)."""
    groups = {}
    for g, kind in group_types(type(params)).items():
        group = getattr(params, g)
        changes = {}
        for f in fields(kind):
            spec, v = spec_of(f), getattr(group, f.name)
            if spec.dimension in UNSCALED or v is None:
                continue
            k = factors[spec.dimension]
            changes[f.name] = tuple(x * k for x in v) if isinstance(v, tuple) else v * k
        groups[g] = replace(group, **changes) if changes else group
    return replace(params, **groups)


def overridden(params, overrides: Mapping[str, object], error: type[Exception], what: str):
    """``params`` with ``overrides`` (``{"group.field": value}``) applied; an unknown name
    raises ``error`` listing the valid ones (and the likely meant ones first)."""
    valid = names(type(params))
    unknown = [n for n in overrides if n not in valid]
    if unknown:
        hints = [v for n in unknown for v in _likely(n, valid)]
        meant = f" (did you mean {', '.join(dict.fromkeys(hints))}?)" if hints else ""
        raise error(f"unknown {what}(s) {', '.join(unknown)}{meant}; valid: {', '.join(valid)}")
    per_group: dict[str, dict] = {}
    for name, value in overrides.items():
        g, leaf = name.split(".")
        per_group.setdefault(g, {})[leaf] = value
    return replace(params, **{g: replace(getattr(params, g), **kv)
                              for g, kv in per_group.items()})


def _likely(name: str, valid: list[str]) -> list[str]:
    """The dotted names ``name`` most likely means: those with ``name`` as their field, or as
    their group and field joined by ``_`` either way round (a flat name: ``human_top``,
    ``slow_speed``); else those whose field ``name`` ends with (``human_push_off``) or that is
    close to it."""
    group, _, leaf = name.rpartition(".")
    pool = [v for v in valid if v.startswith(group + ".")] or valid
    parts = {v: v.split(".") for v in pool}
    exact = [v for v, (g, f) in parts.items()
             if leaf in (f, f"{g}_{f}", f"{f}_{g}") or name == f"{g}_{f}"]
    if exact:
        return exact
    near = set(difflib.get_close_matches(leaf, {f for _, f in parts.values()}, n=3, cutoff=0.8))
    return [v for v, (_, f) in parts.items() if f in near or leaf.endswith("_" + f)]
