"""The bounds every run keeps, however it was described (``mjchar run``, the bench, the Python
API, a saved trajectory): a value outside them is a one-line error before anything is
simulated, not a run that never ends.

- :data:`MIN_TIMESTEP_S`, :data:`MAX_TIMESTEP_S`: the physics time step. Below 1e-5 s a second
  of simulation is over 1e5 steps (minutes of wall time for nothing: the controllers here are
  stable at 0.5-2 ms); above 0.01 s explicit contact dynamics are unstable.
- :data:`MAX_CONTROL_DT_S`: seconds between control steps (a tenth of a second is already
  slower than any controller here replans or tracks).
- :data:`MAX_DURATION_S`: simulated seconds of one run, given or implied (a clip's length, a
  trajectory's): an hour.
"""

from __future__ import annotations

import math

MIN_TIMESTEP_S = 1e-5
MAX_TIMESTEP_S = 0.01
MAX_CONTROL_DT_S = 0.1
MAX_DURATION_S = 3600.0


def timestep_problem(value) -> str | None:
    """What is wrong with a physics time step (s), in words, or ``None``."""
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        return f"must be a finite number of seconds, got {value!r}"
    if not MIN_TIMESTEP_S <= value <= MAX_TIMESTEP_S:
        return f"must be between {MIN_TIMESTEP_S:g} and {MAX_TIMESTEP_S:g} s, got {value:g}"
    return None


def control_dt_problem(value, timestep: float | None = None) -> str | None:
    """What is wrong with a control step (s) over physics steps of ``timestep`` s, or ``None``."""
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        return f"must be a finite number of seconds, got {value!r}"
    if not 0 < value <= MAX_CONTROL_DT_S:
        return f"must be > 0 and at most {MAX_CONTROL_DT_S:g} s, got {value:g}"
    if timestep is not None and value < timestep - 1e-12:
        return f"{value:g} s is shorter than the physics step {timestep:g} s"
    return None


def duration_problem(value) -> str | None:
    """What is wrong with a run's length (s), or ``None``."""
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        return f"must be a finite number of seconds, got {value!r}"
    if not 0 < value <= MAX_DURATION_S:
        return f"must be > 0 and at most {MAX_DURATION_S:g} s, got {value:g}"
    return None
