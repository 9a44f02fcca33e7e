"""Project-authored bundled motions: a standing idle and a walk cycle, made from key poses.

Both motions are designed in a *canonical* frame (metres; x to the character's left, y up, z
forward), posed on any skeleton whose legs :func:`mjchar.bvh.rigs.naming.recognise` finds (the
project's default skeleton, ``bvh/humanoid_skeleton.py``, is Y-up, metres, facing +Z, so canonical
axes are its file axes), sampled as key poses and turned into frames by
:func:`mjchar.bvh.editing.interpolation.keyframes_to_motion` (Catmull-Rom, cyclic: both clips loop).

Key poses are not hand-typed angles but the solution of a small gait design:

- **Feet** follow a rocker model. With foot phase ``s`` in ``[0, 1)`` (0 = heel strike) a stance
  foot first rolls about its heel (toes up ``heel_strike_pitch`` to flat), stays flat, then rolls
  about the ball of the foot (heel up to ``toe_off_pitch``, toes flat on the floor) until toe-off
  at ``s = stance``. The contact point never slides. In swing the ankle follows a cubic Hermite
  curve from the toe-off state to the next heel strike (velocity-continuous at toe-off) lifted by
  ``clearance * sin^2(pi u)``; the foot pitches from toe-off to heel-strike attitude.
- **Pelvis** moves forward at ``speed`` with a vertical bob (highest at mid-stance), lateral sway
  over the stance foot, yaw (the swinging leg's hip goes forward), contralateral drop (roll) and a
  slight forward lean; its height is lowered where a leg could not reach its foot with the knee
  bent at least ``min_knee`` (then smoothed).
- **Legs** are solved analytically: the knee is a pure hinge about its rest lateral axis (so the
  ``hinge`` model replays it without off-axis error); its angle follows from the hip-ankle distance
  (law of cosines with Rodrigues' formula), the hip rotation maps the rest hip-ankle vector onto
  the target while keeping the knee axis along the foot's lateral axis, and the ankle and toe take
  whatever local rotation gives the designed foot and toe attitudes.
- **Trunk, arms, head**: the spine counter-rotates the pelvis yaw and undoes its roll and part of
  its lean; arms hang (rotated down from the rest pose, slightly abducted) and swing opposite to
  the legs with the elbows flexing more in the forward swing; the head stays level.

The idle keeps both feet planted (same leg solver) under a slowly swaying pelvis, with breathing
in the spine and arms.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from mjchar.bvh.editing.interpolation import keyframes_to_motion
from mjchar.bvh.errors import MjcharError
from mjchar.bvh.io import save
from mjchar.bvh.io.motion import Motion
from mjchar.bvh.io.skeleton import Skeleton
from mjchar.bvh.kinematics.fk import forward_kinematics
from mjchar.bvh.rigs.naming import recognise
from mjchar.bvh.rigs.units import AXIS_VECTORS, guess_unit_scale, guess_up_axis, transform_motion
from mjchar.bvh.rotations import from_rotation, quat_conj, quat_identity, quat_mul, quat_normalize

__all__ = ["AuthoringError", "WalkStyle", "IdleStyle", "walk_motion", "idle_motion",
           "write_bundled_motions", "BUNDLED_MOTIONS"]

#: file names written by :func:`write_bundled_motions`
BUNDLED_MOTIONS = {"idle": "idle.bvh", "walk": "walk.bvh"}


class AuthoringError(MjcharError):
    """The skeleton lacks what the authored motions need (legs, feet) or a style is invalid."""


@dataclass(frozen=True)
class WalkStyle:
    """Parameters of the authored walk cycle (SI units; angles in degrees).

    ``period`` is one full cycle (two steps); the stride is ``speed * period``. Fractions are of
    the cycle. ``period / frame_time`` and ``keys_per_cycle`` set the sampling.
    """

    speed: float = 1.05
    period: float = 1.0
    stance: float = 0.6
    heel_rocker: float = 0.08
    heel_rise: float = 0.30
    pelvis_over_ankle: float = 0.15  # foot phase at which the pelvis passes over the ankle
    heel_strike_pitch: float = 12.0
    toe_off_pitch: float = 45.0
    clearance: float = 0.045
    lift_skew: float = 0.5         # < 1: the swing foot is highest early in swing
    landing_velocity: tuple[float, float] = (0.25, -0.15)   # forward, up (m/s) at heel strike
    step_width: float = 0.8        # distance between the feet over hip width
    hip_drop: float = 0.02         # mean pelvis height below standing (m)
    bob: float = 0.012             # pelvis vertical half range (m)
    sway: float = 0.02             # pelvis lateral half range (m)
    min_knee: float = 6.0          # least knee flexion the pelvis height allows
    pelvis_yaw: float = 5.0
    pelvis_roll: float = 3.0
    lean: float = 2.0
    trunk_counter_yaw: float = 0.6  # thorax yaw opposite the pelvis, fraction of pelvis yaw
    arm_swing: float = 16.0
    arm_forward: float = 3.0
    arm_abduction: float = 8.0
    elbow: float = 15.0
    elbow_swing: float = 14.0
    keys_per_cycle: int = 24
    frame_time: float = 1.0 / 60.0


@dataclass(frozen=True)
class IdleStyle:
    """Parameters of the authored standing idle (SI units; angles in degrees)."""

    duration: float = 4.0          # one loop; breathing and sway periods divide it
    breath_period: float = 4.0
    sway_period: float = 4.0
    sway: float = 0.012            # pelvis lateral half range (m)
    surge: float = 0.004           # pelvis fore-aft half range (m)
    knee_drop: float = 0.005       # pelvis height below standing (m): soft knees
    breath_pitch: float = 1.2      # spine flexion half range
    pelvis_yaw: float = 1.0
    arm_abduction: float = 7.0
    breath_arm: float = 1.0
    elbow: float = 10.0
    keys: int = 16
    frame_time: float = 1.0 / 60.0


# ----------------------------------------------------------------------------------------------
# small rotation helpers (canonical frame, wxyz)
# ----------------------------------------------------------------------------------------------
def _axis_angle(axis: np.ndarray, angle: np.ndarray | float) -> np.ndarray:
    """``(..., 4)`` rotation about unit ``axis`` (3,) by ``angle`` radians."""
    a = np.asarray(angle, dtype=float)[..., None]
    return np.concatenate([np.cos(a / 2), np.sin(a / 2) * np.asarray(axis, float)], axis=-1)


def _rx(a):
    return _axis_angle(np.array([1.0, 0, 0]), a)


def _ry(a):
    return _axis_angle(np.array([0, 1.0, 0]), a)


def _rz(a):
    return _axis_angle(np.array([0, 0, 1.0]), a)


def _rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    from mjchar.bvh.rotations import quat_rotate

    return quat_rotate(q, v)


def _from_frames(src: np.ndarray, dst: np.ndarray) -> np.ndarray:
    """Rotation (wxyz) taking the orthonormal frame ``src`` (3x3 columns) onto ``dst``."""
    return from_rotation(Rotation.from_matrix(dst @ src.T))


def _frame(primary: np.ndarray, secondary: np.ndarray) -> np.ndarray:
    """Right-handed orthonormal frame (columns) with ``primary`` first and ``secondary`` second
    (made orthogonal to it)."""
    a = primary / np.linalg.norm(primary)
    b = secondary - a * (a @ secondary)
    b /= np.linalg.norm(b)
    return np.stack([a, b, np.cross(a, b)], axis=1)


def _min_rotation(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Smallest rotation (wxyz) taking direction ``u`` to direction ``v``."""
    u = u / np.linalg.norm(u)
    v = v / np.linalg.norm(v)
    q = np.concatenate([[1.0 + u @ v], np.cross(u, v)])
    if q[0] < 1e-9:  # opposite: any perpendicular axis
        perp = np.cross(u, [1.0, 0, 0] if abs(u[0]) < 0.9 else [0, 1.0, 0])
        q = np.concatenate([[0.0], perp])
    return quat_normalize(q)


