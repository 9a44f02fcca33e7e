"""Parameters that carry their physical dimension and their valid values on their declaration.

A controller's tunables are dataclass fields declared through the helpers below, each of which
stores a :class:`Spec` (dimension, unit, kind, range) in the field's metadata. A walker's
parameter set is a frozen dataclass of groups (frozen dataclasses by concern)::

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
``{"swing.duration": 0.45}``). A flat set of fields (SIMBICON's gait, the MPC's options) is
checked with :func:`check_fields`. :func:`tunables` lists the fields with their kind, unit,
range, default and the one-line meaning their class docstring gives them (``mjchar params``).
No list of field names is kept anywhere else.

Dimensions: ``length`` (m), ``time`` (s), ``speed`` (m/s), ``rate`` (1/s), ``per_length`` (1/m),
``torque_gain`` (N m/rad), ``damping_gain`` (N m s/rad), ``force`` (N), ``torque`` (N m), as
:mod:`~mjchar.controllers.core.similarity` scales them; ``acceleration`` (m/s^2, unchanged:
gravity is the same on every body) and ``none`` (angles, phases, scales, counts, switches) stay.

Every number also has a plausible magnitude, :data:`CAPS` (by helper): a bound the declaration
does not give is the cap (a time step of 1e9 s, an angle of 1e9 rad or a gain of 1e30 is a
one-line error, not a fall). Ranges are for the body the defaults were tuned on (what
``--param`` takes); a set carried to another body by :func:`scaled` is not checked again.
"""

from __future__ import annotations

import copy
import difflib
import math
import numbers
import re
from collections.abc import Iterator, Mapping
from dataclasses import MISSING, Field, dataclass, field, fields, is_dataclass, replace
from typing import NamedTuple

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
#: kinds of value a field holds
KINDS = ("number", "integer", "flag", "choice", "mapping")
#: the largest magnitude each helper accepts when its declaration gives no bound, for a
#: human-sized body: generous (ten times anything a walker or tracker was tuned with) but
#: finite, so an absurd value is refused instead of making the character fall
CAPS = {"length": 10.0, "time": 10.0, "speed": 20.0, "rate": 1e3, "per_length": 1e3,
        "acceleration": 100.0, "torque_gain": 1e5, "damping_gain": 1e4, "force": 1e5,
        "torque": 1e4, "angle": 2 * math.pi, "phase": 10.0, "number": 1e3, "integer": 1e6}


