"""The :class:`Action`: what a controller hands the
:class:`~mjchar.controllers.core.character.Character` once per control step (its own module so that
the Character and the Controller protocol can both use it without importing each other)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Action:
    """What a controller asks for during one control step.

    Attributes:
        torque: ``(nv,)`` generalised forces or ``None``. Actuated rows: joint torques (N m);
            unactuated rows (the root's 6): external wrench on the root (hand of god).
        target: ``(nu,)`` native position-actuator set-points (rad) or ``None``.
    """

    torque: np.ndarray | None = None
    target: np.ndarray | None = None
