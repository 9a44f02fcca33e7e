"""A rig read at rest for the walkers: the one place SIMBICON
(:mod:`mjchar.controllers.walking.simbicon`) and IPM (:mod:`mjchar.controllers.walking.ipm`)
learn which joints, bodies, dofs and hinges of a Character they drive, so their controllers hold
only control.

- Both walkers: :func:`leg_joints` (a leg's hip, knee, ankle and toe joints by role, their
  bodies and dofs, its sole site: :class:`LegJoints`; IPM's
  :class:`~mjchar.controllers.walking.leg.Leg` builds its IPM-specific geometry on it) and
  :func:`child_hinges` (the hinges on the pelvis other than the hips': the spine, whose torques
  the stance hip answers).
- SIMBICON's map, read at reset from the rest pose (:class:`RestBody`): one hinge actuator per
  dof (:func:`map_actuators`); each leg's hinges keyed by their rest axes, bodies, actuators
  and the signs measured at rest (:func:`map_leg`, :class:`SimbiconLeg`); the upper body's base
  targets, gain groups, spine-pitch and arm-swing hinges (:func:`map_upper_body`,
  :class:`UpperBody`); and the hinge algebra they use: a joint's hinges keyed by rest axis,
  which way a hinge turns a limb, the knee's flexion hinge and its yaw, a rest pose's offset
  angles, and the error (:class:`SimbiconModelError`) naming the joint that lacks what the walk
  needs.

One module rather than a leg module and a SIMBICON one: every function here answers the same
question (what does this rig's rest pose say a walker drives?) from the same inputs (the
Character and its rest-pose kinematics), and the hinge helpers exist only for the maps. It grew
from the module of SIMBICON's hinge helpers, whose readers were the maps that now live beside
them."""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from ..core.base import ControllerError
from ..core.character import Character, Kinematics

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


# -- the facts of one leg both walkers read --------------------------------------------------
@dataclass(frozen=True, eq=False)
class LegJoints:
    """One leg of a Character by its roles: the joints playing ``{side}_hip``, ``_knee``,
    ``_ankle`` and (if the rig has one) ``_toe``, the bodies they move (thigh, shank, foot) and
    their dofs (indices into qvel; the toe's empty without one). SIMBICON's leg map
    (:func:`map_leg`) and IPM's :class:`~mjchar.controllers.walking.leg.Leg` both read a leg
    from here."""

    side: str
    hip: str
    knee: str
    ankle: str
    toe: str | None
    thigh: int
    shank: int
    foot: int
    hip_dofs: np.ndarray
    knee_dofs: np.ndarray
    ankle_dofs: np.ndarray
    toe_dofs: np.ndarray

    def site(self, ch: Character) -> int:
        """The id of the leg's sole site, ``{side}_foot`` (on the foot: the model contract's)."""
        return ch.site_id(f"{self.side}_foot")


def leg_joints(ch: Character, side: str) -> LegJoints:
    """The :class:`LegJoints` of the ``side`` (``"left"`` or ``"right"``) leg of ``ch``."""
    hip, knee, ankle = (ch.role(f"{side}_{p}") for p in ("hip", "knee", "ankle"))
    toe = ch.role(f"{side}_toe", required=False)
    dofs = [ch.joint_dofs(n) for n in (hip, knee, ankle)]  # (an unknown joint raises here)
    toe_dofs = ch.joint_dofs(toe) if toe else np.zeros(0, int)
    return LegJoints(side, hip, knee, ankle, toe, ch.body_id(hip), ch.body_id(knee),
                     ch.body_id(ankle), *dofs, toe_dofs)


