"""The one timing primitive of :mod:`mjchar.perf`, and the schedules built on it.

:func:`timed` calls a function once and reads three clocks around the call:

- ``wall_s``: ``time.perf_counter``, elapsed time (what a user waits for; counts preemption);
- ``cpu_s``: ``time.process_time``, CPU time of the whole process (every thread: batched
  rollouts' worker threads count, so ``cpu_s / wall_s`` is the number of cores kept busy);
- ``thread_s``: ``time.thread_time``, CPU time of the calling thread only (not inflated when
  other processes preempt it: the least noisy clock for single-threaded work on a shared
  machine).

Every measurement of the package times through :func:`timed`, directly or through
:func:`rounds`, and says which clock it reads. Figures are ratios or rates measured in the same
run: the cases of a comparison take turns (:func:`rounds`) so that a drifting machine load
spreads evenly over them, and a speed is reported beside bare ``mj_step`` measured alongside.
"""

from __future__ import annotations

import gc
import math
import os
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from .errors import PerfError, positive_int

__all__ = ["CLOCKS", "Timing", "Runs", "Laps", "PhysicsClock", "timed", "rounds", "load_average"]

#: the clocks a :class:`Timing` holds (attribute names)
CLOCKS = ("wall_s", "cpu_s", "thread_s")


@dataclass(frozen=True)
class Timing:
    """Seconds one call took on each clock (see the module docstring); timings add up."""

    wall_s: float = 0.0
    cpu_s: float = 0.0
    thread_s: float = 0.0

    def __add__(self, other: Timing) -> Timing:
        return Timing(self.wall_s + other.wall_s, self.cpu_s + other.cpu_s,
                      self.thread_s + other.thread_s)

    def on(self, clock: str) -> float:
        """Seconds on ``clock`` (one of :data:`CLOCKS`)."""
        if clock not in CLOCKS:
            raise PerfError(f"unknown clock {clock!r}; choose from {', '.join(CLOCKS)}")
        return getattr(self, clock)


def timed(fn: Callable[..., Any], *args, **kwargs) -> tuple[Any, Timing]:
    """``(fn(*args, **kwargs), Timing)``: one call, timed on the three clocks (the wall clock
    read first and last, so it encloses the CPU clocks)."""
    w0 = time.perf_counter()
    c0 = time.process_time()
    t0 = time.thread_time()
    out = fn(*args, **kwargs)
    t1 = time.thread_time()
    c1 = time.process_time()
    w1 = time.perf_counter()
    return out, Timing(w1 - w0, c1 - c0, t1 - t0)


