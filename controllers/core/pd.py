"""The PD family: explicit PD, stable PD (Tan, Liu, Turk 2011) and MuJoCo's native PD.

All three track a target ``(q_bar(t), qdot_bar(t))`` (a fixed pose or a reference motion, see
:mod:`mjchar.controllers.core.base`) with per-dof gains ``kp``, ``kd`` (default: the model's gains
table). The floating base has zero gains: none of them pushes the root, unless the hand of god gives
the root rows gains (:meth:`_PDTracker.set_root_gains`); the root rows of the torque are then an
external wrench, reported by every scenario.

- :class:`PDController`, explicit PD computed in Python, applied as torques::

      tau = kp (q_bar - q) + kd (qdot_bar - qdot)

  with ``q_bar - q`` from ``mj_differentiatePos``. Stable only for small time steps.

- :class:`StablePDController`, stable PD (Tan, Liu and Turk, "Stable Proportional-Derivative
  Controllers", IEEE CG&A 2011): the PD law evaluated at the *next* step's state::

      tau = -kp (q + dt qdot - q_bar) - kd (qdot + dt qddot - qdot_bar)
      qddot = (M + kd dt)^-1 (-C - kp (q + dt qdot - q_bar) - kd (qdot - qdot_bar) + tau_ext)

  with the full joint-space mass matrix ``M`` (armature included; solved with MuJoCo's sparse
  factorisation of ``M + kd dt``, which equals the dense ``mj_fullM`` solve), ``C`` =
  ``qfrc_bias``, ``tau_ext`` = passive forces plus the last step's constraint (contact) forces,
  ``kp = kd = 0`` on the floating-base rows, and ``q + dt qdot - q_bar`` taken with
  ``mj_integratePos``/``mj_differentiatePos`` (rotation vector of ``q_pred^-1 q_bar`` for ball
  joints).

- :class:`NativePDController`: MuJoCo ``<position>`` actuators with ``implicitfast`` apply
  ``kp (u - q) - kd qdot`` inside ``mj_step`` with implicit damping. The target velocity is
  folded into the set-point, ``u = q_bar + (kd / kp) qdot_bar``, which gives exactly
  ``kp (q_bar - q) + kd (qdot_bar - qdot)``.
"""

from __future__ import annotations

import numpy as np

from .base import Action, ControllerError, Gains, bind_target
from .character import Character
from .registry import ControllerSpec, register


def _selector(idx: np.ndarray) -> slice | np.ndarray:
    """Integer indices as a slice when they are a contiguous ascending run (a view to read,
    not a gathered copy), else as they are."""
    idx = np.asarray(idx, dtype=int)
    if len(idx) and np.array_equal(idx, np.arange(idx[0], idx[0] + len(idx))):
        return slice(int(idx[0]), int(idx[0]) + len(idx))
    return idx


class _PDTracker:
    """Shared set-up: a target and gains bound to a character at :meth:`reset`."""

    name = "pd"
    actuation = "torque"

    def __init__(self, target=None, gains: Gains | None = None):
        self._target_spec = target
        self._gains_spec = gains
        self.target = None
        self.gains: Gains | None = None

    def reset(self, character: Character) -> None:
        """Bind the target (``None``: hold the pose the character has now) and the gains, and
        switch the character's actuation."""
        character.actuation.set_mode(self.actuation)
        self.target = bind_target(self._target_spec, character)
        g = self._gains_spec if self._gains_spec is not None else Gains.from_character(character)
        self.gains = Gains(np.array(g.kp, float), np.array(g.kd, float)).check(character)

    def set_root_gains(self, character: Character, kp: float, kd: float, kp_rot: float,
                       kd_rot: float) -> None:
        """Put gains on the root's six rows (after :meth:`reset`): the tracker then also pulls
        the root towards the target with an external wrench (the hand of god, see
        :mod:`mjchar.controllers.balance.hand_of_god`). Explicit PD applies it explicitly, stable PD
        inside its implicit prediction, native PD explicitly on top of the actuators."""
        self._require_reset()
        self.gains = self.gains.with_root(character, kp, kd, kp_rot, kd_rot)

    def set_target(self, target, character: Character) -> None:
        """Replace the target (same forms as the constructor's) without resetting anything else."""
        self._target_spec = target
        self.target = bind_target(target, character)

    def _require_reset(self) -> None:
        if self.gains is None:
            raise ControllerError(f"{self.name}: act() called before reset()")


class PDController(_PDTracker):
    """Explicit PD in joint space: ``tau = kp (q_bar - q) + kd (qdot_bar - qdot)``.

    Args:
        target: ``None`` (hold the pose at reset), a pose ``(nq,)``, a ReferenceMotion or a
            target callable ``t -> (q_bar, qdot_bar)``.
        gains: :class:`~mjchar.controllers.core.base.Gains` (default: the model's gains table).
    """

    name = "pd"

    def torque(self, character: Character, t: float) -> np.ndarray:
        """``(nv,)`` PD torques (N m), zero on the root."""
        self._require_reset()
        q_bar, qd_bar = self.target(t)
        e = character.dynamics.difference(character.state.qpos, q_bar)
        return self.gains.kp * e + self.gains.kd * (qd_bar - character.state.qvel)

    def act(self, character: Character, t: float) -> Action:
        """``Action(torque=...)`` with the explicit PD torques."""
        return Action(torque=self.torque(character, t))


