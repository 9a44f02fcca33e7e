"""Settings of ``mjchar bench``: the scenarios, durations, seeds and search settings
(:class:`BenchConfig`, :func:`quick_config`, :func:`full_config`), the performance section's
(:class:`PerfConfig`), the paths the bench reads, and the JSON helpers every part shares."""

from __future__ import annotations

import math
import os
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from mjchar.bvh.errors import MjcharError
from mjchar.controllers.core.scenarios.push_search import PushProtocol
from mjchar.controllers.core.scenarios.shared import DIRECTIONS
from mjchar.perf.report import ROOT, SHARED_BVH  # noqa: F401  (the project root, the shared clips)

#: the results document's JSON Schema, package data of ``mjchar.bench``
SCHEMA_PATH = Path(__file__).with_name("schema.json")
SCHEMA_NAME = "mjchar-bench"
SCHEMA_VERSION = 1

DIRECTION_NAMES = tuple(DIRECTIONS)  # (the scenarios' table: forward, left, backward, right)
#: the reference machine of the bench's stated run times: one core does this many bare
#: ``mj_step`` per second of the bundled humanoid (``performance.raw``), and it has
#: ``REFERENCE_CORES`` cores
REFERENCE_STEPS_PER_S = 30_000
REFERENCE_CORES = 2
#: keys of a run's result that are timings (the rest is physics, identical for equal seeds)
TIMING_KEYS = ("wall_s", "steps_per_s")


class BenchError(MjcharError):
    """The benchmark was asked for something impossible (unknown controller or scenario, bad
    option, an output folder that cannot be written)."""


@dataclass
class PerfConfig:
    """Settings of the performance section (see :mod:`mjchar.perf`).

    Attributes:
        raw_steps, raw_repeats: bare ``mj_step`` throughput run length and repeats.
        cost_steps, cost_repeats: physics steps and repeats of each controller's step cost.
        rollout_samples, rollout_steps, rollout_repeats, rollout_threads: batched rollouts.
        env_steps, env_repeats: env throughput (env steps per env per round, rounds).
        bvh_budget_s: seconds of timing per BVH file.
        envelope_duration_s, envelope_grid, envelope_finer, envelope_kps: the PD stability
            envelope (:func:`mjchar.perf.stability_envelope`).
    """

    raw_steps: int = 5000
    raw_repeats: int = 5
    cost_steps: int = 2000
    cost_repeats: int = 5
    rollout_samples: int = 256
    rollout_steps: int = 50
    rollout_repeats: int = 3
    rollout_threads: tuple[int, ...] = (1, 2)
    env_steps: int = 2000
    env_repeats: int = 3
    bvh_budget_s: float = 1.0
    envelope_duration_s: float = 5.0
    envelope_grid: tuple[int, ...] = (2000, 1500, 1000, 750, 500, 360, 240, 180, 120, 90, 60,
                                      45, 30)
    envelope_finer: tuple[int, ...] = (8000, 6000, 4000, 3000, 2500)
    envelope_kps: tuple[float, ...] = (300.0, 1000.0, 3000.0)


