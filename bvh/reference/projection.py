"""Hinge projection: BVH joint rotations on models with fewer rotational dofs than the clip.

Local rotations ``L_j`` (unit quaternions) become hinge angles by :func:`_hinge_angles`: the
intrinsic Euler angles for a hinge triplet (exact; continuous over frames, unwrapped and
branch-consistent), the first two Euler angles for two hinges, and the swing-twist projection for
one hinge (knees and elbows of the ``hinge`` model): the twist about the axis ``a``,
``t = 2 atan2(v . a, w)``.

Real knees and elbows are not hinges, so the projection alone moves ankles and wrists by
centimetres. :func:`_project_ik` corrects the limb around every reduced body per frame with damped
least squares (Levenberg-Marquardt) in the model's joint space, Jacobians from ``mj_jacBody``:
``dq = (J^T W J + lambda^2 I + M)^-1 (J^T W e + M (q_proj - q))`` (see its docstring and the
module docstring of :mod:`mjchar.bvh.reference.reference_motion`).
"""

from __future__ import annotations

import warnings

import mujoco
import numpy as np

from mjchar.bvh.kinematics.qpos_algebra import _QposAlgebra
from mjchar.bvh.reference.joint_map import _Slot, _subtree_bodies
from mjchar.bvh.rotations import quat_conj, quat_mul, quat_rotate, quat_to_rotvec, to_rotation

# projection IK: Levenberg damping (m), swivel regulariser toward the projection (m^2/rad^2),
# weight of the knee/elbow position, iteration cap, stop when no dof moves more than this (rad),
# orientation weight (m/rad), largest step (rad)
_IK_DAMPING = 1e-3
_IK_REG = 1e-4
_IK_MID_WEIGHT = 0.3
_IK_MAX_ITER = 40
_IK_STEP_TOL = 1e-5
_IK_ROT_WEIGHT = 0.3
_IK_MAX_STEP = 0.5

_AXIS_LETTERS = "XYZ"


def _euler_continuous(q: np.ndarray, order: str) -> np.ndarray:
    """``(F, 3)`` intrinsic Euler angles (radians, ``order`` like ``"ZXY"``) of ``(F, 4)`` quats,
    continuous over frames: unwrapped, and on the Euler branch nearest the previous frame."""
    r = to_rotation(q)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # gimbal lock: the angles still compose to r
        a = r.as_euler(order)
    if len(a) < 2:
        return a
    un = np.unwrap(a, axis=0)
    if np.max(np.abs(np.diff(un, axis=0))) < np.pi / 2:
        return un
    b = np.stack([a[:, 0] + np.pi, np.pi - a[:, 1], a[:, 2] + np.pi], axis=1)
    if order[0] == order[2]:  # proper Euler angles
        b[:, 1] = -a[:, 1]
    out = np.empty_like(a)
    prev = a[0]
    for f in range(len(a)):  # rare (gimbal crossings): greedy branch + 2 pi shift choice
        cands = np.stack([a[f], b[f]])
        cands = cands + 2 * np.pi * np.round((prev - cands) / (2 * np.pi))
        prev = out[f] = cands[np.argmin(np.sum((cands - prev) ** 2, axis=1))]
    return out


def _centre_turns(angles: np.ndarray) -> np.ndarray:
    """Shift each column of ``(F, n)`` unwrapped angles by whole turns so its median is in
    ``(-pi, pi]``."""
    med = np.median(angles, axis=0)
    return angles - 2 * np.pi * np.round(med / (2 * np.pi))


def _hinge_angles(slot: _Slot, local: np.ndarray) -> np.ndarray:
    """``(F, n)`` hinge angles (radians) of a body with ``n`` hinges for local rotations ``(F, 4)``.
    Exact for three hinges; the swing-twist (one hinge) or Euler (two hinges) projection else."""
    n = len(slot.qadr)
    if n == 1:
        a = slot.axes[0]
        ang = 2.0 * np.arctan2(local[:, 1:] @ a, local[:, 0])
        return _centre_turns(np.unwrap(ang)[:, None])
    idx = np.argmax(np.abs(slot.axes), axis=1)
    sign = np.sign(slot.axes[np.arange(n), idx])
    order = "".join(_AXIS_LETTERS[i] for i in idx)
    if n == 2:
        order += next(c for c in _AXIS_LETTERS if c not in order)
    ang = _euler_continuous(local, order)[:, :n] * sign
    return _centre_turns(ang)


