"""Reference motions: a BVH clip expressed in a converted model's coordinates (qpos, qvel, sites).

:class:`ReferenceMotion` turns a :class:`~mjchar.bvh.io.motion.Motion` (file units and axes) into
the generalised coordinates of a model written by :mod:`mjchar.bvh.mjcf` (see
``docs/model-contract.md``):

1. **Units and axes.** ``transform_motion(motion, info.unit_scale, info.basis)`` gives the clip in
   metres in the MuJoCo world (Z up, facing +X). Forward kinematics of that motion gives the BVH
   joints' global positions ``p_j`` ``(F, J, 3)`` and orientations ``G_j`` ``(F, J, 4)``.
2. **Joint map.** Every kept BVH joint ``j`` owns a body whose rest frame is world-aligned at the
   joint's rest position. With ``a`` the kept BVH joint of the model parent body (dropped or fused
   joints in between are folded in), the body's local rotation is ``L_j = G_a^-1 G_j``. Then

   - free root: ``qpos = (p_j, G_j)``;
   - ball: ``qpos = L_j``;
   - three hinges with axes ``a1, a2, a3`` (kinematic order): the intrinsic Euler angles of
     ``L_j = R_a1(t1) R_a2(t2) R_a3(t3)``, continuous over frames (unwrapped, branch-consistent);
   - one hinge (knees, elbows of the ``hinge`` model): the twist of ``L_j`` about the axis
     (swing-twist projection, ``t = 2 atan2(v . a, w)``); two hinges: the first two Euler angles.

3. **Projection IK** (``project=True``, only when some body has fewer than three rotational dofs).
   Real knees and elbows are not hinges, so the projection alone moves ankles and wrists by
   centimetres. Per frame, damped least squares in the model's joint space,
   ``dq = (J^T W J + lambda^2 I + M)^-1 (J^T W e + M (q_proj - q))``, over the limb's dofs (the
   parent joint when it only carries this limb, the hinge itself, the child joint) with ``J``
   from ``mj_jacBody``, the error ``e`` stacking the child body's position and orientation
   (``log(G_target R^T)``, world frame) and, with a lower weight, the hinge body's position;
   ``M`` is a small regulariser on the parent's dofs that keeps the limb's swivel smooth where
   the clip's limb is nearly straight (see :func:`mjchar.bvh.reference.projection._project_ik`).
   Frames are solved in order, each warm-started with the previous frame's correction.
4. **Floor.** The clip is shifted vertically so the lowest foot point over the clip (foot box
   corners, or foot sites) is at ``z = 0`` (``floor="clip"``). Mocap stance feet then float
   centimetres above the floor in mid-stance, which a physical foot cannot follow, so by default
   (``floor="contact"``) every frame where a foot supports the body (low and slow) is shifted
   again so its lowest foot point touches the floor, and frames in flight (runs, jumps) take the
   shift interpolated from the supported frames around them. ``floor="frame"`` shifts every
   frame, flight included.
5. **Loops.** A cyclic clip (given, or detected when its first and last poses agree within
   :data:`CYCLIC_POSE_TOLERANCE` once heading and horizontal position are removed) repeats with
   period ``duration = (F - 1) frame_time`` (the last frame is the first of the next cycle). Each
   cycle applies the rigid horizontal transform ``M`` that takes the root from frame 0 to frame
   ``F - 1``: a translation, plus the heading change when the clip turns by more than
   :data:`TURN_THRESHOLD`.

Times: ``qpos(t)`` interpolates between frames with ``mj_integratePos``/``mj_differentiatePos``
semantics (linear for positions and hinge angles, slerp for quaternions); ``qvel(t)`` interpolates
per-frame central differences (``mj_differentiatePos`` semantics: free-joint linear velocity in
the world frame, angular velocities in the body frame). A non-cyclic clip holds its first/last
pose outside ``[0, duration]`` with zero velocity.

Where the parts live: the joint map in :mod:`mjchar.bvh.reference.joint_map`, hinge angles and the
projection IK in :mod:`mjchar.bvh.reference.projection`, foot points for the floor in
:mod:`mjchar.bvh.reference.foot_points`, the qpos algebra in
:mod:`mjchar.bvh.kinematics.qpos_algebra`; this module holds :class:`ReferenceMotion` and
:func:`replay_errors`.
"""

