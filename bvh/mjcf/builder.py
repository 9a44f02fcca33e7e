"""BVH skeleton -> MJCF: the conversion pipeline behind :func:`bvh.mjcf.convert`.

Steps (each a function below):

1. :func:`_frame` - units and axes: metres per unit, the up axis, and the proper rotation
   ``B`` taking file axes to MuJoCo's (x forward, y left, z up), found from the up axis and the
   left/right joint pairs.
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
"""

from __future__ import annotations

import json
import math
import os
import warnings as _warnings
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import MjcharError
from ..motion import Motion
from ..naming import Recognition, recognise
from ..rotations import from_rotation, to_rotation
from ..skeleton import Skeleton
from ..units import AXIS_VECTORS, guess_unit_scale, guess_up_axis, unit_scale
from . import tables as T
from .info import ConversionError, JointInfo, ModelInfo

JOINT_MODELS = ("hinge", "full", "ball")
AXIS_INDEX = {"x": 0, "y": 1, "z": 2}


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
        skeleton: the source skeleton (file units and axes).
        motion: the source motion, or ``None`` when converting a bare skeleton.
        summary: ``n_bodies``, ``n_dofs`` (incl. the 6 root dofs), ``n_actuators``,
            ``total_mass_kg``, ``height_m``, ``bodies`` (names).
    """

    xml: str
    info: ModelInfo
    warnings: list[str]
    skeleton: Skeleton
    motion: Motion | None = None
    summary: dict = field(default_factory=dict)

    def compile(self):
        """The compiled ``mujoco.MjModel``; :class:`ConversionError` if MuJoCo rejects it."""
        import mujoco

        try:
            return mujoco.MjModel.from_xml_string(self.xml)
        except ValueError as e:
            raise ConversionError(f"MuJoCo rejected the converted model: {e}") from None

    def save(self, path: str | os.PathLike) -> None:
        """Write the MJCF text to ``path`` (UTF-8); parent folders are created."""
        path = os.fspath(path)
        folder = os.path.dirname(path)
        try:
            if folder:
                os.makedirs(folder, exist_ok=True)
            with open(path, "w", encoding="utf-8", newline="\n") as fh:
                fh.write(self.xml)
        except OSError as e:
            raise ConversionError(f"cannot write {path}: {e.strerror or e}") from None


# ------------------------------------------------------------------------------------------------
# internal layout
# ------------------------------------------------------------------------------------------------
@dataclass
class _Geom:
    kind: str  # "capsule" | "box"
    name: str
    a: np.ndarray | None = None  # capsule ends (world, metres, before the floor offset)
    b: np.ndarray | None = None
    radius: float = 0.0
    center: np.ndarray | None = None  # box centre (world)
    half: np.ndarray | None = None  # box half sizes (along foot, lateral, vertical)
    yaw: float = 0.0
    mass: float = 0.0

    @property
    def volume(self) -> float:
        if self.kind == "capsule":
            length = float(np.linalg.norm(self.b - self.a))
            return math.pi * self.radius ** 2 * length + 4.0 / 3.0 * math.pi * self.radius ** 3
        return 8.0 * float(np.prod(self.half))

    def lowest(self) -> float:
        if self.kind == "capsule":
            return float(min(self.a[2], self.b[2]) - self.radius)
        return float(self.center[2] - self.half[2])


@dataclass
class _Body:
    j: int  # BVH joint index
    name: str
    parent: int  # kept parent's BVH index (-1 for the root)
    role: str  # full role
    base: str  # role without side
    side: str | None
    pos: np.ndarray  # world rest position (metres, MuJoCo axes, before offset)
    geoms: list[_Geom] = field(default_factory=list)
    sites: dict[str, np.ndarray] = field(default_factory=dict)
    mass: float = 0.0
    joints: list[dict] = field(default_factory=list)  # {"name","type","axis","range"}
    order: str = ""
    children: list[int] = field(default_factory=list)

    @property
    def volume(self) -> float:
        return float(sum(g.volume for g in self.geoms))


# ------------------------------------------------------------------------------------------------
# public entry point
# ------------------------------------------------------------------------------------------------
def convert(source, *, total_mass: float = 70.0, joint_model: str = "hinge",
            unit: str | float | None = None, up_axis: str | None = None,
            drop: list[str] | None = None, fuse: list[str] | None = None,
            gains: dict | str | os.PathLike | None = None, timestep: float | None = None,
            model_name: str | None = None) -> ConvertedModel:
    """Convert a BVH skeleton into a simulated MuJoCo humanoid (see docs/model-contract.md).

    Args:
        source: a :class:`~bvh.motion.Motion`, a :class:`~bvh.skeleton.Skeleton` or a BVH path.
        total_mass: kg; body masses sum to it exactly (to the 6 significant digits written).
        joint_model: ``"hinge"`` (hinge triplets, one hinge for knees and elbows, anatomical
            ranges), ``"full"`` (hinge triplets everywhere, no ranges: any clip replays exactly)
            or ``"ball"`` (ball joints with motors; knees and elbows stay hinges).
        unit: metres per file unit: ``"m"``, ``"cm"``, ``"mm"``, ``"in"``, ``"ft"`` or a number;
            guessed from the standing height when ``None``.
        up_axis: ``"x"``, ``"y"`` or ``"z"`` of the file; guessed when ``None``.
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

    Returns:
        A :class:`ConvertedModel`.

    Raises:
        ConversionError: impossible options or a skeleton that cannot make a standing humanoid
            (a single joint, no legs, dropping the root or a leg, unknown joint names).
        bvh.BVHError: the BVH file is malformed.
    """
    motion, skeleton, default_name = _load_source(source)
    opts = _check_options(total_mass, joint_model, unit, up_axis, timestep)
    warns: list[str] = []
    if skeleton.n_joints < 2:
        raise ConversionError(
            f"the skeleton has {skeleton.n_joints} joint(s); a humanoid needs a root with legs")

    scale, up = _frame(skeleton, opts["unit"], opts["up_axis"])
    rec = recognise(skeleton, AXIS_VECTORS[up])
    _check_legs(skeleton, rec)
    if rec.left_axis is None:
        warns.append("no left/right joint pairs recognised: assuming the character's left is "
                     "the file's +X axis")
    B = _basis_matrix(rec, up)
    basis = from_rotation(Rotation.from_matrix(B))
    if basis[0] < 0:
        basis = -basis
    sel = _select(skeleton, rec, joint_model, drop, fuse, scale, warns)
    bodies = _layout(skeleton, rec, sel, B, scale)
    if rec.unrecognised:
        kept_unknown = [n for n in rec.unrecognised if skeleton.index(n) in bodies]
        if kept_unknown:
            warns.append("unrecognised joints (wide limits, generic gains): "
                         + ", ".join(kept_unknown))
    if rec.by_structure:
        warns.append("roles found from the hierarchy's shape, not names: "
                     + ", ".join(f"{n}={rec.joint_roles[n]}" for n in rec.by_structure))
    top = _geometry(skeleton, rec, sel, bodies, B, scale)
    offset = _floor_offset(bodies)
    height = top + offset[2]  # standing height: top of the skeleton above the floor
    _masses(bodies, opts["total_mass"])
    _joints(skeleton, bodies, joint_model, motion, B)
    gains_table = _load_gains(gains)
    actuators = _actuators(bodies, joint_model, opts["total_mass"], gains_table, skeleton)

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
        unit_scale=_round(scale),
        up_axis=up,
        basis=np.array([_round(x) for x in basis]),
        offset=np.array([_round(x) for x in offset]),
        joints=joints_meta,
        roles=roles,
        dropped=[names[j] for j in sorted(sel["removed"])],
        fused_into={names[j]: names[sel["into"][j]] for j in sorted(sel["removed"])},
        extra={
            "height": _round(height),
            "total_mass": _round(opts["total_mass"]),
            "sites": sites,
            "foot_geoms": foot_geoms,
            "fused": [names[j] for j in sorted(sel["fused"])],
        },
    )
    xml = _write_xml(model_name or default_name, bodies, actuators, info, offset,
                     opts["timestep"], skeleton)
    n_dofs = 6 + sum(1 if jt["type"] == "hinge" else 3 for b in bodies.values()
                     for jt in b.joints if jt["type"] != "free")
    summary = {
        "n_bodies": len(bodies),
        "n_dofs": n_dofs,
        "n_actuators": len(actuators),
        "total_mass_kg": float(sum(b.mass for b in bodies.values())),
        "height_m": float(height),
        "bodies": [b.name for b in bodies.values()],
        "dropped": info.dropped,
        "fused": info.extra["fused"],
    }
    return ConvertedModel(xml=xml, info=info, warnings=warns, skeleton=skeleton, motion=motion,
                          summary=summary)


# ------------------------------------------------------------------------------------------------
# inputs
# ------------------------------------------------------------------------------------------------
def _load_source(source) -> tuple[Motion | None, Skeleton, str]:
    from ..io import load

    if isinstance(source, Motion):
        return source, source.skeleton, "humanoid"
    if isinstance(source, Skeleton):
        return None, source, "humanoid"
    if isinstance(source, (str, os.PathLike)):
        motion = load(source)
        stem = os.path.splitext(os.path.basename(os.fspath(source)))[0] or "humanoid"
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
    if not (math.isfinite(total_mass) and total_mass > 0):
        raise ConversionError(f"total mass must be a positive number of kg, got {total_mass}")
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
            raise ConversionError(f"up axis must be x, y or z, got {up_axis!r}")
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
        path = os.fspath(gains)
        try:
            with open(path, encoding="utf-8") as fh:
                gains = json.load(fh)
        except OSError as e:
            raise ConversionError(f"cannot read gains file {path}: {e.strerror or e}") from None
        except json.JSONDecodeError as e:
            raise ConversionError(f"gains file {path} is not valid JSON: {e}") from None
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
# 1. frame
# ------------------------------------------------------------------------------------------------
def _frame(sk: Skeleton, unit, up_axis) -> tuple[float, str]:
    """(metres per file unit, up axis of the file): given or guessed from the rest pose."""
    up = up_axis or guess_up_axis(sk)
    if unit is None:
        try:
            scale = guess_unit_scale(sk)
        except MjcharError as e:
            raise ConversionError(f"cannot guess the unit: {e}; pass unit=") from None
    else:
        scale = float(unit)
    return scale, up


def _basis_matrix(rec: Recognition, up: str) -> np.ndarray:
    """Rows: the file's forward, left and up unit vectors (so ``B @ v`` is in MuJoCo axes)."""
    u = AXIS_VECTORS[up]
    cands = [s * AXIS_VECTORS[a] for a in "xyz" if a != up for s in (1.0, -1.0)]
    if rec.left_axis is not None:
        left = max(cands, key=lambda c: float(c @ rec.left_axis))
    else:
        left = AXIS_VECTORS["x"] if up != "x" else AXIS_VECTORS["y"]
    fwd = np.cross(left, u)
    return np.stack([fwd, left, u])