def _smoothstep(u):
    u = np.clip(u, 0.0, 1.0)
    return u * u * (3 - 2 * u)


def _hermite(p0, v0, p1, v1, u, h):
    """Cubic Hermite point at ``u`` in [0, 1] over a segment of ``h`` seconds."""
    u2, u3 = u * u, u * u * u
    return ((2 * u3 - 3 * u2 + 1) * p0 + (u3 - 2 * u2 + u) * h * v0
            + (-2 * u3 + 3 * u2) * p1 + (u3 - u2) * h * v1)


# ----------------------------------------------------------------------------------------------
# the rig: a skeleton seen in the canonical frame
# ----------------------------------------------------------------------------------------------
@dataclass
class _Leg:
    side: str
    sign: float            # +1 left, -1 right (canonical x)
    hip: int
    knee: int
    ankle: int
    toe: int | None
    o1: np.ndarray         # hip -> knee rest offset
    o2: np.ndarray         # knee -> ankle rest offset
    knee_axis: np.ndarray  # rest lateral axis of the knee hinge (flexion positive)
    heel: np.ndarray       # heel contact point, ankle frame at rest
    ball: np.ndarray       # ball contact point (toe joint at floor level), ankle frame at rest


class _Rig:
    """Skeleton geometry and roles in the canonical frame (metres, x left, y up, z forward)."""

    def __init__(self, skeleton: Skeleton):
        if not isinstance(skeleton, Skeleton):
            raise AuthoringError(f"expected a bvh.Skeleton, got {type(skeleton).__name__}")
        self.file_skeleton = skeleton
        up = guess_up_axis(skeleton)
        rec = recognise(skeleton, AXIS_VECTORS[up])
        self.roles = rec.roles
        for r in ("left_hip", "left_knee", "left_ankle", "right_hip", "right_knee", "right_ankle"):
            if r not in rec.roles:
                raise AuthoringError(f"the skeleton has no recognisable {r.replace('_', ' ')}; "
                                     f"the authored motions need two legs with feet")
        if rec.left_axis is None:
            raise AuthoringError("cannot tell the skeleton's left from its right")
        up_v = AXIS_VECTORS[up]
        left = rec.left_axis - up_v * (rec.left_axis @ up_v)
        left /= np.linalg.norm(left)
        fwd = np.cross(left, up_v)
        to_file = np.stack([left, up_v, fwd], axis=1)  # canonical -> file axes (columns)
        self.to_file_rot = from_rotation(Rotation.from_matrix(to_file))
        self.scale = guess_unit_scale(skeleton)        # metres per file unit
        rest_motion = transform_motion(Motion.rest(skeleton), self.scale,
                                       quat_conj(self.to_file_rot))
        self.sk = rest_motion.skeleton
        sk = self.sk
        self.rest = sk.rest_positions()
        self.index = {n: i for i, n in enumerate(sk.names)}
        self._model = self._convert(skeleton)
        self.pelvis = self.index[rec.roles.get("pelvis", sk.names[0])]
        self.spine = [self.index[n] for n in rec.roles.get("spine", [])]
        self.head = self.index.get(rec.roles.get("head", ""), None)
        self.legs = {s: self._leg(s) for s in ("left", "right")}
        self.arms = {}
        for s in ("left", "right"):
            sh, el, wr = (rec.roles.get(f"{s}_{r}") for r in ("shoulder", "elbow", "wrist"))
            if sh and el:
                self.arms[s] = (self.index[sh], self.index[el],
                                self.index[wr] if wr else None)
        feet_y = [self.rest[leg.ankle][1] + leg.heel[1] for leg in self.legs.values()]
        self.ground = float(min(feet_y))
        hips = [self.rest[leg.hip] for leg in self.legs.values()]
        self.hip_width = float(abs(hips[0][0] - hips[1][0]))
        self.height = float(np.ptp(np.concatenate([self.rest, sk.rest_end_sites()])[:, 1])
                            if sk.n_end_sites else np.ptp(self.rest[:, 1]))

    def _model_foot(self, side: str) -> tuple[np.ndarray | None, np.ndarray | None]:
        """Heel and ball contact points (canonical, ankle frame at rest) from the foot box of the
        model :func:`mjchar.bvh.mjcf.convert` makes of this skeleton: the back and front bottom
        edges."""
        if self._model is None:
            return None, None
        import mujoco

        model, info = self._model
        joint = info.roles.get(f"{side}_ankle")
        if not isinstance(joint, str) or joint not in info.joints:
            return None, None
        b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, info.joints[joint].body)
        boxes = [g for g in np.flatnonzero(model.geom_bodyid == b)
                 if int(model.geom_type[g]) == int(mujoco.mjtGeom.mjGEOM_BOX)]
        if b < 0 or not boxes:
            return None, None
        g = boxes[0]
        signs = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], float)
        rmat = Rotation.from_quat(model.geom_quat[g], scalar_first=True).as_matrix()
        corners = model.geom_pos[g] + (signs * model.geom_size[g]) @ rmat.T  # MuJoCo axes
        corners = corners[:, [1, 2, 0]]  # -> canonical (left, up, forward)
        sole = corners[:, 1].min()
        heel = np.array([0.0, sole, corners[:, 2].min()])
        ball = np.array([0.0, sole, corners[:, 2].max()])
        return heel, ball

    def _guess_foot(self, ankle: int, toe: int | None, o1: np.ndarray, o2: np.ndarray):
        sk, rest = self.sk, self.rest
        below = [j for j in range(sk.n_joints) if ankle in sk.chain(j) and j != ankle]
        pts = [rest[j] - rest[ankle] for j in below]
        es = sk.rest_end_sites() if sk.n_end_sites else np.zeros((0, 3))
        pts += [es[e] - rest[ankle] for e in range(sk.n_end_sites)
                if ankle in sk.chain(int(sk.end_site_parents[e]))]
        pts = np.array(pts) if pts else np.zeros((0, 3))
        length = max(np.linalg.norm(o1) + np.linalg.norm(o2), 1e-6)
        sole = float(min([0.0, *pts[:, 1]])) if len(pts) else 0.0
        sole = min(sole - 0.03 * length, -0.09 * length)
        if toe is not None:
            ball_z = float(rest[toe][2] - rest[ankle][2])
        elif len(pts):
            ball_z = float(0.7 * pts[:, 2].max())
        else:
            ball_z = 0.16 * length
        ball_z = max(ball_z, 0.08 * length)
        return np.array([0.0, sole, -0.4 * ball_z]), np.array([0.0, sole, ball_z])

    def _leg(self, side: str) -> _Leg:
        rest, idx = self.rest, self.index
        hip, knee, ankle = (idx[self.roles[f"{side}_{r}"]] for r in ("hip", "knee", "ankle"))
        toe = idx.get(self.roles.get(f"{side}_toe", ""), None)
        o1, o2 = rest[knee] - rest[hip], rest[ankle] - rest[knee]
        fwd = np.array([0.0, 0.0, 1.0])
        axis = np.cross(fwd, o2 / max(np.linalg.norm(o2), 1e-9))
        if np.linalg.norm(axis) < 1e-6:
            raise AuthoringError(f"{side} shin lies along the forward axis in the rest pose")
        axis /= np.linalg.norm(axis)
        heel, ball = self._model_foot(side)
        if heel is None:  # no model: a sole below the lowest foot point, the ball under the toe
            heel, ball = self._guess_foot(ankle, toe, o1, o2)
        return _Leg(side, 1.0 if side == "left" else -1.0, hip, knee, ankle, toe, o1, o2, axis,
                    heel, ball)

    @staticmethod
    def _convert(skeleton: Skeleton):
        """``(model, info)`` of the default conversion of ``skeleton``, or ``None``."""
        try:
            from mjchar.bvh.mjcf import convert

            converted = convert(skeleton)
            return converted.compile(), converted.info
        except (ImportError, MjcharError):
            return None

    # -- posing ------------------------------------------------------------------------------
    def fk(self, root_pos: np.ndarray, rot: np.ndarray):
        """Global positions ``(J, 3)`` and orientations ``(J, 4)`` of one canonical pose."""
        pos = self.sk.offsets[None].copy()
        pos[0, 0] = root_pos
        res = forward_kinematics(Motion(self.sk, 1.0, pos, rot[None]))
        return res.positions[0], res.orientations[0]

    def leg_reach(self, leg: _Leg, min_knee: float) -> float:
        """Hip-ankle distance with the knee flexed by ``min_knee`` radians."""
        v = leg.o1 + _rotate(_axis_angle(leg.knee_axis, min_knee), leg.o2)
        return float(np.linalg.norm(v))

    def solve_leg(self, leg: _Leg, rot: np.ndarray, root_pos: np.ndarray, ankle: np.ndarray,
                  foot: np.ndarray, toe: np.ndarray) -> float:
        """Set the hip, knee, ankle (and toe) local rotations in ``rot`` (J, 4) so the ankle is at
        ``ankle`` (3,) with global foot orientation ``foot`` and toe orientation ``toe`` (wxyz).
        The parents of the hip must already be posed. Returns the knee angle (radians)."""
        gpos, gori = self.fk(root_pos, rot)
        parent = int(self.sk.parents[leg.hip])
        g_hp = gori[parent]
        hip = gpos[leg.hip]
        d_world = ankle - hip
        dist = np.linalg.norm(d_world)
        k = leg.knee_axis
        o1, o2 = leg.o1, leg.o2
        p = (k @ o1) * (k @ o2)
        q = o1 @ o2 - p
        u = o1 @ np.cross(k, o2)
        target = 0.5 * (dist ** 2 - o1 @ o1 - o2 @ o2)
        m = np.hypot(q, u)
        phi0 = np.arctan2(u, q)
        c = np.clip((target - p) / max(m, 1e-12), -1.0, 1.0)
        theta = phi0 + np.arccos(c)
        theta = float(np.angle(np.exp(1j * theta)))
        if theta < 0:
            theta = float(phi0 - np.arccos(c))
        q_knee = _axis_angle(k, theta)
        v_rest = o1 + _rotate(q_knee, o2)
        d_local = _rotate(quat_conj(g_hp), d_world)
        lateral = _rotate(quat_conj(g_hp), _rotate(foot, k))
        q_hip = _from_frames(_frame(v_rest, k), _frame(d_local, lateral))
        rot[leg.hip] = q_hip
        rot[leg.knee] = q_knee
        g_knee = quat_mul(quat_mul(g_hp, q_hip), q_knee)
        rot[leg.ankle] = quat_mul(quat_conj(g_knee), foot)
        if leg.toe is not None:
            g_mid = foot
            for j in self.sk.chain(leg.toe)[self.sk.chain(leg.toe).index(leg.ankle) + 1:-1]:
                g_mid = quat_mul(g_mid, rot[j])
            rot[leg.toe] = quat_mul(quat_conj(g_mid), toe)
        return theta

    def pose_arm(self, side: str, rot: np.ndarray, root_pos: np.ndarray, swing: float,
                 abduction: float, elbow: float) -> None:
        """Hang the arm (rest direction rotated down, ``abduction`` radians out), swing it about
        the lateral axis by ``swing`` (positive backwards) and flex the elbow by ``elbow``."""
        if side not in self.arms:
            return
        sh, el, wr = self.arms[side]
        sign = 1.0 if side == "left" else -1.0
        _, gori = self.fk(root_pos, rot)
        g_par = gori[int(self.sk.parents[sh])]
        u = self.rest[el] - self.rest[sh]
        hang = np.array([sign * np.sin(abduction), -np.cos(abduction), 0.0])
        q_down = _min_rotation(u, hang)
        target = quat_mul(_rx(swing), q_down)
        rot[sh] = quat_mul(quat_conj(g_par), target)
        if wr is not None:
            fore = self.rest[wr] - self.rest[el]
            axis = np.cross(fore, [0.0, 0.0, 1.0])
            if np.linalg.norm(axis) > 1e-9:
                rot[el] = _axis_angle(axis / np.linalg.norm(axis), elbow)

    def level_head(self, rot: np.ndarray, root_pos: np.ndarray, heading: float) -> None:
        if self.head is None:
            return
        _, gori = self.fk(root_pos, rot)
        rot[self.head] = quat_mul(quat_conj(gori[int(self.sk.parents[self.head])]), _ry(heading))

    def root_for_pelvis(self, pelvis_pos: np.ndarray) -> np.ndarray:
        """Root translation placing the pelvis joint at ``pelvis_pos`` (identity above it)."""
        return pelvis_pos - (self.rest[self.pelvis] - self.rest[0])

    def to_file(self, motion: Motion) -> Motion:
        """The canonical motion in the skeleton's own units, axes and channel layout."""
        out = transform_motion(motion, 1.0 / self.scale, self.to_file_rot)
        out.skeleton = self.file_skeleton.copy()
        return out


