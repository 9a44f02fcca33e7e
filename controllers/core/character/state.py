"""``character.state``: what the simulated character is doing now.

Generalised positions and velocities, the root's pose, the centre of mass and its velocity, the
world poses of bodies, joints and sites, and the whole simulation state as a vector to save and
restore (sampling methods). Everything describes the current state: the Character has run
``mj_step1`` on it (see :mod:`mjchar.controllers.core.character`).

The arrays (``qpos``, ``body_positions``, ...) are read-only views of the simulation's own
buffers, made once: they follow the simulation without a copy or a lookup per read. Index them
with the Character's lookups (``character.body_id``, ``character.site_id``, its joint and dof
indices); copy what must outlive the next step.
"""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import numpy as np

from .model import as_vector


def _read_only(a: np.ndarray) -> np.ndarray:
    v = a.view()
    v.flags.writeable = False
    return v


class State:
    """The current state of one character (built by the Character; see the module docstring).

    Attributes (read-only views, updated by every step):
        qpos: ``(nq,)`` generalised positions.
        qvel: ``(nv,)`` generalised velocities.
        body_positions: ``(nbody, 3)`` world positions of the body origins (m; a body origin
            is its BVH joint).
        body_rotations: ``(nbody, 3, 3)`` world rotation matrices of the bodies (columns: the
            body's x, y, z axes).
        body_quaternions: ``(nbody, 4)`` the same orientations as unit quaternions
            ``(w, x, y, z)``.
        body_angular_velocities: ``(nbody, 3)`` world angular velocities of the bodies (rad/s).
        subtree_coms: ``(nbody, 3)`` world centre of mass of each body's subtree (m).
        joint_axes: ``(njnt, 3)`` world axes of the MuJoCo joints (unit; hinges).
        joint_anchors: ``(njnt, 3)`` world positions of the MuJoCo joints' anchors (m).
        site_positions: ``(nsite, 3)`` world positions of the sites (m).
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, root_body: int,
                 joint_bodies: np.ndarray, restored: Callable[[], None]):
        self._model, self._data = model, data
        self._root = int(root_body)
        self._joint_bodies = joint_bodies
        self._restored = restored
        self._signature = int(mujoco.mjtState.mjSTATE_INTEGRATION)
        self._size = int(mujoco.mj_stateSize(model, self._signature))
        self._physics = int(mujoco.mjtState.mjSTATE_FULLPHYSICS)
        self._physics_size = int(mujoco.mj_stateSize(model, self._physics))
        self._jac = np.zeros((3, model.nv))
        d = data
        self.qpos = _read_only(d.qpos)
        self.qvel = _read_only(d.qvel)
        self.body_positions = _read_only(d.xpos)
        self.body_rotations = _read_only(d.xmat.reshape(-1, 3, 3))
        self.body_quaternions = _read_only(d.xquat)
        self.body_angular_velocities = _read_only(d.cvel[:, :3])
        self.subtree_coms = _read_only(d.subtree_com)
        self.joint_axes = _read_only(d.xaxis)
        self.joint_anchors = _read_only(d.xanchor)
        self.site_positions = _read_only(d.site_xpos)

    # -- the root -----------------------------------------------------------------------------
    @property
    def root_position(self) -> np.ndarray:
        """``(3,)`` world position of the root body's origin (m; a copy)."""
        return self.body_positions[self._root].copy()

    @property
    def root_rotation(self) -> np.ndarray:
        """``(3, 3)`` world rotation matrix of the root body (columns: its x, y, z axes; a
        copy)."""
        return self.body_rotations[self._root].copy()

    @property
    def root_height(self) -> float:
        """Height (m) of the root body's origin above the world plane z = 0."""
        return float(self.body_positions[self._root, 2])

    # -- centre of mass and joints ------------------------------------------------------------
    def com(self) -> np.ndarray:
        """``(3,)`` world centre of mass of the character (m)."""
        return self.subtree_coms[self._root].copy()

    def com_velocity(self) -> np.ndarray:
        """``(3,)`` centre-of-mass velocity in m/s (``J_com @ qvel``, ``mj_jacSubtreeCom``)."""
        mujoco.mj_jacSubtreeCom(self._model, self._data, self._jac, self._root)
        return self._jac @ self._data.qvel

    def joint_positions(self) -> np.ndarray:
        """``(J, 3)`` world positions of the BVH joints (body origins), in the Character's
        ``joint_names`` order (m; a copy)."""
        return self._data.xpos[self._joint_bodies]

    # -- the whole state ----------------------------------------------------------------------
    def get(self) -> np.ndarray:
        """The simulation state as a vector: ``mjSTATE_INTEGRATION`` (time, qpos, qvel, act,
        everything of ``mjSTATE_FULLPHYSICS``, plus controls, applied forces, ``eq_active`` and
        the solver warm start), so that :meth:`set` replays bit for bit.

        Pushes are scheduled by time and stay scheduled (``character.pushes``); restoring an
        earlier state replays them.
        """
        s = np.empty(self._size)
        mujoco.mj_getState(self._model, self._data, s, self._signature)
        return s

    def get_physics(self) -> np.ndarray:
        """The physical state only, ``mjSTATE_FULLPHYSICS`` (time, qpos, qvel, act, ...; no
        controls, applied forces or warm start): what a batched rollout
        (:mod:`mjchar.controllers.sampling.rollout`) starts from."""
        s = np.empty(self._physics_size)
        mujoco.mj_getState(self._model, self._data, s, self._physics)
        return s

    def clear_warm_start(self) -> None:
        """Zero the constraint solver's warm start (``qacc_warmstart``), as every batched
        rollout from :meth:`get_physics` starts: the next step then matches such a rollout."""
        self._data.qacc_warmstart[:] = 0.0

    def set(self, state: np.ndarray) -> None:
        """Restore a vector from :meth:`get` and recompute everything derived from it (the
        native PD set-points become the restored controls)."""
        state = as_vector(state, self._size, "state")
        mujoco.mj_setState(self._model, self._data, state, self._signature)
        self._restored()