def _check_legs(sk: Skeleton, rec: Recognition) -> None:
    missing = [f"{s}_{r}" for s in ("left", "right") for r in ("hip", "knee", "ankle")
               if f"{s}_{r}" not in rec.roles]
    if missing:
        raise ConversionError(
            "no legs: cannot find " + ", ".join(missing) + " (expected knee joints named like "
            "lKnee/LeftLeg/LeftKnee, or two limb chains reaching the floor); joints are: "
            + ", ".join(sk.names))


# ------------------------------------------------------------------------------------------------
# 2. selection
# ------------------------------------------------------------------------------------------------
def _expand(names: list[str] | None, defaults: list[int], sk: Skeleton, what: str) -> set[int]:
    if names is None:
        return set(defaults)
    if isinstance(names, str):
        names = [n for n in names.split(",") if n.strip()]
    out: set[int] = set()
    for n in names:
        n = n.strip()
        if n.lower() == "default":
            out |= set(defaults)
        elif n.lower() == "none":
            continue
        elif n in sk.names:
            out.add(sk.names.index(n))
        else:
            close = [x for x in sk.names if n.lower() in x.lower() or x.lower() in n.lower()]
            hint = f" (did you mean {', '.join(close[:5])}?)" if close else ""
            raise ConversionError(f"{what}: unknown joint {n!r}{hint}; joints are: "
                                  + ", ".join(sk.names))
    return out