class StablePDController(_PDTracker):
    """Stable PD (Tan, Liu, Turk 2011) with the full mass matrix; see the module docstring.

    Args:
        target, gains: as :class:`PDController`.
        external: include ``tau_ext`` (passive + last step's constraint forces) in the predicted
            acceleration (default ``True``).
    """

    name = "spd"

    def __init__(self, target=None, gains: Gains | None = None, *, external: bool = True):
        super().__init__(target, gains)
        self.external = external

    def torque(self, character: Character, t: float) -> np.ndarray:
        """``(nv,)`` stable-PD torques (N m) for the time step ``character.timestep``."""
        self._require_reset()
        dt = character.timestep
        kp, kd = self.gains.kp, self.gains.kd
        q_bar, qd_bar = self.target(t)
        dyn = character.dynamics
        qd = character.state.qvel
        q_pred = dyn.integrate(character.state.qpos, qd, dt)
        e = dyn.difference(q_pred, q_bar)                 # -(q + dt qdot - q_bar)
        p_term = kp * e
        v_err = qd_bar - qd
        rhs = p_term + kd * v_err - dyn.bias_forces()
        if self.external:
            rhs += dyn.passive_forces() + dyn.constraint_forces()
        qdd = dyn.solve_mass(rhs, kd * dt)                # (M + kd dt)^-1 rhs, sparse LDL
        v_err -= dt * qdd
        v_err *= kd
        p_term += v_err
        return p_term                                     # kp e + kd (qd_bar - qd - dt qdd)

    def act(self, character: Character, t: float) -> Action:
        """``Action(torque=...)`` with the stable-PD torques."""
        return Action(torque=self.torque(character, t))


class NativePDController(_PDTracker):
    """MuJoCo position actuators: writes the gains into the model at :meth:`reset`, then sends
    set-points ``u = q_bar + (kd / kp) qdot_bar`` per actuator.

    Needs a position actuator on every actuated dof (the ``hinge`` and ``full`` joint models).
    """

    name = "native_pd"
    actuation = "native"

    def reset(self, character: Character) -> None:
        """Bind target and gains, switch to native actuation and write the gains into the
        position actuators."""
        if not np.all(character.actuation.position_actuators):
            raise ControllerError("native PD needs <position> actuators on every actuated dof; "
                                  "this model drives ball joints with motors (use 'spd')")
        super().reset(character)
        character.actuation.set_native_gains(self.gains.kp, self.gains.kd)
        kp = self.gains.kp[character.actuator_dof]
        kd = self.gains.kd[character.actuator_dof]
        self._lead = np.divide(kd, kp, out=np.zeros_like(kd), where=kp > 0)
        self._qadr = _selector(character.actuator_qpos)
        self._dof = _selector(character.actuator_dof)
        self._root_gains_of = None  # the Gains object _root_gains was read from

    def act(self, character: Character, t: float) -> Action:
        """``Action(target=u)`` (plus the explicit root wrench when the root has gains)."""
        self._require_reset()
        q_bar, qd_bar = self.target(t)
        u = q_bar[self._qadr] + self._lead * qd_bar[self._dof]
        r = character.root_dofs
        if self._root_gains_of is not self.gains:  # gains replaced (set_root_gains): re-read
            self._root_gains = bool(self.gains.kp[r].any() or self.gains.kd[r].any())
            self._root_gains_of = self.gains
        if not self._root_gains:
            return Action(target=u)
        tau = np.zeros(character.nv)  # root gains (hand of god): explicit PD on the root rows
        e = character.dynamics.difference(character.state.qpos, q_bar)[r]
        tau[r] = self.gains.kp[r] * e + self.gains.kd[r] * (qd_bar[r] - character.state.qvel[r])
        return Action(torque=tau, target=u)


# -- registration --------------------------------------------------------------------------------
def _pd_factory(cls):
    def make(character: Character, target=None, *, gains: Gains | None = None, **options):
        return cls(target, gains, **options)

    return make


_PD_BENCH = ("stand", "random-push", "push-search", "track")
register(ControllerSpec(
    name="pd", label="explicit PD (1/2000 s)", kind="pd", factory=_pd_factory(PDController),
    abilities=("stand", "track"),
    default_scenario="stand", timestep=1 / 2000,
    bench=_PD_BENCH))
register(ControllerSpec(
    name="spd", label="stable PD", kind="pd", factory=_pd_factory(StablePDController),
    abilities=("stand", "track"),
    default_scenario="stand", bench=_PD_BENCH))
register(ControllerSpec(
    name="native_pd", label="MuJoCo <position> PD", kind="pd",
    factory=_pd_factory(NativePDController),
    abilities=("stand", "track"),
    default_scenario="stand", bench=_PD_BENCH))
