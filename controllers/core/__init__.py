"""The core of the dynamic layer, shared by every controller.

- :mod:`~mjchar.controllers.core.character`: :class:`Character`, one converted humanoid behind
  named access (names and indices, reset, stepping), and its parts, one module each:
  ``character.state`` (qpos, qvel, world frames, centre of mass, save/restore),
  ``character.dynamics`` (mass matrix, bias forces, Jacobians, joint-space arithmetic),
  ``character.contacts`` (the floor and what touches it), ``character.actuation`` (native PD or
  torques, gains, limits, applying an action, the root weld), ``character.pushes`` (scheduled
  external forces), ``character.poses`` (kinematics on a scratch copy: standing pose, lowest
  point, world frames, IK); its model loading and metadata in
  :mod:`~mjchar.controllers.core.character.model`. Beside it
  :mod:`~mjchar.controllers.core.geometry` (support polygon) and
  :mod:`~mjchar.controllers.core.errors`.
- :mod:`~mjchar.controllers.core.action` and :mod:`~mjchar.controllers.core.base`:
  :class:`Action`, the ``Controller`` protocol, :class:`Gains`, PD targets.
- :mod:`~mjchar.controllers.core.registry`: the controller registry (:class:`ControllerSpec`,
  :func:`register`, :func:`make_controller`).
- :mod:`~mjchar.controllers.core.scenarios`: the scenario registry and the scenarios (stand,
  push, random-push, push-search, track, walk, slopes).
- :mod:`~mjchar.controllers.core.builder`: the run builder (:class:`RunSpec`, :func:`run`), which
  every entry point (CLI, bench, Python) uses.
- :mod:`~mjchar.controllers.core.pd`: explicit, stable and native PD (registered as ``pd``,
  ``spd``, ``native_pd``).
- :mod:`~mjchar.controllers.core.metrics` (:class:`Result`, fall detection).

``MotionRecorder`` (a run's qpos, written as BVH) is the kinematic layer's
(:mod:`mjchar.bvh.reference.export`), re-exported here beside the runs it records.
"""

# the scenarios register before the controllers, which are checked against them
# isort: off
from . import scenarios  # noqa: F401  (fills the scenario registry)
from . import pd as pd  # registers pd, spd, native_pd
# isort: on
from mjchar.bvh.reference.export import MotionRecorder

from .action import Action
from .base import Controller, ControllerError, Gains, PoseTarget, ReferenceTarget, joint_error
from .builder import RunError, RunSpec, run
from .character import Character
from .errors import CharacterError, SimulationDiverged
from .metrics import Result
from .pd import NativePDController, PDController, StablePDController
from .registry import (
    ControllerSpec,
    RegistryError,
    default_timestep,
    make_controller,
    register,
)
from .scenarios import ScenarioSpec, run_scenario

__all__ = ["Action", "Character", "CharacterError", "Controller", "ControllerError",
           "ControllerSpec", "Gains", "MotionRecorder", "NativePDController", "PDController",
           "PoseTarget", "ReferenceTarget", "RegistryError", "Result", "RunError", "RunSpec",
           "ScenarioSpec", "SimulationDiverged", "StablePDController", "default_timestep",
           "joint_error", "make_controller", "register", "run", "run_scenario", "scenarios"]