@dataclass
class BenchConfig:
    """Durations, seeds and search settings of a bench run (SI units: s, N, m, deg).

    Use :func:`full_config` or :func:`quick_config`, then ``dataclasses.replace`` for changes.
    """

    quick: bool = False
    seeds: tuple[int, ...] = (0, 1, 2)
    stand_duration: float = 10.0
    random_push_duration: float = 30.0
    random_push_force: float = 10.0
    push_phases: int = 8
    push_seeds: int = 5
    push_directions: tuple[str, ...] = DIRECTION_NAMES
    push_standing_cap: float = 600.0
    push_walking_cap: float = 800.0
    push_resolution: float = 50.0
    push_after: float = 5.0
    push_after_walking: float | None = None
    push_warmup: float = 4.0
    push_full_curves: bool = True
    walk_duration: float = 30.0
    steady_window: float = 10.0
    slope_degrees: float = 5.0
    slope_distance: float = 10.0
    slope_duration: float = 20.0
    ipm_speed: float = 1.0
    gait_speed: float = 1.2
    gait_gaits: tuple[str, ...] = ("walk", "natural")
    track_duration: float | None = None
    sample_rate: float = 20.0
    fps: float = 30.0
    perf: PerfConfig = field(default_factory=PerfConfig)

    def check(self) -> BenchConfig:
        """Raise :class:`BenchError` on impossible settings; returns self."""
        if not self.seeds or any(not isinstance(s, int | np.integer) or s < 0
                                 for s in self.seeds):
            raise BenchError(f"seeds must be non-negative integers, got {self.seeds!r}")
        for name in ("stand_duration", "random_push_duration", "walk_duration",
                     "slope_duration", "push_standing_cap", "push_walking_cap",
                     "push_resolution", "push_after", "push_warmup", "sample_rate", "fps",
                     "random_push_force", "ipm_speed", "gait_speed"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise BenchError(f"{name} must be a positive number, got {v!r}")
        self._check_gait_gaits()
        w = self.push_after_walking
        if w is not None and not (isinstance(w, int | float) and math.isfinite(w) and w > 0):
            raise BenchError(f"push_after_walking must be a positive number or None, got {w!r}")
        if not (0 < abs(self.slope_degrees) < 45):
            raise BenchError(f"slope_degrees must be in (0, 45), got {self.slope_degrees}")
        bad = [d for d in self.push_directions if d not in DIRECTION_NAMES]
        if bad or not self.push_directions:
            raise BenchError(f"push directions must be among {', '.join(DIRECTION_NAMES)}, "
                             f"got {self.push_directions!r}")
        for name in ("push_phases", "push_seeds"):
            if getattr(self, name) < 1:
                raise BenchError(f"{name} must be at least 1")
        return self

    def _check_gait_gaits(self) -> None:
        """``gait_gaits``: a sequence of known gaits that take a speed command."""
        from mjchar.controllers.walking.gaits import GaitError, get_gait

        gaits = self.gait_gaits
        if isinstance(gaits, str) or not isinstance(gaits, tuple | list) or not gaits:
            raise BenchError(f"gait_gaits must be a list of gait names, got {gaits!r}")
        for name in gaits:
            try:
                gait = get_gait(name)
            except GaitError as e:
                raise BenchError(f"gait_gaits: {e}") from None
            if gait.froude is None:
                raise BenchError(f"gait_gaits: the {name!r} gait takes no speed command, so it "
                                 f"cannot walk at gait_speed")

    def push_protocol(self, mode: str = "standing") -> PushProtocol:
        """The push protocol of the push-search cells (``mode``: the controller's push mode,
        ``"standing"`` or ``"walking"``: the grid's cap differs)."""
        cap = self.push_walking_cap if mode == "walking" else self.push_standing_cap
        after = (self.push_after_walking if mode == "walking"
                 and self.push_after_walking is not None else self.push_after)
        return PushProtocol.grid(cap, min(self.push_resolution, cap), phases=self.push_phases,
                                 seeds=tuple(range(self.push_seeds)),
                                 directions=tuple(self.push_directions), after=after,
                                 warmup=self.push_warmup, full_curves=self.push_full_curves)

    def to_dict(self) -> dict:
        return json_ready(asdict(self))


def full_config(seeds: int | None = None) -> BenchConfig:
    """The full benchmark: the push protocol at 8 phases x 5 seeds on a 50 N grid (45 minutes
    for the push cells alone on two cores); ``seeds`` = how many for the seeded scenarios
    (default 3)."""
    c = BenchConfig()
    return c if seeds is None else replace(c, seeds=tuple(range(_count(seeds))))


def quick_config(seeds: int | None = None) -> BenchConfig:
    """The same cells, cheaper (``mjchar bench --quick``): short durations, the push protocol at
    4 phases x 2 seeds on a 50 N grid, 3 s after a push while walking (5 s standing: the PD
    trackers fall unpushed within 5 s), each curve up to its first rate below 90 %, quick
    performance runs, 2 seeds by default (docs/bench.md states what it takes)."""
    perf = PerfConfig(raw_steps=2000, raw_repeats=3, cost_steps=300, cost_repeats=3,
                      rollout_samples=64, rollout_steps=50, rollout_repeats=2,
                      env_steps=300, env_repeats=2, bvh_budget_s=0.15,
                      envelope_duration_s=2.0,
                      envelope_grid=(2000, 1000, 500, 240, 120, 60, 30),
                      envelope_finer=(8000, 4000))
    c = BenchConfig(quick=True, seeds=(0, 1), stand_duration=10.0, random_push_duration=10.0,
                    push_phases=4, push_seeds=2, push_standing_cap=500.0,
                    push_walking_cap=600.0, push_resolution=50.0, push_after_walking=3.0,
                    push_full_curves=False,
                    walk_duration=10.0, steady_window=4.0, slope_distance=3.0,
                    slope_duration=8.0, perf=perf)
    return c if seeds is None else replace(c, seeds=tuple(range(_count(seeds))))


def _count(n) -> int:
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise BenchError(f"the number of seeds must be a positive integer, got {n!r}")
    return n


def json_ready(v):
    """JSON-ready copy: numpy scalars and arrays to Python, non-finite floats to ``None``,
    tuples to lists, paths to strings."""
    if isinstance(v, dict):
        return {str(k): json_ready(x) for k, x in v.items()}
    if isinstance(v, list | tuple | np.ndarray):
        return [json_ready(x) for x in v]
    if isinstance(v, bool | np.bool_):
        return bool(v)
    if isinstance(v, int | np.integer):
        return int(v)
    if isinstance(v, float | np.floating):
        v = float(v)
        return v if math.isfinite(v) else None
    if isinstance(v, Path):
        return str(v)
    return v


def relative_path(p: Path) -> str:
    """``p`` relative to the project root (``assets/...``, or ``../shared/...`` for a folder
    beside it), so that a results document names no folder of the machine it ran on; a path
    elsewhere is returned as given."""
    path = Path(p).resolve()
    if path.is_relative_to(ROOT.parent):
        return os.path.relpath(path, ROOT)
    return str(p)