# -- SIMBICON's map of a body at rest --------------------------------------------------------
@dataclass(frozen=True, eq=False)
class RestBody:
    """A Character at rest as SIMBICON's maps read it: the rest pose's kinematics ``kin``
    (every joint at zero), the actuator of each dof ``dof2act`` ``(nv,)`` (-1: none) and the
    pelvis's axes at rest ``fwd``, ``left``, ``up`` ``(3,)`` (the canonical rest's x, y, z)."""

    ch: Character
    kin: Kinematics
    dof2act: np.ndarray
    fwd: np.ndarray
    left: np.ndarray
    up: np.ndarray

    def hinges(self, joint: str) -> dict[str, Hinge]:
        """``joint``'s hinges keyed by the world axis they are closest to at rest (``x y z``)."""
        return joint_hinges(self.ch, self.kin.joint_axes, self.dof2act, joint)

    def position(self, joint: str) -> np.ndarray:
        """``(3,)`` world position (m) at rest of the body ``joint`` moves."""
        return self.kin.body_positions[self.ch.body_id(joint)]

    def axis(self, h: Hinge) -> np.ndarray:
        """``(3,)`` world axis at rest of hinge ``h``."""
        return self.kin.joint_axes[h.jnt]


def rest_body(ch: Character, pelvis: int, dof2act: np.ndarray) -> RestBody:
    """The :class:`RestBody` of ``ch`` (``pelvis``: the pelvis body's id)."""
    kin = ch.poses.kinematics(ch.poses.rest())
    Rp = kin.body_rotations[pelvis]
    return RestBody(ch, kin, dof2act, Rp[:, 0], Rp[:, 1], Rp[:, 2])


@dataclass(eq=False)
class SimbiconLeg:
    """One leg as SIMBICON drives it (:func:`map_leg`): its hinges keyed by rest axis, bodies,
    actuators, and the signs measured on the model at rest (anatomical ``+`` = this many times
    hinge ``+``; heading-frame rotations of the thigh: flexion about left, abduction about
    forward).

    Attributes:
        side: ``"left"`` or ``"right"``.
        joints: the leg's joints, bodies and dofs by role (:class:`LegJoints`).
        hip, ankle: the joint's hinges keyed by rest axis (``x y z``); knee: its flexion hinge.
        hip_body, ankle_body: the thigh's and the foot's body ids.
        hip_joints, hip_dofs, hip_acts: the hip hinges' MuJoCo joints, dofs, actuators.
        ankle_joints, ankle_acts: the ankle hinges' MuJoCo joints and actuators.
        knee_flex, ankle_dorsi, hip_flex: the hinge signs of knee flexion, ankle dorsiflexion,
            hip flexion.
        knee_across: a knee tilted off lateral: how much a turn bends the leg
            (:func:`knee_hinge`, :func:`knee_angle`); ``None`` about lateral.
        flex_sign, abd_sign: the signs of the thigh's flexion and abduction in the heading frame.
        out: ``(3,)`` the side's outward axis at rest (``left`` or ``-left``).
        thigh_dir: ``(3,)`` the thigh's unit direction (hip to knee) at rest.
        foot_pitch_sign: + rotation about the heading frame's lateral axis lifts the toes?
        foot_axes: ``(3, 2)`` the foot's forward and left axes in its own frame (at rest).
        twist_sign: +1 if a positive turn of the hip's twist hinge yaws the thigh to the left
            (about up), else -1; 1 without a twist hinge.
        knee_yaw: yaw (rad, about up) of the knee's flexion axis from the lateral axis at rest:
            the hip twists the thigh by minus this so the knee flexes in the sagittal plane, and
            the ankle twists the foot back (0 for a knee about lateral).
        leg_acts, leg_dofs: actuators and dofs of the leg's hinges (hip, knee, ankle, toe).
        leg_mass: mass (kg) of the thigh's subtree.
        support_joints, support_acts: the stance leg's chain for virtual forces (foot fixed):
            the ankle hinges and the knee.
        hip_limits: the hip actuators' torque clamps ``(low, high)``, set by the controller at
            reset.
    """

    side: str
    joints: LegJoints
    hip: dict[str, Hinge]
    knee: Hinge
    ankle: dict[str, Hinge]
    hip_body: int
    ankle_body: int
    hip_joints: np.ndarray
    hip_dofs: np.ndarray
    hip_acts: np.ndarray
    ankle_joints: np.ndarray
    ankle_acts: np.ndarray
    knee_flex: float
    knee_across: float | None
    ankle_dorsi: float
    hip_flex: float
    flex_sign: float
    abd_sign: float
    out: np.ndarray
    thigh_dir: np.ndarray
    foot_pitch_sign: float
    foot_axes: np.ndarray
    twist_sign: float
    knee_yaw: float
    leg_acts: np.ndarray
    leg_dofs: np.ndarray
    leg_mass: float
    support_joints: np.ndarray
    support_acts: np.ndarray
    hip_limits: tuple[np.ndarray, np.ndarray] | None = None