def default_drop(sk: Skeleton, rec: Recognition) -> list[int]:
    """Joints dropped by default: hand joints below the wrists and leaf end markers."""
    return [j for j in range(1, sk.n_joints)
            if rec.joint_roles[sk.names[j]] in ("hand", "end")]


def default_fuse(sk: Skeleton, rec: Recognition, scale: float, joint_model: str) -> list[int]:
    """Zero-length joints (offset < 2 mm) of unknown role; none in the ``full`` model."""
    if joint_model == "full":
        return []
    lengths = sk.bone_lengths() * scale
    return [j for j in range(1, sk.n_joints)
            if lengths[j] < 0.002 and rec.joint_roles[sk.names[j]] == "unknown"
            and sk.children(j)]


def _select(sk: Skeleton, rec: Recognition, joint_model: str, drop, fuse, scale: float,
            warns: list[str]) -> dict:
    n = sk.n_joints
    drop_set = _expand(drop, default_drop(sk, rec), sk, "drop")
    fuse_set = _expand(fuse, default_fuse(sk, rec, scale, joint_model), sk, "fuse")
    for what, s in (("drop", drop_set), ("fuse", fuse_set)):
        if 0 in s:
            raise ConversionError(f"cannot {what} the root joint {sk.names[0]!r}")
    both = drop_set & fuse_set
    if both:
        raise ConversionError("joints both dropped and fused: "
                              + ", ".join(sk.names[j] for j in sorted(both)))
    # dropping removes whole subtrees
    dropped: set[int] = set()
    for j in range(n):
        p = sk.parents[j]
        if j in drop_set or (p >= 0 and p in dropped):
            dropped.add(j)
    fuse_set -= dropped
    essential = {rec.roles.get(f"{s}_{r}") for s in ("left", "right")
                 for r in ("hip", "knee", "ankle")}
    lost = sorted(x for x in essential if x and sk.index(x) in dropped)
    if lost:
        raise ConversionError("cannot drop the legs (the model must stand): "
                              + ", ".join(lost) + " would be removed")
    lost = sorted(x for x in essential if x and sk.index(x) in fuse_set)
    if lost:
        raise ConversionError("cannot fuse leg joints (hips, knees, ankles): " + ", ".join(lost))
    removed = dropped | fuse_set
    into = {}
    for j in range(n):
        if j in removed:
            a = int(sk.parents[j])
            while a in removed:
                a = int(sk.parents[a])
            into[j] = a
    if joint_model == "full" and fuse_set:
        warns.append("full model with fused joints: replay is exact only while their rotations "
                     "stay identity: " + ", ".join(sk.names[j] for j in sorted(fuse_set)))
    moving = [sk.names[j] for j in range(1, n) if j not in removed
              and any(c.endswith("position") for c in sk.channels[j])]
    if moving:
        warns.append("translation channels of non-root joints are ignored (bones are rigid): "
                     + ", ".join(moving))
    lengths = sk.bone_lengths() * scale
    big = [sk.names[j] for j in sorted(fuse_set) if lengths[j] >= 0.002]
    if big:
        warns.append("fused joints with non-zero length (their bone becomes rigid): "
                     + ", ".join(big))
    return {"removed": removed, "dropped": dropped, "fused": fuse_set, "into": into}