@dataclass(frozen=True)
class Spec:
    """What one parameter is: its dimension, unit and accepted values.

    Attributes:
        dimension: one of :data:`SCALED` or :data:`UNSCALED`.
        unit: shown in messages (``"s"``, ``"N m/rad"``; ``""`` for pure numbers).
        kind: one of :data:`KINDS`: ``"number"``, ``"integer"`` (a whole number, stored as an
            int), ``"flag"`` (a bool), ``"choice"`` (one of ``choices``) or ``"mapping"`` (a
            dict of numbers, keys among ``choices`` when given, each value in the range).
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

    def type_name(self) -> str:
        """The kind of value in a word or two (``"number"``, ``"3 numbers"``, ``"integer"``)."""
        name = {"number": "number" if self.size == 0 else f"{self.size} numbers",
                "integer": "integer", "flag": "true/false", "choice": "text",
                "mapping": "object"}[self.kind]
        return name + (" or null" if self.optional else "")

    def range_text(self) -> str:
        """The accepted values without the type (``"> 0 and <= 10"``, ``"one of 'a', 'b'"``);
        ``""`` when any value of the type is."""
        if self.kind == "flag":
            return ""
        if self.kind == "choice":
            return "one of " + ", ".join(repr(c) for c in self.choices)
        shown = (lambda x: f"{int(x)}") if self.kind == "integer" else (lambda x: f"{x:g}")
        bounds = []
        if self.low is not None:
            bounds.append(f"{'>' if self.low_open else '>='} {shown(self.low)}")
        if self.high is not None:
            bounds.append(f"{'<' if self.high_open else '<='} {shown(self.high)}")
        return " and ".join(bounds)

    def accepted(self) -> str:
        """What the field accepts, in words (``"a finite number > 0 and <= 10 (s)"``)."""
        if self.kind in ("flag", "choice"):
            what = "true or false" if self.kind == "flag" else self.range_text()
            return what + (", or null" if self.optional else "")
        bounds = self.range_text()
        if self.kind == "mapping":
            keys = f" ({', '.join(self.choices)})" if self.choices else ""
            what = f"an object of names{keys} to finite numbers"
            what += (", each " + bounds) if bounds else ""
        elif self.kind == "integer":
            what = "an integer" + (" " + bounds if bounds else "")
        else:
            what = "a finite number" if self.size == 0 else f"{self.size} finite numbers"
            if bounds:
                what += (" " if self.size == 0 else ", each ") + bounds
        if self.unit:
            what += f" ({self.unit})"
        return what + (", or null" if self.optional else "")

    def coerce(self, value):
        """``value`` as stored (ints as floats, sequences as tuples of floats, whole numbers of
        an ``integer`` field as ints), or :data:`REFUSED` when the field does not accept it."""
        if value is None:
            return None if self.optional else REFUSED
        if self.kind == "flag":
            return value if isinstance(value, bool) else REFUSED
        if self.kind == "choice":
            return value if isinstance(value, str) and value in self.choices else REFUSED
        if self.kind == "integer":
            if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Integral):
                return REFUSED
            x = self._number(value)
            return REFUSED if x is REFUSED else int(value)
        if self.kind == "mapping":
            if not isinstance(value, Mapping):
                return REFUSED
            out = {}
            for k, v in value.items():
                x = self._number(v)
                if not isinstance(k, str) or (self.choices and k not in self.choices) \
                        or x is REFUSED:
                    return REFUSED
                out[k] = x
            return out
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


def _spec(dimension: str, unit: str, cap: float, kind: str = "number", *, size: int = 0,
          gt=None, ge=None, lt=None, le=None, optional: bool = False,
          choices: tuple[str, ...] = ()) -> Spec:
    """A :class:`Spec` whose missing bounds are ``-cap`` and ``cap``."""
    low, low_open = (gt, True) if gt is not None else (ge, False)
    high, high_open = (lt, True) if lt is not None else (le, False)
    return Spec(dimension, unit, kind, size=size, optional=optional,
                low=-cap if low is None else low, low_open=low_open,
                high=cap if high is None else high, high_open=high_open, choices=choices)


def _field(spec: Spec, default) -> Field:
    """A dataclass field of ``spec`` (``default``: its value, ``MISSING`` for none); a default
    the spec refuses, or stores differently, is a declaration error."""
    if default is MISSING:
        return field(metadata={SPEC: spec})
    stored = spec.coerce(default)
    if stored is REFUSED or stored != default:
        raise ValueError(f"default {default!r} is not {spec.accepted()}")
    return field(default=default, metadata={SPEC: spec})


def _declare(dimension: str, unit: str, cap_name: str | None = None):
    """A field helper for parameters of one dimension: ``helper(default, *, gt=, ge=, lt=,
    le=, size=, optional=, unit=)`` (``size`` from a tuple default unless given; ``default``
    may be left out for a field every instance sets; bounds not given are the helper's
    :data:`CAPS`)."""
    cap = CAPS[cap_name or dimension]

    def helper(default=MISSING, *, gt: float | None = None, ge: float | None = None,
               lt: float | None = None, le: float | None = None, size: int | None = None,
               optional: bool = False, unit: str = unit) -> Field:
        if size is None:
            size = len(default) if isinstance(default, tuple) else 0
        return _field(_spec(dimension, unit, cap, size=size, gt=gt, ge=ge, lt=lt, le=le,
                            optional=optional), default)

    helper.__name__ = helper.__qualname__ = cap_name or dimension
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
angle = _declare("none", "rad", "angle")
phase = _declare("none", "step phase", "phase")
number = _declare("none", "", "number")


def integer(default=MISSING, *, ge: int | None = None, le: int | None = None,
            optional: bool = False, unit: str = "") -> Field:
    """A whole number (counts, seeds), stored as an int."""
    return _field(_spec("none", unit, CAPS["integer"], "integer", ge=ge, le=le,
                        optional=optional), default)


def mapping(default_factory, *, ge: float | None = None, le: float | None = None,
            keys: tuple[str, ...] = (), unit: str = "") -> Field:
    """A dict of names (among ``keys`` when given) to numbers, each within the bounds."""
    spec = _spec("none", unit, CAPS["number"], "mapping", ge=ge, le=le, choices=keys)
    if spec.coerce(default_factory()) is REFUSED:
        raise ValueError(f"default {default_factory()!r} is not {spec.accepted()}")
    return field(default_factory=default_factory, metadata={SPEC: spec})


def flag(default: bool = MISSING) -> Field:
    """A switch (``True`` / ``False``)."""
    return _field(Spec("none", kind="flag"), default)


def choice(default: str, choices: tuple[str, ...]) -> Field:
    """One of ``choices`` (text)."""
    return _field(Spec("none", kind="choice", choices=choices), default)


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


def check_fields(obj, error: type[Exception], what: str, prefix: str = "",
                 skip: tuple[str, ...] = ()) -> dict[str, object]:
    """The declared fields of one dataclass instance ``obj`` whose values needed converting,
    converted, as ``{field name: value}``; raises ``error`` (one line: ``{what}
    {prefix}{field} must be ..., got ...``) for a value a field does not accept. Fields
    without a :class:`Spec` and those in ``skip`` are left to the caller."""
    changes = {}
    for f in fields(obj):
        if f.name in skip or not isinstance(f.metadata.get(SPEC), Spec):
            continue
        spec, value = spec_of(f), getattr(obj, f.name)
        stored = spec.coerce(value)
        if stored is REFUSED:
            raise error(f"{what} {prefix}{f.name} must be {spec.accepted()}, got "
                        f"{_shown(value)}")
        if not _same(stored, value):
            changes[f.name] = stored
    return changes


def _shown(value) -> str:
    """A refused value as the message shows it (``repr``, cut to 60 characters)."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


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
        for f in fields(kind):
            spec_of(f)  # every field of a group is declared
        changes = check_fields(group, error, what, prefix=f"{g}.")
        if changes:
            out[g] = replace(group, **changes)
    return out


