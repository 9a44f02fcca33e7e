"""``character.pushes``: external forces on a body for a time window, scheduled on a
:class:`~mjchar.controllers.core.character.Character` and written into MuJoCo's ``xfrc_applied``
(world-frame force at the body's centre of mass) for the physics steps they cover."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import mujoco
import numpy as np

from ..errors import CharacterError


@dataclass(frozen=True)
class Push:
    """A horizontal (or any) force on one body for a time window.

    Attributes:
        body: body name (a BVH joint name for converted models).
        force: ``(3,)`` world-frame force in N, applied at the body's centre of mass.
        start: simulated time (s) the push begins.
        duration: seconds it lasts.
    """

    body: str
    force: tuple[float, float, float]
    start: float
    duration: float

    @property
    def end(self) -> float:
        """Simulated time (s) the push ends."""
        return self.start + self.duration


class PushSchedule:
    """``character.pushes``: the pushes scheduled on one character; the Character's step writes
    the forces active at each physics step into ``xfrc_applied``.

    Args:
        data: the simulation's ``MjData`` (its ``xfrc_applied`` is written).
        body_id: the Character's body lookup (name -> id; unknown names raise).

    Attributes:
        scheduled: the scheduled :class:`Push` es, in order.
        applied: some force is currently written into ``xfrc_applied``.
        written: ``(nbody, 6)`` what the pushes wrote into ``xfrc_applied`` (zeros while
            none acts): the root-help check tells a declared push from outside help by it.
    """

    def __init__(self, data: mujoco.MjData, body_id: Callable[[str], int]):
        self._data = data
        self._lookup = body_id
        self.scheduled: list[Push] = []
        self.applied = False
        self.written = np.zeros_like(data.xfrc_applied)
        self._body_id: dict[str, int] = {}

    def add(self, body: str, force, duration: float, start: float | None = None) -> Push:
        """Schedule a force ``(3,)`` N (world frame) on ``body`` for ``duration`` s from ``start``
        s (default: now), applied at the body's centre of mass."""
        body_id = self._lookup(body)
        f = np.asarray(force, dtype=float)
        if f.shape != (3,) or not np.all(np.isfinite(f)):
            raise CharacterError(f"push force must be 3 finite numbers (N), got {force!r}")
        if not (math.isfinite(duration) and duration > 0):
            raise CharacterError(f"push duration must be positive seconds, got {duration}")
        start = float(self._data.time) if start is None else start
        p = Push(body, tuple(float(x) for x in f), float(start), float(duration))
        self._body_id[body] = int(body_id)
        self.scheduled.append(p)
        return p

    def active_force(self) -> np.ndarray:
        """``(3,)`` sum of the push forces (N) applied during the last step."""
        return self._data.xfrc_applied[:, :3].sum(axis=0)

    def clear(self) -> None:
        """Forget every push and stop any force being applied."""
        self.scheduled = []
        if self.applied:
            self._data.xfrc_applied[:] = 0
            self.written[:] = 0
            self.applied = False

    def any_between(self, t0: float, t1: float) -> bool:
        """Whether a push acts at some time in ``(t0, t1)`` (s)."""
        return any(p.start < t1 and p.end > t0 for p in self.scheduled)

    def apply(self, t: float) -> None:
        """Write the sum of the pushes active at time ``t`` (s) into ``xfrc_applied``."""
        xf, written = self._data.xfrc_applied, self.written
        xf[:] = 0
        on = False
        for p in self.scheduled:
            if p.start <= t < p.end:
                xf[self._body_id[p.body], :3] += p.force
                on = True
        if on or self.applied:
            written[:] = xf
        self.applied = on
