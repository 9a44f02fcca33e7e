"""Kinematic queries on a pose, computed on a scratch ``MjData`` so the simulation state is
untouched: the lowest point of the character's geoms, a body's world pose, and damped
least-squares inverse kinematics (``mj_jacBody``, ``mj_integratePos``)."""

from __future__ import annotations

import mujoco
import numpy as np

_GEOM_SPHERE = int(mujoco.mjtGeom.mjGEOM_SPHERE)
_GEOM_CAPSULE = int(mujoco.mjtGeom.mjGEOM_CAPSULE)
_GEOM_BOX = int(mujoco.mjtGeom.mjGEOM_BOX)


def lowest_point(model: mujoco.MjModel, qpos: np.ndarray, bodies: np.ndarray) -> float:
    """Lowest world z (m) of the geoms of ``bodies`` (ids) at pose ``qpos`` ``(nq,)``: boxes,
    capsules and spheres exactly, other shapes by their bounding sphere."""
    m = model
    scratch = mujoco.MjData(m)
    scratch.qpos[:] = qpos
    mujoco.mj_kinematics(m, scratch)
    geoms = np.flatnonzero(np.isin(m.geom_bodyid, bodies))
    z = []
    for g in geoms:
        c = scratch.geom_xpos[g]
        R = scratch.geom_xmat[g].reshape(3, 3)
        s = m.geom_size[g]
        t = m.geom_type[g]
        if t == _GEOM_BOX:
            z.append(c[2] - np.abs(R[2]) @ s)
        elif t == _GEOM_CAPSULE:
            z.append(c[2] - abs(R[2, 2]) * s[1] - s[0])
        elif t == _GEOM_SPHERE:
            z.append(c[2] - s[0])
        else:
            z.append(c[2] - m.geom_rbound[g])
    return float(min(z))


def body_pose(model: mujoco.MjModel, qpos: np.ndarray, body: int) -> tuple[np.ndarray, np.ndarray]:
    """World position ``(3,)`` and wxyz orientation ``(4,)`` of body id ``body`` at ``qpos``."""
    sd = mujoco.MjData(model)
    sd.qpos[:] = qpos
    mujoco.mj_kinematics(model, sd)
    return sd.xpos[body].copy(), sd.xquat[body].copy()


def solve_ik(model: mujoco.MjModel, qpos: np.ndarray, targets: list, dofs: np.ndarray, *,
             iterations: int = 100, damping: float = 1e-3, tol: float = 1e-11) -> np.ndarray:
    """Damped least-squares IK from ``qpos`` ``(nq,)``.

    Args:
        targets: list of ``(body id, position, quat)``: the body's world origin target ``(3,)``
            m (or ``None``) and world orientation target ``(4,)`` wxyz (or ``None``).
        dofs: ``(k,)`` dof indices allowed to move.
        iterations, damping, tol: DLS iterations, damping (m), squared-error tolerance.
    Returns:
        ``(nq,)`` the solved pose.
    """
    m = model
    sd = mujoco.MjData(m)
    sd.qpos[:] = qpos
    dofs = np.asarray(dofs, dtype=int)
    jacp = np.zeros((3, m.nv))
    jacr = np.zeros((3, m.nv))
    for _ in range(iterations):
        mujoco.mj_kinematics(m, sd)
        mujoco.mj_comPos(m, sd)
        rows, errs = [], []
        for b, pos, quat in targets:
            mujoco.mj_jacBody(m, sd, jacp, jacr, b)
            if pos is not None:
                rows.append(jacp[:, dofs].copy())
                errs.append(np.asarray(pos, float) - sd.xpos[b])
            if quat is not None:
                dq = np.empty(4)
                mujoco.mju_mulQuat(dq, np.asarray(quat, float),
                                   sd.xquat[b] * np.array([1.0, -1.0, -1.0, -1.0]))
                rv = np.empty(3)
                mujoco.mju_quat2Vel(rv, dq, 1.0)
                rows.append(jacr[:, dofs].copy())
                errs.append(rv)
        J = np.vstack(rows)
        e = np.concatenate(errs)
        if e @ e < tol:
            break
        dq = J.T @ np.linalg.solve(J @ J.T + damping ** 2 * np.eye(len(e)), e)
        v = np.zeros(m.nv)
        v[dofs] = dq
        mujoco.mj_integratePos(m, sd.qpos, v, 1.0)
    return sd.qpos.copy()