def _layout(sk: Skeleton, rec: Recognition, sel: dict, B: np.ndarray,
            scale: float) -> dict[int, _Body]:
    rest = scale * sk.rest_positions() @ B.T
    bodies: dict[int, _Body] = {}
    for j in range(sk.n_joints):
        if j in sel["removed"]:
            continue
        p = int(sk.parents[j])
        while p >= 0 and p in sel["removed"]:
            p = int(sk.parents[p])
        name = sk.names[j]
        role = rec.joint_roles[name]
        base = rec.base_role(name)
        bodies[j] = _Body(j=j, name=name, parent=p, role=role, base=base, side=rec.side(name),
                          pos=rest[j])
        if p >= 0:
            bodies[p].children.append(j)
    return bodies


# ------------------------------------------------------------------------------------------------
# 3. geometry
# ------------------------------------------------------------------------------------------------
def _geometry(sk: Skeleton, rec: Recognition, sel: dict, bodies: dict[int, _Body],
              B: np.ndarray, scale: float) -> float:
    """Fill each body's geoms and sites; returns the top of the skeleton (m, before offset)."""
    rest = scale * sk.rest_positions() @ B.T
    ends = scale * sk.rest_end_sites() @ B.T if sk.n_end_sites else np.zeros((0, 3))
    pts = np.concatenate([rest, ends])
    height = float(pts[:, 2].max() - pts[:, 2].min())
    s = height / T.REFERENCE_HEIGHT if height > 0 else 1.0
    desc = {j: _descendants(sk, j) for j in range(sk.n_joints)}

    def subtree_points(j: int) -> np.ndarray:
        idx = desc[j]
        e = [k for k in range(sk.n_end_sites) if sk.end_site_parents[k] in idx or
             sk.end_site_parents[k] == j]
        return np.concatenate([rest[idx], ends[e]]) if (idx or e) else np.zeros((0, 3))

    # where each end site hangs in the model (fused joints pass theirs on)
    site_body = {}
    for k in range(sk.n_end_sites):
        p = int(sk.end_site_parents[k])
        if p in sel["fused"]:
            p = sel["into"][p]
        if p in bodies:
            site_body.setdefault(p, []).append(ends[k])

    def end_points(b: _Body) -> list[np.ndarray]:
        out = [bodies[c].pos for c in b.children] + list(site_body.get(b.j, []))
        out = [p for p in out if np.linalg.norm(p - b.pos) > 0.005 * s]
        if out:
            return out
        # no kept children: the dropped children stand for the segment (e.g. fingers for a hand)
        gone = [c for c in sk.children(b.j) if c in sel["removed"]]
        if gone:
            m = np.mean(rest[gone], axis=0)
            if np.linalg.norm(m - b.pos) > 0.005 * s:
                return [m]
            sub = np.concatenate([subtree_points(c) for c in gone] + [rest[gone]])
            far = sub[np.argmax(np.linalg.norm(sub - b.pos, axis=1))]
            if np.linalg.norm(far - b.pos) > 0.005 * s:
                return [far]
        return []

    # feet first: the sole level is shared by both feet
    feet = {b.side: b for b in bodies.values() if b.base == "ankle" and b.side}
    sole = None
    for b in feet.values():
        below = subtree_points(b.j)
        lo = float(below[:, 2].min()) if len(below) else b.pos[2]
        sole_b = lo - 0.025 * s if lo < b.pos[2] - 0.01 * s else b.pos[2] - 0.075 * s
        sole = sole_b if sole is None else min(sole, sole_b)

    for b in bodies.values():
        r = T.RADIUS.get(b.base, T.RADIUS["unknown"]) * s
        if b.base == "ankle" and b.side:
            _foot(b, bodies, subtree_points, sole, s)
            continue
        if b.base == "toe" and b.side and b.parent in bodies and bodies[b.parent].base == "ankle":
            _toe(b, subtree_points, end_points(b), sole, s, bodies[b.parent])
            continue
        if b.parent < 0 and b.base != "pelvis":
            continue  # a reference root above the pelvis (e.g. on the floor): no geometry
        pts_b = _dedupe(end_points(b), b.pos)
        if not pts_b:
            pts_b = _default_segment(b, bodies, s)
        for i, e in enumerate(pts_b):
            d = e - b.pos
            length = float(np.linalg.norm(d))
            u = d / length
            rr = r
            if b.base in ("unknown", "end", "hand"):  # thin helpers stay thin
                rr = min(r, 0.25 * length + 0.005 * s)
            if b.base == "head":
                a = b.pos + u * min(0.5 * length, rr)
                c = e - u * rr
                if (c - a) @ u < 0:
                    a = c = b.pos + u * 0.5 * length
            else:
                k = min(rr, 0.3 * length)
                a, c = b.pos + u * k, e - u * k
            if float((c - a) @ u) < 0.002:  # MuJoCo needs distinct fromto points
                mid = 0.5 * (a + c)
                a, c = mid - 0.001 * u, mid + 0.001 * u
            gname = f"{b.name}_geom{i}" if i else f"{b.name}_geom"
            if b.base == "spine" and abs(u[2]) > 0.7:
                # the trunk is wider than deep: two capsules side by side (a flat back, so a
                # fallen character lies still instead of rolling on a round torso)
                side = np.array([0.0, T.TRUNK_PAIR_OFFSET * rr, 0.0])
                for tag, sgn in (("l", 1.0), ("r", -1.0)):
                    b.geoms.append(_Geom("capsule", f"{gname}_{tag}", a=a + sgn * side,
                                         b=c + sgn * side, radius=T.TRUNK_PAIR_RADIUS * rr))
                continue
            b.geoms.append(_Geom("capsule", gname, a=a, b=c, radius=rr))
        # sites
        if b.base == "head":
            g = b.geoms[0]
            b.sites["head"] = 0.5 * (g.a + g.b)
        if b.base == "wrist" and b.side:
            e = pts_b[0]
            b.sites[f"{b.side}_hand"] = 0.5 * (b.pos + e)
    # hands without a recognised wrist: the elbow's far end
    for side in ("left", "right"):
        if not any(f"{side}_hand" in b.sites for b in bodies.values()):
            el = [b for b in bodies.values() if b.base == "elbow" and b.side == side]
            if el and el[0].geoms:
                g = el[0].geoms[0]
                el[0].sites[f"{side}_hand"] = g.b
    return float(pts[:, 2].max())


