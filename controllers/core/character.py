"""The simulated :class:`Character`: one converted humanoid (MjModel + MjData) behind named access.

Everything in :mod:`controllers` talks to MuJoCo through this class: controllers read the state
(joint angles, centre of mass, contacts, mass matrix, Jacobians) and hand back an
:class:`~mjchar.controllers.core.action.Action`; the Character turns it into actuator controls and
applied forces, steps the physics, applies scheduled pushes and watches for divergence.

It relies on the converted-model contract (``docs/model-contract.md``): bodies named like the BVH
joints, a free joint ``root``, one actuator per actuated dof, the ``mjchar`` metadata (joint map
and roles), the ``floor`` plane, foot boxes and the inactive ``root_weld`` equality.

Stepping uses MuJoCo's split step: after every :meth:`Character.step` (and after
:meth:`Character.reset` / :meth:`Character.set_state`) ``mj_step1`` has run on the current state,
so position- and velocity-dependent quantities (body poses, centre of mass, contacts, mass matrix,
bias forces) describe *now*; the next :meth:`Character.step` applies the controls and finishes
the step with ``mj_step2``. That costs the same as ``mj_step`` and is exact for the Euler and
implicit integrators.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import mujoco
import numpy as np

from . import poses
from .action import Action
from .errors import CharacterError, SimulationDiverged
from .geometry import convex_hull_2d
from .model import actuator_map, load_model, model_info, model_source
from .pushes import Push, PushSchedule

_GEOM_PLANE = int(mujoco.mjtGeom.mjGEOM_PLANE)
_GEOM_SPHERE = int(mujoco.mjtGeom.mjGEOM_SPHERE)
_GEOM_CAPSULE = int(mujoco.mjtGeom.mjGEOM_CAPSULE)
_GEOM_BOX = int(mujoco.mjtGeom.mjGEOM_BOX)
_JNT_FREE = int(mujoco.mjtJoint.mjJNT_FREE)
_JNT_BALL = int(mujoco.mjtJoint.mjJNT_BALL)
_JNT_HINGE = int(mujoco.mjtJoint.mjJNT_HINGE)
_JNT_SLIDE = int(mujoco.mjtJoint.mjJNT_SLIDE)
_BAD_STATE_WARNINGS = (
    int(mujoco.mjtWarning.mjWARN_BADCTRL),
    int(mujoco.mjtWarning.mjWARN_BADQPOS),
    int(mujoco.mjtWarning.mjWARN_BADQVEL),
    int(mujoco.mjtWarning.mjWARN_BADQACC),
)
#: actuation modes of :meth:`Character.set_actuation`
ACTUATION_MODES = ("native", "torque")


@dataclass(frozen=True)
class GroundContact:
    """One contact between the floor and a character geom.

    Attributes:
        body: name of the character body touching the floor.
        position: ``(3,)`` world contact point (m).
        distance: penetration distance (m, negative when penetrating).
    """

    body: str
    position: np.ndarray
    distance: float


class Character:
    """A converted humanoid in simulation.

    Args:
        model: ``None`` (the bundled humanoid, ``mjchar.bvh.bundled.assets.humanoid_path()``), an
            MJCF path, or an ``MjModel`` (copied: the Character edits its own model's actuator
            gains, time step and weld).
        info: the converter's ``ModelInfo``; read from the model's metadata when ``None``.
        timestep: physics time step in s (default: the model's).
        max_velocity: a generalised velocity above this (rad/s or m/s) counts as divergence.

    Attributes:
        model, data: the MuJoCo model and data.
        info: the joint map and roles (``ModelInfo``).
        nq, nv, nu: sizes of qpos, qvel and ctrl.
        root_body: body id of the root (the body carrying the free joint ``root``).
        root_dofs: ``(6,)`` dof indices of the free joint (x, y, z, then rotation in body frame).
        actuator_dof: ``(nu,)`` the dof each actuator drives.
        actuated: ``(nv,)`` bool, dofs driven by an actuator.
        mass: total mass in kg; model_timestep: the model's own time step (s).
        source: the MJCF path the model was loaded from (``None`` when given an ``MjModel``).
    """

    def __init__(self, model=None, *, info=None, timestep: float | None = None,
                 max_velocity: float = 200.0):
        self.model = load_model(model)
        self.source = model_source(model)
        self.data = mujoco.MjData(self.model)
        self.info = info if info is not None else model_info(self.model)
        m = self.model
        self.nq, self.nv, self.nu = int(m.nq), int(m.nv), int(m.nu)
        self.max_velocity, self.model_timestep = float(max_velocity), float(m.opt.timestep)

        rj = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "root")
        if rj < 0 or m.jnt_type[rj] != _JNT_FREE:
            raise CharacterError("model has no free joint named 'root' "
                                 "(see docs/model-contract.md)")
        self.root_body = int(m.jnt_bodyid[rj])
        self.root_dofs = np.arange(m.jnt_dofadr[rj], m.jnt_dofadr[rj] + 6)
        self.root_qpos = np.arange(m.jnt_qposadr[rj], m.jnt_qposadr[rj] + 7)
        self.mass = float(m.body_subtreemass[self.root_body])
        self.floor_geom = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "floor")
        if self.floor_geom < 0:
            planes = np.flatnonzero(m.geom_type == _GEOM_PLANE)
            if len(planes) == 0:
                raise CharacterError("model has no floor (a plane geom named 'floor')")
            self.floor_geom = int(planes[0])
        self._weld = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_EQUALITY, "root_weld")

        self._map_actuators()
        self._map_joints()
        self._native_gainprm = m.actuator_gainprm.copy()
        self._native_biasprm = m.actuator_biasprm.copy()
        self._native_ctrlrange = m.actuator_ctrlrange.copy()
        self._native_ctrllimited = m.actuator_ctrllimited.copy()
        self._native_forcelimited = m.actuator_forcelimited.copy()
        self._torque_limited = True
        self._mode = "native"
        self._native_target = np.zeros(self.nu)  # native set-points before any feed-forward
        self._table = self.native_gains()
        self._pushes = PushSchedule(self.data)
        self._root_wrench = np.zeros(6)
        self._state_sig = int(mujoco.mjtState.mjSTATE_INTEGRATION)
        self._warn_idx = np.array(_BAD_STATE_WARNINGS)
        self._warn_before = 0
        self._jac = np.zeros((3, self.nv))
        self._M = np.zeros((self.nv, self.nv))
        self._scratch = mujoco.MjData(m)
        self._M_diag = m.M_rowadr + m.M_rownnz - 1  # diagonal entries of the CSR mass matrix
        self.timestep_chosen = False  # set_timestep's ``chosen``: make_controller keeps it
        if timestep is not None:
            self.set_timestep(timestep)
        self.reset()

    # -- structure ----------------------------------------------------------------------------
    def _map_actuators(self) -> None:
        m = self.model
        self.actuator_dof, self.actuator_qpos = actuator_map(m)
        self.actuated = np.zeros(self.nv, dtype=bool)
        self.actuated[self.actuator_dof] = True
        self.unactuated = np.flatnonzero(~self.actuated)
        self.position_actuators = m.actuator_biasprm[:, 1] < 0  # bias -kp q: <position>

    def _map_joints(self) -> None:
        m = self.model
        self.joint_names = list(self.info.joints)
        self._joint_dofs: dict[str, np.ndarray] = {}
        self._joint_qpos: dict[str, np.ndarray] = {}
        self._joint_body: dict[str, int] = {}
        for name, ji in self.info.joints.items():
            b = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, ji.body)
            if b < 0:
                raise CharacterError(f"metadata names body {ji.body!r} (joint {name!r}) that the "
                                     f"model does not have")
            self._joint_body[name] = b
            dofs, qps = [], []
            for jn in ji.mj_joints:
                j = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, jn)
                if j < 0:
                    raise CharacterError(f"metadata names MuJoCo joint {jn!r} that the model lacks")
                nd = {_JNT_FREE: 6, _JNT_BALL: 3}.get(int(m.jnt_type[j]), 1)
                nqj = {_JNT_FREE: 7, _JNT_BALL: 4}.get(int(m.jnt_type[j]), 1)
                dofs.extend(range(m.jnt_dofadr[j], m.jnt_dofadr[j] + nd))
                qps.extend(range(m.jnt_qposadr[j], m.jnt_qposadr[j] + nqj))
            self._joint_dofs[name] = np.array(dofs, dtype=int)
            self._joint_qpos[name] = np.array(qps, dtype=int)
        self.joint_bodies = np.array([self._joint_body[n] for n in self.joint_names], dtype=int)
        names = []
        for d in range(self.nv):
            j = int(m.dof_jntid[d])
            jn = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint{j}"
            k = d - int(m.jnt_dofadr[j])
            if m.jnt_type[j] == _JNT_FREE:
                names.append(f"{jn}_{('x', 'y', 'z', 'rx', 'ry', 'rz')[k]}")
            elif m.jnt_type[j] == _JNT_BALL:
                names.append(f"{jn}_{'xyz'[k]}")
            else:
                names.append(jn)
        self.dof_names = names
        feet = []
        for side in ("left", "right"):
            for part in ("ankle", "toe"):
                j = self.role(f"{side}_{part}", required=False)
                if j is not None:
                    feet.append(self._joint_body[j])
        if not feet:  # contract fallback: foot geoms are the boxes
            feet = sorted({int(m.geom_bodyid[g]) for g in np.flatnonzero(m.geom_type == _GEOM_BOX)})
        self.foot_bodies = np.array(sorted(set(feet)), dtype=int)
        self._is_foot = np.zeros(m.nbody, dtype=bool)
        self._is_foot[self.foot_bodies] = True
        self._side_of_body = np.full(m.nbody, -1)
        for s, side in enumerate(("left", "right")):
            for part in ("ankle", "toe"):
                j = self.role(f"{side}_{part}", required=False)
                if j is not None:
                    self._side_of_body[self._joint_body[j]] = s
        self._geom_body = m.geom_bodyid.astype(int)
        self._geom_side = self._side_of_body[self._geom_body]
        # bodies of the character: the root's subtree
        self.character_bodies = np.flatnonzero(
            [self._is_descendant(b, self.root_body) for b in range(m.nbody)])

    def _is_descendant(self, b: int, ancestor: int) -> bool:
        while b > 0:
            if b == ancestor:
                return True
            b = int(self.model.body_parentid[b])
        return ancestor == 0

    def role(self, role: str, *, required: bool = True) -> str | None:
        """BVH joint name that plays ``role`` (``"pelvis"``, ``"left_knee"``, ...).

        For ``"spine"`` (a list in the metadata) the first spine joint is returned; use
        :meth:`roles` for all of them. Raises :class:`CharacterError` if absent and ``required``.
        """
        r = self.info.roles.get(role)
        if isinstance(r, (list, tuple)):
            r = r[0] if r else None
        if r is None and required:
            raise CharacterError(f"model has no joint with role {role!r}; roles: "
                                 f"{sorted(self.info.roles)}")
        return r

    def roles(self, role: str) -> list[str]:
        """All BVH joint names with ``role`` (a list; empty when the role is absent)."""
        r = self.info.roles.get(role)
        if r is None:
            return []
        return list(r) if isinstance(r, (list, tuple)) else [r]

    def _check_joint(self, name: str) -> None:
        if name not in self._joint_dofs:
            raise CharacterError(f"unknown joint {name!r}; the model's joints are "
                                 f"{', '.join(self.joint_names)}")

    def joint_dofs(self, name: str) -> np.ndarray:
        """Dof indices (into qvel / qfrc) of BVH joint ``name``: ``(k,)`` int."""
        self._check_joint(name)
        return self._joint_dofs[name]

    def joint_qpos(self, name: str) -> np.ndarray:
        """qpos indices of BVH joint ``name``: ``(k,)`` int."""
        self._check_joint(name)
        return self._joint_qpos[name]

    def dofs(self, names: Iterable[str]) -> np.ndarray:
        """Concatenated dof indices of several BVH joints (or roles): ``(k,)`` int."""
        out = []
        for n in names:
            if n not in self._joint_dofs and n in self.info.roles:
                out.extend(self.dofs(self.roles(n)))
            else:
                out.extend(self.joint_dofs(n).tolist())
        return np.array(out, dtype=int)

    def body_id(self, name: str) -> int:
        """MuJoCo body id of a body (BVH joint names are body names)."""
        if name in self._joint_body:
            return self._joint_body[name]
        b = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, name)
        if b < 0:
            raise CharacterError(f"unknown body {name!r}; the model's joints are "
                                 f"{', '.join(self.joint_names)}")
        return b

    def site_id(self, name: str) -> int:
        """MuJoCo site id of a site (``head``, ``left_foot``, ...); unknown names raise."""
        s = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SITE, name)
        if s < 0:
            raise CharacterError(f"unknown site {name!r}")
        return s

    # -- state --------------------------------------------------------------------------------
    @property
    def time(self) -> float:
        """Simulated time in s."""
        return float(self.data.time)

    @property
    def timestep(self) -> float:
        """Physics time step in s."""
        return float(self.model.opt.timestep)

    @property
    def qpos(self) -> np.ndarray:
        """``(nq,)`` generalised positions (a view: do not write; use :meth:`set_state`)."""
        return self.data.qpos

    @property
    def qvel(self) -> np.ndarray:
        """``(nv,)`` generalised velocities (a view)."""
        return self.data.qvel

    @property
    def root_position(self) -> np.ndarray:
        """``(3,)`` world position of the root body's origin (m)."""
        return self.data.xpos[self.root_body].copy()

    @property
    def root_quat(self) -> np.ndarray:
        """``(4,)`` wxyz world orientation of the root body."""
        return self.data.xquat[self.root_body].copy()

    @property
    def root_rotation(self) -> np.ndarray:
        """``(3, 3)`` world rotation matrix of the root body (columns: its x, y, z axes)."""
        return self.data.xmat[self.root_body].reshape(3, 3).copy()

    @property
    def root_height(self) -> float:
        """Height (m) of the root body's origin above the floor plane z = 0."""
        return float(self.data.xpos[self.root_body, 2])

    def body_position(self, name: str) -> np.ndarray:
        """``(3,)`` world position of a body's origin (= its BVH joint) in m."""
        return self.data.xpos[self.body_id(name)].copy()

    def joint_positions(self) -> np.ndarray:
        """``(J, 3)`` world positions of the BVH joints (body origins), in ``joint_names`` order."""
        return self.data.xpos[self.joint_bodies].copy()

    def site_position(self, name: str) -> np.ndarray:
        """``(3,)`` world position of a site (``left_foot``, ``head``, ...)."""
        return self.data.site_xpos[self.site_id(name)].copy()

    def reset(self, qpos: np.ndarray | None = None, qvel: np.ndarray | None = None) -> None:
        """Reset time to 0, clear pushes and applied forces, release the root weld, and set the
        state (default: qpos0 at rest).

        ``qpos``: ``(nq,)``; ``qvel``: ``(nv,)`` (zeros when ``None``).
        """
        mujoco.mj_resetData(self.model, self.data)
        self._native_target[:] = 0
        if qpos is not None:
            self.data.qpos[:] = self._vec(qpos, self.nq, "qpos")
        if qvel is not None:
            self.data.qvel[:] = self._vec(qvel, self.nv, "qvel")
        self._pushes.clear()
        self._root_wrench[:] = 0
        self._refresh()

    def _vec(self, x, n: int, what: str) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        if x.shape != (n,):
            raise CharacterError(f"{what} must have shape ({n},), got {x.shape}")
        return x

    def get_state(self) -> np.ndarray:
        """The simulation state as a vector: ``mjSTATE_INTEGRATION`` (time, qpos, qvel, act,
        everything of ``mjSTATE_FULLPHYSICS``, plus controls, applied forces, ``eq_active`` and
        the solver warm start), so that :meth:`set_state` replays bit for bit.

        Pushes are scheduled by time and stay in :attr:`pushes`; restoring an earlier state
        replays them.
        """
        s = np.empty(mujoco.mj_stateSize(self.model, self._state_sig))
        mujoco.mj_getState(self.model, self.data, s, self._state_sig)
        return s

    def set_state(self, state: np.ndarray) -> None:
        """Restore a vector from :meth:`get_state` and recompute everything derived from it."""
        state = self._vec(state, mujoco.mj_stateSize(self.model, self._state_sig), "state")
        mujoco.mj_setState(self.model, self.data, state, self._state_sig)
        self._native_target[:] = self.data.ctrl
        self._refresh()

    def _refresh(self, check: bool = True) -> None:
        """Recompute position/velocity-dependent quantities for the current state (mj_step1)."""
        self._warn_before = int(self.data.warning.number[self._warn_idx].sum())
        mujoco.mj_step1(self.model, self.data)
        if check:
            self._check()

    # -- model settings -----------------------------------------------------------------------
    def set_timestep(self, dt: float, *, chosen: bool = True) -> None:
        """Set the physics time step (s); ``chosen``: a choice for this character that
        :func:`~mjchar.controllers.core.registry.make_controller` keeps (``False``: a
        controller's own step, applied by it)."""
        if not (math.isfinite(dt) and dt > 0):
            raise CharacterError(f"time step must be a positive number of seconds, got {dt}")
        self.model.opt.timestep = float(dt)
        self.timestep_chosen = chosen

    @property
    def actuation(self) -> str:
        """``"native"`` (MuJoCo position actuators apply PD) or ``"torque"`` (ctrl = N m)."""
        return self._mode

    @property
    def torque_limited(self) -> bool:
        """Whether actuator torques are clamped to the model's limits (``forcerange``)."""
        return self._torque_limited

    def set_torque_limits(self, enabled: bool) -> None:
        """Clamp actuator torques to the model's ``forcerange`` (default) or lift the clamp
        (for stability studies: MuJoCo drops the implicit damping of a clamped actuator)."""
        self._torque_limited = bool(enabled)
        self.model.actuator_forcelimited[:] = self._native_forcelimited if enabled else 0
        self.set_actuation(self._mode)

    def set_actuation(self, mode: str) -> None:
        """Switch every actuator between native PD and torque control (contract, "Actuation").

        Torque mode rewrites ``actuator_gainprm``/``biasprm`` to gain 1, bias 0 and widens the
        control range to the force range, so ``ctrl`` is a torque in N m clamped to the torque
        limit. Native mode restores the position actuators' ``kp``/``kv`` (motors on ball joints
        stay torque-controlled).
        """
        if mode not in ACTUATION_MODES:
            raise CharacterError(f"actuation must be one of {ACTUATION_MODES}, got {mode!r}")
        m = self.model
        if mode == "torque":
            m.actuator_gainprm[:] = 0
            m.actuator_gainprm[:, 0] = 1
            m.actuator_biasprm[:] = 0
            lim = m.actuator_forcelimited.astype(bool)
            m.actuator_ctrlrange[:] = np.where(lim[:, None], m.actuator_forcerange, 0)
            m.actuator_ctrllimited[:] = lim
        else:
            m.actuator_gainprm[:] = self._native_gainprm
            m.actuator_biasprm[:] = self._native_biasprm
            m.actuator_ctrlrange[:] = self._native_ctrlrange
            m.actuator_ctrllimited[:] = self._native_ctrllimited
        self.data.ctrl[:] = 0
        self._native_target[:] = 0
        self._mode = mode

    def native_gains(self) -> tuple[np.ndarray, np.ndarray]:
        """``(kp, kd)``, each ``(nv,)``: the native PD gains per dof (N m/rad, N m s/rad).

        Zero on unactuated dofs (the root) and on dofs driven by motors.
        """
        kp = np.zeros(self.nv)
        kd = np.zeros(self.nv)
        pa = self.position_actuators
        kp[self.actuator_dof[pa]] = self._native_gainprm[pa, 0]
        kd[self.actuator_dof[pa]] = -self._native_biasprm[pa, 2]
        return kp, kd

    def default_gains(self) -> tuple[np.ndarray, np.ndarray]:
        """``(kp, kd)``, each ``(nv,)``: the model's own gains table (as loaded, before any
        :meth:`set_native_gains`)."""
        return self._table[0].copy(), self._table[1].copy()

    def set_native_gains(self, kp: np.ndarray, kd: np.ndarray) -> None:
        """Set the position actuators' ``kp``/``kv`` from per-dof gains ``(nv,)`` each."""
        kp = self._vec(kp, self.nv, "kp")
        kd = self._vec(kd, self.nv, "kd")
        pa = self.position_actuators
        d = self.actuator_dof[pa]
        self._native_gainprm[pa, 0] = kp[d]
        self._native_biasprm[pa, 1] = -kp[d]
        self._native_biasprm[pa, 2] = -kd[d]
        if self._mode == "native":
            self.model.actuator_gainprm[pa] = self._native_gainprm[pa]
            self.model.actuator_biasprm[pa] = self._native_biasprm[pa]

    def torque_limits(self) -> np.ndarray:
        """``(nv,)`` torque limit per dof in N m (inf where unlimited or unactuated)."""
        lim = np.full(self.nv, np.inf)
        m = self.model
        fl = m.actuator_forcelimited.astype(bool)
        lim[self.actuator_dof[fl]] = np.abs(m.actuator_forcerange[fl]).max(axis=1)
        return lim

    def weld_root(self, active: bool = True) -> None:
        """Hold the root body fixed to the world where it is now (``root_weld``), or release it."""
        if self._weld < 0:
            raise CharacterError("model has no equality constraint named 'root_weld'")
        if active:
            # weld data: anchor on body2 (the world), pose of body2 relative to body1
            q = self.data.xquat[self.root_body]
            self.model.eq_data[self._weld, 0:3] = self.data.xpos[self.root_body]
            self.model.eq_data[self._weld, 3:6] = 0.0
            self.model.eq_data[self._weld, 6:10] = q * np.array([1.0, -1.0, -1.0, -1.0])
        self.data.eq_active[self._weld] = 1 if active else 0
        self._refresh(check=False)

    @property
    def root_welded(self) -> bool:
        """Whether the ``root_weld`` equality is active."""
        return self._weld >= 0 and bool(self.data.eq_active[self._weld])

    # -- dynamics quantities ------------------------------------------------------------------
    def com(self) -> np.ndarray:
        """``(3,)`` world centre of mass of the character (m)."""
        return self.data.subtree_com[self.root_body].copy()

    def com_jacobian(self) -> np.ndarray:
        """``(3, nv)`` Jacobian of the centre of mass (``mj_jacSubtreeCom`` on the root body)."""
        mujoco.mj_jacSubtreeCom(self.model, self.data, self._jac, self.root_body)
        return self._jac.copy()

    def com_velocity(self) -> np.ndarray:
        """``(3,)`` centre-of-mass velocity in m/s (``J_com @ qvel``)."""
        mujoco.mj_jacSubtreeCom(self.model, self.data, self._jac, self.root_body)
        return self._jac @ self.data.qvel

    def point_jacobian(self, body: str | int, point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Jacobians ``(jacp, jacr)``, each ``(3, nv)``, of a world ``point`` (m) fixed to
        ``body``."""
        b = body if isinstance(body, (int, np.integer)) else self.body_id(body)
        jacp = np.zeros((3, self.nv))
        jacr = np.zeros((3, self.nv))
        mujoco.mj_jac(self.model, self.data, jacp, jacr, np.asarray(point, dtype=float), int(b))
        return jacp, jacr

    def mass_matrix(self) -> np.ndarray:
        """``(nv, nv)`` joint-space inertia matrix M(q) (``mj_fullM``; includes armature)."""
        mujoco.mj_fullM(self.model, self.data, self._M)
        return self._M.copy()

    def solve_mass(self, rhs: np.ndarray, diagonal: np.ndarray | None = None) -> np.ndarray:
        """``(nv,)`` solution ``x`` of ``(M(q) + diag(diagonal)) x = rhs`` for ``rhs`` ``(nv,)``.

        Uses MuJoCo's sparse ``L^T D L`` factorisation of the tree-structured mass matrix on a
        scratch copy (``mj_factorM``/``mj_solveM``), a few microseconds for a humanoid.
        """
        sd = self._scratch
        sd.M[:] = self.data.M
        if diagonal is not None:
            sd.M[self._M_diag] += diagonal
        mujoco.mj_factorM(self.model, sd)
        x = np.empty((1, self.nv))
        mujoco.mj_solveM(self.model, sd, x, np.ascontiguousarray(rhs, dtype=float).reshape(1, -1))
        return x[0]

    def bias_forces(self) -> np.ndarray:
        """``(nv,)`` Coriolis, centrifugal and gravity forces C(q, qdot) (``qfrc_bias``)."""
        return self.data.qfrc_bias.copy()

    def passive_forces(self) -> np.ndarray:
        """``(nv,)`` passive forces (joint damping, springs) at the current state."""
        return self.data.qfrc_passive.copy()

    def constraint_forces(self) -> np.ndarray:
        """``(nv,)`` contact/limit/equality forces of the last completed step (one step old)."""
        return self.data.qfrc_constraint.copy()

    def integrate(self, qpos: np.ndarray, qvel: np.ndarray, dt: float) -> np.ndarray:
        """``(nq,)`` ``qpos`` moved by velocity ``qvel`` ``(nv,)`` for ``dt`` s
        (quaternion-aware, ``mj_integratePos``)."""
        q = np.array(qpos, dtype=float)
        mujoco.mj_integratePos(self.model, q, np.asarray(qvel, dtype=float), float(dt))
        return q

    def difference(self, qpos1: np.ndarray, qpos2: np.ndarray) -> np.ndarray:
        """``(nv,)`` joint-space difference ``qpos2 - qpos1`` (``mj_differentiatePos`` with dt=1).

        Hinges: angle difference; ball and free-joint rotations: the rotation vector of
        ``q1^-1 q2`` in the child frame; free-joint translation: world difference.
        """
        v = np.empty(self.nv)
        mujoco.mj_differentiatePos(self.model, v, 1.0, np.asarray(qpos1, dtype=float),
                                   np.asarray(qpos2, dtype=float))
        return v

    def root_wrench_to_qfrc(self, force: np.ndarray, torque: np.ndarray) -> np.ndarray:
        """``(6,)`` free-joint generalised force for a world ``force`` (N, at the root origin) and
        world ``torque`` (N m): the rotational rows are in the root body frame."""
        R = self.root_rotation
        return np.concatenate([np.asarray(force, dtype=float), R.T @ np.asarray(torque, float)])

    @property
    def root_wrench(self) -> np.ndarray:
        """``(6,)`` world force (N) and torque (N m) the last action applied to the root from
        outside (the "hand of god"); zeros for controllers that need none."""
        return self._root_wrench.copy()

    # -- contacts -----------------------------------------------------------------------------
    def ground_contacts(self) -> list[GroundContact]:
        """Every contact between the floor and the character (list of :class:`GroundContact`)."""
        out = []
        for b, p, d in zip(*self._floor_contacts(), strict=True):
            out.append(GroundContact(mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_BODY, b)
                                     or str(b), p, float(d)))
        return out

    def _floor_geoms(self) -> tuple[np.ndarray, np.ndarray]:
        """(character geoms touching the floor (k,), their contact indices (k,))."""
        n = self.data.ncon
        if n == 0:
            return np.zeros(0, int), np.zeros(0, int)
        g = self.data.contact.geom[:n]
        g0, g1 = g[:, 0], g[:, 1]
        f = self.floor_geom
        other = np.where(g0 == f, g1, np.where(g1 == f, g0, -1))
        idx = np.flatnonzero(other >= 0)
        return other[idx], idx

    def _floor_contacts(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(bodies (k,), positions (k, 3), distances (k,)) of floor contacts."""
        geoms, idx = self._floor_geoms()
        if len(idx) == 0:
            return np.zeros(0, int), np.zeros((0, 3)), np.zeros(0)
        c = self.data.contact
        return (self.model.geom_bodyid[geoms].astype(int), c.pos[idx].copy(),
                c.dist[idx].copy())

    def foot_contacts(self) -> tuple[bool, bool]:
        """``(left, right)``: whether each foot (ankle or toe body) touches the floor."""
        geoms, _ = self._floor_geoms()
        sides = self._geom_side[geoms].tolist()
        return 0 in sides, 1 in sides

    def non_foot_ground_contact(self) -> list[str]:
        """Names of character bodies other than the feet that touch the floor (a fall)."""
        geoms, _ = self._floor_geoms()
        bodies = self._geom_body[geoms]
        bad = sorted(set(bodies[~self._is_foot[bodies]].tolist()))
        return [mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_BODY, b) or str(b)
                for b in bad]

    def support_polygon(self) -> np.ndarray:
        """``(K, 2)`` counter-clockwise convex hull of the feet's floor contact points (x, y, m).

        Empty ``(0, 2)`` when no foot touches the floor; fewer than 3 rows when the contacts are
        a point or a segment.
        """
        bodies, pos, _ = self._floor_contacts()
        return convex_hull_2d(pos[self._is_foot[bodies], :2])

    def foot_sites(self) -> tuple[np.ndarray, np.ndarray]:
        """World positions ``(3,)`` of the ``left_foot`` and ``right_foot`` sites (sole centres)."""
        return self.site_position("left_foot"), self.site_position("right_foot")

    # -- pushes -------------------------------------------------------------------------------
    def push(self, body: str, force, duration: float, start: float | None = None) -> Push:
        """Schedule a force ``(3,)`` N (world frame) on ``body`` for ``duration`` s from ``start``
        (default: now). Applied at the body's centre of mass via ``xfrc_applied``."""
        return self._pushes.add(body, self.body_id(body), force, duration,
                                self.time if start is None else start)

    @property
    def pushes(self) -> list[Push]:
        """The scheduled pushes (:class:`~mjchar.controllers.core.pushes.Push`), in order."""
        return self._pushes.pushes

    def active_push_force(self) -> np.ndarray:
        """``(3,)`` sum of the push forces (N) applied during the last step."""
        return self.data.xfrc_applied[:, :3].sum(axis=0)

    # -- stepping -----------------------------------------------------------------------------
    def apply(self, action: Action | None) -> None:
        """Write an action into the controls.

        ``action.torque`` ``(nv,)``: actuated rows become actuator controls in torque mode, or a
        feed-forward on top of the PD in native mode (folded into the position actuators'
        set-points, ``u + tau / kp``, so that MuJoCo clamps the joint's total torque to its
        ``forcerange``); either way the applied joint torque never exceeds the model's limit
        (unless :meth:`set_torque_limits` lifted it). Unactuated rows (the root's 6) are applied
        as an external generalised force (the hand of god).
        ``action.target`` ``(nu,)``: native PD set-points (only in native mode).
        A non-finite torque or target raises :class:`SimulationDiverged`.
        """
        d = self.data
        d.qfrc_applied[:] = 0
        self._root_wrench[:] = 0
        if action is None:
            d.ctrl[:] = 0 if self._mode == "torque" else self._native_target
            return
        tau = action.torque
        if tau is not None:
            if tau.shape != (self.nv,):
                raise CharacterError(f"action torque must have shape ({self.nv},), got {tau.shape}")
            if not np.isfinite(tau).all():
                raise SimulationDiverged("the controller produced a non-finite torque", d.time)
            d.qfrc_applied[self.unactuated] = tau[self.unactuated]
            rw = tau[self.root_dofs]
            if rw.any():
                R = d.xmat[self.root_body].reshape(3, 3)
                self._root_wrench[:3] = rw[:3]
                self._root_wrench[3:] = R @ rw[3:]
        if self._mode == "torque":
            if action.target is not None:
                raise CharacterError("PD targets given while the actuators are in torque mode")
            d.ctrl[:] = 0 if tau is None else tau[self.actuator_dof]
            return
        if action.target is not None:
            if action.target.shape != (self.nu,):
                raise CharacterError(f"action target must have shape ({self.nu},), got "
                                     f"{action.target.shape}")
            if not np.isfinite(action.target).all():
                raise SimulationDiverged("the controller produced a non-finite target", d.time)
            self._native_target[:] = action.target
        d.ctrl[:] = self._native_target
        if tau is not None and tau[self.actuator_dof].any():
            self._add_feedforward(tau[self.actuator_dof])

    def _add_feedforward(self, ff: np.ndarray) -> None:
        """Native mode: add the ``(nu,)`` feed-forward torques ``ff`` (N m) through the actuators
        (position actuators: ``ctrl += ff / kp``; motors: ``ctrl += ff``), so the actuator's
        force range clamps PD and feed-forward together. Position actuators without stiffness
        cannot carry it: there it is applied directly, clipped to the torque limit."""
        gain = self.model.actuator_gainprm[:, 0]
        direct = self.position_actuators & (gain <= 0)
        carried = ~direct
        self.data.ctrl[carried] += ff[carried] / gain[carried]
        if direct.any():
            lim = self.torque_limits()[self.actuator_dof[direct]] if self._torque_limited \
                else np.inf
            self.data.qfrc_applied[self.actuator_dof[direct]] += np.clip(ff[direct], -lim, lim)

    def step(self, action: Action | None = None, n: int = 1) -> None:
        """Apply ``action`` (held for all ``n`` physics steps) and advance ``n`` steps.

        Raises :class:`SimulationDiverged` when the state becomes non-finite or a velocity
        exceeds ``max_velocity`` (also when MuJoCo had to reset a bad state).
        """
        if action is not None:
            self.apply(action)
        m, d = self.model, self.data
        self._warn_before = int(d.warning.number[self._warn_idx].sum())
        pushes = self._pushes
        if pushes.pushes or pushes.applied:
            t_end = d.time + (n + 1) * m.opt.timestep
            if pushes.applied or pushes.any_between(d.time, t_end):
                pushes.apply(d.time + 0.5 * m.opt.timestep)  # the step's midpoint decides
                mujoco.mj_step2(m, d)
                for _ in range(n - 1):
                    pushes.apply(d.time + 0.5 * m.opt.timestep)
                    mujoco.mj_step(m, d)
                mujoco.mj_step1(m, d)
                self._check()
                return
        mujoco.mj_step2(m, d)
        if n > 1:
            mujoco.mj_step(m, d, n - 1)
        mujoco.mj_step1(m, d)
        self._check()

    def _check(self) -> None:
        d = self.data
        if int(d.warning.number[self._warn_idx].sum()) != self._warn_before:
            names = [mujoco.mjtWarning(w).name for w in _BAD_STATE_WARNINGS]
            raise SimulationDiverged(f"MuJoCo reset a bad state (one of {', '.join(names)})",
                                     d.time)
        vmax = np.abs(d.qvel).max() if self.nv else 0.0
        if not vmax <= self.max_velocity:  # also catches NaN
            if not np.isfinite(vmax):
                raise SimulationDiverged("non-finite velocity", d.time)
            dof = int(np.argmax(np.abs(d.qvel)))
            raise SimulationDiverged(f"velocity {vmax:.3g} at dof {self.dof_names[dof]} exceeds "
                                     f"{self.max_velocity:g}", d.time)

    # -- poses ---------------------------------------------------------------------------------
    def leg_length(self) -> float:
        """The leg length (m): the hips' mean height over the character's lowest point at rest
        (``qpos0``, every joint at zero). Walkers scale their gaits and speeds with it (equal
        Froude speed ``v / sqrt(g L)`` on every body)."""
        q = self.model.qpos0
        hips = [poses.body_pose(self.model, q, self.body_id(self.role(f"{side}_hip")))[0][2]
                for side in ("left", "right")]
        return float(np.mean(hips)) - self.lowest_point(q)

    def lowest_point(self, qpos: np.ndarray) -> float:
        """Lowest world z (m) of the character's geoms at pose ``qpos`` ``(nq,)`` (boxes, capsules,
        spheres exactly; other shapes by their bounding sphere). Does not change the state."""
        return poses.lowest_point(self.model, self._vec(qpos, self.nq, "qpos"),
                                  self.character_bodies)

    def body_pose(self, qpos: np.ndarray, body: str | int) -> tuple[np.ndarray, np.ndarray]:
        """World position ``(3,)`` and wxyz orientation ``(4,)`` of ``body`` at pose ``qpos``
        ``(nq,)`` (forward kinematics on a scratch copy; the state is untouched)."""
        b = self.body_id(body) if isinstance(body, str) else int(body)
        return poses.body_pose(self.model, self._vec(qpos, self.nq, "qpos"), b)

    def solve_ik(self, qpos: np.ndarray, targets: list, dofs: np.ndarray, *,
                 iterations: int = 100, damping: float = 1e-3, tol: float = 1e-11) -> np.ndarray:
        """Damped least-squares IK on a scratch copy of the kinematics (the state is untouched):
        :func:`mjchar.controllers.core.poses.solve_ik` with body names resolved.

        Args:
            qpos: ``(nq,)`` starting pose.
            targets: list of ``(body, position, quat)``: a body name, its world origin target
                ``(3,)`` m (or ``None``) and world orientation target ``(4,)`` wxyz (or ``None``).
            dofs: ``(k,)`` dof indices allowed to move.
            iterations, damping, tol: DLS iterations, damping (m), squared-error tolerance.
        Returns:
            ``(nq,)`` the solved pose.
        """
        ids = [(self.body_id(b) if isinstance(b, str) else int(b), pos, quat)
               for b, pos, quat in targets]
        return poses.solve_ik(self.model, self._vec(qpos, self.nq, "qpos"), ids, dofs,
                              iterations=iterations, damping=damping, tol=tol)

    def on_floor(self, qpos: np.ndarray, clearance: float = 0.0) -> np.ndarray:
        """``(nq,)`` copy of ``qpos`` with the root raised/lowered so the lowest geom point is
        ``clearance`` m above the floor."""
        q = np.array(self._vec(qpos, self.nq, "qpos"))
        q[self.root_qpos[2]] += clearance - self.lowest_point(q)
        return q