from __future__ import annotations

import os

import mujoco
import numpy as np

from mjchar.bvh.errors import ReferenceMotionError
from mjchar.bvh.io import load
from mjchar.bvh.io.motion import FrameTimes, Motion
from mjchar.bvh.kinematics.fk import end_site_positions, forward_kinematics
from mjchar.bvh.kinematics.qpos_algebra import _QposAlgebra
from mjchar.bvh.reference.foot_points import (
    FOOT_SIDES,
    _FootPoints,
    _geom_local_points,  # noqa: F401  (tests import it from here)
    contact_grounding,
    foot_contact,
)
from mjchar.bvh.reference.joint_map import _build_slots, _model_info
from mjchar.bvh.reference.projection import _hinge_angles, _project_ik
from mjchar.bvh.rigs.layouts import apply_record
from mjchar.bvh.rigs.units import transform_motion
from mjchar.bvh.rotations import (
    heading_angle,
    quat_conj,
    quat_fix_continuity,
    quat_mul,
    quat_normalize,
    quat_rotate,
)

__all__ = [
    "ReferenceMotion",
    "ReferenceMotionError",
    "replay_errors",
    "CYCLIC_POSE_TOLERANCE",
    "TURN_THRESHOLD",
    "END_EFFECTOR_ROLES",
]

#: metres: first and last poses (root-relative, heading-aligned) closer than this make a clip cyclic
CYCLIC_POSE_TOLERANCE = 0.025

#: ``floor=`` choices of :class:`ReferenceMotion`
FLOOR_MODES = ("contact", "clip", "frame")
#: radians: a cyclic clip whose heading changes less than this per cycle loops without turning
TURN_THRESHOLD = np.radians(10.0)
#: roles whose joints (and the end sites below them) count as end effectors in error reports
END_EFFECTOR_ROLES = ("head", "left_wrist", "right_wrist", "left_ankle", "right_ankle",
                      "left_toe", "right_toe")