def _descendants(sk: Skeleton, j: int) -> list[int]:
    out, stack = [], list(sk.children(j))
    while stack:
        c = stack.pop()
        out.append(c)
        stack.extend(sk.children(c))
    return sorted(out)


def _dedupe(points: list[np.ndarray], origin: np.ndarray, max_angle_deg: float = 25.0):
    """Drop end points in (nearly) the same direction as a farther one."""
    pts = sorted(points, key=lambda p: -float(np.linalg.norm(p - origin)))
    kept: list[np.ndarray] = []
    cos_max = math.cos(math.radians(max_angle_deg))
    for p in pts:
        d = (p - origin) / np.linalg.norm(p - origin)
        if all(float(d @ ((q - origin) / np.linalg.norm(q - origin))) < cos_max for q in kept):
            kept.append(p)
    return kept


def _default_segment(b: _Body, bodies: dict[int, _Body], s: float) -> list[np.ndarray]:
    """A short segment for a body with nothing below it, along its parent bone."""
    if b.base == "head":
        return [b.pos + np.array([0.0, 0.0, 0.2 * s])]
    if b.parent >= 0:
        d = b.pos - bodies[b.parent].pos
        length = float(np.linalg.norm(d))
        if length > 1e-9:
            ext = {"wrist": 0.08 * s, "toe": 0.05 * s}.get(b.base, max(0.25 * length, 0.03 * s))
            return [b.pos + d / length * ext]
    return [b.pos + np.array([0.0, 0.0, 0.1 * s])]


def _yaw_frame(d: np.ndarray) -> tuple[np.ndarray, float]:
    h = np.array([d[0], d[1], 0.0])
    n = np.linalg.norm(h)
    u = h / n if n > 1e-9 else np.array([1.0, 0.0, 0.0])
    return u, math.atan2(u[1], u[0])


def _foot(b: _Body, bodies, subtree_points, sole: float, s: float) -> None:
    """Foot box from the heel to the toe joint (or the foot's end), from the sole to the ankle."""
    toe = [c for c in b.children if bodies[c].base == "toe"]
    if toe:
        front = bodies[toe[0]].pos
    else:
        pts = subtree_points(b.j)
        if len(pts):
            u0, _ = _yaw_frame(np.mean(pts, axis=0) - b.pos)
            front = pts[np.argmax((pts - b.pos) @ u0)]
        else:
            front = b.pos + np.array([0.15 * s, 0.0, 0.0])
    u, yaw = _yaw_frame(front - b.pos)
    reach = float((front - b.pos) @ u)
    if reach < 0.05 * s:
        reach = 0.12 * s
    heel = max(0.05 * s, 0.3 * reach)
    top = b.pos[2] if b.pos[2] - sole > 0.03 * s else sole + 0.05 * s
    half = np.array([0.5 * (reach + heel), T.RADIUS["ankle"] * s, 0.5 * (top - sole)])
    center = b.pos + u * (0.5 * (reach - heel))
    center = np.array([center[0], center[1], 0.5 * (top + sole)])
    b.geoms.append(_Geom("box", f"{b.name}_geom", center=center, half=half, yaw=yaw))
    b.sites[f"{b.side}_foot"] = np.array([center[0], center[1], sole])


