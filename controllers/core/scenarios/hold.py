"""A PD stability check: can a PD variant hold the standing pose with the root welded?

Not a scenario of a controller's behaviour but of the PD law's integration (time step x gain):
the stability envelope of the performance measurements is built on it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..base import Gains
from ..character import Character
from ..errors import SimulationDiverged
from ..registry import make_controller
from .registry import ScenarioError
from .shared import standing_pose


@dataclass
class HoldResult:
    """Outcome of :func:`hold_pose` (a PD stability check with the root welded).

    Attributes:
        held: no divergence, and over the last second the RMS joint error stayed below
            ``HOLD_ERROR`` rad and the RMS joint velocity below ``HOLD_VELOCITY`` rad/s.
        diverged: the simulation blew up (NaN, exploding velocity).
        rms_error: RMS joint error over the last second (rad; ``inf`` if diverged).
        rms_velocity: RMS joint velocity over the last second (rad/s; ``inf`` if diverged).
        time_s: simulated time reached.
    """

    held: bool
    diverged: bool
    rms_error: float
    rms_velocity: float
    time_s: float


#: thresholds of :func:`hold_pose` (rad, rad/s)
HOLD_ERROR = 0.05
HOLD_VELOCITY = 0.5


def hold_pose(character: Character, controller: str, *, kp: float, timestep: float,
              duration: float = 5.0, seed: int = 0, perturbation: float = 0.2,
              kd: float | None = None, torque_limits: bool = False) -> HoldResult:
    """Can PD variant ``controller`` (``pd``, ``spd``, ``native_pd``) hold the standing pose?

    The root is welded 0.1 m above its standing height (no floor contact), every actuated dof
    starts off target by a uniform random error in ``[-perturbation, perturbation]`` rad (seeded),
    and the controller, with uniform gains ``kp`` and ``kd`` (default ``kp / 10``), runs for
    ``duration`` s at ``timestep`` s, acting every physics step. The torque limits are lifted
    unless ``torque_limits``: the check is about integrating the PD law; with limits, a clamped
    native actuator loses its implicit damping in MuJoCo and saturation limit cycles appear.
    """
    if controller not in ("pd", "spd", "native_pd"):
        raise ScenarioError(f"hold_pose is for the PD variants, not {controller!r}")
    rng = np.random.default_rng(seed)
    character.set_timestep(timestep)
    pose = standing_pose(character)
    pose[character.root_qpos[2]] += 0.1
    v = np.zeros(character.nv)
    v[character.actuated] = rng.uniform(-perturbation, perturbation, int(character.actuated.sum()))
    start = character.dynamics.integrate(pose, v, 1.0)
    character.reset(start)
    character.actuation.weld_root(True)  # the root of `start` is the root of `pose`
    ctrl = make_controller(controller, character, pose, gains=Gains.uniform(character, kp, kd))
    ctrl.reset(character)
    character.actuation.set_torque_limits(torque_limits)
    n = int(round(duration / timestep))
    tail = max(1, int(round(1.0 / timestep)))
    act = character.actuated
    err2 = vel2 = 0.0
    try:
        for k in range(n):
            character.step(ctrl.act(character, character.time))
            if k >= n - tail:
                e = character.dynamics.difference(character.state.qpos, pose)[act]
                err2 += float(e @ e) / len(e)
                q = character.state.qvel[act]
                vel2 += float(q @ q) / len(q)
    except SimulationDiverged:
        return HoldResult(False, True, math.inf, math.inf, character.time)
    finally:
        character.actuation.set_torque_limits(True)
        character.actuation.weld_root(False)
    rms_e, rms_v = math.sqrt(err2 / tail), math.sqrt(vel2 / tail)
    return HoldResult(rms_e < HOLD_ERROR and rms_v < HOLD_VELOCITY, False, rms_e, rms_v,
                      character.time)
