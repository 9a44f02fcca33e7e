"""mjchar's dynamic layer: everything that simulates, in subpackages by concern.

- :mod:`mjchar.controllers.core`: the :class:`~mjchar.controllers.core.character.Character` (the one
  door to
  MuJoCo), the Controller protocol, actions and gains, the controller registry, the PD family,
  scenarios, metrics, pushes and terrain.
- :mod:`mjchar.controllers.balance`: hand-of-god and static balance.
- :mod:`mjchar.controllers.walking`: SIMBICON and its gaits, IPM stepping, swing-foot trajectories.
- :mod:`mjchar.controllers.sampling`: batched rollouts, executors, saved trajectories, SAMCON,
  CMA-ES.

Importing the package imports the four subpackages, which registers every controller
(:mod:`mjchar.controllers.core.registry`). The most used names are re-exported here.
"""

# Registration order is the order of the CLI's choices and the bench's rows:
# isort: off
from . import core, balance, walking, sampling  # noqa: F401  (fills the controller registry)
# isort: on
from .core import (
    Action,
    Character,
    ControllerSpec,
    Gains,
    Result,
    default_timestep,
    make_controller,
    register,
)
from .core import registry as registry

__all__ = ["Action", "Character", "ControllerSpec", "Gains", "Result", "default_timestep",
           "make_controller", "register", "registry"]
