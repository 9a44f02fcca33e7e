"""What the sampling MPC (:mod:`mjchar.controllers.sampling.mpc`) plans against.

- The **planning model** (:func:`planning_model`): the character's physics, compiled from its
  model file with the tracking sensors, checked against the character
  (:func:`~mjchar.controllers.sampling.trajectory.model_fingerprint`), at the planning time step,
  with the character's own solver settings or the fast ones (sparse constraint Jacobian, no
  solver warm start).
- The **reference on the control grid** (:class:`ReferenceGrid`): base targets (inverse
  dynamics on the reference) at control midpoints and the cost's reference features at control
  ends, computed on demand in blocks.
"""

from __future__ import annotations

import math
import os
from dataclasses import fields

import mujoco
import numpy as np

from mjchar.bvh.errors import MjcharError

from ..core.character import Character
from .rollout import RolloutModel
from .tracking import (
    ReferenceFeatures,
    inverse_dynamics_targets,
    reference_features,
    tracking_rollout_model,
)
from .trajectory import model_fingerprint

__all__ = ["MPC_STANCE_HEIGHT", "PLAN_SOLVERS", "MpcError", "ReferenceGrid",
           "constraint_time_constant", "coarsest_plan_step", "model_file", "planning_model",
           "whole_multiple"]

#: the planning model's solver settings: ``"fast"`` (sparse constraint Jacobian, no solver warm
#: start: the same physics to the solver's tolerance, cheaper steps) or ``"exact"`` (the
#: character's own)
PLAN_SOLVERS = ("fast", "exact")
#: the stance labels' height (fraction of the root height) on a contact-floor reference, whose
#: supporting feet are on the floor: 3 % labels walk60's landing foot only once it is down
#: (the raw-mocap 12 % labels it 5 cm up and gives it half the weight); measured closed loop
#: on walk60, walk_forward and walk_and_turn_right at 2, 3, 6 and 12 % (docs/mpc.md)
MPC_STANCE_HEIGHT = 0.03
def whole_multiple(span: float, step: float) -> bool:
    """Whether ``span`` is a whole number (>= 1) of ``step`` (to 1e-6 of a step)."""
    n = span / step
    return abs(n - round(n)) <= 1e-6 and round(n) >= 1


class MpcError(MjcharError):
    """The MPC was given settings it cannot use (sizes, times, an unknown update)."""


def constraint_time_constant(model: mujoco.MjModel) -> float | None:
    """The shortest time constant (s) of ``model``'s constraints: its contacts (geoms and
    explicit pairs), limited joints and tendons, and equality constraints (the first ``solref``
    number where positive; a negative one is a direct stiffness, without a time constant), or
    of the global override when it is enabled. ``None`` when no constraint has one."""
    found = [model.geom_solref[:, 0], model.pair_solref[:, 0],
             model.jnt_solref[model.jnt_limited.astype(bool), 0],
             model.tendon_solref_lim[model.tendon_limited.astype(bool), 0],
             model.eq_solref[:, 0]]
    if model.opt.enableflags & mujoco.mjtEnableBit.mjENBL_OVERRIDE:
        found.append(np.array([model.opt.o_solref[0]]))
    v = np.concatenate([np.ravel(a) for a in found])
    v = v[v > 0]
    return float(v.min()) if len(v) else None


def coarsest_plan_step(model: mujoco.MjModel, control_dt: float) -> float:
    """The planning model's default time step for a character of ``model`` controlled every
    ``control_dt`` s: the coarsest whole divisor of ``control_dt`` at which every constraint
    keeps its own time constant (MuJoCo treats a time constant under two time steps as two
    time steps, so a coarser step would plan on softer contacts and limits than the
    character's: half the shortest :func:`constraint_time_constant`), and never finer than
    the model's own step. 0.005 s for a model with the contacts of 0.01 s the converter
    writes, stepping at 0.002 s: 4 planning steps per control of 0.02 s instead of 10."""
    dt = float(model.opt.timestep)
    tc = constraint_time_constant(model)
    if tc is None:
        return dt
    n = max(1, math.ceil(control_dt / (tc / 2.0) - 1e-6))
    step = control_dt / n
    return step if step >= dt * (1 - 1e-9) else dt