def rebuilt(obj, **changes):
    """A copy of the dataclass instance ``obj`` with ``changes``, built without running its
    checks again: for values derived from checked ones by positive factors (a parameter set
    carried to another body keeps its signs and kinds; its ranges are the tuned body's)."""
    out = copy.copy(obj)
    for k, v in changes.items():
        object.__setattr__(out, k, v)
    return out


def _same(stored, value) -> bool:
    """Whether ``value`` is already stored as ``stored`` (same types, tuples of floats)."""
    if type(stored) is not type(value) or stored != value:
        return False
    return not isinstance(value, tuple) or all(type(x) is float for x in value)


def scaled(params, factors: Mapping[str, float]):
    """``params`` with every dimensional value multiplied by its dimension's factor (``None``
    and unscaled dimensions left as they are; tuples element by element), not checked again
    (:func:`rebuilt`: the ranges are the tuned body's)."""
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
        groups[g] = rebuilt(group, **changes) if changes else group
    return rebuilt(params, **groups)


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


def suggest(name: str, valid) -> list[str]:
    """The valid names closest to a mistyped ``name`` (at most three)."""
    return difflib.get_close_matches(name, list(valid), n=3, cutoff=0.75)


# -- listing: what ``mjchar params`` shows -------------------------------------------------------
class Tunable(NamedTuple):
    """One tunable as ``mjchar params`` lists it: its name as ``--param`` takes it, its
    :class:`Spec`, its default value and a one-line meaning."""

    name: str
    spec: Spec
    default: object
    meaning: str

    def row(self) -> dict:
        """A JSON-ready description (``name``, ``type``, ``unit``, ``range``, ``default``,
        ``meaning``)."""
        default = self.default
        if isinstance(default, tuple):
            default = list(default)
        return {"name": self.name, "type": self.spec.type_name(), "unit": self.spec.unit,
                "range": self.spec.range_text(), "default": default, "meaning": self.meaning}


