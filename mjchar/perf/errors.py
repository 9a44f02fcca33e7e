"""The measurement package's exceptions and argument checks."""

from __future__ import annotations

import numpy as np

from mjchar.bvh.errors import MjcharError

__all__ = ["PerfError", "PerfUnavailable", "positive_int"]


class PerfError(MjcharError):
    """A performance measurement was given impossible settings."""


class PerfUnavailable(PerfError):
    """An optional measurement cannot run here (missing package or module); the message says
    why and what to install."""


def positive_int(n, what: str) -> int:
    """``n`` as an ``int``; :class:`PerfError` unless it is a positive integer."""
    if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 1:
        raise PerfError(f"{what} must be a positive integer, got {n!r}")
    return int(n)