# --------------------------------------------------------------------------------------------
# the reference motion
# --------------------------------------------------------------------------------------------
class ReferenceMotion(FrameTimes):
    """A BVH motion expressed in a converted model's coordinates, sampled at any time.

    Args:
        model: compiled ``mujoco.MjModel`` of a model written by :func:`mjchar.bvh.mjcf.convert`.
        motion: :class:`~mjchar.bvh.io.motion.Motion` in file units and axes, with (at least) every
        BVH joint
            the model keeps, matched by name (joint order may differ from the model's source).
        info: the model's ``ModelInfo``; read from ``model`` when ``None``.
        cyclic: loop the clip; ``None`` detects it (first and last poses agree within
            :data:`CYCLIC_POSE_TOLERANCE` metres after removing root heading and position).
        project: for bodies with fewer rotational dofs than the BVH joint (the ``hinge`` model's
            knees and elbows), correct the projected angles with damped-least-squares IK so the
            limb's joints land where the clip puts them. ``False``: projection only.
        floor: ``"contact"`` (default: every frame where a foot supports the body shifted so
            its lowest foot point is at ``z = 0``, frames in flight interpolated between them:
            :func:`mjchar.bvh.reference.foot_points.contact_grounding`), ``"clip"`` (one vertical
            shift for the whole clip: its lowest foot point at ``z = 0``) or ``"frame"`` (each frame
            shifted so its own lowest foot point is at ``z = 0``, flight included).
        progress: called as ``progress(frames_done, frames)`` during the IK correction (a long
            clip takes seconds), or ``None``.

    Attributes:
        model, info: the model and its metadata.
        motion: the clip in metres and MuJoCo axes (before floor placement), a ``Motion``.
        frame_time: seconds per frame; ``n_frames``: ``F``; ``duration``: ``(F-1) frame_time``
            seconds, also the loop period of a cyclic clip; ``cyclic``: bool.
        frame_qpos: ``(F, nq)`` qpos per frame; ``frame_qvel``: ``(F, nv)`` per-frame velocities.
        joint_names: ``(K,)`` kept BVH joints (bodies) in the model's joint-map order;
            ``joint_body_ids``: ``(K,)`` their body ids.
        z_offset: metres added to every height to put the lowest foot point at ``z = 0``.
        grounding: ``(F,)`` metres added to each frame's heights on top of ``z_offset`` (zero with
            ``floor="clip"``; ``<= 0`` otherwise); ``support``: ``(F,)`` bool, the frames with a
            supporting foot (all with ``"clip"`` and ``"frame"``).
        cycle_heading: radians turned per cycle; ``cycle_displacement``: ``(2,)`` metres the root
            moves per cycle (frame ``F-1`` minus frame 0, horizontal).
    """

    def __init__(self, model: mujoco.MjModel, motion: Motion, *, info=None,
                 cyclic: bool | None = None, project: bool = True, floor: str = "contact",
                 progress=None):
        if not isinstance(model, mujoco.MjModel):
            raise ReferenceMotionError(
                f"model must be a mujoco.MjModel, got {type(model).__name__}")
        if not isinstance(motion, Motion):
            raise ReferenceMotionError(f"motion must be a bvh.Motion, got {type(motion).__name__}")
        if motion.n_frames < 1:
            raise ReferenceMotionError("the motion has no frames")
        self.model = model
        self.info = info if info is not None else _model_info(model)
        self._data = mujoco.MjData(model)
        self._alg = _QposAlgebra(model)
        self._set_motion(motion)

        fk = forward_kinematics(self.motion)
        qpos = self._map_frames(fk)
        self.projected_joints = [s.name for s in self._slots
                                 if s.kind == "hinge" and len(s.qadr) < 3]
        self.ik_iterations = np.zeros(self.n_frames, dtype=int)
        if project and self.projected_joints:
            qpos, self.ik_iterations = _project_ik(self.model, self._data, self._slots,
                                                   self._alg, qpos, fk, progress)
        self._place_on_floor(qpos, fk, floor)
        self._set_cycle(qpos, cyclic)
        self.frame_qvel = self._frame_velocities(qpos)

    # -- construction helpers ----------------------------------------------------------------------
    def _set_motion(self, motion: Motion) -> None:
        """The clip through the converter's rig steps, in metres and MuJoCo axes, and the joint
        map onto the model's bodies."""
        rig = self.info.extra.get("rig")
        if rig:  # the converter normalised the rig (folded root, bones, rest): same steps
            motion = apply_record(motion, rig, self.info.source()[0])
        basis = np.asarray(self.info.basis, dtype=float).reshape(4)
        self.motion = transform_motion(motion, float(self.info.unit_scale), basis)
        self.frame_time = float(motion.frame_time)
        self.n_frames = int(motion.n_frames)
        sk = self.motion.skeleton
        self._slots = _build_slots(self.model, self.info, sk)
        self._root = next(s for s in self._slots if s.kind == "free")
        self.joint_names = [s.name for s in self._slots]
        self.joint_body_ids = np.array([s.body for s in self._slots], dtype=int)
        self._joint_bvh = np.array([s.bvh for s in self._slots], dtype=int)

    def _place_on_floor(self, qpos: np.ndarray, fk, floor: str) -> None:
        """Floor placement (in place on ``qpos``): the lowest foot point over the clip (or of
        every frame) at z = 0, and with ``"contact"`` each frame's supporting foot on the
        floor; the joint, end-site and foot points lifted alike."""
        if floor not in FLOOR_MODES:
            raise ReferenceMotionError(
                f"floor must be one of {', '.join(FLOOR_MODES)}, got {floor!r}")
        self.floor = floor
        self._feet = _FootPoints(self.model, self.info)
        pts = self._sample_points(qpos)
        all_pts = np.concatenate([p for p in pts.values()], axis=1)
        lowest = (np.min(all_pts[..., 2], axis=1) if all_pts.size
                  else np.zeros(self.n_frames))                    # (F,) per frame
        self.z_offset = float(-np.min(lowest))
        self.grounding = np.zeros(self.n_frames)
        self.support = np.ones(self.n_frames, dtype=bool)  # frames with a foot on the floor
        if floor == "frame":
            self.grounding = np.min(lowest) - lowest
        elif floor == "contact" and all(k in pts for k in FOOT_SIDES):
            root_z = qpos[:, self._root.qadr[0] + 2] + self.z_offset
            self.grounding, self.support = contact_grounding(
                {k: pts[k] for k in FOOT_SIDES}, self.frame_time,
                max(float(np.mean(root_z)), 1e-3))
        lift = self.z_offset + self.grounding                         # (F,)
        qpos[:, self._root.qadr[0] + 2] += lift
        shift = lift[:, None, None] * np.array([0.0, 0.0, 1.0])       # (F, 1, 3)
        self._foot_pts = {k: v + shift for k, v in pts.items() if k in FOOT_SIDES}
        self._joint_pos = fk.positions + shift                       # (F, J, 3) all BVH joints
        self._end_sites = end_site_positions(self.motion, fk) + shift  # (F, E, 3)
        self.frame_qpos = qpos

    def _set_cycle(self, qpos: np.ndarray, cyclic: bool | None) -> None:
        """Whether the clip loops (given, or :meth:`_looks_cyclic`), the seam's floor shift
        made continuous (in place on ``qpos``), and the heading turned and the root
        displacement per cycle."""
        rq = qpos[:, self._root.qadr[0] + 3: self._root.qadr[0] + 7]
        heading = heading_angle(rq, up="z")
        rxy = qpos[:, self._root.qadr[0]: self._root.qadr[0] + 2]
        self.cyclic = bool(self._looks_cyclic(heading)) if cyclic is None else bool(cyclic)
        if self.cyclic and self.n_frames < 3:
            raise ReferenceMotionError("a cyclic clip needs at least 3 frames")
        if self.cyclic and self.grounding.any():
            # the last frame is the first of the next cycle: it takes frame 0's floor shift, so
            # the loop has no vertical step at the seam
            dz = self.grounding[0] - self.grounding[-1]
            self.grounding[-1] += dz
            qpos[-1, self._root.qadr[0] + 2] += dz
            for arr in (*self._foot_pts.values(), self._joint_pos, self._end_sites):
                arr[-1, :, 2] += dz
        dpsi = float(np.angle(np.exp(1j * (heading[-1] - heading[0]))))
        self.cycle_heading = dpsi if (self.cyclic and abs(dpsi) >= TURN_THRESHOLD) else 0.0
        self.cycle_displacement = (rxy[-1] - rxy[0]).copy() if self.cyclic else np.zeros(2)
        r = np.exp(1j * self.cycle_heading)
        p0, pf = complex(*rxy[0]), complex(*rxy[-1])
        self._cycle_b = pf - r * p0  # M(p) = r p + b (complex horizontal coordinates)

    def _map_frames(self, fk) -> np.ndarray:
        """``(F, nq)`` qpos from the global BVH transforms (exact except for reduced bodies)."""
        n_f = self.n_frames
        qpos = np.tile(self.model.qpos0, (n_f, 1))
        sk = self.motion.skeleton
        rest = sk.rest_positions()
        for s in self._slots:
            g = fk.orientations[:, s.bvh]
            if s.parent_bvh >= 0:
                gp = fk.orientations[:, s.parent_bvh]
                local = quat_mul(quat_conj(gp), g)
            else:
                gp = None
                local = g
            local = quat_fix_continuity(quat_normalize(local), axis=0)
            if s.kind == "free":
                qpos[:, s.qadr[0]: s.qadr[0] + 3] = fk.positions[:, s.bvh]
                qpos[:, s.qadr[0] + 3: s.qadr[0] + 7] = local
            elif s.kind == "ball":
                qpos[:, s.qadr[0]: s.qadr[0] + 4] = local
            elif s.kind == "hinge":
                qpos[:, s.qadr] = _hinge_angles(s, local)
            if len(s.slide_qadr) and s.parent_bvh >= 0:
                # translation of the joint in its parent's frame beyond the rest offset
                d = quat_rotate(quat_conj(gp),
                                fk.positions[:, s.bvh] - fk.positions[:, s.parent_bvh])
                d = d - (rest[s.bvh] - rest[s.parent_bvh])
                qpos[:, s.slide_qadr] = d @ s.slide_axes.T
        return qpos

    def _sample_points(self, qpos: np.ndarray) -> dict[str, np.ndarray]:
        """Foot points per side ``(F, P, 3)`` (and ``"all"`` when no feet are known)."""
        m, d = self.model, self._data
        groups = dict(self._feet.sides)
        if not groups:
            groups = {"all": self._feet.fallback}
        out = {k: [] for k in groups}
        for f in range(len(qpos)):
            d.qpos[:] = qpos[f]
            mujoco.mj_kinematics(m, d)
            for k, items in groups.items():
                out[k].append(self._feet.sample(d, items))
        return {k: np.array(v) for k, v in out.items()}

    def _looks_cyclic(self, heading: np.ndarray) -> bool:
        if self.n_frames < 4:
            return False
        pts = np.concatenate([self._joint_pos[:, self._joint_bvh], self._end_sites], axis=1)
        root = self._joint_pos[:, self._root.bvh]
        rel = pts - root[:, None] * np.array([1.0, 1.0, 0.0])
        c = np.exp(-1j * heading[[0, -1]])
        xy = (rel[[0, -1], :, 0] + 1j * rel[[0, -1], :, 1]) * c[:, None]
        diff_xy = np.abs(xy[0] - xy[1])
        diff_z = np.abs(rel[0, :, 2] - rel[-1, :, 2])
        return bool(np.max(np.hypot(diff_xy, diff_z)) < CYCLIC_POSE_TOLERANCE)

    def _cycle_apply_qpos(self, q: np.ndarray, k: np.ndarray) -> np.ndarray:
        """Apply ``M^k`` (per row) to the root of qpos rows ``(N, nq)``."""
        k = np.asarray(k)
        if not np.any(k):
            return q
        q = q.copy()
        a = self._root.qadr[0]
        ang, off = self._cycle_powers(k)
        z = (q[:, a] + 1j * q[:, a + 1]) * np.exp(1j * ang) + off
        q[:, a], q[:, a + 1] = z.real, z.imag
        yaw = np.zeros((len(k), 4))
        yaw[:, 0], yaw[:, 3] = np.cos(ang / 2), np.sin(ang / 2)
        q[:, a + 3: a + 7] = quat_mul(yaw, q[:, a + 3: a + 7])
        return q

    def _cycle_powers(self, k: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Heading ``k * dpsi`` and complex offset of ``M^k(p) = e^{i k dpsi} p + off_k``."""
        k = np.asarray(k, dtype=float)
        ang = k * self.cycle_heading
        r = np.exp(1j * self.cycle_heading)
        if abs(self.cycle_heading) < 1e-12:
            off = k * self._cycle_b
        else:
            off = self._cycle_b * (1 - np.exp(1j * ang)) / (1 - r)
        return ang, off

    def _frame_velocities(self, qpos: np.ndarray) -> np.ndarray:
        """``(F, nv)`` central-difference velocities (one-sided at the ends of non-cyclic clips;
        across the seam for cyclic ones)."""
        n_f, dt = self.n_frames, self.frame_time
        if n_f < 2:
            return np.zeros((n_f, self.model.nv))
        fwd = self._alg.diff(qpos[:-1], qpos[1:]) / dt  # (F-1, nv)
        v = np.empty((n_f, self.model.nv))
        v[1:-1] = 0.5 * (fwd[:-1] + fwd[1:])
        if self.cyclic:
            before = self._cycle_apply_qpos(qpos[-2:-1], np.array([-1]))[0]
            after = self._cycle_apply_qpos(qpos[1:2], np.array([1]))[0]
            v[0] = 0.5 * (self._alg.diff(before, qpos[0]) / dt + fwd[0])
            v[-1] = 0.5 * (fwd[-1] + self._alg.diff(qpos[-1], after) / dt)
        else:
            v[0], v[-1] = fwd[0], fwd[-1]
        return v

    # -- time lookup -------------------------------------------------------------------------------
    def _locate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, tuple]:
        """Frame index ``i``, fraction ``a``, cycle ``k`` and in-range mask for times ``t``."""
        t = np.asarray(t, dtype=float)
        shape = t.shape
        t = t.reshape(-1)
        if not np.all(np.isfinite(t)):
            raise ReferenceMotionError("times must be finite numbers of seconds")
        n_f, dt = self.n_frames, self.frame_time
        inside = np.ones(len(t), dtype=bool)
        if n_f == 1:
            z = np.zeros(len(t), dtype=int)
            return z, np.zeros(len(t)), z, inside, shape
        T = self.duration
        if self.cyclic:
            k = np.floor(t / T)
            tau = t - k * T
        else:
            k = np.zeros(len(t))
            eps = 1e-9 * max(T, 1.0)
            inside = (t >= -eps) & (t <= T + eps)
            tau = np.clip(t, 0.0, T)
        s = tau / dt
        i = np.clip(np.floor(s), 0, n_f - 2).astype(int)
        a = np.clip(s - i, 0.0, 1.0)
        return i, a, k.astype(int), inside, shape

    # -- public sampling ---------------------------------------------------------------------------
    def qpos(self, t) -> np.ndarray:
        """Generalised positions at time(s) ``t`` (seconds, any shape): ``(*t.shape, nq)``.

        Between frames: linear hinge angles and root position, slerped quaternions. Cyclic clips
        continue past ``duration`` with the accumulated root displacement (and heading)."""
        i, a, k, _, shape = self._locate(t)
        q = self.frame_qpos
        if self.n_frames == 1:
            out = q[i]
        else:
            out = self._alg.interpolate(q[i], q[i + 1], a)
        out = self._cycle_apply_qpos(out, k)
        return out.reshape((*shape, self.model.nq))

    def qvel(self, t) -> np.ndarray:
        """Generalised velocities at time(s) ``t``: ``(*t.shape, nv)`` (rad/s, m/s).

        Per-frame central differences (``mj_differentiatePos`` semantics: root linear velocity in
        the world frame, angular velocities in the body frame) interpolated linearly; zero outside
        ``[0, duration]`` for non-cyclic clips."""
        i, a, k, inside, shape = self._locate(t)
        v = self.frame_qvel
        if self.n_frames == 1:
            out = v[i].copy()
        else:
            out = v[i] + a[:, None] * (v[i + 1] - v[i])
        if np.any(k) and self.cycle_heading:
            ra = self._root.dadr[0]
            ang = k * self.cycle_heading
            z = (out[:, ra] + 1j * out[:, ra + 1]) * np.exp(1j * ang)
            out[:, ra], out[:, ra + 1] = z.real, z.imag
        out[~inside] = 0.0
        return out.reshape((*shape, self.model.nv))

    def _kinematics(self, t, attr: str) -> np.ndarray:
        q = self.qpos(t)
        shape = q.shape[:-1]
        q = q.reshape(-1, self.model.nq)
        d = self._data
        rows = []
        for row in q:
            d.qpos[:] = row
            mujoco.mj_kinematics(self.model, d)
            rows.append(getattr(d, attr).copy())
        n = getattr(d, attr).shape[0]
        return np.array(rows).reshape((*shape, n, 3))

    def body_positions(self, t) -> np.ndarray:
        """World positions of every model body (index = body id, 0 the world) at ``t``:
        ``(*t.shape, nbody, 3)`` metres, from ``mj_kinematics`` on :meth:`qpos`."""
        return self._kinematics(t, "xpos")

    def site_positions(self, t) -> np.ndarray:
        """World positions of every model site (index = site id) at ``t``: ``(*t.shape, nsite,
        3)`` metres."""
        return self._kinematics(t, "site_xpos")

    def joint_positions(self, t) -> np.ndarray:
        """Positions of the kept BVH joints (:attr:`joint_names`) in the model frame, as the clip
        has them (not the model): ``(*t.shape, K, 3)`` metres, linear between frames, placed on the
        floor and looped like :meth:`qpos`. Compare with ``body_positions(t)[..., joint_body_ids,
        :]`` for tracking errors."""
        i, a, k, _, shape = self._locate(t)
        p = self._joint_pos[:, self._joint_bvh]
        out = p[i] if self.n_frames == 1 else p[i] + a[:, None, None] * (p[i + 1] - p[i])
        out = self._cycle_apply_points(out, k)
        return out.reshape((*shape, len(self._joint_bvh), 3))

    def _cycle_apply_points(self, pts: np.ndarray, k: np.ndarray) -> np.ndarray:
        if not np.any(k):
            return pts
        ang, off = self._cycle_powers(k)
        z = (pts[..., 0] + 1j * pts[..., 1]) * np.exp(1j * ang)[:, None] + off[:, None]
        out = pts.copy()
        out[..., 0], out[..., 1] = z.real, z.imag
        return out

    def frame_contacts(self, height: float = 0.1, speed: float = 0.5) -> np.ndarray:
        """``(F, 2)`` bool foot-contact labels per frame, columns (left, right).

        A foot is in contact when one of its lowest points (foot and toe box corners, or foot
        sites) is below ``height`` metres and moves slower than ``speed`` m/s
        (:func:`mjchar.bvh.reference.foot_points.foot_contact`; central differences across the seam
        for cyclic clips). The shared clips' stance feet float up to ~9 cm above the placed floor at
        heel strike, hence the generous height.
        """
        if set(self._foot_pts) != set(FOOT_SIDES):
            raise ReferenceMotionError("the model has no recognisable left/right feet (no ankle "
                                       "roles with geoms, no left_foot/right_foot sites)")
        out = np.zeros((self.n_frames, 2), dtype=bool)
        dt = self.frame_time
        for c, side in enumerate(FOOT_SIDES):
            p = self._foot_pts[side]  # (F, P, 3)
            vel = None
            if self.n_frames > 1 and self.cyclic:  # central differences across the seam
                vel = np.gradient(p, dt, axis=0)
                before = self._cycle_apply_points(p[-2][None], np.array([-1]))[0]
                after = self._cycle_apply_points(p[1][None], np.array([1]))[0]
                vel[0] = (p[1] - before) / (2 * dt)
                vel[-1] = (after - p[-2]) / (2 * dt)
            out[:, c] = foot_contact(p, dt, height, speed, velocity=vel)
        return out

    def foot_contacts(self, t, height: float = 0.1, speed: float = 0.5) -> np.ndarray:
        """Foot-contact labels at ``t`` (nearest frame): ``(*t.shape, 2)`` bool, (left, right).
        See :meth:`frame_contacts` for ``height`` (m) and ``speed`` (m/s)."""
        i, a, _, _, shape = self._locate(t)
        idx = np.minimum(i + (a >= 0.5), self.n_frames - 1)
        return self.frame_contacts(height, speed)[idx].reshape((*shape, 2))

    # -- errors ------------------------------------------------------------------------------------
    def end_effectors(self) -> dict[str, tuple[int, np.ndarray, int, int]]:
        """End effectors compared by :meth:`replay_errors`: name -> ``(body id, offset (3,) in the
        body frame, BVH joint index or -1, end site index or -1)``. They are the joints with the
        roles in :data:`END_EFFECTOR_ROLES` and every end site hanging from a kept joint."""
        sk = self.motion.skeleton
        rest = sk.rest_positions()
        rest_es = sk.rest_end_sites() if sk.n_end_sites else np.zeros((0, 3))
        by_bvh = {s.bvh: s for s in self._slots}
        roles = dict(getattr(self.info, "roles", {}) or {})
        out = {}
        for role in END_EFFECTOR_ROLES:
            name = roles.get(role)
            if isinstance(name, str) and name in self.joint_names:
                s = self._slots[self.joint_names.index(name)]
                out[name] = (s.body, np.zeros(3), s.bvh, -1)
        for e, (par, nm) in enumerate(zip(sk.end_site_parents, sk.end_site_names, strict=True)):
            if int(par) in by_bvh:
                s = by_bvh[int(par)]
                out[nm] = (s.body, rest_es[e] - rest[s.bvh], -1, e)
        return out

    def replay_errors(self) -> dict:
        """Model kinematics of every frame's qpos against the clip's joint positions.

        Returns a dict (distances in millimetres)::

            n_frames, max_mm, max_joint, worst_frame, mean_mm,
            joints_mm {joint: worst over frames},
            end_effector_max_mm, end_effector, end_effectors_mm {name: worst over frames}
        """
        m, d = self.model, self._data
        ee = self.end_effectors()
        ee_names = list(ee)
        n_f, k = self.n_frames, len(self._slots)
        model_j = np.empty((n_f, k, 3))
        model_e = np.empty((n_f, len(ee_names), 3))
        for f in range(n_f):
            d.qpos[:] = self.frame_qpos[f]
            mujoco.mj_kinematics(m, d)
            model_j[f] = d.xpos[self.joint_body_ids]
            for c, nm in enumerate(ee_names):
                body, off, _, _ = ee[nm]
                model_e[f, c] = d.xpos[body] + d.xmat[body].reshape(3, 3) @ off
        ref_j = self._joint_pos[:, self._joint_bvh]
        ref_e = np.empty_like(model_e)
        for c, nm in enumerate(ee_names):
            _, _, j, e = ee[nm]
            ref_e[:, c] = self._joint_pos[:, j] if j >= 0 else self._end_sites[:, e]
        err_j = 1000.0 * np.linalg.norm(model_j - ref_j, axis=-1)  # (F, K)
        err_e = 1000.0 * np.linalg.norm(model_e - ref_e, axis=-1)
        worst = np.unravel_index(int(np.argmax(err_j)), err_j.shape)
        per_j = err_j.max(axis=0)
        per_e = err_e.max(axis=0) if err_e.size else np.zeros(0)
        return {
            "n_frames": n_f,
            "max_mm": float(err_j.max()),
            "max_joint": self.joint_names[int(worst[1])],
            "worst_frame": int(worst[0]),
            "mean_mm": float(err_j.mean()),
            "joints_mm": {n: float(v) for n, v in zip(self.joint_names, per_j, strict=True)},
            "end_effector_max_mm": float(per_e.max()) if per_e.size else 0.0,
            "end_effector": ee_names[int(np.argmax(per_e))] if per_e.size else None,
            "end_effectors_mm": {n: float(v) for n, v in zip(ee_names, per_e, strict=True)},
        }


def replay_errors(model_or_converted, motion, *, project: bool = True, progress=None) -> dict:
    """Replay ``motion`` kinematically in a converted model and measure how far it lands.

    Args:
        model_or_converted: a ``mujoco.MjModel`` written by :mod:`mjchar.bvh.mjcf`, or a
            ``ConvertedModel`` (compiled here; its ``info`` is used).
        motion: a :class:`~mjchar.bvh.io.motion.Motion` in file units/axes, or a BVH path.
        project: IK correction for reduced (hinge) joints, as in :class:`ReferenceMotion`.
        progress: ``progress(frames_done, frames)`` during that correction, or ``None``.

    Runs ``mj_kinematics`` on every frame's qpos (:class:`ReferenceMotion`, not looped) and
    compares body positions with the clip's joint positions from ``bvh.forward_kinematics``,
    converted to metres/MuJoCo axes and placed on the floor the same way; end effectors (hands,
    feet, toes, head and the end sites below kept joints) are compared likewise. Returns the dict
    of :meth:`ReferenceMotion.replay_errors` (millimetres: ``max_mm``, ``joints_mm``,
    ``end_effector_max_mm``, ...).
    """
    if isinstance(motion, (str, os.PathLike)):
        motion = load(motion)
    info = None
    if isinstance(model_or_converted, mujoco.MjModel):
        model = model_or_converted
    elif hasattr(model_or_converted, "compile") and hasattr(model_or_converted, "info"):
        model = model_or_converted.compile()
        info = model_or_converted.info
    else:
        raise ReferenceMotionError(f"expected a mujoco.MjModel or a ConvertedModel, got "
                                   f"{type(model_or_converted).__name__}")
    ref = ReferenceMotion(model, motion, info=info, cyclic=False, project=project,
                          progress=progress)
    return ref.replay_errors()