def map_leg(body: RestBody, side: str) -> SimbiconLeg:
    """The ``side`` leg of ``body`` as SIMBICON drives it (:class:`SimbiconLeg`); a
    :class:`SimbiconModelError` naming the joint when it lacks a hinge the walk needs."""
    ch, rest, fwd, left, up = body.ch, body.kin, body.fwd, body.left, body.up
    j = leg_joints(ch, side)
    H, K, A = body.hinges(j.hip), body.hinges(j.knee), body.hinges(j.ankle)
    require_hinge(H, "y", j.hip, "flexion")
    require_hinge(A, "y", j.ankle, "dorsiflexion")
    out = left if side == "left" else -left
    at = rest.body_positions
    thigh = at[j.shank] - at[j.thigh]
    shank = at[j.foot] - at[j.shank]
    kh, across = knee_hinge(K, rest.joint_axes, shank, left, j.knee)
    # the sole: the toe joint, else the sole site
    sole = body.position(j.toe) if j.toe else rest.site_positions[j.site(ch)]
    foot = sole - at[j.foot]
    knee_flex = -hinge_sign(body.axis(kh), shank, fwd, j.knee)
    signs = {
        "ankle_dorsi": hinge_sign(body.axis(A["y"]), foot, up, j.ankle),
        "hip_flex": hinge_sign(body.axis(H["y"]), thigh + shank, fwd, j.hip),
        "flex_sign": hinge_sign(np.array([0.0, 1.0, 0.0]), thigh, fwd, j.hip),
        "abd_sign": hinge_sign(np.array([1.0, 0.0, 0.0]), thigh, out, j.hip),
        "foot_pitch_sign": hinge_sign(np.array([0.0, 1.0, 0.0]), foot, up, j.ankle),
        "twist_sign": (hinge_sign(body.axis(H["z"]), fwd, left, j.hip) if "z" in H else 1.0),
    }
    leg_hinges = [*H.values(), kh, *A.values()]
    if j.toe:
        leg_hinges += list(body.hinges(j.toe).values())
    support = [*A.values(), kh]
    return SimbiconLeg(
        side=side, joints=j, hip=H, knee=kh, ankle=A, hip_body=j.thigh, ankle_body=j.foot,
        hip_joints=np.array([h.jnt for h in H.values()]),
        hip_dofs=np.array([h.dof for h in H.values()]),
        hip_acts=np.array([h.act for h in H.values()]),
        ankle_joints=np.array([h.jnt for h in A.values()]),
        ankle_acts=np.array([h.act for h in A.values()]),
        knee_flex=knee_flex, knee_across=across, **signs,
        out=out, thigh_dir=thigh / np.linalg.norm(thigh),
        foot_axes=rest.body_rotations[j.foot].T @ np.stack([fwd, left], axis=1),
        knee_yaw=knee_yaw(knee_flex * body.axis(kh), fwd, left),
        leg_acts=np.array([h.act for h in leg_hinges]),
        leg_dofs=np.array([h.dof for h in leg_hinges]),
        leg_mass=ch.dynamics.subtree_mass(j.thigh),
        support_joints=np.array([h.jnt for h in support]),
        support_acts=np.array([h.act for h in support]))


