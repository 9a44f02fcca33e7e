"""User role maps (``mjchar convert --roles roles.toml``): joints the names cannot tell.

The file is TOML (read with the standard library's ``tomllib``); roles are keys, BVH joint names
values, either at the top level or in a ``[roles]`` table::

    # roles.toml
    [roles]
    pelvis = "Bip01_Pelvis"
    left_hip = "Bip01_L_Thigh"
    left_knee = "Bip01_L_Calf"
    left_ankle = "Bip01_L_Foot"
    right_knee = "Bip01_R_Calf"
    spine = ["Bip01_Spine", "Bip01_Spine1"]   # lists for spine and neck

Valid roles: :data:`VALID_ROLES`. Given roles override recognition; given knees and elbows also
anchor their limbs (hip, ankle, toe / shoulder, clavicle, wrist follow from the hierarchy), so
mapping the knees and elbows is usually enough.
"""

from __future__ import annotations

import os
import tomllib

from mjchar.bvh.errors import name_list
from mjchar.bvh.io.inputs import read_parsed
from mjchar.bvh.mjcf.info import ConversionError

SIDED = ("hip", "knee", "ankle", "toe", "clavicle", "shoulder", "elbow", "wrist")
#: role names a roles file may map
VALID_ROLES = ("pelvis", "spine", "neck", "head") + tuple(
    f"{s}_{r}" for s in ("left", "right") for r in SIDED)
#: roles every humanoid needs (a missing one is an error)
ESSENTIAL_ROLES = ("pelvis",) + tuple(f"{s}_{r}" for s in ("left", "right")
                                      for r in ("hip", "knee", "ankle"))

EXAMPLE = 'left_knee = "JointName"'
#: largest roles file read, in bytes
MAX_ROLES_BYTES = 2**20


def load_roles(source) -> dict[str, object]:
    """Read a role map: a dict, or the path of a TOML file. Returns role -> name (or list of
    names for ``spine``/``neck``). Raises :class:`ConversionError` (one line) for a file that
    cannot be read or is not valid TOML, an unknown role, or a value of the wrong type."""
    if source is None:
        return {}
    where = "roles"
    if isinstance(source, (str, os.PathLike)):
        where = os.fspath(source)
        data = read_parsed(where, what="roles file", max_bytes=MAX_ROLES_BYTES, expected="TOML",
                           parse=tomllib.loads, invalid=tomllib.TOMLDecodeError,
                           error=ConversionError, example=f"lines like {EXAMPLE}",
                           invalid_hint=f"; expected lines like {EXAMPLE}")
    else:
        data = dict(source)
    if isinstance(data.get("roles"), dict) and len(data) == 1:
        data = data["roles"]
    out: dict[str, object] = {}
    for role, value in data.items():
        if role not in VALID_ROLES:
            raise ConversionError(f"{where}: unknown role {role!r}; valid roles: "
                                  + ", ".join(VALID_ROLES))
        if role in ("spine", "neck"):
            value = [value] if isinstance(value, str) else value
            if not (isinstance(value, list) and value and all(isinstance(v, str) for v in value)):
                raise ConversionError(f"{where}: {role} must be a joint name or a list of names")
        elif not isinstance(value, str):
            raise ConversionError(f"{where}: {role} must be a joint name (a string), "
                                  f"got {value!r}")
        out[role] = value
    return out


def check_roles(roles: dict[str, object], names: list[str], where: str = "roles") -> None:
    """Every joint a role map names must exist: one error listing those that do not."""
    bad = []
    for role, value in roles.items():
        for v in ([value] if isinstance(value, str) else value):
            if v not in names:
                bad.append(f"{role} = {v!r}")
    if bad:
        raise ConversionError(f"{where} names joints the skeleton does not have: "
                              + name_list(bad) + "; joints are: " + name_list(names))


def missing_roles_error(missing: list[str], names: list[str], found: dict,
                        problem: str | None = None) -> ConversionError:
    """The one-line error for missing essential roles."""
    have = ", ".join(f"{r}={v}" for r, v in found.items() if isinstance(v, str)) or "none"
    why = f" ({problem})" if problem else ""
    return ConversionError(
        "missing essential roles: " + ", ".join(missing) + why + f"; recognised: {have}; "
        "map them in a roles file (mjchar convert --roles roles.toml) with lines like "
        + ", ".join(f'{r} = "<joint>"' for r in missing[:2])
        + "; joints are: " + name_list(names))
