"""The simulated :class:`Character`: one converted humanoid (MjModel + MjData) behind named access,
and the parts a controller uses.

Everything in :mod:`controllers` talks to MuJoCo through a Character. The Character itself owns
the model and its data, the names and indices (roles, BVH joints and their dofs and qpos, bodies,
sites, actuators), the time step, :meth:`~Character.reset` and :meth:`~Character.step`; the rest
is in its parts, one concern each:

- ``character.state`` (:class:`~.state.State`): qpos, qvel, the root's pose, centre of mass and
  its velocity, world frames of bodies, joints and sites, the whole state to save and restore.
- ``character.dynamics`` (:class:`~.dynamics.Dynamics`): mass matrix and solves with it, bias,
  passive and constraint forces, point and centre-of-mass Jacobians, masses and gravity, joint-
  space integration and differences.
- ``character.contacts`` (:class:`~.contacts.Contacts`): the floor and what touches it: ground
  and foot contacts, foot normal forces, support polygon, sole sites, the floor's plane.
- ``character.actuation`` (:class:`~.actuation.Actuation`): native PD or torque control, gains,
  torque limits, applying an :class:`~mjchar.controllers.core.action.Action` (feed-forward, the
  root wrench), the root weld.
- ``character.pushes`` (:class:`~.pushes.PushSchedule`): external forces scheduled by time.
- ``character.poses`` (:class:`~.poses.Poses`): kinematics on a pose other than the current one
  (rest and standing poses, leg length, lowest point, world frames, IK), on a scratch copy.

It relies on the converted-model contract (``docs/model-contract.md``): bodies named like the BVH
joints, a free joint ``root``, one actuator per actuated dof, the ``mjchar`` metadata (joint map
and roles), the ``floor`` plane, foot boxes and the inactive ``root_weld`` equality.

Stepping uses MuJoCo's split step: after every :meth:`Character.step` (and after
:meth:`Character.reset` / ``state.set``) ``mj_step1`` has run on the current state, so position-
and velocity-dependent quantities (body poses, centre of mass, contacts, mass matrix, bias
forces) describe *now*; the next :meth:`Character.step` applies the controls and finishes the
step with ``mj_step2``. That costs the same as ``mj_step`` and is exact for the Euler and
implicit integrators.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import mujoco
import numpy as np

from mjchar.bvh.errors import name_list

from ..action import Action
from ..errors import CharacterError, SimulationDiverged
from .actuation import ACTUATION_MODES, Actuation
from .contacts import Contacts, GroundContact
from .dynamics import Dynamics
from .model import actuator_map, as_vector, load_model, model_info, model_source
from .poses import Kinematics, Poses
from .pushes import Push, PushSchedule
from .state import State

__all__ = ["ACTUATION_MODES", "Actuation", "Character", "CharacterError", "Contacts", "Dynamics",
           "GroundContact", "Kinematics", "Poses", "Push", "PushSchedule", "SimulationDiverged",
           "State"]

_GEOM_PLANE = int(mujoco.mjtGeom.mjGEOM_PLANE)
_GEOM_BOX = int(mujoco.mjtGeom.mjGEOM_BOX)
_JNT_FREE = int(mujoco.mjtJoint.mjJNT_FREE)
_JNT_BALL = int(mujoco.mjtJoint.mjJNT_BALL)
_JNT_HINGE = int(mujoco.mjtJoint.mjJNT_HINGE)
_BAD_STATE_WARNINGS = (
    int(mujoco.mjtWarning.mjWARN_BADCTRL),
    int(mujoco.mjtWarning.mjWARN_BADQPOS),
    int(mujoco.mjtWarning.mjWARN_BADQVEL),
    int(mujoco.mjtWarning.mjWARN_BADQACC),
)


class Character:
    """A converted humanoid in simulation.

    Args:
        model: ``None`` (the bundled humanoid, ``mjchar.bvh.bundled.assets.humanoid_path()``), an
            MJCF path, or an ``MjModel`` (copied: the Character edits its own model's actuator
            gains, time step, weld and floor).
        info: the converter's ``ModelInfo``; read from the model's metadata when ``None``.
        timestep: physics time step in s (default: the model's).
        max_velocity: a generalised velocity above this (rad/s or m/s) counts as divergence.

    Attributes:
        state, dynamics, contacts, actuation, pushes, poses: the parts (module docstring).
        model, data: the MuJoCo model and data (read them through the parts; the batched
            rollouts build their own ``MjData`` from ``model``).
        info: the joint map and roles (``ModelInfo``).
        source: the MJCF path the model was loaded from (``None`` when given an ``MjModel``).
        nq, nv, nu: sizes of qpos, qvel and ctrl.
        model_timestep: the model's own time step (s).
        root_body: body id of the root (the body carrying the free joint ``root``).
        root_dofs: ``(6,)`` dof indices of the free joint (x, y, z, then rotation in body frame).
        root_qpos: ``(7,)`` qpos indices of the free joint (position, then wxyz quaternion).
        actuator_dof: ``(nu,)`` the dof each actuator drives.
        actuator_qpos: ``(nu,)`` the qpos address of each actuator's hinge (-1 for ball motors).
        actuated: ``(nv,)`` bool, dofs driven by an actuator; unactuated: ``(k,)`` the others.
        joint_names: the BVH joints, in the metadata's order; joint_bodies: ``(J,)`` their body
            ids.
        dof_names: ``(nv,)`` readable dof names (``lKnee_y``, ``root_x``, ...).
        dof_joint, dof_body: ``(nv,)`` the MuJoCo joint and the body of each dof.
        dof_qpos: ``(nv,)`` the qpos address of each hinge or slide dof (-1 on free and ball
            joints).
        hinge_dofs: ``(nv,)`` bool, dofs of hinge joints.
        body_parent: ``(nbody,)`` the parent body of each body (0, the world, for the root).
        character_bodies: ``(k,)`` ids of the character's bodies (the root's subtree).
        site_names: the model's site names, in site-id order.
    """

    def __init__(self, model=None, *, info=None, timestep: float | None = None,
                 max_velocity: float = 200.0):
        self.model = load_model(model)
        self.source = model_source(model)
        self.data = mujoco.MjData(self.model)
        self.info = info if info is not None else model_info(self.model)
        m, d = self.model, self.data
        self.nq, self.nv, self.nu = int(m.nq), int(m.nv), int(m.nu)
        self.max_velocity, self.model_timestep = float(max_velocity), float(m.opt.timestep)

        rj = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "root")
        if rj < 0 or m.jnt_type[rj] != _JNT_FREE:
            raise CharacterError("model has no free joint named 'root' "
                                 "(see docs/model-contract.md)")
        self.root_body = int(m.jnt_bodyid[rj])
        self.root_dofs = np.arange(m.jnt_dofadr[rj], m.jnt_dofadr[rj] + 6)
        self.root_qpos = np.arange(m.jnt_qposadr[rj], m.jnt_qposadr[rj] + 7)
        floor = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "floor")
        if floor < 0:
            planes = np.flatnonzero(m.geom_type == _GEOM_PLANE)
            if len(planes) == 0:
                raise CharacterError("model has no floor (a plane geom named 'floor')")
            floor = int(planes[0])

        self._map_actuators()
        self._map_joints()
        foot_bodies, foot_side = self._map_feet()
        # the bad-state warning counters, read through a live view of ``data.warning.number``
        # (a slice when they are adjacent, as in MuJoCo's enum) before and after every step
        self._warn_numbers = self.data.warning.number
        lo, hi = min(_BAD_STATE_WARNINGS), max(_BAD_STATE_WARNINGS) + 1
        self._warn_idx = (slice(lo, hi) if hi - lo == len(_BAD_STATE_WARNINGS)
                          else np.array(_BAD_STATE_WARNINGS))
        self._warn_before = 0
        self._opt = self.model.opt  # (read per step: one wrapper, not one per access)
        self.timestep_chosen = False  # set_timestep's ``chosen``: make_controller keeps it

        self.state = State(m, d, self.root_body, self.joint_bodies, self._restored)
        self.dynamics = Dynamics(m, d, self.root_body, self.body_id)
        sites = tuple(mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, f"{s}_foot")
                      for s in ("left", "right"))
        self.contacts = Contacts(m, d, floor, foot_side, foot_bodies, sites)
        self.actuation = Actuation(m, d, self.actuator_dof, self.root_dofs, self.root_body,
                                   self._refresh)
        self.pushes = PushSchedule(d, self.body_id)
        self.poses = Poses(m, self.root_qpos, self.character_bodies, self.body_id, self.role)
        if timestep is not None:
            self.set_timestep(timestep)
        self.reset()

    # -- structure ----------------------------------------------------------------------------
    def _map_actuators(self) -> None:
        self.actuator_dof, self.actuator_qpos = actuator_map(self.model)
        self.actuated = np.zeros(self.nv, dtype=bool)
        self.actuated[self.actuator_dof] = True
        self.unactuated = np.flatnonzero(~self.actuated)

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
        self.dof_joint = m.dof_jntid.astype(int)
        self.dof_body = m.dof_bodyid.astype(int)
        one_dof = np.isin(m.jnt_type[self.dof_joint], (_JNT_FREE, _JNT_BALL), invert=True)
        self.dof_qpos = np.where(one_dof, m.jnt_qposadr[self.dof_joint], -1)
        self.hinge_dofs = m.jnt_type[self.dof_joint] == _JNT_HINGE
        self.body_parent = m.body_parentid.astype(int)
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
        self.site_names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_SITE, i) or ""
                           for i in range(m.nsite)]
        # bodies of the character: the root's subtree
        self.character_bodies = np.flatnonzero(
            [self._is_descendant(b, self.root_body) for b in range(m.nbody)])

    def _map_feet(self) -> tuple[np.ndarray, np.ndarray]:
        """(foot bodies (k,), side of every body (nbody,): 0 left, 1 right, -1 not a foot)."""
        m = self.model
        feet = []
        side_of_body = np.full(m.nbody, -1)
        for s, side in enumerate(("left", "right")):
            for part in ("ankle", "toe"):
                j = self.role(f"{side}_{part}", required=False)
                if j is not None:
                    feet.append(self._joint_body[j])
                    side_of_body[self._joint_body[j]] = s
        if not feet:  # contract fallback: foot geoms are the boxes
            feet = sorted({int(m.geom_bodyid[g]) for g in np.flatnonzero(m.geom_type == _GEOM_BOX)})
        return np.array(sorted(set(feet)), dtype=int), side_of_body

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
                                 f"{name_list(self.joint_names)}")

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
                                 f"{name_list(self.joint_names)}")
        return b

    def site_id(self, name: str) -> int:
        """MuJoCo site id of a site (``head``, ``left_foot``, ...); unknown names raise."""
        s = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SITE, name)
        if s < 0:
            raise CharacterError(f"unknown site {name!r}")
        return s

    # -- time and stepping ----------------------------------------------------------------------
    @property
    def time(self) -> float:
        """Simulated time in s."""
        return float(self.data.time)

    @property
    def timestep(self) -> float:
        """Physics time step in s."""
        return float(self._opt.timestep)

    def set_timestep(self, dt: float, *, chosen: bool = True) -> None:
        """Set the physics time step (s); ``chosen``: a choice for this character that
        :func:`~mjchar.controllers.core.registry.make_controller` keeps (``False``: a
        controller's own step, applied by it)."""
        if not (math.isfinite(dt) and dt > 0):
            raise CharacterError(f"time step must be a positive number of seconds, got {dt}")
        self.model.opt.timestep = float(dt)
        self.timestep_chosen = chosen

    def reset(self, qpos: np.ndarray | None = None, qvel: np.ndarray | None = None) -> None:
        """Reset time to 0, clear pushes, applied forces and the last action, release the root
        weld, and set the state (default: qpos0 at rest).

        ``qpos``: ``(nq,)``; ``qvel``: ``(nv,)`` (zeros when ``None``).
        """
        mujoco.mj_resetData(self.model, self.data)
        self.actuation.reset()
        if qpos is not None:
            self.data.qpos[:] = as_vector(qpos, self.nq, "qpos")
        if qvel is not None:
            self.data.qvel[:] = as_vector(qvel, self.nv, "qvel")
        self.pushes.clear()
        self._refresh()

    def step(self, action: Action | None = None, n: int = 1) -> None:
        """Apply ``action`` (held for all ``n`` physics steps; ``None``: the controls as they
        are) and advance ``n`` steps.

        Raises :class:`SimulationDiverged` when the state becomes non-finite or a velocity
        exceeds ``max_velocity`` (also when MuJoCo had to reset a bad state).
        """
        self.begin_step(action)
        m, d = self.model, self.data
        if self._pushes_act(n):
            self._step_with_pushes(n)
        else:
            mujoco.mj_step2(m, d)
            if n > 1:
                mujoco.mj_step(m, d, n - 1)
            mujoco.mj_step1(m, d)
        self._check()

    # :meth:`step` in three parts, for stepping many characters in threads of one process
    # (mjchar.envs.vector): ``begin_step`` and ``end_step`` hold the interpreter briefly,
    # ``advance`` is physics only (MuJoCo releases the GIL inside each call).
    def begin_step(self, action: Action | None = None) -> None:
        """Apply ``action`` (``None``: the controls as they are); then :meth:`advance` and
        :meth:`end_step` complete what :meth:`step` does."""
        if action is not None:
            self.actuation.apply(action)
        self._warn_before = self._bad_state_warnings()

    def advance(self, n: int = 1) -> None:
        """The physics of :meth:`step`: ``n`` steps and ``mj_step1`` on the new state, as
        ``mj_step(m, d, n)`` and ``mj_step1`` (the step's first ``mj_step1`` recomputes what
        the last one left, from the same inputs: the same numbers as :meth:`step`, with two
        calls into MuJoCo instead of three and no Python between the steps, unless a push acts
        during them)."""
        m, d = self.model, self.data
        if self._pushes_act(n):
            self._step_with_pushes(n)
        else:
            mujoco.mj_step(m, d, n)
            mujoco.mj_step1(m, d)

    def end_step(self) -> None:
        """After :meth:`advance`: raise :class:`SimulationDiverged` as :meth:`step` does."""
        self._check()

    def _pushes_act(self, n: int) -> bool:
        """Whether a push acts during the next ``n`` steps (then they are taken one by one)."""
        pushes = self.pushes
        if not (pushes.scheduled or pushes.applied):
            return False
        return bool(pushes.applied or pushes.any_between(self.data.time,
                                                          self.data.time + (n + 1)
                                                          * self._opt.timestep))

    def _step_with_pushes(self, n: int) -> None:
        m, d, pushes = self.model, self.data, self.pushes
        dt = self._opt.timestep
        pushes.apply(d.time + 0.5 * dt)  # the step's midpoint decides
        mujoco.mj_step2(m, d)
        for _ in range(n - 1):
            pushes.apply(d.time + 0.5 * dt)
            mujoco.mj_step(m, d)
        mujoco.mj_step1(m, d)

    def _restored(self) -> None:
        """After ``state.set``: the restored controls are the native set-points; recompute."""
        self.actuation.hold_controls()
        self._refresh()

    def _refresh(self, check: bool = True) -> None:
        """Recompute position/velocity-dependent quantities for the current state (mj_step1)."""
        self._warn_before = self._bad_state_warnings()
        mujoco.mj_step1(self.model, self.data)
        if check:
            self._check()

    def _bad_state_warnings(self) -> int:
        """How many bad-state warnings MuJoCo has counted so far (``_BAD_STATE_WARNINGS``)."""
        return int(sum(self._warn_numbers[self._warn_idx].tolist()))

    def _check(self) -> None:
        d = self.data
        # fast path: every |qvel_i| is at most the Euclidean norm (NaN fails the comparison;
        # the margin covers the norm's rounding), so a norm within the limit and an unchanged
        # warning count need nothing more
        if (self._bad_state_warnings() == self._warn_before
                and mujoco.mju_norm(d.qvel) <= 0.999999 * self.max_velocity):
            return
        if self._bad_state_warnings() != self._warn_before:
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