_ATTR_RE = re.compile(r"^(\s*)([A-Za-z_][\w]*(?:,\s*[A-Za-z_][\w]*)*):\s*(.*)$")


def field_docs(cls) -> dict[str, str]:
    """``{field name: one-line meaning}`` from the ``Attributes:`` section of ``cls``'s
    docstring (an entry may name several fields: ``slow, fast: ...``); the meaning is the
    entry's first sentence, markup removed."""
    doc = cls.__doc__ or ""
    lines = doc.splitlines()
    try:
        start = next(i for i, ln in enumerate(lines) if ln.strip() == "Attributes:")
    except StopIteration:
        return {}
    out: dict[str, str] = {}
    entry_indent, current, text = None, [], []

    def flush():
        if current:
            meaning = _first_sentence(" ".join(text))
            for n in current:
                out.setdefault(n, meaning)

    for ln in lines[start + 1:]:
        if not ln.strip():
            continue
        indent = len(ln) - len(ln.lstrip())
        m = _ATTR_RE.match(ln)
        if entry_indent is None and m:
            entry_indent = indent
        if entry_indent is None or indent < entry_indent:
            break
        if indent == entry_indent and m:
            flush()
            current = [n.strip() for n in m.group(2).split(",")]
            text = [m.group(3)]
        elif indent == entry_indent:
            break  # the section ended
        else:
            text.append(ln.strip())
    flush()
    return out


def _first_sentence(text: str, limit: int = 90) -> str:
    text = re.sub(r":\w+:`~?([^`]*)`", lambda m: m.group(1).rsplit(".", 1)[-1], text)
    text = text.replace("``", "").replace("`", "")
    text = re.sub(r"\s+", " ", text).strip()
    depth = 0
    for i, c in enumerate(text):  # the first '.' or ';' outside brackets that ends a sentence
        depth += (c in "([{") - (c in ")]}")
        if (depth == 0 and c in ".;" and (i + 1 == len(text) or text[i + 1] == " ")
                and not text[max(0, i - 3):i].endswith(("i.e", "e.g", "etc"))):
            text = text[:i]
            break
    text = text.rstrip(":, ")
    return text if len(text) <= limit else text[:limit - 3].rstrip() + "..."


def tunables(obj, prefix: str = "", skip: tuple[str, ...] = ()) -> list[Tunable]:
    """The declared fields of the dataclass instance ``obj`` as :class:`Tunable` rows
    (``prefix`` before each name, meanings from its class docstring); a parameter set of groups
    (:func:`group_types`) is listed group by group with dotted names."""
    cls = type(obj)
    if fields(cls) and all(isinstance(f.default_factory, type) and is_dataclass(f.default_factory)
                           and SPEC not in f.metadata for f in fields(cls)):
        return [t for g in group_types(cls)
                for t in tunables(getattr(obj, g), prefix=f"{prefix}{g}.")]
    docs = field_docs(cls)
    return [Tunable(prefix + f.name, spec_of(f), getattr(obj, f.name), docs.get(f.name, ""))
            for f in fields(cls) if f.name not in skip and SPEC in f.metadata]