@dataclass(eq=False)
class UpperBody:
    """What SIMBICON holds beyond the legs' hips, knees and ankles (:func:`map_upper_body`).

    Attributes:
        base: ``(nu,)`` base PD target (rad) per actuator: the arms lowered from a T-pose, the
            elbows flexed, a tilted knee's twist undone at hip and ankle; 0 elsewhere.
        group: ``(nu,)`` gain group per actuator (``hip``, ``knee``, ``ankle``, ``spine``,
            ``head``, ``toe``, ``arm``, ``other``): the gait's gains by group.
        spine_pitch: ``(actuator, sign)`` of the spine's pitch hinges (anatomical forward lean =
            sign x hinge +): their targets follow the gait in use.
        arm_swing: per side, ``(actuator, sign)`` of the shoulder's swing hinge (the lowered arm
            forward = sign x hinge +).
    """

    base: np.ndarray
    group: np.ndarray
    spine_pitch: list[tuple[int, float]]
    arm_swing: dict[str, tuple[int, float]]


def map_upper_body(body: RestBody, legs: list[SimbiconLeg], shoulder_down: float,
                   elbow_flexion: float) -> UpperBody:
    """The :class:`UpperBody` of ``body`` walking on ``legs`` (:func:`map_leg`), its arms
    lowered by ``shoulder_down`` rad from a T-pose and its elbows flexed by ``elbow_flexion``
    rad (a gait's)."""
    ch, nu = body.ch, body.ch.nu
    ub = UpperBody(np.zeros(nu), np.array(["other"] * nu, dtype=object), [], {})
    group = ub.group
    for leg in legs:
        for h in leg.hip.values():
            group[h.act] = "hip"
        group[leg.knee.act] = "knee"
        for h in leg.ankle.values():
            group[h.act] = "ankle"
    for j in ch.roles("spine"):
        hs = body.hinges(j)
        for h in hs.values():
            group[h.act] = "spine"
        if "y" in hs:
            ub.spine_pitch.append((hs["y"].act, hinge_sign(body.axis(hs["y"]), body.up,
                                                           body.fwd, j)))
    head = ch.role("head", required=False)
    if head:
        for h in body.hinges(head).values():
            group[h.act] = "head"
    for leg in legs:
        if leg.joints.toe:
            for h in body.hinges(leg.joints.toe).values():
                group[h.act] = "toe"
        for part in ("clavicle", "shoulder", "elbow", "wrist"):
            j = ch.role(f"{leg.side}_{part}", required=False)
            if j:
                for h in body.hinges(j).values():
                    group[h.act] = "arm"
        _map_arm(body, leg.side, shoulder_down, elbow_flexion, ub)
    for leg in legs:
        # the foot turned back by what the hip turns the thigh (see SimbiconLeg.knee_yaw)
        if leg.knee_yaw and "z" in leg.ankle and "z" in leg.hip:
            hz = leg.ankle["z"]
            ub.base[hz.act] = leg.knee_yaw * hinge_sign(body.axis(hz), body.fwd, body.left,
                                                        leg.joints.ankle)
            ub.base[leg.hip["z"].act] = -leg.knee_yaw * leg.twist_sign
    return ub


