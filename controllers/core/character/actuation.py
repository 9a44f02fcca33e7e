"""``character.actuation``: how an :class:`~mjchar.controllers.core.action.Action` reaches the
joints.

Two modes (contract, "Actuation"): ``"native"``, MuJoCo's ``<position>`` actuators apply PD
inside the step, and ``"torque"``, the controls are joint torques. This part switches between
them, keeps the native gains and the torque limits, writes an action into the controls (with a
feed-forward torque folded into the PD set-points in native mode), applies the unactuated rows of
an action to the root from outside (the "hand of god") and records that wrench, and holds the
root fixed in the world with the ``root_weld`` equality.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import mujoco
import numpy as np

from ..action import Action
from ..errors import CharacterError, SimulationDiverged
from .model import as_vector

#: actuation modes of :meth:`Actuation.set_mode`
ACTUATION_MODES = ("native", "torque")


def _selector(idx: np.ndarray) -> slice | np.ndarray:
    """``idx`` (int array) as a slice when it is a contiguous ascending run, else itself."""
    idx = np.asarray(idx, dtype=int)
    if len(idx) and np.array_equal(idx, np.arange(idx[0], idx[0] + len(idx))):
        return slice(int(idx[0]), int(idx[0]) + len(idx))
    return idx


def _l1(x: np.ndarray) -> float:
    """Sum of the absolute values of the 1-D array ``x`` (MuJoCo's ``mju_L1`` when ``x`` is a
    writeable contiguous float64 vector, numpy otherwise)."""
    try:
        return mujoco.mju_L1(x)
    except TypeError:
        return float(np.abs(x).sum())


def _all_finite(x: np.ndarray) -> bool:
    """Whether every element of ``x`` is finite: a finite sum of absolute values says so (a NaN
    or an infinity makes it non-finite); only a sum that overflows, or a bad element, takes
    numpy's element-wise test."""
    return math.isfinite(_l1(x)) or bool(np.isfinite(x).all())


def _check_action(x: np.ndarray, n: int, what: str, data: mujoco.MjData) -> None:
    """An action's ``torque`` or ``target`` (``what``) must have shape ``(n,)``
    (:class:`CharacterError`) and be finite (:class:`SimulationDiverged` at ``data.time``)."""
    if x.shape != (n,):
        raise CharacterError(f"action {what} must have shape ({n},), got {x.shape}")
    if not _all_finite(x):
        raise SimulationDiverged(f"the controller produced a non-finite {what}", data.time)


