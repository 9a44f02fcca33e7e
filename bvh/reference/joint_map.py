"""The joint map of a reference motion: which model body and joints carry each kept BVH joint.

A model written by :mod:`mjchar.bvh.mjcf` records, per kept BVH joint, its body and the names of
that body's joints (``ModelInfo.joints``). :func:`_build_slots` resolves them in a compiled
``mujoco.MjModel`` into :class:`_Slot` records (body id, parent kept joint, joint kind ``free`` /
``ball`` / ``hinge`` / ``fixed``, qpos and dof addresses, hinge axes) and checks that the layout
is one :class:`mjchar.bvh.reference.reference_motion.ReferenceMotion` can fill (see
``docs/model-contract.md``). :func:`_subtree_bodies` walks the model's body tree.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from mjchar.bvh.errors import ReferenceMotionError
from mjchar.bvh.kinematics.qpos_algebra import _BALL, _FREE, _HINGE, _SLIDE
from mjchar.bvh.mjcf import ModelInfo


@dataclass
class _Slot:
    """One kept BVH joint and the model joints of its body."""

    name: str
    bvh: int                    # index in the (converted) motion's skeleton
    body: int                   # model body id
    parent_bvh: int             # kept BVH joint owning the model parent body, -1 for the world
    kind: str                   # "free", "ball", "hinge" or "fixed"
    qadr: np.ndarray            # qpos addresses of the rotation joints, kinematic order
    dadr: np.ndarray            # dof addresses of the rotation joints
    axes: np.ndarray            # (n, 3) hinge axes in the body frame
    slide_qadr: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    slide_axes: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))


def _model_info(model: mujoco.MjModel):
    return ModelInfo.from_model(model)


def _name2id(model: mujoco.MjModel, obj, name: str, what: str) -> int:
    i = mujoco.mj_name2id(model, obj, name)
    if i < 0:
        raise ReferenceMotionError(f"the model has no {what} named {name!r} (joint map and model "
                                   f"disagree; was the model written by mjchar.bvh.mjcf?)")
    return int(i)


def _build_slots(model: mujoco.MjModel, info, skeleton) -> list[_Slot]:
    names = list(info.joints)
    missing = [n for n in names if n not in skeleton.names]
    if missing:
        shown = ", ".join(missing[:3]) + (", ..." if len(missing) > 3 else "")
        raise ReferenceMotionError(
            f"the motion lacks {len(missing)} of the {len(names)} joints the model was built with "
            f"({shown}): it is not on the model's skeleton; convert the clip "
            f"(mjchar convert CLIP -o model.xml) and use that model (--model model.xml)")
    body_of = {n: _name2id(model, mujoco.mjtObj.mjOBJ_BODY, info.joints[n].body, "body")
               for n in names}
    bvh_of_body = {b: skeleton.index(n) for n, b in body_of.items()}
    slots = []
    for n in names:
        b = body_of[n]
        pb = int(model.body_parentid[b])
        while pb != 0 and pb not in bvh_of_body:
            pb = int(model.body_parentid[pb])
        parent_bvh = bvh_of_body.get(pb, -1)
        jids = np.flatnonzero(model.jnt_bodyid == b)
        types = model.jnt_type[jids].astype(int)
        slide = jids[types == _SLIDE]
        rot = jids[types != _SLIDE]
        if len(slide) and len(rot) and slide.max() > rot.min():
            raise ReferenceMotionError(f"body {info.joints[n].body!r}: slide joints after rotation "
                                       f"joints are not supported")
        kinds = {int(k) for k in types[types != _SLIDE]}
        if not len(rot):
            kind = "fixed"
        elif kinds == {_FREE} and len(rot) == 1:
            kind = "free"
        elif kinds == {_BALL} and len(rot) == 1:
            kind = "ball"
        elif kinds == {_HINGE} and len(rot) <= 3:
            kind = "hinge"
        else:
            raise ReferenceMotionError(f"body {info.joints[n].body!r}: unsupported joint layout "
                                       f"(types {sorted(int(k) for k in kinds)})")
        axes = model.jnt_axis[rot].copy() if kind == "hinge" else np.zeros((0, 3))
        axes /= np.maximum(np.linalg.norm(axes, axis=1, keepdims=True), 1e-300)
        if kind == "hinge" and len(rot) >= 2 and not np.allclose(np.abs(axes).max(axis=1), 1.0,
                                                                 atol=1e-6):
            raise ReferenceMotionError(f"body {info.joints[n].body!r}: hinge triplets must turn "
                                       f"about the body axes, got {axes.tolist()}")
        slots.append(_Slot(
            name=n, bvh=skeleton.index(n), body=b, parent_bvh=parent_bvh, kind=kind,
            qadr=model.jnt_qposadr[rot].astype(int), dadr=model.jnt_dofadr[rot].astype(int),
            axes=axes, slide_qadr=model.jnt_qposadr[slide].astype(int),
            slide_axes=model.jnt_axis[slide].copy(),
        ))
    roots = [s for s in slots if s.kind == "free"]
    if len(roots) != 1:
        raise ReferenceMotionError(f"expected exactly one free (root) joint among the mapped "
                                   f"bodies, found {len(roots)}")
    return slots


def _subtree_bodies(model: mujoco.MjModel, body: int) -> list[int]:
    out = []
    for b in range(model.nbody):
        c = b
        while c > 0 and c != body:
            c = int(model.body_parentid[c])
        if c == body:
            out.append(b)
    return out
