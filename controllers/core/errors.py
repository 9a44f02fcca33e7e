"""The simulation's exceptions: :class:`CharacterError` (a Character asked for something the
model does not have) and :class:`SimulationDiverged` (the physics blew up)."""

from __future__ import annotations

from mjchar.bvh.errors import MjcharError


class CharacterError(MjcharError):
    """A Character was asked for something the model does not have (unknown joint, bad shape)."""


class SimulationDiverged(MjcharError):
    """The simulation blew up: NaN or exploding velocities (or MuJoCo reset a bad state).

    Scenarios catch it and report a failure; it never escapes as a crash or a silent NaN.

    Attributes:
        time: simulated time (s) at which the divergence was detected.
        reason: what was detected.
    """

    def __init__(self, reason: str, time: float):
        self.reason = reason
        self.time = float(time)
        super().__init__(f"simulation diverged at t={time:.4f} s: {reason}")
