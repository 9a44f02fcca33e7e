"""mjchar's dynamic layer (``mjchar.controllers``): everything that simulates, by concern.

- :mod:`~mjchar.controllers.core`: the :class:`Character` (the one door to MuJoCo), the
  Controller protocol, actions and gains, the controller and scenario registries, the run
  builder, the PD family, metrics, pushes and terrain.
- :mod:`~mjchar.controllers.balance`: hand-of-god and static balance.
- :mod:`~mjchar.controllers.walking`: SIMBICON and its gaits, IPM stepping, swing-foot
  trajectories.
- :mod:`~mjchar.controllers.sampling`: batched rollouts, executors, saved trajectories, SAMCON,
  CMA-ES, the MPC tracker.
- :mod:`~mjchar.controllers.learned`: learned tracking policies (``mjchar learn``) as
  controllers, numpy inference.

Importing the package imports the five subpackages, which registers every scenario and
controller. The Python entry points::

    from mjchar.controllers import Character, make_controller, run, run_scenario

    result = run("simbicon", "walk", speed=1.2, gait="natural", duration=20.0)  # as mjchar run

    character = Character()                                # the bundled humanoid
    walker = make_controller("simbicon", character, speed=1.2, gait="natural")
    result = run_scenario("walk", character, walker, duration=20.0)  # the same run, by hand
"""

# Registration order is the order of the CLI's choices and the bench's rows:
# isort: off
from . import core, balance, walking, sampling, learned  # noqa: F401  (fills the registries)
# isort: on
from .core import (
    Action,
    Character,
    ControllerSpec,
    Gains,
    MotionRecorder,
    Result,
    RunError,
    RunSpec,
    ScenarioSpec,
    default_timestep,
    make_controller,
    register,
    run,
    run_scenario,
    scenarios,
)
from .core import registry as registry

__all__ = ["Action", "Character", "ControllerSpec", "Gains", "MotionRecorder", "Result",
           "RunError", "RunSpec", "ScenarioSpec", "default_timestep", "make_controller",
           "register", "registry", "run", "run_scenario", "scenarios"]
