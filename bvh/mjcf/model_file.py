"""Loading an MJCF model file a user names, refusing what MuJoCo would load wrongly.

:func:`load_mjcf` is what every ``--model`` path goes through:

- a file over :data:`MAX_MODEL_BYTES`, binary data or another format (:mod:`mjchar.bvh.io.inputs`)
  is refused before MuJoCo reads it;
- a number attribute reading ``nan`` or ``inf`` is refused naming its line (MuJoCo loads
  ``mass="nan"`` with a warning on its console and puts a mass of its own in its place);
- MuJoCo's own multi-line errors (a truncated file, a bad ``<include>``, a compiler error) come
  back as one line naming the file and the line;
- the compiled model's physical fields are checked (:func:`check_physical`): masses, inertias,
  sizes, damping, armature, friction, gains and the time step must be finite and in range.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable

import numpy as np

from mjchar.bvh.io.inputs import read_text

__all__ = ["MAX_MODEL_BYTES", "MAX_BODY_MASS_KG", "load_mjcf", "check_physical",
           "mujoco_message"]

#: largest MJCF file read, in bytes (a converted humanoid is 30-100 KB)
MAX_MODEL_BYTES = 64 * 2**20
#: heaviest body accepted, in kg (far beyond any character: a typo in units)
MAX_BODY_MASS_KG = 1e5
_NONFINITE_RE = re.compile(r"""([\w:-]+)\s*=\s*(["'])([^"']*?(?<![\w.])[+-]?(?:nan|inf|infinity)"""
                           r"""(?![\w.])[^"']*)\2""", re.IGNORECASE)
_XML_LINE_RE = re.compile(r"Line number=(\d+)")
_ELEMENT_LINE_RE = re.compile(r"Element (?:name )?'?([^',\n]*)'?(?:, id \d+)?, line (\d+)")


def mujoco_message(message: str) -> str:
    """MuJoCo's (multi-line) loading error as one line: a parse error says where the XML stops
    being well formed, an include error which file, anything else its lines joined by '; '."""
    text = str(message).strip()
    include = "Include error" in text or "Error opening file" in text
    m = _XML_LINE_RE.search(text)
    if m is not None:
        where = "an included file" if include else "the file"
        el = _ELEMENT_LINE_RE.search(text)
        inc = f" (the <include> on line {el.group(2)})" if include and el else ""
        return (f"{where} is not well-formed XML near line {m.group(1)}{inc}: is it truncated "
                f"or damaged?")
    opening = re.search(r"Error opening file '([^']*)'", text)
    if opening is not None:
        el = _ELEMENT_LINE_RE.search(text)
        line = f" on line {el.group(2)}" if el else ""
        return f"the <include>{line} names {opening.group(1)!r}, which cannot be opened"
    return "; ".join(ln.strip() for ln in text.splitlines() if ln.strip())


def load_mjcf(path: str | os.PathLike, error: Callable[[str], Exception]):
    """The compiled ``mujoco.MjModel`` of the MJCF file at ``path``, checked as the module
    docstring says; ``error(message)`` makes the exception raised (``message`` names the file,
    one line)."""
    import mujoco

    path = os.fspath(path)
    text = read_text(path, what="model file", max_bytes=MAX_MODEL_BYTES, expected="XML",
                     error=lambda reason, line: error(f"{path}: {reason}"))
    for m in _NONFINITE_RE.finditer(text):
        if not all(_is_float(t) for t in m.group(3).split()):
            continue  # a name or a file that happens to hold the word
        line = text.count("\n", 0, m.start()) + 1
        raise error(f"{path}, line {line}: {m.group(1)}=\"{m.group(3)[:40]}\" is not a finite "
                    f"number (MuJoCo would put a value of its own in its place): give a finite "
                    f"value")
    try:
        path.encode("utf-8")
    except UnicodeEncodeError:
        shown = path.encode("utf-8", "surrogateescape").decode("utf-8", "replace")
        raise error(f"{shown}: the path is not valid UTF-8, which MuJoCo cannot open: rename "
                    f"the file (or its folder)") from None
    try:
        model = mujoco.MjModel.from_xml_path(path)
    except ValueError as e:
        raise error(f"{path}: MuJoCo cannot load it: {mujoco_message(str(e))}") from None
    problem = check_physical(model)
    if problem is not None:
        raise error(f"{path}: {problem}")
    return model


def _is_float(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


def _name(model, obj, i: int, what: str) -> str:
    import mujoco

    name = mujoco.mj_id2name(model, obj, int(i))
    return f"{what} {name!r}" if name else f"{what} {int(i)}"


def check_physical(model) -> str | None:
    """The first non-physical field of a compiled model, as one line, or ``None``: masses and
    inertias finite, >= 0 and a body at most :data:`MAX_BODY_MASS_KG`; geometry, damping,
    armature, friction, stiffness, actuator parameters and gravity finite (the scalar ones
    >= 0); a time step in (0, 0.1] s."""
    import mujoco

    ts = float(model.opt.timestep)
    if not (np.isfinite(ts) and 0 < ts <= 0.1):
        return f"timestep {ts:g} s is not a simulation time step (expected in (0, 0.1] s)"
    body = mujoco.mjtObj.mjOBJ_BODY
    checks = (
        ("mass", model.body_mass, body, "body", True, "kg"),
        ("inertia", model.body_inertia, body, "body", True, "kg m^2"),
        ("size", model.geom_size, mujoco.mjtObj.mjOBJ_GEOM, "geom", True, "m"),
        ("friction", model.geom_friction, mujoco.mjtObj.mjOBJ_GEOM, "geom", True, ""),
        ("damping", model.dof_damping, mujoco.mjtObj.mjOBJ_DOF, "dof", True, "N m s/rad"),
        ("armature", model.dof_armature, mujoco.mjtObj.mjOBJ_DOF, "dof", True, "kg m^2"),
        ("frictionloss", model.dof_frictionloss, mujoco.mjtObj.mjOBJ_DOF, "dof", True, "N m"),
        ("stiffness", model.jnt_stiffness, mujoco.mjtObj.mjOBJ_JOINT, "joint", True, "N m/rad"),
        ("range", model.jnt_range, mujoco.mjtObj.mjOBJ_JOINT, "joint", False, ""),
        ("gear", model.actuator_gear, mujoco.mjtObj.mjOBJ_ACTUATOR, "actuator", False, ""),
        ("gain", model.actuator_gainprm, mujoco.mjtObj.mjOBJ_ACTUATOR, "actuator", False, ""),
        ("bias", model.actuator_biasprm, mujoco.mjtObj.mjOBJ_ACTUATOR, "actuator", False, ""),
        ("ctrlrange", model.actuator_ctrlrange, mujoco.mjtObj.mjOBJ_ACTUATOR, "actuator", False,
         ""),
        ("position", model.body_pos, body, "body", False, "m"),
        ("orientation", model.body_quat, body, "body", False, ""),
    )
    for field, values, obj, what, non_negative, unit in checks:
        v = np.asarray(values, dtype=float).reshape(len(values), -1)
        bad = ~np.isfinite(v)
        if non_negative:
            bad |= v < 0
        rows = np.flatnonzero(bad.any(axis=1))
        if len(rows):
            i = int(rows[0])
            shown = " ".join(f"{x:g}" for x in v[i][:6])
            need = "finite and >= 0" if non_negative else "finite"
            return (f"{_name(model, obj, i, what)} has {field} {shown} {unit}".rstrip()
                    + f": not physical (expected {need})")
    heavy = np.flatnonzero(np.asarray(model.body_mass) > MAX_BODY_MASS_KG)
    if len(heavy):
        i = int(heavy[0])
        return (f"{_name(model, body, i, 'body')} has mass {model.body_mass[i]:g} kg: not a "
                f"body's mass (at most {MAX_BODY_MASS_KG:g} kg; a unit mix-up?)")
    if not np.all(np.isfinite(model.opt.gravity)):
        return "gravity is not finite"
    return None
