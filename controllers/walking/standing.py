"""The poses IPM stands in (:mod:`~mjchar.controllers.walking.ipm`): its upper body's, the rest
pose with the arms hanging, and, when it stops, the feet where they are, the pelvis upright over
them, the knees bent as while walking, the legs by IK."""

from __future__ import annotations

import math

import numpy as np

from ..core.character import Character
from ..core.geometry import heading_yaw
from .leg import Leg
from .swing import rotation_z


def arms_down_pose(ch: Character, abduction: float) -> np.ndarray:
    """``(nq,)`` the rest pose with the arms hanging, each hand ``abduction`` rad out from
    straight below its shoulder (the shoulders turned by IK; an arm without both roles is left
    at rest)."""
    q = ch.poses.rest()
    for side, sgn in (("left", 1.0), ("right", -1.0)):
        sh = ch.role(f"{side}_shoulder", required=False)
        hand = ch.role(f"{side}_wrist", required=False)
        if sh is None or hand is None:
            continue
        x = ch.poses.kinematics(q).body_positions
        p_sh = x[ch.body_id(sh)]
        p_hand = x[ch.body_id(hand)]
        arm = float(np.linalg.norm(p_hand - p_sh))
        target = p_sh + arm * np.array([0.0, sgn * math.sin(abduction), -math.cos(abduction)])
        q = ch.poses.solve_ik(q, [(hand, target, None)], ch.joint_dofs(sh))
    return q


def standing_pose(ch: Character, legs: tuple[Leg, Leg], upper_q: np.ndarray,
                  upper_pose: np.ndarray, rest_axes: np.ndarray, root_above_soles: float,
                  knee: float) -> np.ndarray:
    """``(nq,)`` a standing pose for the feet where they are: the upper body's joints
    ``upper_q`` (qpos addresses) as in ``upper_pose``, the pelvis upright at the current heading
    over the middle of the feet (at most ``root_above_soles`` m above the soles), both knees
    bent ``knee`` rad, the feet flat on the floor where they are, the legs by IK.
    ``rest_axes``: the joints' world axes at rest (which hinge of the hip and ankle pitches)."""
    s = ch.state
    q = s.qpos.copy()
    q[upper_q] = upper_pose[upper_q]
    yaw = heading_yaw(s.body_rotations[ch.root_body])
    q[ch.root_qpos[3:7]] = [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]
    # pelvis over the middle of the feet (COM offset kept) at standing height
    soles = np.array([s.site_positions[lg.site] for lg in legs])
    q[ch.root_qpos[:2]] += soles[:, :2].mean(axis=0) - s.com()[:2]
    q[ch.root_qpos[2]] = min(q[ch.root_qpos[2]], soles[:, 2].mean() + root_above_soles)
    # knees bent like the stance knee while walking (no sudden drop when a step starts):
    # seed hip and ankle pitch with half the flexion each, lower the pelvis, then IK
    drop = 0.0
    for lg in legs:
        q[lg.knee_q] = knee
        knee_axis = rest_axes[ch.dof_joint[lg.knee_dof]]
        for dofs in (lg.hip, lg.ankle):  # the hinge nearest the knee's axis: the pitch
            cos = rest_axes[ch.dof_joint[dofs]] @ knee_axis
            i = int(np.argmax(np.abs(cos)))
            if abs(cos[i]) > 0.7:
                q[ch.dof_qpos[dofs[i]]] = -0.5 * knee * math.copysign(1.0, cos[i])
        drop = max(drop, lg.l1 + lg.l2 - math.hypot(
            lg.l1 * math.cos(0.5 * knee) + lg.l2 * math.cos(0.5 * knee), 0.0))
    q[ch.root_qpos[2]] -= drop
    # feet flat on the floor where they are (a foot still on its heel or toes is laid flat)
    touch = {}
    for gc in ch.contacts.ground():
        touch[gc.body] = min(touch.get(gc.body, math.inf), float(gc.position[2]))
    targets = []
    for lg in legs:
        fy = heading_yaw(s.body_rotations[lg.foot])
        ground = min(touch.get(lg.ankle_name, math.inf), touch.get(lg.toe_name, math.inf),
                     float(s.site_positions[lg.site][2]))
        R = rotation_z(fy)
        ankle = s.site_positions[lg.site].copy() - R @ lg.site_offset
        ankle[2] = ground - lg.site_offset[2]
        targets.append((lg.foot, ankle, np.array([math.cos(fy / 2), 0.0, 0.0, math.sin(fy / 2)])))
    # every ankle within the reach of its leg at that knee flexion: a foot laid flat from its
    # toes (a perturbed start) may sit lower than the straight leg reaches from this pelvis
    # height; an unreachable target sends the IK through the straight knee's singularity to
    # wound-up angles (a hip at 48 rad) that the PD then spins the leg towards
    q[ch.root_qpos[2]] -= reach_drop(ch, legs, q, [a for _, a, _ in targets], knee)
    dofs = np.concatenate([lg.leg for lg in legs])
    return ch.poses.solve_ik(q, targets, dofs)


def reach_drop(ch: Character, legs: tuple[Leg, Leg], q: np.ndarray, ankles: list,
               knee: float) -> float:
    """How far (m) to lower the pelvis of pose ``q`` so each leg reaches its ankle target
    (``ankles``, world, one per leg) with the knee bent ``knee`` rad: the reach is
    :meth:`Leg.reach`, hip joint to ankle joint (0 when both already reach)."""
    anchors = ch.poses.kinematics(q).joint_anchors
    drop = 0.0
    for lg, ankle in zip(legs, ankles, strict=True):
        reach = lg.reach(knee)
        d = anchors[lg.hip_jnt[0]] - ankle
        horizontal = float(d[0] ** 2 + d[1] ** 2)
        if horizontal >= reach ** 2:
            continue  # out of reach sideways: lowering does not help
        drop = max(drop, float(d[2]) - math.sqrt(reach ** 2 - horizontal))
    return drop