def _toe(b: _Body, subtree_points, ends: list[np.ndarray], sole: float, s: float,
         ankle: _Body) -> None:
    """Toe box from the toe joint to the toe's end, from the sole up."""
    u, yaw = _yaw_frame(b.pos - ankle.pos)
    pts = list(ends) + list(subtree_points(b.j))
    reach = max([float((p - b.pos) @ u) for p in pts] + [0.0])
    if reach < 0.03 * s:
        reach = 0.05 * s
    top = sole + float(np.clip(2.0 * (b.pos[2] - sole), 0.02 * s, 0.05 * s))
    half = np.array([0.5 * reach, T.RADIUS["toe"] * s, 0.5 * (top - sole)])
    c = b.pos + u * 0.5 * reach
    center = np.array([c[0], c[1], 0.5 * (top + sole)])
    b.geoms.append(_Geom("box", f"{b.name}_geom", center=center, half=half, yaw=yaw))
    b.sites[f"{b.side}_toe"] = np.array([center[0], center[1], sole])


def _floor_offset(bodies: dict[int, _Body]) -> np.ndarray:
    """Translation putting the root above the origin and the lowest geom on the floor (z=0)."""
    root = next(iter(bodies.values()))
    lows = [g.lowest() for b in bodies.values() for g in b.geoms]
    low = min(lows) if lows else min(b.pos[2] for b in bodies.values())
    return np.array([-root.pos[0], -root.pos[1], -low])


# ------------------------------------------------------------------------------------------------
# 4. masses
# ------------------------------------------------------------------------------------------------
def _masses(bodies: dict[int, _Body], total: float) -> None:
    """Body and geom masses summing to ``total`` kg (see the module docstring)."""
    min_mass = 1e-3 * total
    vols = {j: b.volume for j, b in bodies.items()}
    all_vol = sum(vols.values())
    fixed = 0.0
    groups: dict[tuple[str, str | None], list[int]] = {}
    for j, b in bodies.items():
        if vols[j] <= 0:
            b.mass = min_mass
            fixed += min_mass
            continue
        g = T.ROLE_GROUP.get(b.base)
        if g is None:
            b.mass = T.DENSITY * vols[j] * total / max(T.DENSITY * all_vol, 1e-12)
            fixed += b.mass
            continue
        side = b.side if g not in ("trunk", "head_neck") else None
        groups.setdefault((g, side), []).append(j)
    remaining = total - fixed
    if remaining <= 0:
        raise ConversionError("the bodies of unknown role leave no mass for the recognised ones")
    frac = {k: T.GROUP_FRACTION[k[0]] for k in groups}
    f_sum = sum(frac.values())
    for key, members in groups.items():
        m_group = remaining * frac[key] / f_sum
        if key[0] == "trunk":
            fixed_share = {j: T.TRUNK_SHARE[bodies[j].base] for j in members
                           if bodies[j].base in T.TRUNK_SHARE}
            spine = [j for j in members if j not in fixed_share]
            share_total = T.GROUP_FRACTION["trunk"]
            if not spine:  # no spine bodies: the fixed shares take all of the trunk
                share_total = sum(fixed_share.values())
            for j, sh in fixed_share.items():
                bodies[j].mass = m_group * sh / share_total
            rest = m_group - sum(bodies[j].mass for j in fixed_share)
            v = sum(vols[j] for j in spine)
            for j in spine:
                bodies[j].mass = rest * vols[j] / v
        else:
            v = sum(vols[j] for j in members)
            for j in members:
                bodies[j].mass = m_group * vols[j] / v
    for j, b in bodies.items():
        if vols[j] > 0:
            for g in b.geoms:
                g.mass = b.mass * g.volume / vols[j]


# ------------------------------------------------------------------------------------------------
# 5. joints
# ------------------------------------------------------------------------------------------------
def _flexion_axis(b: _Body, bodies: dict[int, _Body]) -> tuple[str, float]:
    """(world axis name, sign) of the flexion hinge of a knee or an elbow.

    Knee flexion moves the shank backward (-x), elbow flexion moves the forearm forward (+x): the
    rotation axis is ``e x flex_dir`` for the distal segment direction ``e``, snapped to the
    nearest world axis; ``sign`` is +1 when flexion is a positive rotation about that axis.
    """
    kids = [bodies[c].pos for c in b.children]
    ends = [g.b for g in b.geoms if g.kind == "capsule"]
    tip = kids[0] if kids else (ends[0] if ends else None)
    flex_dir = np.array([-1.0, 0.0, 0.0]) if b.base == "knee" else np.array([1.0, 0.0, 0.0])
    if tip is not None and np.linalg.norm(tip - b.pos) > 1e-9:
        e = (tip - b.pos) / np.linalg.norm(tip - b.pos)
        a = np.cross(e, flex_dir)
        if np.linalg.norm(a) > 0.3:
            i = int(np.argmax(np.abs(a)))
            return "xyz"[i], float(np.sign(a[i]))
    return ("y", 1.0) if b.base == "knee" else ("z", -1.0 if b.side == "left" else 1.0)


def _best_order(q_mj: np.ndarray) -> str:
    """Hinge order (of the six Tait-Bryan ones) whose middle angle stays smallest over ``q_mj``."""
    r = to_rotation(q_mj)
    best, best_val = "zyx", np.inf
    with _warnings.catch_warnings():
        _warnings.simplefilter("ignore")
        for order in ("zyx", "yxz", "zxy", "xyz", "xzy", "yzx"):
            mid = float(np.max(np.abs(r.as_euler(order.upper())[:, 1])))
            if mid < best_val - 1e-9:
                best, best_val = order, mid
    return best