def _map_arm(body: RestBody, side: str, shoulder_down: float, elbow_flexion: float,
             ub: UpperBody) -> None:
    """The ``side`` arm's base targets and swing hinge into ``ub`` (:func:`map_upper_body`):
    the shoulder lowers the arm from the T-pose, the elbow flexes, each less what the rest
    pose already does; an arm without shoulder and elbow roles is left as it is."""
    ch, fwd, left, up = body.ch, body.fwd, body.left, body.up
    sh = ch.role(f"{side}_shoulder", required=False)
    el = ch.role(f"{side}_elbow", required=False)
    if not (sh and el):
        return
    hs = body.hinges(sh)
    arm = body.position(el) - body.position(sh)
    if "x" in hs:  # lowering the arm from the T-pose: rotation about forward
        # less what the rest pose already lowers it (an A-pose rig's arm hangs
        # part of the way down at rest; a T-pose's drop is 0)
        drop = math.atan2(-float(arm @ up), abs(float(arm @ left)))
        ub.base[hs["x"].act] = (shoulder_down - drop) * hinge_sign(
            body.axis(hs["x"]), arm, -up, sh, needed=False)
    if "y" in hs:  # swinging the lowered arm forward: rotation about lateral
        s_y = hinge_sign(body.axis(hs["y"]), -up, fwd, sh, needed=False)
        ub.arm_swing[side] = (hs["y"].act, s_y)
        # the swing is about the arm hanging in the coronal plane: a rest arm
        # that points forward or back is brought back to it first
        ahead = rest_angle(float(arm @ fwd) / float(np.linalg.norm(arm)))
        if ahead:
            ub.base[hs["y"].act] = -ahead * s_y
    wr = ch.role(f"{side}_wrist", required=False)
    he = body.hinges(el)
    if wr and he:
        h = next(iter(he.values()))
        fore = body.position(wr) - body.position(el)
        # flexion brings the forearm forward once the arm hangs down
        s_e = hinge_sign(body.axis(h), fore, fwd, el, needed=False)
        # less the rest pose's own flexion (a rig whose elbow is bent at rest)
        ax = body.axis(h)
        bent = s_e * math.atan2(float(np.cross(arm, fore) @ ax), float(arm @ fore))
        ub.base[h.act] = (elbow_flexion - rest_angle(math.sin(bent))) * s_e


# -- the actuators and the pelvis ------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Actuators:
    """SIMBICON's actuators, one hinge actuator per dof: ``act_dof`` and ``act_qpos``
    ``(nu,)`` (each actuator's dof and qpos address), ``dof2act`` ``(nv,)`` (each dof's
    actuator, -1 for none: the root's)."""

    act_dof: np.ndarray
    act_qpos: np.ndarray
    dof2act: np.ndarray


def map_actuators(ch: Character) -> Actuators:
    """The :class:`Actuators` of ``ch``; a :class:`SimbiconModelError` naming the joint of an
    actuator that is not one hinge's."""
    if not np.all(ch.actuator_qpos >= 0):
        a = int(np.flatnonzero(ch.actuator_qpos < 0)[0])
        j = mujoco.mj_id2name(ch.model, mujoco.mjtObj.mjOBJ_JOINT,
                              int(ch.model.actuator_trnid[a, 0]))
        raise SimbiconModelError(
            f"{j}: SIMBICON needs one hinge actuator per dof and this joint's actuator is "
            f"not one: {HINGE_FIX}")
    act_dof = ch.actuator_dof.copy()
    dof2act = np.full(ch.nv, -1)
    dof2act[act_dof] = np.arange(ch.nu)
    return Actuators(act_dof, ch.actuator_qpos.copy(), dof2act)


def child_hinges(ch: Character, parent: int, skip: set[int]) -> list[np.ndarray]:
    """Hinge dofs of each body attached to body ``parent`` (id) but those in ``skip`` (ids):
    one ``(k,)`` array per body, in dof order (on the pelvis with the thighs skipped: the
    spine's hinges, whose torques react on the pelvis; both walkers' stance hip takes them)."""
    by_body: dict[int, list[int]] = {}
    for dof in np.flatnonzero(ch.hinge_dofs):
        b = int(ch.dof_body[dof])
        if ch.body_parent[b] == parent and b not in skip:
            by_body.setdefault(b, []).append(int(dof))
    return [np.array(dofs) for dofs in by_body.values()]
