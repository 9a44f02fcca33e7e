"""The core of the dynamic layer, shared by every controller.

- :mod:`~mjchar.controllers.core.character`: :class:`Character`, one converted humanoid behind named
  access (state, centre of mass, contacts, pushes, stepping), with its pieces:
  :mod:`~mjchar.controllers.core.model` (loading, metadata), :mod:`~mjchar.controllers.core.pushes`
  (scheduled external forces), :mod:`~mjchar.controllers.core.poses` (kinematics on a scratch copy:
  lowest point, body pose, IK), :mod:`~mjchar.controllers.core.geometry` (support polygon) and
  :mod:`~mjchar.controllers.core.errors`.
- :mod:`~mjchar.controllers.core.action` and :mod:`~mjchar.controllers.core.base`: :class:`Action`,
  the
  ``Controller`` protocol, :class:`Gains`, PD targets.
- :mod:`~mjchar.controllers.core.registry`: :class:`ControllerSpec`, :func:`register`,
  :func:`make_controller`.
- :mod:`~mjchar.controllers.core.pd`: explicit, stable and native PD (registered as ``pd``, ``spd``,
  ``native_pd``).
- :mod:`~mjchar.controllers.core.scenarios` (stand, push, push-search, random-push, track, walk),
  :mod:`~mjchar.controllers.core.terrain` (level and sloped walks, pushes at stride phases),
  :mod:`~mjchar.controllers.core.metrics` (:class:`Result`, fall detection, recording),
  :mod:`~mjchar.controllers.core.push_protocol` (push survival rates over phases, seeds and forces).
"""

from . import pd as pd  # registers pd, spd, native_pd
from .action import Action
from .base import Controller, ControllerError, Gains, PoseTarget, ReferenceTarget, joint_error
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

__all__ = ["Action", "Character", "CharacterError", "Controller", "ControllerError",
           "ControllerSpec", "Gains", "NativePDController", "PDController", "PoseTarget",
           "ReferenceTarget", "RegistryError", "Result", "SimulationDiverged",
           "StablePDController", "default_timestep", "joint_error", "make_controller",
           "register"]