def _joints(sk: Skeleton, bodies: dict[int, _Body], joint_model: str, motion: Motion | None,
            B: np.ndarray) -> None:
    basis_r = Rotation.from_matrix(B)
    for j, b in bodies.items():
        if b.parent < 0:
            b.joints = [{"name": "root", "type": "free"}]
            b.order = "free"
            continue
        if not sk.rotation_order(j):
            b.joints, b.order = [], ""
            continue
        role_rng = T.RANGE_DEG.get(b.base, T.RANGE_DEG["unknown"])
        if b.base in ("knee", "elbow") and joint_model in ("hinge", "ball") and b.side:
            axis, sign = _flexion_axis(b, bodies)
            lo, hi = T.FLEXION_RANGE[b.base]
            rng = (lo, hi) if sign > 0 else (-hi, -lo)
            b.joints = [{"name": f"{b.name}_{axis}", "type": "hinge", "axis": axis, "range": rng}]
            b.order = axis
            continue
        if joint_model == "ball":
            cone = max(max(abs(v) for v in role_rng[a]) for a in "xyz")
            b.joints = [{"name": b.name, "type": "ball", "range": (0.0, min(cone, 180.0))}]
            b.order = "ball"
            continue
        order = T.EULER_ORDER.get(b.base, "zyx")
        if b.base in ("unknown", "end") and motion is not None:
            q = to_rotation(motion.rotations[:, j])
            order = _best_order(from_rotation(basis_r * q * basis_r.inv()))
        b.order = order
        b.joints = []
        for a in order:
            rng = None
            if joint_model == "hinge":
                rng = T.mirrored_range(role_rng[a], a, b.side)
            b.joints.append({"name": f"{b.name}_{a}", "type": "hinge", "axis": a, "range": rng})


# ------------------------------------------------------------------------------------------------
# 6. actuators
# ------------------------------------------------------------------------------------------------
def _subtree_mass(bodies: dict[int, _Body], j: int) -> float:
    b = bodies[j]
    return b.mass + sum(_subtree_mass(bodies, c) for c in b.children)


def _actuators(bodies: dict[int, _Body], joint_model: str, total: float, overrides: dict,
               sk: Skeleton) -> list[dict]:
    used: set[str] = set()
    out = []
    for j, b in bodies.items():
        if not b.joints or b.joints[0]["type"] == "free":
            continue
        m_sub = _subtree_mass(bodies, j)
        if b.base in T.GAINS:
            kp, kd, tau, frac = T.GAINS[b.base]
            f = float(np.clip(m_sub / (frac * total), *T.GAIN_SCALE_BOUNDS))
            f *= total / T.REFERENCE_MASS
            kp, kd, tau = kp * f, kd * f, tau * f
        else:
            kp = float(np.clip(T.UNKNOWN_KP_PER_KG * m_sub, 5.0, 1000.0))
            kd, tau = 0.1 * kp, 0.3 * kp
        arm = T.ARMATURE.get(b.base, T.ARMATURE["unknown"])
        damp = T.DAMPING.get(b.base, T.DAMPING["unknown"])
        gains = {"kp": kp, "kd": kd, "torque": tau, "armature": arm, "damping": damp}
        for key in ("default", b.base, b.role, b.name):
            if key in overrides:
                gains.update(overrides[key])
                used.add(key)
        for jt in b.joints:
            jt["armature"] = gains["armature"]
            jt["damping"] = gains["damping"]
            if jt["type"] == "hinge":
                out.append({"type": "position", "name": jt["name"], "joint": jt["name"],
                            "kp": gains["kp"], "kv": gains["kd"], "torque": gains["torque"]})
            else:
                for i, a in enumerate("xyz"):
                    gear = [0.0, 0.0, 0.0]
                    gear[i] = 1.0
                    out.append({"type": "motor", "name": f"{jt['name']}_{a}", "joint": jt["name"],
                                "gear": gear, "torque": gains["torque"]})
    unused = set(overrides) - used
    if unused:
        raise ConversionError(
            "gains: keys match no kept joint or role: " + ", ".join(sorted(unused))
            + "; use BVH joint names, roles (left_knee) or base roles (knee), or 'default'")
    return out


# ------------------------------------------------------------------------------------------------
# 7. XML
# ------------------------------------------------------------------------------------------------
def _round(x: float) -> float:
    """A float rounded to 9 significant digits (stable JSON output)."""
    return float(f"{float(x):.9g}") + 0.0  # + 0.0 turns -0.0 into 0.0


def _f(x: float) -> str:
    x = float(x)
    if abs(x) < 1e-9:
        return "0"
    s = f"{x:.6g}"
    return "0" if s in ("-0", "0") else s


def _v(v) -> str:
    return " ".join(_f(x) for x in v)


def _yaw_quat(yaw: float) -> np.ndarray:
    return np.array([math.cos(0.5 * yaw), 0.0, 0.0, math.sin(0.5 * yaw)])


