"""What SIMBICON reads from a model's hinges at rest: the error it raises when a body lacks
what the walk needs, a joint's hinges keyed by their rest axes, which way a hinge turns a limb,
the knee's flexion hinge and its yaw, and a rest pose's offset angles
(:mod:`mjchar.controllers.walking.simbicon` uses them when it maps a body at reset:
``Simbicon._map``, ``_map_leg``, ``_map_upper_body``, ``_set_gains``). This module grows into
the one map of a rig the walkers read."""

from __future__ import annotations

import math

import numpy as np

from ..core.base import ControllerError

#: the rest pose's axes a hinge is keyed by (the canonical rest: x forward, y left, z up)
AXIS_NAMES = {"x": "forward", "y": "lateral", "z": "vertical"}
#: the least lateral component (of a unit axis) a knee hinge needs to flex the leg: 0.3 is
#: 72 degrees off the lateral axis
KNEE_MIN_LATERAL = 0.3


class SimbiconModelError(ControllerError):
    """The model lacks what SIMBICON reads from it (a hinge at a leg joint, a knee that flexes
    about one axis near the lateral one, a hinge whose sign the rest pose tells); the message
    names the joint and what would fix it."""


#: how a body made by ``mjchar convert`` gets hinge triplets and a single knee hinge
HINGE_FIX = "convert the BVH with the default --joint-model hinge"


def rest_angle(sine: float) -> float:
    """``asin(sine)`` (rad), 0 below 1e-6 rad: a rest pose's offset from the pose a gait assumes
    (numerical noise on a rig in that pose is no offset)."""
    a = math.asin(min(max(sine, -1.0), 1.0))
    return a if abs(a) > 1e-6 else 0.0


def knee_yaw(flex_axis: np.ndarray, fwd: np.ndarray, left: np.ndarray) -> float:
    """Yaw (rad, about up) that turns the lateral axis ``left`` ``(3,)`` onto the horizontal part
    of a knee's flexion axis ``flex_axis`` ``(3,)`` (a positive rotation about it flexes the
    knee); exactly 0 for an axis with no forward component."""
    f = float(flex_axis @ fwd)
    return math.atan2(-f, float(flex_axis @ left)) if f else 0.0


def knee_hinge(hinges: dict, axes: np.ndarray, shank: np.ndarray, left: np.ndarray,
               knee: str) -> tuple[Hinge, float | None]:
    """The knee's flexion hinge: its one hinge, whichever canonical axis it is nearest at rest
    (a knee fitted to a capture may lie far off the lateral axis), as long as turning about it
    swings the shank ``(3,)`` fore and aft (its axis has a lateral part across the shank;
    ``axes``: the joints' world axes at rest, ``left``: the pelvis's lateral axis).

    Returns the hinge and, for a hinge nearest another axis than the lateral one, ``1 - (a.u)^2``
    (``a`` its axis, ``u`` the shank's direction): how much of a turn about it bends the leg
    (:func:`knee_angle`); ``None`` for a knee about the lateral axis (its angle is the bend)."""
    if len(hinges) != 1:
        raise SimbiconModelError(
            f"{knee}: SIMBICON needs a single flexion hinge at the knee; it has {len(hinges)} "
            f"hinge(s) about {', '.join(AXIS_NAMES[k] for k in hinges) or 'nothing'}: "
            f"{HINGE_FIX}, or map left_knee/right_knee to the knees (--roles)")
    h = next(iter(hinges.values()))
    u = shank / max(float(np.linalg.norm(shank)), 1e-12)
    if abs(float(axes[h.jnt] @ left)) < KNEE_MIN_LATERAL or abs(float(axes[h.jnt] @ u)) > 0.9:
        raise SimbiconModelError(
            f"{knee}: the knee's hinge turns about an axis that cannot flex the leg fore and aft "
            f"(world axis {np.round(axes[h.jnt], 2).tolist()} at rest): convert the BVH again "
            "(mjchar convert fits the knee on the clip's flexion), or map left_knee/right_knee "
            "to the knees (--roles)")
    if abs(float(axes[h.jnt] @ left)) >= np.max(np.abs(axes[h.jnt])) - 1e-12:
        return h, None
    return h, 1.0 - float(axes[h.jnt] @ u) ** 2


