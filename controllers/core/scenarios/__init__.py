"""Scenarios: what happens to a controller, and what is measured.

Every scenario is one module plus one registration (:mod:`.registry`); the CLI, the bench, the
run builder (:mod:`~mjchar.controllers.core.builder`) and :func:`run_scenario` read the registry.

- :mod:`.shared`: the loop every scenario runs (:func:`simulate`), start states, pushes.
- :mod:`.standing`: ``stand``, ``push``, ``random-push``.
- :mod:`.locomotion`: ``track``, ``walk``, ``slopes``.
- :mod:`.push_search`: ``push-search``, the push-recovery protocol.
- :mod:`.terrain`: tilted floors, walk starts, pushes at a phase of the stride.
- :mod:`.hold`: the PD stability check (:func:`hold_pose`).

The most used names are re-exported here (``scenarios.stand``, ``scenarios.PushEvent``).
"""

# registration order is the order of the CLI's choices and the bench's columns
# isort: off
from . import standing, push_search, locomotion  # noqa: F401  (fills the scenario registry)
# isort: on
from .hold import HOLD_ERROR, HOLD_VELOCITY, HoldResult, hold_pose
from .locomotion import WALK_DURATION, slope_walk, track, walk
from .registry import Run, ScenarioError, ScenarioSpec, names, register, run_scenario
from .shared import (
    DIRECTIONS,
    PushEvent,
    heading_frame_direction,
    perturbed_start,
    simulate,
    standing_pose,
    survived,
    with_push,
)
from .standing import push, random_push, stand

__all__ = ["DIRECTIONS", "HOLD_ERROR", "HOLD_VELOCITY", "HoldResult", "PushEvent", "Run",
           "ScenarioError", "ScenarioSpec", "WALK_DURATION", "heading_frame_direction",
           "hold_pose", "names", "perturbed_start", "push", "random_push", "register",
           "run_scenario", "simulate", "slope_walk", "stand", "standing_pose", "survived",
           "track", "walk", "with_push"]