@dataclass
class Runs:
    """Every timed call of one case of :func:`rounds`, in order (with what each returned, when
    asked to keep it)."""

    timings: list[Timing] = field(default_factory=list)
    results: list[Any] = field(default_factory=list)

    def _order(self, clock: str) -> list[int]:
        if not self.timings:
            raise PerfError("no timed runs")
        return sorted(range(len(self.timings)), key=lambda i: self.timings[i].on(clock))

    def best(self, clock: str = "wall_s") -> Timing:
        """The fastest run on ``clock`` (its other clocks come with it)."""
        return self.timings[self._order(clock)[0]]

    def median(self, clock: str = "wall_s") -> Timing:
        """The median run on ``clock`` (the upper one of an even count)."""
        order = self._order(clock)
        return self.timings[order[len(order) // 2]]

    def total(self) -> Timing:
        out = Timing()
        for t in self.timings:
            out = out + t
        return out


def rounds(cases: Mapping[str, Callable[[], Any]], *, repeats: int = 1,
           budget_s: float | None = None, max_rounds: int | None = None,
           calls: Mapping[str, int] | None = None, warmup: bool = False,
           before: Callable[[str], None] | None = None, gc_off: bool = False,
           keep_results: bool = False) -> dict[str, Runs]:
    """Time ``cases`` taking turns: each round calls every case in order (``calls[name]`` times,
    default once), each call timed by :func:`timed`.

    Args:
        cases: ``{name: fn}``, called with no arguments.
        repeats: rounds at least.
        budget_s: go on with more rounds until about this many wall seconds have passed (at
            least ``repeats`` rounds, at most ``max_rounds``); ``None``: exactly ``repeats``.
        max_rounds: cap on rounds with a budget.
        calls: calls of a case per round (e.g. more of a fast case than of a slow one).
        warmup: call every case once first, untimed.
        before: called with the case's name before each call, untimed (a reset).
        gc_off: garbage collection off while timing (as :mod:`timeit` does).
        keep_results: keep what each call returned in :attr:`Runs.results` (by default they
            are dropped at once, so that big results do not pile up).
    Returns:
        ``{name: Runs}``.
    """
    repeats = positive_int(repeats, "repeats")
    if budget_s is not None and not (math.isfinite(budget_s) and budget_s > 0):
        raise PerfError(f"budget_s must be positive seconds, got {budget_s!r}")
    calls = dict(calls or {})
    out = {name: Runs() for name in cases}
    if warmup:
        for name, fn in cases.items():
            if before is not None:
                before(name)
            fn()
    start = time.perf_counter()
    was_enabled = gc.isenabled()
    if gc_off:
        gc.collect()
        gc.disable()
    try:
        r = 0
        while True:
            for name, fn in cases.items():
                for _ in range(calls.get(name, 1)):
                    if before is not None:
                        before(name)
                    result, t = timed(fn)
                    out[name].timings.append(t)
                    if keep_results:
                        out[name].results.append(result)
                    del result
            r += 1
            if r >= repeats and (budget_s is None or time.perf_counter() - start > budget_s
                                 or (max_rounds is not None and r >= max_rounds)):
                break
    finally:
        if gc_off and was_enabled:
            gc.enable()
    return out


class Laps:
    """A callback that reads the process CPU clock (``time.process_time``) at every call, for
    timing a loop from inside (a run's ``frame_callback``: called after the reset and after
    every control step).

    :attr:`span` is the CPU seconds from the first call to the last, less the callbacks' own
    cost (:meth:`overhead`, measured once per process): what the loop between them cost.
    """

    _cost: float | None = None

    def __init__(self) -> None:
        self.first: float | None = None
        self.last: float | None = None
        self.calls = 0

    def __call__(self, *_args) -> None:
        t = time.process_time()
        if self.first is None:
            self.first = t
        self.last = t
        self.calls += 1

    @classmethod
    def overhead(cls, calls: int = 20000) -> float:
        """CPU seconds one call adds to the loop it times (the smallest of three measurements
        of ``calls`` calls in a row)."""
        if cls._cost is None:
            best = math.inf
            for _ in range(3):
                laps = cls()
                for _ in range(calls):
                    laps()
                best = min(best, (laps.last - laps.first) / (calls - 1))
            cls._cost = best
        return cls._cost

    @property
    def span(self) -> float:
        """CPU seconds between the first and the last call, less the calls' own cost."""
        if self.first is None or self.calls < 2:
            raise PerfError("Laps was called fewer than twice")
        return max(self.last - self.first - (self.calls - 1) * self.overhead(), 0.0)


class PhysicsClock:
    """Process CPU seconds spent inside MuJoCo's stepping functions (``mj_step``, ``mj_step1``,
    ``mj_step2``) called through the name ``mujoco`` of some modules, while active.

    A context manager: on entry, each module's global ``mujoco`` is replaced by a stand-in that
    forwards every attribute to the real module and times the three stepping functions (two
    clock reads around each call); on exit the modules get the real one back. For measurements
    only. The timing's own cost lands outside the timed intervals: :meth:`overhead` measures it
    per call, and :meth:`share` takes it out of the loop's time.
    """

    STEPPING = ("mj_step", "mj_step1", "mj_step2")
    _cost: float | None = None

    def __init__(self, *modules):
        self.modules = modules
        self.cpu_s = 0.0
        self.calls = 0
        self._saved: list = []

    @classmethod
    def overhead(cls, calls: int = 20000) -> float:
        """CPU seconds the timing adds per stepping call outside the timed interval (the
        smallest of three measurements of ``calls`` timed calls of a function that does
        nothing, less the time inside them)."""
        if cls._cost is None:
            import types

            best = math.inf
            for _ in range(3):
                fake = types.SimpleNamespace(**{n: (lambda *a, **k: None) for n in cls.STEPPING})
                holder = types.SimpleNamespace(mujoco=fake)
                with cls(holder) as clock:
                    step = holder.mujoco.mj_step
                    t0 = time.process_time()
                    for _ in range(calls):
                        step()
                    total = time.process_time() - t0
                best = min(best, max(total - clock.cpu_s, 0.0) / calls)
            cls._cost = best
        return cls._cost

    def share(self, loop_cpu_s: float) -> float:
        """The fraction of a loop's CPU seconds ``loop_cpu_s`` (timed around the loop while this
        clock was active) spent inside the stepping functions, the timing's own cost taken out
        of the loop's time."""
        return self.cpu_s / max(loop_cpu_s - self.calls * self.overhead(), 1e-12)

    def __enter__(self) -> PhysicsClock:
        clock = self

        class _Timed:
            def __init__(self, real):
                self._real = real
                for name in PhysicsClock.STEPPING:
                    setattr(self, name, self._timer(getattr(real, name)))

            @staticmethod
            def _timer(fn):
                def call(*args, **kwargs):
                    t0 = time.process_time()
                    try:
                        return fn(*args, **kwargs)
                    finally:
                        clock.cpu_s += time.process_time() - t0
                        clock.calls += 1
                return call

            def __getattr__(self, name):
                return getattr(self._real, name)

        self._saved = [(m, m.mujoco) for m in self.modules]
        for m, real in self._saved:
            m.mujoco = _Timed(real)
        return self

    def __exit__(self, *exc) -> None:
        for m, real in self._saved:
            m.mujoco = real
        self._saved = []


def load_average() -> float | None:
    """The 1-minute load average (other processes sharing the cores), or ``None``."""
    try:
        return float(os.getloadavg()[0])
    except (AttributeError, OSError):
        return None