def _model_geometry_positions(model: mujoco.MjModel, slots: list[_Slot], fk) -> np.ndarray:
    """``(F, J, 3)`` positions of the kept joints when the clip's global orientations drive
    the *model's* bones (its body offsets): the targets of the projection IK. Equal to the
    clip's positions when the model was converted from the clip's skeleton; for a model of
    other proportions, what the clip's pose looks like on this model."""
    pos = fk.positions.copy()
    for s in slots:  # parents first (joint-map order is BVH order)
        if s.parent_bvh >= 0:
            pos[:, s.bvh] = pos[:, s.parent_bvh] + quat_rotate(
                fk.orientations[:, s.parent_bvh], model.body_pos[s.body])
    return pos


def _project_ik(model: mujoco.MjModel, data: mujoco.MjData, slots: list[_Slot],
                alg: _QposAlgebra, qpos: np.ndarray, fk,
                progress=None) -> tuple[np.ndarray, np.ndarray]:
    """Damped-least-squares correction of the limbs around reduced (1-2 hinge) bodies.

    Per frame, Gauss-Newton with Levenberg damping on

        |e_end|^2 + |w_rot e_rot|^2 + |w_mid e_mid|^2 + mu |q_parent - q_proj|^2

    over the limb dofs (parent triplet, hinge, child triplet): ``e_end``/``e_rot`` are the
    child body's (ankle's, wrist's) position and orientation errors, ``e_mid`` the hinge
    body's (knee's, elbow's) position error. The limb can always put its end exactly (hip +
    knee reach the ankle, the ankle triplet turns the foot); the knee then lies on a circle
    about the hip-ankle line (the swivel). Matching the clip's knee exactly on it needs a hip
    twist of up to 90 degrees when the clip's knee is nearly straight but bent off the hinge
    plane, flipping from frame to frame; the small regulariser on the parent's dofs (toward
    the projected angles) trades a few millimetres of knee error for a smooth twist there,
    and vanishes in effect when the knee is bent (then the knee term decides).

    Args:
        model, data: the model and a scratch ``mujoco.MjData`` (its kinematics are overwritten).
        slots: the joint map (:func:`mjchar.bvh.reference.joint_map._build_slots`).
        alg: the model's :class:`~mjchar.bvh.kinematics.qpos_algebra._QposAlgebra`.
        qpos: ``(F, nq)`` projected qpos per frame (the regulariser pulls toward it).
        fk: forward kinematics of the clip in metres and MuJoCo axes (positions ``(F, J, 3)``,
            orientations ``(F, J, 4)``).
        progress: called as ``progress(frames_done, frames)`` as the frames are corrected
            (the slow part of following a long clip), or ``None``.

    Returns:
        ``(qpos (F, nq), iterations (F,) int)``: corrected qpos and the iterations per frame.
    """
    m, d = model, data
    iterations = np.zeros(len(qpos), dtype=int)
    dofs, swivel, targets = _limb_targets(m, slots)
    if not dofs:
        return qpos, iterations
    pos_t, rot_t = _model_geometry_positions(model, slots, fk), fk.orientations
    jacp = np.zeros((3, m.nv))
    jacr = np.zeros((3, m.nv))
    out = qpos.copy()
    prev_delta = np.zeros(m.nv)
    reg = np.where(np.isin(dofs, swivel), _IK_REG, 0.0)
    lm = np.diag(reg + _IK_DAMPING ** 2)
    for f in range(len(qpos)):
        if progress is not None and f % 25 == 0:
            progress(f, len(qpos))
        q_ref = qpos[f]
        q = alg.integrate(q_ref, prev_delta) if f else q_ref.copy()
        q, iterations[f] = _correct_frame(m, d, alg, q, q_ref, targets, pos_t[f], rot_t[f],
                                          dofs, reg, lm, jacp, jacr)
        out[f] = q
        prev_delta = alg.diff(q_ref, q)
    return out, iterations