def _write_xml(name: str, bodies: dict[int, _Body], actuators: list[dict], info: ModelInfo,
               offset: np.ndarray, timestep: float, sk: Skeleton) -> str:
    root_el = ET.Element("mujoco", {"model": name})
    ET.SubElement(root_el, "compiler", {"angle": "radian", "autolimits": "true"})
    ET.SubElement(root_el, "option", {"timestep": _f(timestep), "integrator": "implicitfast"})
    vis = ET.SubElement(root_el, "visual")
    ET.SubElement(vis, "global", {"offwidth": "1280", "offheight": "720"})
    default = ET.SubElement(root_el, "default")
    ET.SubElement(default, "geom", {"contype": "2", "conaffinity": "1", "condim": "3",
                                    "friction": _v(T.FRICTION), "solref": _v(T.SOLREF),
                                    "material": "body"})
    ET.SubElement(default, "site", {"size": "0.02", "rgba": "1 0.3 0.3 0.5", "group": "4"})
    asset = ET.SubElement(root_el, "asset")
    ET.SubElement(asset, "texture", {"name": "grid", "type": "2d", "builtin": "checker",
                                     "width": "512", "height": "512", "rgb1": "0.2 0.3 0.4",
                                     "rgb2": "0.3 0.4 0.5"})
    ET.SubElement(asset, "material", {"name": "grid", "texture": "grid", "texrepeat": "1 1",
                                      "texuniform": "true", "reflectance": "0.1"})
    ET.SubElement(asset, "material", {"name": "body", "rgba": "0.8 0.6 0.45 1"})
    world = ET.SubElement(root_el, "worldbody")
    ET.SubElement(world, "light", {"name": "sun", "pos": "0 0 4", "dir": "0 0 -1",
                                   "directional": "true"})
    ET.SubElement(world, "geom", {"name": "floor", "type": "plane", "size": "0 0 0.05",
                                  "contype": "1", "conaffinity": "1", "friction": _v(T.FRICTION),
                                  "solref": _v(T.SOLREF), "material": "grid"})

    def emit(parent_el, j: int, parent_pos: np.ndarray) -> None:
        b = bodies[j]
        world_pos = b.pos + offset
        rel = world_pos - parent_pos
        el = ET.SubElement(parent_el, "body", {"name": b.name, "pos": _v(rel)})
        for jt in b.joints:
            if jt["type"] == "free":
                ET.SubElement(el, "freejoint", {"name": "root"})
                continue
            attrs = {"name": jt["name"], "type": jt["type"]}
            if jt["type"] == "hinge":
                axis = [0, 0, 0]
                axis[AXIS_INDEX[jt["axis"]]] = 1
                attrs["axis"] = _v(axis)
            if jt.get("range") is not None:
                attrs["range"] = _v(np.radians(jt["range"]))
            attrs["armature"] = _f(jt.get("armature", 0.0))
            attrs["damping"] = _f(jt.get("damping", 0.0))
            ET.SubElement(el, "joint", attrs)
        if b.parent < 0:
            ET.SubElement(el, "camera", {"name": "track", "mode": "trackcom", "pos": "0 -3.5 0.2",
                                         "xyaxes": "1 0 0 0 0 1"})
        if not b.geoms:
            m = b.mass
            i = m * 0.02 ** 2
            ET.SubElement(el, "inertial", {"pos": "0 0 0", "mass": _f(m),
                                           "diaginertia": _v([i] * 3)})
        for g in b.geoms:
            if g.kind == "capsule":
                ET.SubElement(el, "geom", {"name": g.name, "type": "capsule",
                                           "fromto": _v(np.concatenate([g.a - b.pos, g.b - b.pos])),
                                           "size": _f(g.radius), "mass": _f(g.mass)})
            else:
                attrs = {"name": g.name, "type": "box", "pos": _v(g.center - b.pos),
                         "size": _v(g.half), "mass": _f(g.mass)}
                if abs(g.yaw) > 1e-9:
                    attrs["quat"] = _v(_yaw_quat(g.yaw))
                ET.SubElement(el, "geom", attrs)
        for sname in sorted(b.sites):
            ET.SubElement(el, "site", {"name": sname, "pos": _v(b.sites[sname] - b.pos)})
        for c in b.children:
            emit(el, c, world_pos)

    root_j = next(iter(bodies))
    emit(world, root_j, np.zeros(3))
    eq = ET.SubElement(root_el, "equality")
    ET.SubElement(eq, "weld", {"name": "root_weld", "body1": bodies[root_j].name,
                               "active": "false"})
    act = ET.SubElement(root_el, "actuator")
    for a in actuators:
        if a["type"] == "position":
            ET.SubElement(act, "position", {"name": a["name"], "joint": a["joint"],
                                            "kp": _f(a["kp"]), "kv": _f(a["kv"]),
                                            "forcerange": _v([-a["torque"], a["torque"]])})
        else:
            ET.SubElement(act, "motor", {"name": a["name"], "joint": a["joint"],
                                         "gear": _v(a["gear"]),
                                         "forcerange": _v([-a["torque"], a["torque"]])})
    custom = ET.SubElement(root_el, "custom")
    ET.SubElement(custom, "text", {"name": "mjchar",
                                   "data": json.dumps(info.to_dict(), separators=(", ", ": "))})
    ET.indent(root_el, space="  ")
    return ET.tostring(root_el, encoding="unicode") + "\n"