def planning_model(source, character: Character, timestep: float,
                   solver: str = "exact") -> RolloutModel:
    """The model the candidates are rolled out on: ``source`` compiled with the tracking
    sensors (:func:`tracking_rollout_model`), checked to have the character's physics
    (:func:`model_fingerprint`, before the changes below), at the time step ``timestep``. With
    ``solver="fast"`` the constraint Jacobian is sparse and the solver's warm start is off:
    the physics is the same (the solver still converges to its tolerance; a sparse Jacobian
    changes only the rounding), a step of the bundled humanoid walking costs about 0.75 of one
    with the character's settings, and a full-physics state then holds everything a step reads,
    so a rollout continued from a recorded state is bit-identical to one that ran on
    (:meth:`RolloutResult.then`: what the MPC's early termination relies on)."""
    if solver not in PLAN_SOLVERS:
        raise MpcError(f"plan_solver must be one of {', '.join(PLAN_SOLVERS)}, got {solver!r}")
    rm = tracking_rollout_model(source, character)
    m = rm.model
    m.opt.timestep = float(timestep)  # the fingerprint leaves the time step out
    if model_fingerprint(m) != model_fingerprint(character.model):
        raise MpcError(f"the character's physics differs from its model file {source} "
                       f"(edited gains or options?)")
    if solver == "fast":
        m.opt.jacobian = int(mujoco.mjtJacobian.mjJAC_SPARSE)
        m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_WARMSTART)
    return rm


class ReferenceGrid:
    """Base targets at control midpoints and reference features at control ends on the grid
    ``origin + n control_dt`` (``n = 0, 1, ...``), computed in blocks of ``block`` controls on
    demand (so an endless cyclic reference costs memory in proportion to the time tracked).

    Base targets (:func:`inverse_dynamics_targets`) of a block are computed with a margin of
    four smoothing widths on each side, so blocks join without a visible seam.
    """

    def __init__(self, character: Character, reference, rmodel, control_dt: float,
                 smoothing: float, block: int = 50, *, stance_height: float,
                 origin: float = 0.0):
        self.character, self.reference, self.rmodel = character, reference, rmodel
        self.stance_height = float(stance_height)
        self.dt, self.smoothing, self.block = float(control_dt), float(smoothing), int(block)
        self.origin = float(origin)
        self.pad = int(math.ceil(4 * smoothing / control_dt)) + 1 if smoothing > 0 else 0
        self._base = np.zeros((0, character.nu))
        self.features: ReferenceFeatures | None = None

    @property
    def size(self) -> int:
        return len(self._base)

    def ensure(self, n_end: int) -> None:
        """Compute rows up to control ``n_end`` (exclusive)."""
        while self.size < n_end:
            a = self.size
            b = a + self.block
            n = np.arange(a - self.pad, b + self.pad)
            # both feet where no foot is labelled: measured better closed loop than SAMCON's
            # lowest foot (docs/mpc.md, "The clip's start and grounded stance labels")
            base = inverse_dynamics_targets(self.character, self.reference,
                                            self.origin + (n + 0.5) * self.dt,
                                            smoothing=self.smoothing, unlabelled="both",
                                            stance_height=self.stance_height,
                                            )[self.pad:len(n) - self.pad]
            f = reference_features(self.rmodel, self.reference,
                                   self.origin + (np.arange(a, b) + 1) * self.dt)
            self._base = np.concatenate([self._base, base])
            if self.features is None:
                self.features = f
            else:
                self.features = ReferenceFeatures(*(
                    np.concatenate([getattr(self.features, k.name), getattr(f, k.name)])
                    for k in fields(ReferenceFeatures)))

    def base(self, a: int, b: int) -> np.ndarray:
        """``(b - a, nu)`` base targets of controls ``a .. b-1``."""
        self.ensure(b)
        return self._base[a:b]


def model_file(character: Character) -> str:
    """The MJCF file the rollout model is compiled from: the Character's own, or for a
    Character built from an ``MjModel`` the bundled humanoid's when the physics is the same
    (what ``mjchar bench`` does); else :class:`MpcError`."""
    if character.source is not None:
        return character.source
    from mjchar.bvh.bundled.assets import humanoid_path

    path = os.fspath(humanoid_path())
    if model_fingerprint(mujoco.MjModel.from_xml_path(path)) == model_fingerprint(
            character.model):
        return path
    raise MpcError("mpc builds its rollout model from the model file: give the Character an "
                   "MJCF path (a Character built from an MjModel works only for the bundled "
                   "humanoid)")