def _limb_targets(m: mujoco.MjModel, slots: list[_Slot]
                  ) -> tuple[list[int], list[int], list[tuple[str, int, int]]]:
    """The limbs around reduced (1-2 hinge) bodies: ``(dofs, swivel, targets)``, the limb dofs
    (sorted), the parents' dofs (where a limb's free swivel lives) and the error terms
    ``(kind, body, bvh joint)`` (``"mid"``: the hinge body's position; ``"pos"``/``"rot"``:
    the limb end's position and orientation)."""
    by_body = {s.body: s for s in slots}
    children: dict[int, list[int]] = {}
    for b in range(1, m.nbody):
        children.setdefault(int(m.body_parentid[b]), []).append(b)
    dofs: list[int] = []
    swivel: list[int] = []  # the parent joint's dofs: where the limb's free swivel lives
    targets: list[tuple[str, int, int]] = []  # (kind, body, bvh joint)
    for s in slots:
        if not (s.kind == "hinge" and len(s.qadr) < 3):
            continue
        kids = [by_body[c] for c in children.get(s.body, []) if c in by_body]
        child = max(kids, key=lambda k: len(_subtree_bodies(m, k.body)), default=None)
        parent = by_body.get(int(m.body_parentid[s.body]))
        chain = [s]
        if parent is not None and parent.kind in ("hinge", "ball") and \
                len(children.get(parent.body, [])) == 1:
            chain.insert(0, parent)
        if child is not None and child.kind in ("hinge", "ball"):
            chain.append(child)
        for c in chain:
            dd = [int(x) for x in (c.dadr if c.kind == "hinge" else c.dadr[0] + np.arange(3))]
            dofs += dd
            if c is parent:
                swivel += dd
        eff = child if child is not None else s
        if eff is not s:
            targets.append(("mid", s.body, s.bvh))
        targets.append(("pos", eff.body, eff.bvh))
        targets.append(("rot", eff.body, eff.bvh))
    return sorted(set(dofs)), swivel, targets


def _correct_frame(m: mujoco.MjModel, d: mujoco.MjData, alg: _QposAlgebra, q: np.ndarray,
                   q_ref: np.ndarray, targets: list[tuple[str, int, int]], pos_f: np.ndarray,
                   rot_f: np.ndarray, dofs: list[int], reg: np.ndarray, lm: np.ndarray,
                   jacp: np.ndarray, jacr: np.ndarray) -> tuple[np.ndarray, int]:
    """One frame's damped Gauss-Newton iterations from ``q`` toward the clip's positions
    ``pos_f`` ``(J, 3)`` and orientations ``rot_f`` ``(J, 4)``, regularised toward ``q_ref``
    on the swivel dofs; ``(q, iterations)``. ``jacp``, ``jacr``: ``(3, nv)`` work arrays."""
    for it in range(_IK_MAX_ITER + 1):
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        e, jac = _limb_errors(m, d, targets, pos_f, rot_f, jacp, jacr)
        if it == _IK_MAX_ITER:
            break
        jd = jac[:, dofs]
        back = alg.diff(q, q_ref)[dofs]
        dq = np.linalg.solve(jd.T @ jd + lm, jd.T @ e + reg * back)
        step = np.abs(dq).max()
        if step > _IK_MAX_STEP:
            dq *= _IK_MAX_STEP / step
        v = np.zeros(m.nv)
        v[dofs] = dq
        q = alg.integrate(q, v)
        if step < _IK_STEP_TOL:
            break
    return q, it


def _limb_errors(m: mujoco.MjModel, d: mujoco.MjData, targets: list[tuple[str, int, int]],
                 pos_f: np.ndarray, rot_f: np.ndarray, jacp: np.ndarray,
                 jacr: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The weighted error rows ``(3 T,)`` of the ``targets`` in the current kinematics of
    ``d`` and their Jacobian ``(3 T, nv)``."""
    n_rows = 3 * len(targets)
    e = np.empty(n_rows)
    jac = np.empty((n_rows, m.nv))
    for k, (kind, body, j) in enumerate(targets):
        if kind == "mid":
            mujoco.mj_jacBody(m, d, jacp, None, body)
            e[3 * k: 3 * k + 3] = _IK_MID_WEIGHT * (pos_f[j] - d.xpos[body])
            jac[3 * k: 3 * k + 3] = _IK_MID_WEIGHT * jacp
        elif kind == "pos":
            mujoco.mj_jacBody(m, d, jacp, jacr, body)
            e[3 * k: 3 * k + 3] = pos_f[j] - d.xpos[body]
            jac[3 * k: 3 * k + 3] = jacp
        else:  # same body as the "pos" row before it: jacr is current
            err = quat_to_rotvec(quat_mul(rot_f[j], quat_conj(d.xquat[body])))
            e[3 * k: 3 * k + 3] = _IK_ROT_WEIGHT * err
            jac[3 * k: 3 * k + 3] = _IK_ROT_WEIGHT * jacr
    return e, jac