def knee_angle(bend: float, across: float | None) -> float:
    """The turn (rad) about a knee's hinge that bends the leg by ``bend`` rad (the angle between
    thigh and shank directions, from a straight leg), ``across`` from :func:`knee_hinge`: a
    hinge tilted towards the shank bends it by ``1 - cos(bend) = across (1 - cos(q))``; ``bend``
    itself for a knee about the lateral axis, at most half a turn."""
    if across is None:
        return bend
    c = 1.0 - (1.0 - math.cos(bend)) / across
    return math.copysign(math.acos(min(max(c, -1.0), 1.0)), bend)


class Hinge:
    """One hinge dof of a joint: dof index, qpos address, joint id and actuator index."""

    __slots__ = ("dof", "qadr", "jnt", "act")

    def __init__(self, dof: int, qadr: int, jnt: int, act: int):
        self.dof, self.qadr, self.jnt, self.act = dof, qadr, jnt, act


def joint_hinges(character, rest_axes: np.ndarray, dof2act: np.ndarray,
                 joint: str) -> dict[str, Hinge]:
    """``joint``'s hinges keyed by the world axis they are closest to at rest (``x y z``;
    ``rest_axes``: the joints' world axes at rest, ``dof2act``: the actuator of each dof)."""
    out: dict[str, Hinge] = {}
    for dof in character.joint_dofs(joint):
        if not character.hinge_dofs[dof]:
            raise SimbiconModelError(
                f"SIMBICON needs hinge joints; {joint} is not a hinge: {HINGE_FIX}"
            )
        j = int(character.dof_joint[dof])
        a = rest_axes[j]
        key = "xyz"[int(np.argmax(np.abs(a)))]
        out[key] = Hinge(int(dof), int(character.dof_qpos[dof]), j, int(dof2act[dof]))
    return out


def require_hinge(hinges: dict, axis: str, joint: str, what: str) -> None:
    """A one-line :class:`SimbiconModelError` unless ``hinges`` has one about ``axis``."""
    if axis not in hinges:
        raise SimbiconModelError(
            f"{joint}: SIMBICON needs a {what} hinge (about the {AXIS_NAMES[axis]} axis "
            f"at rest) and this joint has {len(hinges)} hinge(s) about "
            f"{', '.join(AXIS_NAMES[k] for k in hinges) or 'nothing'}: give the BVH "
            "joint rotation channels, or map the role to a joint that has them (--roles)")


def hinge_sign(axis: np.ndarray, lever: np.ndarray, towards: np.ndarray, joint: str = "",
               needed: bool = True) -> float:
    """+1 if a positive rotation about ``axis`` moves ``lever``'s tip to ``towards``, else -1;
    a hinge the walk does not need (an arm's) whose sense the rest pose does not tell gives 0:
    it is held at its rest angle (plain PD) instead of stopping the walker."""
    s = float(np.dot(np.cross(axis, lever), towards))
    if not needed:  # an arm: a sense under 3 degrees of the lever's swing is none
        return 0.0 if abs(s) < 0.05 * float(np.linalg.norm(lever)) else math.copysign(1.0, s)
    if abs(s) < 1e-9:
        raise SimbiconModelError(
            f"{joint or 'a hinge'}: SIMBICON cannot tell which way the hinge turns the "
            "limb in the rest pose (its axis is along the bone, or the bone has no "
            "length); convert the BVH again so the rest pose stands with legs down "
            "(mjchar convert), or map the role to a joint with a bone (--roles)")
    return 1.0 if s > 0 else -1.0