# ----------------------------------------------------------------------------------------------
# walk
# ----------------------------------------------------------------------------------------------
class _WalkDesign:
    """The gait design of the module docstring, as functions of time (canonical frame)."""

    def __init__(self, rig: _Rig, st: WalkStyle):
        self.rig, self.st = rig, st
        self.T = st.period
        self.S = st.speed * st.period
        self.s1 = st.heel_rocker
        self.s2 = st.heel_rise
        self.p_hs = -np.radians(st.heel_strike_pitch)
        self.p_to = np.radians(st.toe_off_pitch)
        self.s_mid = st.pelvis_over_ankle
        half = 0.5 * st.step_width * rig.hip_width
        self.foot_x = {"left": half, "right": -half}
        self.phase0 = {"left": 0.0, "right": 0.5}
        # heel strike point of cycle n (foot time n): ankle over the hip at mid-flat
        self.z_heel0 = self.s_mid * self.S + rig.legs["left"].heel[2]
        self.h_stand = float(rig.rest[rig.pelvis][1] - rig.ground)

    # foot ---------------------------------------------------------------------------------
    def _heel_point(self, side: str, n: np.ndarray | float) -> np.ndarray:
        z = self.z_heel0 + (n - self.phase0[side]) * self.S
        return np.array([self.foot_x[side], 0.0, z])

    def _stance(self, leg: _Leg, side: str, n: int, s: float):
        """Ankle position, foot pitch and toe global pitch at stance phase ``s``."""
        wh = self._heel_point(side, n)
        if s < self.s1:
            p = self.p_hs * (1.0 - _smoothstep(s / self.s1))
            ankle = wh - _rotate(_rx(p), leg.heel)
            return ankle, p, p
        if s < self.s2:
            return wh - leg.heel, 0.0, 0.0
        u = (s - self.s2) / (self.st.stance - self.s2)
        p = self.p_to * u * u
        wb = wh - leg.heel + leg.ball
        return wb - _rotate(_rx(p), leg.ball), p, 0.0

    def foot(self, side: str, t: float):
        """``(ankle (3,), foot pitch, toe global pitch)`` of foot ``side`` at time ``t``."""
        leg = self.rig.legs[side]
        st = self.st
        tau = t / self.T + self.phase0[side]
        n = int(np.floor(tau + 1e-12))
        s = tau - n
        if s < st.stance:
            return self._stance(leg, side, n, s)
        # swing: Hermite from toe-off (velocity of the heel-rise motion) to the next heel strike
        h = (1.0 - st.stance) * self.T
        u = (s - st.stance) / (1.0 - st.stance)
        a_to, p_to, _ = self._stance(leg, side, n, st.stance)
        eps = 1e-4
        a_prev, p_prev, _ = self._stance(leg, side, n, st.stance - eps)
        v_to = (a_to - a_prev) / (eps * self.T)
        w_to = (p_to - p_prev) / (eps * self.T)
        a_hs = self._heel_point(side, n + 1) - _rotate(_rx(self.p_hs), leg.heel)
        v_hs = np.array([0.0, st.landing_velocity[1], st.landing_velocity[0]])
        ankle = _hermite(a_to, v_to, a_hs, v_hs, u, h)
        lift = np.sin(np.pi * u ** st.lift_skew) ** 2  # peaks early in swing
        ankle = ankle + np.array([0.0, st.clearance * lift, 0.0])
        pitch = float(_hermite(p_to, w_to, self.p_hs, 0.0, u, h))
        toe_rel = -p_to * (1.0 - _smoothstep(u / 0.35))
        return ankle, pitch, pitch + toe_rel

    # pelvis -------------------------------------------------------------------------------------
    def pelvis_angles(self, t: float) -> tuple[float, float, float]:
        st = self.st
        w = 2 * np.pi * t / self.T
        yaw = -np.radians(st.pelvis_yaw) * np.cos(w)
        roll = np.radians(st.pelvis_roll) * np.cos(w - 2 * np.pi * self.s_mid)
        return yaw, roll, np.radians(st.lean)

    def pelvis_xz(self, t: float) -> tuple[float, float]:
        x = self.st.sway * np.cos(2 * np.pi * (t / self.T - self.s_mid))
        return x, self.st.speed * t

    def pelvis_orientation(self, t: float) -> np.ndarray:
        yaw, roll, lean = self.pelvis_angles(t)
        return quat_mul(quat_mul(_ry(yaw), _rz(roll)), _rx(lean))

    def nominal_height(self, t: float) -> float:
        st = self.st
        return self.h_stand - st.hip_drop + st.bob * np.cos(4 * np.pi * (t / self.T - self.s_mid))

    def max_height(self, t: float) -> float:
        """Highest pelvis at ``t`` that lets both legs reach their ankles with bent knees."""
        rig = self.rig
        x, z = self.pelvis_xz(t)
        g = self.pelvis_orientation(t)
        best = np.inf
        for side, leg in rig.legs.items():
            ankle = self.foot(side, t)[0]
            off = _rotate(g, rig.rest[leg.hip] - rig.rest[rig.pelvis])
            reach = rig.leg_reach(leg, np.radians(self.st.min_knee))
            horiz = np.hypot(ankle[0] - x - off[0], ankle[2] - z - off[2])
            if horiz >= reach:
                raise AuthoringError(f"walk style too long-legged for this skeleton: the {side} "
                                     f"ankle is {horiz:.3f} m from the hip horizontally")
            best = min(best, ankle[1] - off[1] + np.sqrt(reach ** 2 - horiz ** 2))
        return float(best)

    def heights(self, ts: np.ndarray) -> np.ndarray:
        """Pelvis heights at ``ts`` (one cycle, periodic): the nominal bob, lowered where needed
        and smoothed (periodic Gaussian, then clipped again so the legs always reach)."""
        n = 240
        grid = np.arange(n) * self.T / n
        hmax = np.array([self.max_height(t) for t in grid]) - 0.002
        h = np.minimum([self.nominal_height(t) for t in grid], hmax)
        k = np.arange(-n // 2, n // 2)
        ker = np.exp(-0.5 * (k / (0.03 * n)) ** 2)
        ker /= ker.sum()
        hs = np.real(np.fft.ifft(np.fft.fft(h) * np.fft.fft(np.fft.ifftshift(ker))))
        hs = np.minimum(hs, hmax)
        tt = np.mod(ts, self.T) / self.T * n
        i0 = np.floor(tt).astype(int) % n
        a = tt - np.floor(tt)
        return (1 - a) * hs[i0] + a * hs[(i0 + 1) % n]

    def pose(self, t: float, height: float) -> tuple[np.ndarray, np.ndarray, dict]:
        """Root translation (3,), local rotations (J, 4) and diagnostics at time ``t``."""
        rig, st = self.rig, self.st
        rot = quat_identity((rig.sk.n_joints,))
        x, z = self.pelvis_xz(t)
        g_pelvis = self.pelvis_orientation(t)
        root = rig.root_for_pelvis(np.array([x, height, z]))
        rot[rig.pelvis] = g_pelvis  # joints above the pelvis (if any) stay at rest
        yaw, roll, lean = self.pelvis_angles(t)
        if rig.spine:
            n = len(rig.spine)
            each = quat_mul(quat_mul(_ry(-yaw * (1 + st.trunk_counter_yaw) / n),
                                     _rz(-roll / n)), _rx(-0.6 * lean / n))
            for j in rig.spine:
                rot[j] = each
        info = {}
        for side, leg in rig.legs.items():
            ankle, pitch, toe_pitch = self.foot(side, t)
            info[side] = rig.solve_leg(leg, rot, root, ankle, _rx(pitch), _rx(toe_pitch))
        w = 2 * np.pi * t / self.T
        for side, sgn in (("left", 1.0), ("right", -1.0)):
            c = sgn * np.cos(w)  # +1: this arm fully back
            rig.pose_arm(side, rot, root, np.radians(st.arm_swing * c - st.arm_forward),
                         np.radians(st.arm_abduction),
                         np.radians(st.elbow + st.elbow_swing * 0.5 * (1 - c)))
        rig.level_head(rot, root, 0.0)
        return root, rot, info


def walk_motion(skeleton: Skeleton, style: WalkStyle | None = None) -> Motion:
    """One cycle of the authored walk on ``skeleton`` (file units and axes), cyclic.

    Returns a :class:`Motion` of ``period / frame_time + 1`` frames whose last frame repeats the
    first, displaced by one stride (``speed * period`` metres forward). Raises
    :class:`AuthoringError` when the skeleton has no recognisable legs or the style is invalid.
    """
    st = style or WalkStyle()
    _check_style(st.period, st.frame_time, st.keys_per_cycle)
    rig = _Rig(skeleton)
    design = _WalkDesign(rig, st)
    n_k = st.keys_per_cycle
    times = np.arange(n_k + 1) * st.period / n_k
    heights = design.heights(times)
    roots, rots = [], []
    for t, h in zip(times[:-1], heights[:-1], strict=True):
        root, rot, _ = design.pose(t, h)
        roots.append(root)
        rots.append(rot)
    roots.append(roots[0] + np.array([0.0, 0.0, design.S]))
    rots.append(rots[0].copy())
    motion = keyframes_to_motion(rig.sk, times, np.array(rots), np.array(roots), st.frame_time,
                                 method="catmull_rom", cyclic=True)
    return rig.to_file(motion)


# ----------------------------------------------------------------------------------------------
# idle
# ----------------------------------------------------------------------------------------------
def idle_motion(skeleton: Skeleton, style: IdleStyle | None = None) -> Motion:
    """The authored standing idle on ``skeleton`` (file units and axes), a seamless loop.

    Feet stay planted at their rest stance; the pelvis sways slowly over them with soft knees,
    the spine and arms breathe, the head stays level. ``duration / frame_time + 1`` frames, the
    last equal to the first.
    """
    st = style or IdleStyle()
    _check_style(st.duration, st.frame_time, st.keys)
    for name, period in (("breath_period", st.breath_period), ("sway_period", st.sway_period)):
        if not period > 0 or abs(st.duration / period - round(st.duration / period)) > 1e-9:
            raise AuthoringError(f"{name} must divide the idle duration ({st.duration} s)")
    rig = _Rig(skeleton)
    h_stand = float(rig.rest[rig.pelvis][1] - rig.ground)
    feet = {}
    for side, leg in rig.legs.items():
        a = rig.rest[leg.ankle] - rig.rest[rig.pelvis]
        feet[side] = np.array([a[0], -leg.heel[1], a[2]])
    times = np.arange(st.keys + 1) * st.duration / st.keys
    roots, rots = [], []
    for t in times[:-1]:
        wb = 2 * np.pi * t / st.breath_period
        ws = 2 * np.pi * t / st.sway_period
        breath = np.sin(wb)
        pelvis = np.array([st.sway * np.sin(ws), h_stand - st.knee_drop,
                           st.surge * np.sin(2 * ws)])
        yaw = np.radians(st.pelvis_yaw) * np.sin(ws)
        roll = -np.arctan2(st.sway * np.sin(ws), h_stand) * 0.5
        rot = quat_identity((rig.sk.n_joints,))
        rot[rig.pelvis] = quat_mul(_ry(yaw), _rz(roll))
        root = rig.root_for_pelvis(pelvis)
        for j in rig.spine:
            rot[j] = quat_mul(_ry(-yaw / len(rig.spine)),
                              _rx(np.radians(st.breath_pitch) * breath / len(rig.spine)))
        for side, leg in rig.legs.items():
            rig.solve_leg(leg, rot, root, feet[side], quat_identity(), quat_identity())
        for side in ("left", "right"):
            rig.pose_arm(side, rot, root, np.radians(-0.5 * st.breath_arm * breath),
                         np.radians(st.arm_abduction + st.breath_arm * breath),
                         np.radians(st.elbow + st.breath_arm * breath))
        rig.level_head(rot, root, 0.0)
        roots.append(root)
        rots.append(rot)
    roots.append(roots[0].copy())
    rots.append(rots[0].copy())
    motion = keyframes_to_motion(rig.sk, times, np.array(rots), np.array(roots), st.frame_time,
                                 method="catmull_rom", cyclic=True)
    return rig.to_file(motion)


def _check_style(duration: float, frame_time: float, keys: int) -> None:
    if not (np.isfinite(duration) and duration > 0 and np.isfinite(frame_time) and frame_time > 0):
        raise AuthoringError("durations and frame_time must be positive seconds")
    if abs(duration / frame_time - round(duration / frame_time)) > 1e-6:
        raise AuthoringError(f"the loop ({duration} s) must be a whole number of frames "
                             f"({frame_time} s each) to close seamlessly")
    if int(keys) < 4:
        raise AuthoringError("at least 4 keys per loop are needed")


# ----------------------------------------------------------------------------------------------
# bundling
# ----------------------------------------------------------------------------------------------
def write_bundled_motions(skeleton: Skeleton, out_dir: str | os.PathLike) -> list[Path]:
    """Write ``idle.bvh`` and ``walk.bvh`` for ``skeleton`` into ``out_dir`` (created if needed).

    Returns the paths written, ``[out_dir/idle.bvh, out_dir/walk.bvh]``. Deterministic: the same
    skeleton gives the same files.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, make in (("idle", idle_motion), ("walk", walk_motion)):
        path = out / BUNDLED_MOTIONS[name]
        save(make(skeleton), path)
        paths.append(path)
    return paths
