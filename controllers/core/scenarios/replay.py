"""Playing a saved trajectory: the ``track`` scenario of a controller that brings its own start
state, control step and reference (a replay of a SAMCON or CMA-ES trajectory).

Such a controller has ``replay_setup(character, *, duration, reference, hold_last)`` returning a
:class:`ReplaySetup`; :func:`play` runs it from that start through
:func:`~mjchar.controllers.core.scenarios.shared.simulate` and adds what a replay reports beyond
the usual metrics (lowest root, flight, the root's distance from the reference at the end).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..character import Character
from ..metrics import Result
from .registry import ScenarioError
from .shared import PushEvent, simulate, with_push

__all__ = ["ReplaySetup", "play", "plays_itself"]


@dataclass
class ReplaySetup:
    """What a replay starts from: ``qpos (nq,)``, ``qvel (nv,)``, ``control_dt`` (s), the run's
    ``duration`` (s, already checked against the trajectory's end), the ``reference`` tracking
    errors are measured against (``None``: none), and ``info`` for the result's ``extra``."""

    qpos: np.ndarray
    qvel: np.ndarray
    control_dt: float
    duration: float
    reference: Any = None
    info: dict = field(default_factory=dict)


def plays_itself(controller) -> bool:
    """Whether ``controller`` brings its own start, control step and reference (a replay)."""
    return hasattr(controller, "replay_setup")


def play(character: Character, controller, *, duration: float | None = None,
         stop_on_fall: bool = True, frame_callback=None, reference=None,
         push: PushEvent | None = None, hold_last: bool = False, progress=None) -> Result:
    """Play ``controller``'s trajectory open-loop on ``character`` from its own start state
    (scenario ``"replay"``).

    ``extra`` holds ``min_root_height_m``, ``max_clearance_m`` (the largest height of the
    character's lowest point above the floor: flight), ``final_root_height_m``, with a
    reference ``final_root_error_m`` (3-D distance between the simulated and reference root at
    the end), and the controller's ``info``.
    """
    setup = controller.replay_setup(character, duration=duration, reference=reference,
                                    hold_last=hold_last)
    stats = {"min_root": math.inf, "clear": 0.0}

    def watch(ch: Character) -> None:
        stats["min_root"] = min(stats["min_root"], ch.state.root_height)
        stats["clear"] = max(stats["clear"], ch.poses.lowest_point(ch.state.qpos))
        if frame_callback is not None:
            frame_callback(ch)

    if push is not None and push.end > setup.duration + 1e-9:
        raise ScenarioError(f"the push ({push.time} s + {push.duration} s) ends after the "
                            f"replay ({setup.duration:.2f} s)")
    result = simulate(character, controller, duration=setup.duration, scenario="replay",
                      qpos=setup.qpos, qvel=setup.qvel, reference=setup.reference,
                      control_dt=setup.control_dt, stop_on_fall=stop_on_fall,
                      progress=progress, **with_push(push, {"frame_callback": watch}))
    if push is not None:
        result.push_N, result.push_direction_deg = float(push.force), float(push.direction)
    extra = {"min_root_height_m": stats["min_root"], "max_clearance_m": stats["clear"],
             "final_root_height_m": character.state.root_height, **setup.info}
    if setup.reference is not None:
        ref_root = setup.reference.body_positions(character.time)[character.root_body]
        extra["final_root_error_m"] = float(np.linalg.norm(character.state.root_position
                                                           - ref_root))
    result.extra.update(extra)
    return result
