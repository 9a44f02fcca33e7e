"""Dynamic similarity: how a walker's dimensional parameters carry from the body they were tuned
on to another body, shared by SIMBICON's gaits and IPM stepping's parameters.

With ``l`` the leg-length ratio and ``m`` the mass ratio (new body / tuned body), a body that
moves the same way in Froude-scaled time has lengths x ``l``, times and speeds x ``sqrt(l)``,
rates (1/s) x ``1/sqrt(l)``, per-length gains x ``1/l``, torque stiffness and torques x ``m l``,
damping x ``m l sqrt(l)`` and forces x ``m``; angles, phases and scales are unchanged.
"""

from __future__ import annotations

import math


def similarity_factors(length_ratio: float, mass_ratio: float) -> dict[str, float]:
    """The factor of each kind of quantity (``length``, ``time``, ``speed``, ``rate``,
    ``per_length``, ``torque_gain``, ``damping_gain``, ``force``, ``torque``)."""
    t = math.sqrt(length_ratio)
    return {"length": length_ratio, "time": t, "speed": t, "rate": 1 / t,
            "per_length": 1 / length_ratio, "torque_gain": mass_ratio * length_ratio,
            "damping_gain": mass_ratio * length_ratio * t, "force": mass_ratio,
            "torque": mass_ratio * length_ratio}
