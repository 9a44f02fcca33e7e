"""BVH skeleton -> MJCF: the conversion pipeline behind :func:`mjchar.bvh.mjcf.convert`.

Steps (each a function; where it lives is said below):

0. :func:`.prepare.prepare` - the rig made a standing figure in world axes (a static chain
   above the pelvis folded into the root, bones from translation channels, a rest pose taken
   from the clip when the file's is not standing), the unit and up axis guessed from anatomy,
   the joint roles (names, shape, the user's roles file) and the check of the essential ones.
1. :func:`_basis_matrix` - the proper rotation ``B`` taking file axes to MuJoCo's (x forward,
   y left, z up), found from the up axis and the left/right joint pairs.
2. :func:`_select` - which joints get bodies: dropped subtrees (fingers, ``*_End`` markers by
   default) and fused joints (zero-length helpers of unknown role by default, ``hinge``/``ball``
   models only) have none; each maps to the kept body that carries its position.
3. :func:`_geometry` - capsules along the bones from each body's joint to its kept children (or
   end sites), boxes for feet and toes, the sole level and the floor offset.
4. :func:`_masses` - de Leva (1996) segment fractions per role group, split inside a group by
   geometric volume; bodies of unknown role weigh by volume at water density; the whole sums to
   the requested mass exactly. Inertias follow from the geoms (MuJoCo integrates them).
5. :func:`_joints` - free root; hinge triplets (Euler order per role), single flexion hinges for
   knees and elbows, or balls; anatomical ranges in ``hinge`` mode, none in ``full`` mode.
6. :func:`_actuators` - a ``<position>`` actuator per hinge (gains per role scaled by the subtree
   mass they move), ``<motor>`` triplets for balls.
7. :func:`_write_xml` - deterministic MJCF text with the JSON joint map in ``<custom>``.

This module holds the public entry point :func:`convert`, its result :class:`ConvertedModel` and
the checking of its inputs; step 0 lives in :mod:`.prepare`, 1-2 in :mod:`.layout`, 3 in
:mod:`.geometry`, 4-6 in :mod:`.dynamics`, 7 in :mod:`.writer`.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from mjchar.bvh.errors import MjcharError
from mjchar.bvh.io import load
from mjchar.bvh.io.files import write_text
from mjchar.bvh.io.inputs import read_parsed
from mjchar.bvh.io.motion import Motion
from mjchar.bvh.io.skeleton import Skeleton
from mjchar.bvh.mjcf import tables as T
from mjchar.bvh.mjcf.dynamics import _actuators, _joints, _masses
from mjchar.bvh.mjcf.geometry import _floor_offset, _geom_top, _geometry
from mjchar.bvh.mjcf.info import ConversionError, JointInfo, ModelInfo, source_record
from mjchar.bvh.mjcf.layout import (
    _basis_matrix,
    _Body,
    _layout,
    _select,
    default_drop,  # noqa: F401  (public: mjchar.bvh.mjcf imports it from here)
    default_fuse,  # noqa: F401  (public: mjchar.bvh.mjcf imports it from here)
)
from mjchar.bvh.mjcf.prepare import Prepared, describe_unit, prepare
from mjchar.bvh.mjcf.roles import load_roles
from mjchar.bvh.mjcf.writer import (
    AXIS_INDEX,  # noqa: F401  (kept importable from mjchar.bvh.mjcf.builder)
    _write_xml,
)
from mjchar.bvh.rigs.naming import Recognition
from mjchar.bvh.rigs.units import AXIS_VECTORS, HEIGHT_RANGE_M, unit_name, unit_scale
from mjchar.bvh.rotations import from_rotation

JOINT_MODELS = ("hinge", "full", "ball")
#: the heaviest body the converter builds (kg): ten tonnes, beyond any character
MAX_MASS_KG = 1e4
#: largest gains file read, in bytes
MAX_GAINS_BYTES = 2**20


# ------------------------------------------------------------------------------------------------
# result
# ------------------------------------------------------------------------------------------------
@dataclass
class ConvertedModel:
    """A converted model.

    Attributes:
        xml: the MJCF text (deterministic for given inputs).
        info: the :class:`ModelInfo` written into it.
        warnings: human-readable notes (unrecognised joints, fused joints in ``full`` mode...).
        skeleton: the skeleton the model was built from (file units and axes, after the
            normalisation of :mod:`.prepare`: folded root, bones from translation channels,
            standing rest pose).
        motion: the source motion as given (before normalisation), or ``None`` when converting
            a bare skeleton; :class:`mjchar.bvh.reference.reference_motion.ReferenceMotion` applies
            the model's ``rig`` record to it.
        prepared: the :class:`~.prepare.Prepared` rig (normalised motion, roles, guesses).
        summary: ``n_bodies``, ``n_dofs`` (incl. the 6 root dofs), ``n_actuators``,
            ``total_mass_kg``, ``height_m``, ``bodies`` (names); ``unit`` (how the unit was
            found, in words), ``unit_name`` (``"cm"``, ``"cmu"``..., ``None`` for another
            scale), ``unit_scale`` (m per file unit), ``height_warning`` (the warning when the
            body is outside 1.0-2.3 m, else ``None``).
    """

    xml: str
    info: ModelInfo
    warnings: list[str]
    skeleton: Skeleton
    motion: Motion | None = None
    summary: dict = field(default_factory=dict)
    prepared: Prepared | None = None

    def compile(self):
        """The compiled ``mujoco.MjModel``; :class:`ConversionError` if MuJoCo rejects it."""
        import mujoco

        try:
            return mujoco.MjModel.from_xml_string(self.xml)
        except ValueError as e:
            raise ConversionError(f"MuJoCo rejected the converted model: {e}") from None

    def save(self, path: str | os.PathLike) -> None:
        """Write the MJCF text to ``path`` (UTF-8, atomically: a failed write leaves what was
        there); parent folders are created."""
        path = os.fspath(path)
        folder = os.path.dirname(path)
        try:
            if folder:
                os.makedirs(folder, exist_ok=True)
            write_text(path, self.xml)
        except OSError as e:
            raise ConversionError(f"cannot write {path}: {e.strerror or e}") from None



# ------------------------------------------------------------------------------------------------
# public entry point
# ------------------------------------------------------------------------------------------------
def convert(source, *, total_mass: float = 70.0, joint_model: str = "hinge",
            unit: str | float | None = None, up_axis: str | None = None,
            drop: list[str] | None = None, fuse: list[str] | None = None,
            gains: dict | str | os.PathLike | None = None, timestep: float | None = None,
            model_name: str | None = None,
            roles: dict | str | os.PathLike | None = None) -> ConvertedModel:
    """Convert a BVH skeleton into a simulated MuJoCo humanoid (see docs/model-contract.md).

    Args:
        source: a :class:`~mjchar.bvh.io.motion.Motion`, a
            :class:`~mjchar.bvh.io.skeleton.Skeleton` or a BVH path (a file with no frames, a
            skeleton template, is refused).
        total_mass: kg; body masses sum to it exactly (to the 6 significant digits written).
        joint_model: ``"hinge"`` (hinge triplets, one hinge for knees and elbows, anatomical
            ranges), ``"full"`` (hinge triplets everywhere, no ranges: any clip replays exactly)
            or ``"ball"`` (ball joints with motors; knees and elbows stay hinges).
        unit: metres per file unit: ``"m"``, ``"cm"``, ``"mm"``, ``"in"``, ``"ft"``, ``"cmu"``
            (the CMU ASF unit, 1/0.45 inch) or a number; guessed from the body's size when
            ``None`` (:func:`mjchar.bvh.rigs.units.unit_from_stature`).
        up_axis: ``"x"``, ``"y"`` or ``"z"`` of the file, ``"-y"`` etc. when it points down;
            guessed when ``None``.
        drop: joints to remove with their whole subtree. ``None`` = the defaults (hand joints
            below the wrists, ``*_End``/``Nub`` leaf markers); the word ``"default"`` in the list
            adds the defaults; ``[]`` drops nothing.
        fuse: joints merged rigidly into their parent body (their children hang from it).
            ``None`` = the defaults (zero-length joints of unknown role, in ``hinge``/``ball``
            models only; ``full`` fuses nothing so that replay stays exact); ``"default"`` adds
            them; ``[]`` fuses nothing.
        gains: overrides of the gains table: a dict (or a JSON file path) mapping a BVH joint
            name, a role (``"left_knee"``), a base role (``"knee"``) or ``"default"`` to
            ``{"kp": N m/rad, "kd": N m s/rad, "torque": N m, "armature": kg m^2}`` (any
            subset; absolute values, not mass-scaled).
        timestep: seconds; default :data:`tables.TIMESTEP`.
        model_name: MJCF model name (default: the file stem or ``"humanoid"``).
        roles: a role map (dict, or the path of a TOML roles file, :mod:`.roles`): role ->
            BVH joint name, for rigs whose names and shape do not tell.

    Returns:
        A :class:`ConvertedModel`.

    Raises:
        ConversionError: impossible options or a skeleton that cannot make a standing humanoid
            (a single joint, no legs, dropping the root or a leg, unknown joint names).
        bvh.BVHError: the BVH file is malformed.
    """
    source_motion, source_skeleton, default_name = _load_source(source)
    opts = _check_options(total_mass, joint_model, unit, up_axis, timestep)
    role_map = load_roles(roles)
    if source_skeleton.n_joints < 2:
        raise ConversionError(
            f"the skeleton has {source_skeleton.n_joints} joint(s); a humanoid needs a root "
            "with legs")
    prep = prepare(source_motion, source_skeleton, opts["unit"], opts["up_axis"], role_map)
    skeleton, scale, rec = prep.skeleton, prep.scale, prep.rec
    warns: list[str] = list(prep.warnings)
    B, basis = _basis(rec, prep.up, warns)
    sel = _select(skeleton, rec, joint_model, drop, fuse, scale, warns)
    bodies = _layout(skeleton, rec, sel, B, scale)
    _role_warnings(skeleton, rec, bodies, warns)
    top = _geometry(skeleton, rec, sel, bodies, B, scale)
    offset = _floor_offset(bodies)
    # standing height: the top of the skeleton (or of the body, e.g. a head capsule above a
    # head joint with no end site) above the floor
    height = max(top, _geom_top(bodies)) + offset[2]
    _masses(bodies, opts["total_mass"])
    _joints(skeleton, bodies, joint_model, prep.motion, B)
    gains_table = _load_gains(gains)
    actuators = _actuators(bodies, joint_model, opts["total_mass"], gains_table, skeleton)
    info = _joint_map(prep, source_skeleton, joint_model, bodies, sel, basis, offset, height,
                      opts["total_mass"])
    xml = _write_xml(model_name or default_name, bodies, actuators, info, offset,
                     opts["timestep"], skeleton)
    summary = _summary(prep, bodies, actuators, info, height, warns)
    return ConvertedModel(xml=xml, info=info, warnings=warns, skeleton=skeleton,
                          motion=source_motion, summary=summary, prepared=prep)


def _basis(rec: Recognition, up: str, warns: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """Step 1: ``(B, basis)``, the rotation matrix from file axes to MuJoCo's and its
    quaternion (``w >= 0``); a note in ``warns`` when no left/right pair tells the left."""
    if rec.left_axis is None:
        warns.append("no left/right joint pairs recognised: assuming the character's left is "
                     "the file's +X axis")
    B = _basis_matrix(rec, up)
    basis = from_rotation(Rotation.from_matrix(B))
    if basis[0] < 0:
        basis = -basis
    return B, basis


def _role_warnings(skeleton: Skeleton, rec: Recognition, bodies: dict[int, _Body],
                   warns: list[str]) -> None:
    """Notes on the kept joints of unknown role and on the roles found from the shape."""
    if rec.unrecognised:
        kept_unknown = [n for n in rec.unrecognised if skeleton.index(n) in bodies]
        if kept_unknown:
            warns.append("unrecognised joints (wide limits, generic gains): "
                         + ", ".join(kept_unknown))
    if rec.by_structure:
        warns.append("roles found from the hierarchy's shape, not names: "
                     + ", ".join(f"{n}={rec.joint_roles[n]}" for n in rec.by_structure))


def _joint_map(prep: Prepared, source_skeleton: Skeleton, joint_model: str,
               bodies: dict[int, _Body], sel: dict, basis: np.ndarray, offset: np.ndarray,
               height: float, total_mass: float) -> ModelInfo:
    """The :class:`ModelInfo` written into the model: each kept joint's body and joints, the
    roles of kept joints, what was dropped or fused, sites, foot geoms and the source rig."""
    skeleton, rec = prep.skeleton, prep.rec
    names = skeleton.names
    joints_meta = {}
    for j, b in bodies.items():
        joints_meta[names[j]] = JointInfo(b.name, tuple(jt["name"] for jt in b.joints),
                                          b.order, b.role)
    roles = {r: v for r, v in rec.roles.items()
             if (isinstance(v, list) and any(skeleton.index(x) in bodies for x in v))
             or (isinstance(v, str) and skeleton.index(v) in bodies)}
    for r in ("spine", "neck"):
        if r in roles:
            roles[r] = [x for x in roles[r] if skeleton.index(x) in bodies]
    foot_geoms = {s: [g.name for b in bodies.values()
                      if b.side == s and b.base in ("ankle", "toe") for g in b.geoms]
                  for s in ("left", "right")}
    sites = {sn: b.name for b in bodies.values() for sn in b.sites}
    info = ModelInfo(
        joint_model=joint_model,
        unit_scale=_round(prep.scale),
        up_axis=prep.up,
        basis=np.array([_round(x) for x in basis]),
        offset=np.array([_round(x) for x in offset]),
        joints=joints_meta,
        roles=roles,
        dropped=[names[j] for j in sorted(sel["removed"])],
        fused_into={names[j]: names[sel["into"][j]] for j in sorted(sel["removed"])},
        extra={
            "height": _round(height),
            "total_mass": _round(total_mass),
            "sites": sites,
            "foot_geoms": foot_geoms,
            "fused": [names[j] for j in sorted(sel["fused"])],
            "source": source_record(skeleton, prep.motion),
        },
    )
    if prep.record:  # with the file's own hierarchy, so an export can go back to it
        info.extra["rig"] = dict(prep.record,
                                 original=source_record(source_skeleton)["hierarchy"])
    return info


def _summary(prep: Prepared, bodies: dict[int, _Body], actuators: list[dict], info: ModelInfo,
             height: float, warns: list[str]) -> dict:
    """:attr:`ConvertedModel.summary`; the warning of a body outside the usual heights is
    added to ``warns`` too."""
    scale = prep.scale
    n_dofs = 6 + sum(1 if jt["type"] == "hinge" else 3 for b in bodies.values()
                     for jt in b.joints if jt["type"] != "free")
    unit_text = describe_unit(prep)
    height_warning = None
    lo, hi = HEIGHT_RANGE_M
    if not lo <= height <= hi:
        height_warning = (f"the body is {height:.2f} m tall, outside {lo:.1f}-{hi:.1f} m: if the "
                          f"unit is wrong ({unit_text}), give it with --unit (m, dm, cm, mm, in, "
                          "ft, cmu or metres per unit)")
        warns.append(height_warning)
    return {
        "unit": unit_text,
        "unit_name": prep.unit.name if prep.unit is not None else unit_name(scale),
        "unit_scale": float(scale),
        "height_warning": height_warning,
        "n_bodies": len(bodies),
        "n_dofs": n_dofs,
        "n_actuators": len(actuators),
        "total_mass_kg": float(sum(b.mass for b in bodies.values())),
        "height_m": float(height),
        "bodies": [b.name for b in bodies.values()],
        "dropped": info.dropped,
        "fused": info.extra["fused"],
    }


# ------------------------------------------------------------------------------------------------
# inputs
# ------------------------------------------------------------------------------------------------
def _load_source(source) -> tuple[Motion | None, Skeleton, str]:
    if isinstance(source, Motion):
        return source, source.skeleton, "humanoid"
    if isinstance(source, Skeleton):
        return None, source, "humanoid"
    if isinstance(source, (str, os.PathLike)):
        motion = load(source)
        if motion.n_frames == 0:
            raise ConversionError(
                f"{os.fspath(source)}: Frames: 0, a skeleton template with no motion: the body is "
                "fitted to a clip's poses (up axis, unit, knee and elbow axes), so export the "
                "clip with its frames (a Skeleton object converts from its rest pose alone)")
        stem = os.path.splitext(os.path.basename(os.fspath(source)))[0] or "humanoid"
        # a file name that is not valid text (bytes undecodable in the locale) still names it
        stem = stem.encode("utf-8", "surrogateescape").decode("utf-8", "replace")
        return motion, motion.skeleton, stem
    raise ConversionError(
        f"cannot convert a {type(source).__name__}: expected a Motion, a Skeleton or a BVH path")


def _check_options(total_mass, joint_model, unit, up_axis, timestep) -> dict:
    if joint_model not in JOINT_MODELS:
        raise ConversionError(
            f"unknown joint model {joint_model!r}; expected one of {', '.join(JOINT_MODELS)}")
    try:
        total_mass = float(total_mass)
    except (TypeError, ValueError):
        raise ConversionError(f"total mass must be a number of kg, got {total_mass!r}") from None
    if not (math.isfinite(total_mass) and 0 < total_mass <= MAX_MASS_KG):
        raise ConversionError(f"total mass must be a positive number of kg up to "
                              f"{MAX_MASS_KG:g}, got {total_mass:g}")
    if unit is not None:
        if isinstance(unit, str):
            try:
                unit = float(unit)
            except ValueError:
                try:
                    unit = unit_scale(unit)
                except MjcharError as e:
                    raise ConversionError(str(e)) from None
        unit = float(unit)
        if not (math.isfinite(unit) and unit > 0):
            raise ConversionError(f"unit must be a positive number of metres per unit, got {unit}")
    if up_axis is not None:
        up_axis = str(up_axis).lower()
        if up_axis not in AXIS_VECTORS:
            raise ConversionError(f"up axis must be x, y, z, -x, -y or -z, got {up_axis!r}")
    if timestep is None:
        timestep = T.TIMESTEP
    timestep = float(timestep)
    if not (math.isfinite(timestep) and 0 < timestep <= 0.05):
        raise ConversionError(f"timestep must be in (0, 0.05] s, got {timestep}")
    return {"total_mass": total_mass, "unit": unit, "up_axis": up_axis, "timestep": timestep}


def _load_gains(gains) -> dict:
    if gains is None:
        return {}
    if isinstance(gains, (str, os.PathLike)):
        gains = read_parsed(gains, what="gains file", max_bytes=MAX_GAINS_BYTES, expected="JSON",
                            parse=json.loads, invalid=json.JSONDecodeError,
                            error=ConversionError, example='{"joint or role": {"kp": 300}}')
    if not isinstance(gains, dict):
        raise ConversionError("gains must map joint names or roles to {kp, kd, torque, armature}")
    out = {}
    for key, val in gains.items():
        if not isinstance(val, dict):
            raise ConversionError(f"gains[{key!r}] must be an object like {{\"kp\": 300}}")
        bad = set(val) - {"kp", "kd", "torque", "armature", "damping"}
        if bad:
            raise ConversionError(f"gains[{key!r}]: unknown fields {sorted(bad)}; "
                                  "expected kp, kd, torque, armature, damping")
        for k, v in val.items():
            if not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
                raise ConversionError(f"gains[{key!r}][{k!r}] must be a number >= 0, got {v!r}")
        out[str(key)] = {k: float(v) for k, v in val.items()}
    return out



# ------------------------------------------------------------------------------------------------
# numbers written into the joint map
# ------------------------------------------------------------------------------------------------
def _round(x: float) -> float:
    """A float rounded to 9 significant digits (stable JSON output)."""
    return float(f"{float(x):.9g}") + 0.0  # + 0.0 turns -0.0 into 0.0