class Actuation:
    """The actuators of one character (built by the Character; see the module docstring).

    Attributes:
        position_actuators: ``(nu,)`` bool, the actuators that are ``<position>`` actuators
            (native PD; the others are motors, e.g. on ball joints).
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, actuator_dof: np.ndarray,
                 root_dofs: np.ndarray, root_body: int, refresh: Callable[..., None]):
        self._model, self._data = model, data
        m = model
        self._nv, self._nu = int(m.nv), int(m.nu)
        self._actuator_dof = actuator_dof
        actuated = np.zeros(self._nv, dtype=bool)
        actuated[actuator_dof] = True
        self._unactuated = np.flatnonzero(~actuated)
        self._root_dofs = root_dofs
        # the same indices as slices where they are contiguous and ascending (the converter's
        # layout: the root's 6 dofs first, one actuator per dof after them, in dof order): a
        # slice reads a view instead of gathering a copy
        self._act_sel = _selector(actuator_dof)
        self._unact_sel = _selector(self._unactuated)
        self._root_sel = _selector(root_dofs)
        self._root_body = int(root_body)
        self._refresh = refresh
        self._weld = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_EQUALITY, "root_weld")
        self.position_actuators = m.actuator_biasprm[:, 1] < 0  # bias -kp q: <position>
        self._native_gainprm = m.actuator_gainprm.copy()
        self._native_biasprm = m.actuator_biasprm.copy()
        self._native_ctrlrange = m.actuator_ctrlrange.copy()
        self._native_ctrllimited = m.actuator_ctrllimited.copy()
        self._native_forcelimited = m.actuator_forcelimited.copy()
        self._torque_limited = True
        self._mode = "native"
        self._native_target = np.zeros(self._nu)  # native set-points before any feed-forward
        self._table = self.native_gains()
        self._root_wrench = np.zeros(6)
        self._wrench_applied = False

    # -- modes and gains ----------------------------------------------------------------------
    @property
    def mode(self) -> str:
        """``"native"`` (MuJoCo position actuators apply PD) or ``"torque"`` (ctrl = N m)."""
        return self._mode

    def set_mode(self, mode: str) -> None:
        """Switch every actuator between native PD and torque control.

        Torque mode rewrites ``actuator_gainprm``/``biasprm`` to gain 1, bias 0 and widens the
        control range to the force range, so ``ctrl`` is a torque in N m clamped to the torque
        limit. Native mode restores the position actuators' ``kp``/``kv`` (motors on ball joints
        stay torque-controlled).
        """
        if mode not in ACTUATION_MODES:
            raise CharacterError(f"actuation must be one of {ACTUATION_MODES}, got {mode!r}")
        m = self._model
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
        self._data.ctrl[:] = 0
        self._native_target[:] = 0
        self._mode = mode

    def native_gains(self) -> tuple[np.ndarray, np.ndarray]:
        """``(kp, kd)``, each ``(nv,)``: the native PD gains per dof (N m/rad, N m s/rad).

        Zero on unactuated dofs (the root) and on dofs driven by motors.
        """
        kp = np.zeros(self._nv)
        kd = np.zeros(self._nv)
        pa = self.position_actuators
        kp[self._actuator_dof[pa]] = self._native_gainprm[pa, 0]
        kd[self._actuator_dof[pa]] = -self._native_biasprm[pa, 2]
        return kp, kd

    def default_gains(self) -> tuple[np.ndarray, np.ndarray]:
        """``(kp, kd)``, each ``(nv,)``: the model's own gains table (as loaded, before any
        :meth:`set_native_gains`)."""
        return self._table[0].copy(), self._table[1].copy()

    def set_native_gains(self, kp: np.ndarray, kd: np.ndarray) -> None:
        """Set the position actuators' ``kp``/``kv`` from per-dof gains ``(nv,)`` each."""
        kp = as_vector(kp, self._nv, "kp")
        kd = as_vector(kd, self._nv, "kd")
        pa = self.position_actuators
        d = self._actuator_dof[pa]
        self._native_gainprm[pa, 0] = kp[d]
        self._native_biasprm[pa, 1] = -kp[d]
        self._native_biasprm[pa, 2] = -kd[d]
        if self._mode == "native":
            self._model.actuator_gainprm[pa] = self._native_gainprm[pa]
            self._model.actuator_biasprm[pa] = self._native_biasprm[pa]

    def torque_limits(self) -> np.ndarray:
        """``(nv,)`` torque limit per dof in N m (inf where unlimited or unactuated)."""
        lim = np.full(self._nv, np.inf)
        m = self._model
        fl = m.actuator_forcelimited.astype(bool)
        lim[self._actuator_dof[fl]] = np.abs(m.actuator_forcerange[fl]).max(axis=1)
        return lim

    def set_torque_limits(self, enabled: bool) -> None:
        """Clamp actuator torques to the model's ``forcerange`` (default) or lift the clamp
        (for stability studies: MuJoCo drops the implicit damping of a clamped actuator)."""
        self._torque_limited = bool(enabled)
        self._model.actuator_forcelimited[:] = self._native_forcelimited if enabled else 0
        self.set_mode(self._mode)

    # -- actions ------------------------------------------------------------------------------
    def apply(self, action: Action | None) -> None:
        """Write an action into the controls.

        ``action.torque`` ``(nv,)``: actuated rows become actuator controls in torque mode, or a
        feed-forward on top of the PD in native mode (folded into the position actuators'
        set-points, ``u + tau / kp``, so that MuJoCo clamps the joint's total torque to its
        ``forcerange``); either way the applied joint torque never exceeds the model's limit
        (unless :meth:`set_torque_limits` lifted it). Unactuated rows (the root's 6) are applied
        as an external generalised force (the hand of god).
        ``action.target`` ``(nu,)``: native PD set-points (only in native mode).
        ``None``: no torque, the last native set-points held.
        A non-finite torque or target raises :class:`SimulationDiverged`.
        """
        d = self._data
        d.qfrc_applied[:] = 0
        if self._wrench_applied:
            self._root_wrench[:] = 0
            self._wrench_applied = False
        if action is None:
            d.ctrl[:] = 0 if self._mode == "torque" else self._native_target
            return
        tau = action.torque
        if tau is not None:
            _check_action(tau, self._nv, "torque", d)
            d.qfrc_applied[self._unact_sel] = tau[self._unact_sel]
            rw = tau[self._root_sel]
            if _l1(rw) != 0.0:  # (finite here: = rw.any())
                R = d.xmat[self._root_body].reshape(3, 3)
                self._root_wrench[:3] = rw[:3]
                self._root_wrench[3:] = R @ rw[3:]
                self._wrench_applied = True
        target = action.target
        if self._mode == "torque":
            if target is not None:
                raise CharacterError("PD targets given while the actuators are in torque mode")
            d.ctrl[:] = 0 if tau is None else tau[self._act_sel]
            return
        if target is not None:
            _check_action(target, self._nu, "target", d)
            self._native_target[:] = target
        d.ctrl[:] = self._native_target
        if tau is not None:
            ff = tau[self._act_sel]
            if _l1(ff) != 0.0:  # (finite here: = ff.any())
                self._add_feedforward(np.array(ff))

    def _add_feedforward(self, ff: np.ndarray) -> None:
        """Native mode: add the ``(nu,)`` feed-forward torques ``ff`` (N m) through the actuators
        (position actuators: ``ctrl += ff / kp``; motors: ``ctrl += ff``), so the actuator's
        force range clamps PD and feed-forward together. Position actuators without stiffness
        cannot carry it: there it is applied directly, clipped to the torque limit."""
        gain = self._model.actuator_gainprm[:, 0]
        direct = self.position_actuators & (gain <= 0)
        carried = ~direct
        self._data.ctrl[carried] += ff[carried] / gain[carried]
        if direct.any():
            lim = self.torque_limits()[self._actuator_dof[direct]] if self._torque_limited \
                else np.inf
            self._data.qfrc_applied[self._actuator_dof[direct]] += np.clip(ff[direct], -lim, lim)

    @property
    def root_wrench(self) -> np.ndarray:
        """``(6,)`` world force (N) and torque (N m) the last action applied to the root from
        outside (the "hand of god"); zeros for controllers that need none."""
        return self._root_wrench.copy()

    @property
    def root_wrench_applied(self) -> bool:
        """Whether the last action applied a root wrench (:attr:`root_wrench` is not zero)."""
        return self._wrench_applied

    def reset(self) -> None:
        """Forget the last action (set-points and root wrench); ``character.reset`` calls it."""
        self._native_target[:] = 0
        self._root_wrench[:] = 0
        self._wrench_applied = False

    def hold_controls(self) -> None:
        """Take the current controls as the native set-points (after a restored state)."""
        self._native_target[:] = self._data.ctrl

    # -- the root weld ------------------------------------------------------------------------
    def weld_root(self, active: bool = True) -> None:
        """Hold the root body fixed to the world where it is now (``root_weld``), or release it."""
        if self._weld < 0:
            raise CharacterError("model has no equality constraint named 'root_weld'")
        d = self._data
        if active:
            # weld data: anchor on body2 (the world), pose of body2 relative to body1
            q = d.xquat[self._root_body]
            eq = self._model.eq_data
            eq[self._weld, 0:3] = d.xpos[self._root_body]
            eq[self._weld, 3:6] = 0.0
            eq[self._weld, 6:10] = q * np.array([1.0, -1.0, -1.0, -1.0])
        d.eq_active[self._weld] = 1 if active else 0
        self._refresh(check=False)
