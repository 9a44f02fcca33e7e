"""The converter's body layout: frame, joint selection and the body records (steps 1-2).

Step 1, :func:`_basis_matrix`: the proper rotation ``B`` taking file axes to MuJoCo's x forward,
y left, z up (units and the up axis come from :mod:`.prepare`).
Step 2, :func:`_select`: which joints get bodies (dropped subtrees, fused joints; defaults
:func:`default_drop` and :func:`default_fuse`), and :func:`_layout`: the kept joints as
:class:`_Body` records (world rest positions in metres, MuJoCo axes), which the later steps fill
with :class:`_Geom` geoms, masses, joints and sites. Part of :func:`mjchar.bvh.mjcf.convert`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from mjchar.bvh.errors import name_list
from mjchar.bvh.io.skeleton import Skeleton
from mjchar.bvh.mjcf.info import ConversionError
from mjchar.bvh.rigs.naming import DETAIL_ROLES, Recognition
from mjchar.bvh.rigs.units import AXIS_VECTORS


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
# 1. frame
# ------------------------------------------------------------------------------------------------
def _basis_matrix(rec: Recognition, up: str) -> np.ndarray:
    """Rows: the file's forward, left and up unit vectors (so ``B @ v`` is in MuJoCo axes)."""
    u = AXIS_VECTORS[up]
    cands = [s * AXIS_VECTORS[a] for a in "xyz" if a != up[-1] for s in (1.0, -1.0)]
    if rec.left_axis is not None:
        left = max(cands, key=lambda c: float(c @ rec.left_axis))
    else:
        left = AXIS_VECTORS["x"] if up[-1] != "x" else AXIS_VECTORS["y"]
    fwd = np.cross(left, u)
    return np.stack([fwd, left, u])


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
                                  + name_list(sk.names))
    return out


def default_drop(sk: Skeleton, rec: Recognition) -> list[int]:
    """Joints dropped by default: hand joints below the wrists, leaf end markers, the face
    below the head, toe phalanges and other toes beside the toe joint, twist helpers without
    children."""
    return [j for j in range(1, sk.n_joints)
            if rec.joint_roles[sk.names[j]] in DETAIL_ROLES
            or (rec.joint_roles[sk.names[j]] == "twist" and not sk.children(j))]


#: roles whose joints, when they are all the children of a joint of unknown role, make that
#: joint a helper of the body's structure (CMU's ``LHipJoint`` above ``LeftUpLeg``, a
#: ``buttock``, Daz's ``pelvis`` above both thighs)
_STRUCTURE_ROLES = ("hip", "clavicle", "shoulder", "spine", "neck", "head")


def default_fuse(sk: Skeleton, rec: Recognition, scale: float, joint_model: str) -> list[int]:
    """Joints of unknown role that are zero-length (offset < 2 mm) or helpers of the body's
    structure (children that are all hips, clavicles, shoulders or trunk joints: CMU's
    ``LHipJoint``, a ``buttock``, Daz's ``pelvis`` above both thighs), and twist helpers
    inside a limb (they turn about their bone, which keeps the limb's joints in place); none in
    the ``full`` model."""
    if joint_model == "full":
        return []
    lengths = sk.bone_lengths() * scale
    out = []
    for j in range(1, sk.n_joints):
        kids = sk.children(j)
        role = rec.joint_roles[sk.names[j]]
        if not kids or role not in ("unknown", "twist"):
            continue
        helper = all(rec.base_role(sk.names[k]) in _STRUCTURE_ROLES for k in kids)
        if role == "twist" or lengths[j] < 0.002 or helper:
            out.append(j)
    return out


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
                              + name_list(sk.names[j] for j in sorted(both)))
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
    into: dict[int, int] = {}  # parents come first: one pass finds each removed joint's keeper
    for j, a in enumerate(sk.parents.tolist()):
        if j in removed:
            into[j] = into[a] if a in removed else a
    if joint_model == "full" and fuse_set:
        warns.append("full model with fused joints: replay is exact only while their rotations "
                     "stay identity: " + name_list(sk.names[j] for j in sorted(fuse_set)))
    lengths = sk.bone_lengths() * scale
    big = [sk.names[j] for j in sorted(fuse_set) if lengths[j] >= 0.002]
    if big:
        warns.append("fused joints with non-zero length (their bone becomes rigid): "
                     + name_list(big))
    return {"removed": removed, "dropped": dropped, "fused": fuse_set, "into": into}


def _layout(sk: Skeleton, rec: Recognition, sel: dict, B: np.ndarray,
            scale: float) -> dict[int, _Body]:
    rest = scale * sk.rest_positions() @ B.T
    bodies: dict[int, _Body] = {}
    for j in range(sk.n_joints):
        if j in sel["removed"]:
            continue
        p = int(sk.parents[j])
        p = sel["into"].get(p, p)  # the nearest kept ancestor
        name = sk.names[j]
        role = rec.joint_roles[name]
        base = rec.base_role(name)
        bodies[j] = _Body(j=j, name=name, parent=p, role=role, base=base, side=rec.side(name),
                          pos=rest[j])
        if p >= 0:
            bodies[p].children.append(j)
    return bodies

