"""The :class:`Controller` protocol and the pieces every controller shares.

A controller is reset once on a :class:`~mjchar.controllers.core.character.Character`, then asked
once per control step for an :class:`Action`::

    controller.reset(character)
    while ...:
        action = controller.act(character, character.time)
        character.step(action, n_substeps)

An :class:`~mjchar.controllers.core.action.Action` is the minimal common form of what the PD family,
hand-of-god and balance
controllers produce:

- ``torque`` ``(nv,)``: generalised forces in joint space (N m on rotational dofs). Rows of
  actuated dofs are joint torques; the root's six rows are an *external* wrench (the "hand of
  god": world force at the root origin, torque in the root frame). Controllers that need no root
  force leave them zero, and every scenario reports what they applied.
- ``target`` ``(nu,)``: set-points of MuJoCo's own position actuators (native PD), one per
  actuator, used when the character is in ``"native"`` actuation.

Shared here, so no controller re-implements them: :class:`Gains` (per-dof ``kp``/``kd``),
targets (:class:`PoseTarget`, :class:`ReferenceTarget`: ``t -> (q_bar, qdot_bar)``) and
:func:`joint_error` (``mj_differentiatePos``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from mjchar.bvh.errors import MjcharError

from .action import Action
from .character import Character


class ControllerError(MjcharError):
    """A controller was configured with something it cannot use (bad gains, missing reference)."""


@runtime_checkable
class Controller(Protocol):
    """Anything with ``name``, ``actuation``, ``reset(character)`` and ``act(character, t)``.

    ``actuation`` is ``"torque"`` or ``"native"``; ``reset`` switches the character to it and
    captures whatever the controller needs (default targets, gains); ``act`` returns an
    :class:`Action` for simulated time ``t`` (s).
    """

    name: str
    actuation: str

    def reset(self, character: Character) -> None:
        """Prepare to control ``character`` from its current state."""
        ...

    def act(self, character: Character, t: float) -> Action:
        """The action for simulated time ``t`` (s)."""
        ...


# -- gains ---------------------------------------------------------------------------------------
@dataclass
class Gains:
    """Per-dof PD gains.

    Attributes:
        kp: ``(nv,)`` stiffness, N m/rad (N/m on slide dofs); zero on the root.
        kd: ``(nv,)`` damping, N m s/rad; zero on the root.
    """

    kp: np.ndarray
    kd: np.ndarray

    @classmethod
    def from_character(cls, character: Character) -> Gains:
        """The model's own gains table (the position actuators' ``kp``/``kv``).

        Dofs without a position actuator (motors on ball joints) get the mean actuated gains.
        """
        kp, kd = character.actuation.default_gains()
        act = character.actuated
        missing = act & (kp == 0)
        if missing.any():
            have = act & (kp > 0)
            kp[missing] = kp[have].mean() if have.any() else 500.0
            kd[missing] = kd[have].mean() if have.any() else 50.0
        return cls(kp, kd)

    @classmethod
    def uniform(cls, character: Character, kp: float, kd: float | None = None) -> Gains:
        """The same ``kp`` on every actuated dof, ``kd`` (default ``kp / 10``)."""
        if not (np.isfinite(kp) and kp >= 0):
            raise ControllerError(f"kp must be a non-negative number, got {kp}")
        kd = kp / 10.0 if kd is None else kd
        if not (np.isfinite(kd) and kd >= 0):
            raise ControllerError(f"kd must be a non-negative number, got {kd}")
        a = character.actuated.astype(float)
        return cls(a * kp, a * kd)

    def scaled(self, factor: float) -> Gains:
        """Gains with ``kp`` and ``kd`` multiplied by ``factor``."""
        return Gains(self.kp * factor, self.kd * factor)

    def check(self, character: Character) -> Gains:
        """Validate shapes ``(nv,)`` and zero the unactuated (root) rows; returns self."""
        for name, g in (("kp", self.kp), ("kd", self.kd)):
            if np.shape(g) != (character.nv,):
                raise ControllerError(f"{name} must have shape ({character.nv},), got "
                                      f"{np.shape(g)}")
            if not (np.all(np.isfinite(g)) and np.all(np.asarray(g) >= 0)):
                raise ControllerError(f"{name} must be finite and non-negative")
        self.kp = np.array(self.kp, dtype=float)
        self.kd = np.array(self.kd, dtype=float)
        self.kp[~character.actuated] = 0.0
        self.kd[~character.actuated] = 0.0
        return self

    def with_root(self, character: Character, kp: float, kd: float, kp_rot: float,
                  kd_rot: float) -> Gains:
        """A copy with gains on the root's six rows (N/m, N s/m on translation; N m/rad,
        N m s/rad on rotation): the root is then pulled towards the target from outside
        (hand of god)."""
        g = Gains(self.kp.copy(), self.kd.copy())
        r = character.root_dofs
        g.kp[r] = [kp] * 3 + [kp_rot] * 3
        g.kd[r] = [kd] * 3 + [kd_rot] * 3
        return g


# -- targets -------------------------------------------------------------------------------------
class Target(Protocol):
    """``target(t) -> (q_bar (nq,), qdot_bar (nv,))``: the pose and velocity to track at ``t``.

    The returned arrays may be shared with the target (cached): read them, do not modify them.
    """

    def __call__(self, t: float) -> tuple[np.ndarray, np.ndarray]: ...


class PoseTarget:
    """A constant pose ``q_bar`` ``(nq,)`` with zero target velocity."""

    def __init__(self, qpos: np.ndarray):
        self.qpos = np.array(qpos, dtype=float)
        self._zero: np.ndarray | None = None

    def __call__(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        if self._zero is None:
            raise ControllerError("PoseTarget used before bind()")
        return self.qpos, self._zero

    def bind(self, character: Character) -> PoseTarget:
        """Check the pose against ``character`` (shape ``(nq,)``); returns self."""
        if self.qpos.shape != (character.nq,):
            raise ControllerError(f"pose must have shape ({character.nq},), got {self.qpos.shape}")
        self._zero = np.zeros(character.nv)
        return self


class LiftedTarget:
    """Another target with the root's target height raised by ``lift`` m (joints unchanged)."""

    def __init__(self, target, lift: float):
        self.target = target
        self.lift = float(lift)
        self._z: int | None = None

    def bind(self, character: Character) -> LiftedTarget:
        """Bind the wrapped target to ``character``; returns self."""
        self.target = bind_target(self.target, character)
        self._z = int(character.root_qpos[2])
        return self

    def __call__(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        q, qd = self.target(t)
        q = q.copy()
        q[self._z] += self.lift
        return q, qd


class ReferenceTarget:
    """Targets sampled from a ``mjchar.bvh.reference.reference_motion.ReferenceMotion``: ``(qpos(t),
    qvel(t))``.

    ``time_offset`` (s) shifts the clip: the target at simulated time ``t`` is the clip at
    ``t + time_offset``. Times on the physics grid (multiples of the character's time step) are
    served from blocks of :attr:`CHUNK` samples computed in one vectorised call (~100x cheaper
    per sample than one call per step); other times are sampled directly.
    """

    CHUNK = 256

    def __init__(self, reference, time_offset: float = 0.0):
        self.reference = reference
        self.time_offset = float(time_offset)
        self._dt: float | None = None
        self._chunks: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    def __call__(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        tt = t + self.time_offset
        if self._dt is not None and tt >= 0:
            k = tt / self._dt
            i = int(round(k))
            if abs(k - i) < 1e-6:
                c, j = divmod(i, self.CHUNK)
                chunk = self._chunks.get(c)
                if chunk is None:
                    times = (c * self.CHUNK + np.arange(self.CHUNK)) * self._dt
                    chunk = (self.reference.qpos(times), self.reference.qvel(times))
                    if len(self._chunks) >= 4:
                        self._chunks.pop(next(iter(self._chunks)))
                    self._chunks[c] = chunk
                return chunk[0][j], chunk[1][j]
        return self.reference.qpos(tt), self.reference.qvel(tt)

    def bind(self, character: Character) -> ReferenceTarget:
        """Check the reference is for ``character``'s model and cache on its time step."""
        if self.reference.model.nq != character.nq or self.reference.model.nv != character.nv:
            raise ControllerError("the reference motion was built for another model "
                                  f"(nq {self.reference.model.nq} vs {character.nq})")
        self._dt = character.timestep
        self._chunks = {}
        return self


def bind_target(target, character: Character):
    """Validate ``target`` for ``character``: ``None`` -> hold the current pose; an ``(nq,)``
    array -> :class:`PoseTarget`; a ReferenceMotion -> :class:`ReferenceTarget`; a Target object
    is returned as is (after its ``bind`` if it has one)."""
    if target is None:
        return PoseTarget(character.state.qpos.copy()).bind(character)
    if isinstance(target, np.ndarray):
        return PoseTarget(target).bind(character)
    if hasattr(target, "qpos") and hasattr(target, "qvel") and hasattr(target, "duration"):
        return ReferenceTarget(target).bind(character)
    if hasattr(target, "bind"):
        return target.bind(character)
    if callable(target):
        return target
    raise ControllerError(f"cannot use {type(target).__name__} as a PD target")


def joint_error(character: Character, q_bar: np.ndarray, q: np.ndarray | None = None) -> np.ndarray:
    """``(nv,)`` joint-space error ``q_bar - q`` (``mj_differentiatePos``; default ``q`` = now).

    Hinge rows: angle difference (rad); ball rows: rotation vector of ``q^-1 q_bar`` (child
    frame); root rows: position difference (world) and rotation vector (root frame).
    """
    return character.dynamics.difference(character.state.qpos if q is None else q, q_bar)
