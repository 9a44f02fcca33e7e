"""What a tracking policy observes: ``mjchar/Imitation-v0``'s observation, computed below the
environments so the env and the ``policy`` controller share it.

The observation at clip time ``t`` is, in order:

- the body features of :class:`~mjchar.controllers.core.observation.BodyObserver` (root height,
  body positions, x and z axes, linear and angular velocities in the heading frame);
- the phase ``phi`` of ``t`` in the clip as ``(cos a, sin a)``, ``a = 2 pi phi`` for a cyclic
  clip (``pi phi`` otherwise, :func:`clip_phase`);
- for each ``k`` in ``future_steps``, the reference pose ``k`` control steps ahead: every body's
  position relative to the *simulated* root, then every body's x axis, then its z axis, in the
  simulated character's heading frame (``9 K`` numbers).

Values are clipped to :meth:`TrackingObserver.bounds`.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import mujoco
import numpy as np

from ..core.character import Character
from ..core.errors import SimulationDiverged
from ..core.observation import OBS_POSITION_LIMIT, BodyObserver

__all__ = ["TrackingObserver", "clip_phase"]


def clip_phase(t: float, duration: float, cyclic: bool) -> float:
    """Phase of clip time ``t`` (s): ``(t / duration) mod 1`` for a cyclic clip, ``t /
    duration`` clipped to ``[0, 1]`` otherwise (0 for an empty clip)."""
    if duration <= 0:
        return 0.0
    if cyclic:
        return float((t / duration) % 1.0)
    return float(min(max(t / duration, 0.0), 1.0))


class TrackingObserver:
    """Observation of a character tracking ``reference`` (module docstring).

    Args:
        character: the character observed.
        reference: what it tracks (``duration``, ``cyclic`` and ``qpos(t)``, e.g. a
            ``ReferenceMotion``).
        future_steps: control steps ahead whose reference poses are observed.
        control_dt: seconds per control step (the ``k`` of ``future_steps`` are in them).
    """

    def __init__(self, character: Character, reference, future_steps=(),
                 control_dt: float = 1 / 30):
        self.model = character.model
        self.body = BodyObserver(character)
        self.reference = reference
        self.future_steps = tuple(int(k) for k in future_steps)
        self.control_dt = float(control_dt)
        self._fd = mujoco.MjData(self.model)
        k = self.body.n_bodies
        #: numbers after the body features
        self.n_extra = 2 + 9 * k * len(self.future_steps)
        #: length of :meth:`observe`
        self.size = self.body.size + self.n_extra
        lo, hi = self.bounds()
        self._low, self._high = lo, hi

    def extra_bounds(self) -> np.ndarray:
        """``(n_extra,)`` the bounds (``+-``) of the phase and future-pose features."""
        k = self.body.n_bodies
        fut = np.tile(np.concatenate([np.full(3 * k, OBS_POSITION_LIMIT), np.ones(6 * k)]),
                      len(self.future_steps))
        return np.concatenate([np.ones(2), fut])

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """``(low, high)``, each ``(size,)``."""
        lo, hi = self.body.bounds()
        e = self.extra_bounds()
        return np.concatenate([lo, -e]), np.concatenate([hi, e])

    def extra(self, data: mujoco.MjData, t: float,
              qpos_at: Callable[[float], np.ndarray] | None = None) -> np.ndarray:
        """``(n_extra,)`` the phase and future-pose features at clip time ``t`` (s) of the
        character in ``data``; ``qpos_at(t)``: the reference pose at a time (default the
        reference's own ``qpos``)."""
        ref = self.reference
        phi = clip_phase(t, ref.duration, ref.cyclic)
        a = (2.0 if ref.cyclic else 1.0) * math.pi * phi
        parts = [np.array([math.cos(a), math.sin(a)])]
        if not self.future_steps:
            return parts[0]
        qpos_at = ref.qpos if qpos_at is None else qpos_at
        H, r = self.body.frame(data)
        fd = self._fd
        for k in self.future_steps:
            fd.qpos[:] = qpos_at(t + k * self.control_dt)
            mujoco.mj_kinematics(self.model, fd)
            parts.append(self.body.pose(fd, H, r))
        return np.concatenate(parts)

    def observe(self, data: mujoco.MjData, t: float) -> np.ndarray:
        """``(size,)`` float32 observation at clip time ``t`` (clipped to the bounds);
        :class:`~mjchar.controllers.core.errors.SimulationDiverged` on a NaN."""
        x = self.body.observe(data, extra=self.n_extra)
        x[self.body.size:] = self.extra(data, t)
        np.maximum(x, self._low, out=x)
        np.minimum(x, self._high, out=x)
        if not math.isfinite(x.sum()):
            raise SimulationDiverged("non-finite observation", float(data.time))
        return x.astype(np.float32)
