"""The ``push-search`` scenario: the push-recovery protocol, survival rates over phases, seeds and
a force grid.

Every push-robustness figure mjchar reports (``mjchar bench``, ``mjchar run ... --scenario
push-search``, the tests) is measured here, the way the literature reports it (a fixed force and
duration at several phases of the gait, in several directions, over several seeds; e.g. Park et
al. 2022; SIMBICON's 350 N x 0.2 s):

1. **One run**: a controller from the registry, one force ``F`` (N), one direction (degrees in
   the heading frame: 0 forward, 90 left, 180 backward, 270 right), one phase, one seed, a push
   of ``push_duration`` s.

   - Walking controllers (``spec.push == "walking"``): they walk from their own seeded start
     state; the push hits the chest at the given fraction of the first stride that starts after
     ``warmup`` s (:func:`~mjchar.controllers.core.scenarios.terrain.push_walk`). Survived: no fall,
     and still walking (mean speed >= 0.3 m/s over the last 5 s).
   - Standing controllers: they start from the standing pose with seeded uniform joint offsets
     of at most ``perturbation`` rad; the push hits the pelvis at ``first_moment + phase`` s
     (the K moments spread over one second). Survived: no fall, and no foot moved more than
     5 cm unless the controller recovers by stepping (``spec.steps``).

   Every run lasts until ``after`` s after the push ends.
2. **The unpushed check**: each seed is also run with no push over the same window. If the
   controller falls unpushed at any seed, its push figures mean nothing and the measurement says
   ``falls unpushed`` instead.
3. **A cell** (direction, force): the survival rate over ``phases`` x ``seeds`` runs.
4. **The curve** per direction: cells at every force of the grid (``resolution``,
   ``2 resolution``, ... up to ``cap``), from the smallest; a direction stops after its first
   force with rate 0 (no larger force changes the figures below), or, with ``full_curves``
   off, after its first force with rate below 90 % (the figures are already settled there;
   only the curve's tail is not measured).
5. **The figures** per direction: the largest force with survival rate 100 % is the largest grid
   force ``F`` such that every grid force up to ``F`` had rate 100 % (survival need not be
   monotone in force: a failure at a smaller force caps the figure even when a larger force
   survives); likewise the largest force with rate >= 90 %. 0 means the smallest grid force
   already failed; a figure equal to the cap is marked ``at_cap`` (the controller may survive
   more).

Runs are independent and deterministic; ``processes > 1`` spreads them over worker processes,
or ``mapper`` hands them to a pool of the caller's (identical results). Each run rebuilds the
controller from the run's description (:class:`~mjchar.controllers.core.builder.RunSpec`), in
whichever process it runs.
"""

from __future__ import annotations

import contextlib
import math
import os
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from mjchar.bvh.errors import MjcharError

from ..character import Character
from ..metrics import Result
from ..workers import process_pool
from .options import MAX_FORCE, PHASES, PUSH_DURATION, SEEDS, TOLERANCE
from .registry import ScenarioError, ScenarioSpec, register
from .shared import DIRECTIONS, perturbed_start, standing_pose, survived
from .standing import push
from .terrain import push_walk, stride_phases


class PushProtocolError(MjcharError):
    """An impossible protocol (empty grid, bad phases or seeds, unknown direction)."""


@dataclass(frozen=True)
class PushProtocol:
    """How push robustness is measured (see the module docstring for what each field does).

    Attributes:
        forces: the force grid (N), ascending and positive; :meth:`grid` builds the usual one.
        phases: K, the phases of the stride (walkers) or moments (standing) pushed at.
        seeds: S seeds of the start-state perturbation.
        directions: names from :data:`~mjchar.controllers.core.scenarios.DIRECTIONS`.
        push_duration: s.
        after: s simulated after the push ends.
        warmup: walkers: the push falls in the first stride starting after this many s.
        first_moment: standing: the first push moment (s); the others follow every 1/K s.
        perturbation: standing: largest seeded joint offset of the start pose (rad).
        full_curves: measure each direction's curve down to rate 0; ``False``: stop after the
            first force below 90 % (same figures, fewer runs).
    """

    forces: tuple[float, ...]
    phases: int = 4
    seeds: tuple[int, ...] = (0, 1)
    directions: tuple[str, ...] = tuple(DIRECTIONS)
    push_duration: float = 0.2
    after: float = 5.0
    warmup: float = 4.0
    first_moment: float = 1.0
    perturbation: float = 0.02
    full_curves: bool = True

    @classmethod
    def grid(cls, cap: float, resolution: float, **kw) -> PushProtocol:
        """The grid ``resolution, 2 resolution, ..., cap`` (N); other fields as keywords."""
        if not (math.isfinite(cap) and math.isfinite(resolution) and 0 < resolution <= cap):
            raise PushProtocolError(f"need 0 < resolution <= cap, got resolution {resolution} "
                                    f"and cap {cap}")
        n = int(math.floor(cap / resolution + 1e-9))
        forces = [resolution * k for k in range(1, n + 1)]
        if cap - forces[-1] > 1e-9:
            forces.append(cap)
        return cls(forces=tuple(float(f) for f in forces), **kw).check()

    def check(self) -> PushProtocol:
        """Raise :class:`PushProtocolError` on an impossible protocol; returns self."""
        f = np.asarray(self.forces, dtype=float)
        if f.ndim != 1 or len(f) == 0 or not np.all(np.isfinite(f)) or np.any(f <= 0) \
                or np.any(np.diff(f) <= 0):
            raise PushProtocolError(f"forces must be positive and ascending, got {self.forces}")
        if not (isinstance(self.phases, int) and self.phases >= 1):
            raise PushProtocolError(f"phases must be a whole number >= 1, got {self.phases}")
        if not self.seeds or any(not isinstance(s, int | np.integer) or s < 0
                                 for s in self.seeds):
            raise PushProtocolError(f"seeds must be non-negative integers, got {self.seeds}")
        bad = [d for d in self.directions if d not in DIRECTIONS]
        if bad or not self.directions:
            raise PushProtocolError(f"directions must be among {', '.join(DIRECTIONS)}, got "
                                    f"{self.directions}")
        for name in ("push_duration", "after", "warmup", "first_moment"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise PushProtocolError(f"{name} must be a positive number of seconds, got {v}")
        if not (math.isfinite(self.perturbation) and self.perturbation >= 0):
            raise PushProtocolError(f"perturbation must be >= 0 rad, got {self.perturbation}")
        return self

    @property
    def cap(self) -> float:
        """The largest force of the grid (N)."""
        return float(self.forces[-1])

    @property
    def resolution(self) -> float:
        """The grid step (N): the smallest force."""
        return float(self.forces[0])

    def phase_values(self) -> list[float]:
        """The K phases ``0, 1/K, ..., (K-1)/K`` (``terrain.stride_phases``)."""
        return stride_phases(self.phases)

    def describe(self, mode: str = "standing", steps: bool = False) -> str:
        """The protocol in one sentence (what the bench table and the docs print)."""
        where = (f"on the chest at {self.phases} phases of the stride (after a {self.warmup:g} s "
                 "warm-up), survived = no fall and still walking" if mode == "walking" else
                 f"on the pelvis at {self.phases} moments {self.first_moment:g}-"
                 f"{self.first_moment + (self.phases - 1) / self.phases:g} s, survived = no fall"
                 + ("" if steps else " and no step"))
        return (f"{self.push_duration:g} s pushes {where}, {self.after:g} s after the push; "
                f"rate over {self.phases} x {len(self.seeds)} seeds; grid "
                f"{self.resolution:g}-{self.cap:g} N in {self.resolution:g} N steps"
                + ("" if self.full_curves else ", each curve up to its first rate below 90 %"))

    def to_dict(self) -> dict:
        d = asdict(self)
        d["forces"] = list(self.forces)
        d["seeds"] = [int(s) for s in self.seeds]
        d["directions"] = list(self.directions)
        return d


@dataclass(frozen=True)
class PushTask:
    """One run of the protocol (picklable: the worker rebuilds the character and controller
    from ``run``, a :class:`~mjchar.controllers.core.builder.RunSpec`, or a registered
    controller's name on the bundled humanoid)."""

    run: object
    direction: str
    force: float
    phase: float
    seed: int
    protocol: PushProtocol

    def __post_init__(self) -> None:
        if isinstance(self.run, str):
            from ..builder import RunSpec

            object.__setattr__(self, "run", RunSpec(self.run, "push-search"))


def simulate_push(task: PushTask, frame_callback=None) -> tuple[Result, bool]:
    """Simulate one :class:`PushTask` (a fresh character and controller); returns the
    :class:`~mjchar.controllers.core.metrics.Result` and whether the push was survived (see the
    module docstring). ``frame_callback(character)`` is called after every control step."""
    spec = task.run.controller_spec
    p = task.protocol
    ch = Character(task.run.model, timestep=task.run.timestep)
    deg = DIRECTIONS[task.direction]
    if spec.push == "walking":
        ctrl = task.run.make_controller(ch)
        r = push_walk(ch, ctrl, force=task.force, direction=deg, phase=task.phase,
                      push_duration=p.push_duration, warmup=p.warmup, after=p.after,
                      seed=task.seed, frame_callback=frame_callback)
        return r, bool(r.extra["walking_after"])
    pose = standing_pose(ch)
    ctrl = task.run.make_controller(ch, target=pose)
    push_time = p.first_moment + task.phase
    start = perturbed_start(ch, pose, None, task.seed, joint_noise=p.perturbation,
                            root_velocity_noise=0.0, distribution="uniform")
    r = push(ch, ctrl, force=task.force, direction=deg, push_duration=p.push_duration,
             push_time=push_time, duration=push_time + p.push_duration + p.after,
             allow_steps=spec.steps, start=start, seed=task.seed, frame_callback=frame_callback)
    r.extra["push_time_s"] = push_time
    return r, survived(r, spec.steps)


def run_push(task: PushTask) -> dict:
    """One run of the protocol as a JSON-ready record: ``direction``, ``force_N``, ``phase``,
    ``seed``, ``survived``, ``fell``, ``fall_time_s``, ``reason``, ``push_time_s``."""
    r, ok = simulate_push(task)
    return {"direction": task.direction, "force_N": float(task.force),
            "phase": float(task.phase), "seed": int(task.seed), "survived": bool(ok),
            "fell": bool(r.fell), "fall_time_s": r.fall_time_s, "reason": r.fall_reason,
            "push_time_s": r.extra.get("push_time_s")}


def largest_force(forces: Sequence[float], rates: Sequence[float], threshold: float) -> float:
    """The largest force ``F`` of the (ascending) grid such that every grid force up to ``F`` has
    a survival rate ``>= threshold``; 0 when the smallest one does not. Forces after the measured
    ones (a curve stopped early) count as failed."""
    best = 0.0
    for f, r in zip(forces, rates, strict=False):
        if r is None or r < threshold - 1e-12:
            break
        best = float(f)
    return best


@dataclass
class PushRates:
    """The outcome of :func:`survival_rates` (JSON-ready through :meth:`to_dict`).

    Attributes:
        controller: the registry name.
        protocol: the :class:`PushProtocol`.
        mode: ``"walking"`` or ``"standing"``; ``steps``: steps allowed.
        falls_unpushed: some seed falls with no push over the same window (then no figures).
        unpushed: the unpushed runs' records.
        curves: ``{direction: {"forces_N": [...], "rates": [...]}}`` (only the measured forces).
        largest_100_N, largest_90_N: ``{direction: N}`` (see :func:`largest_force`).
        at_cap: ``{direction: bool}``: the 100 % figure is the grid's cap.
        runs: every run's record.
    """

    controller: str
    protocol: PushProtocol
    mode: str
    steps: bool
    falls_unpushed: bool = False
    unpushed: list[dict] = field(default_factory=list)
    curves: dict[str, dict] = field(default_factory=dict)
    largest_100_N: dict[str, float] = field(default_factory=dict)
    largest_90_N: dict[str, float] = field(default_factory=dict)
    at_cap: dict[str, bool] = field(default_factory=dict)
    runs: list[dict] = field(default_factory=list)

    def describe(self) -> str:
        """The protocol sentence for this controller."""
        return self.protocol.describe(self.mode, self.steps)

    def summary(self) -> str:
        """One line per direction: the figures, or ``falls unpushed``."""
        if self.falls_unpushed:
            return f"{self.controller}: falls unpushed ({self.describe()})"
        lines = [f"{self.controller}: {self.describe()}"]
        for d in self.protocol.directions:
            cap = " (at the cap)" if self.at_cap.get(d) else ""
            lines.append(f"  {d}: 100 % up to {self.largest_100_N[d]:.0f} N{cap}, >= 90 % up to "
                         f"{self.largest_90_N[d]:.0f} N")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        d = asdict(self)
        d["protocol"] = self.protocol.to_dict()
        d["description"] = self.describe()
        return d


def survival_rates(run, protocol: PushProtocol, *, model=None, options: dict | None = None,
                   processes: int = 1, progress: Callable[[str], None] | None = None,
                   mapper: Callable[[Callable, list], list] | None = None) -> PushRates:
    """Measure a controller with ``protocol``: the unpushed check, then the survival-rate curve
    per direction over the force grid, and the figures.

    Args:
        run: the run described (a :class:`~mjchar.controllers.core.builder.RunSpec`; its scenario
            does not matter), or a registered controller's name, built on ``model`` (``None``:
            the bundled humanoid; an MJCF path or an ``MjModel``) with the factory ``options``.
        processes: worker processes (``0``: one per core); results do not depend on it.
        mapper: ``mapper(run_push, tasks) -> records`` in order, to run the runs elsewhere (the
            bench's job pool); ``processes`` is then ignored.
        progress: called with one line per finished force level.
    """
    from ..builder import RunSpec

    protocol.check()
    if isinstance(run, str):
        run = RunSpec(run, "push-search", model=model, options=dict(options or {}))
    run = replace(run, scenario="push-search").check()
    spec = run.controller_spec
    controller = spec.name
    out = PushRates(controller, protocol, spec.push, spec.steps)
    workers = (os.cpu_count() or 1) if processes == 0 else max(1, int(processes))
    parallel = workers > 1 and mapper is None
    with (process_pool(workers, start_method=None) if parallel
          else contextlib.nullcontext()) as pool:
        if mapper is not None:
            def run_all(tasks):
                return list(mapper(run_push, tasks))
        elif pool is not None:
            def run_all(tasks):
                return list(pool.map(run_push, tasks))
        else:
            def run_all(tasks):
                return [run_push(t) for t in tasks]

        def task(direction: str, force: float, phase: float, seed: int) -> PushTask:
            return PushTask(run, direction, force, phase, int(seed), protocol)

        # force 0: the unpushed check over the same window, at phase 0
        out.unpushed = run_all([task(protocol.directions[0], 0.0, 0.0, s) for s in protocol.seeds])
        out.falls_unpushed = not all(r["survived"] for r in out.unpushed)
        if out.falls_unpushed:
            if progress is not None:
                progress(f"{controller}: falls unpushed; no push figures")
            return out
        curves = {d: {"forces_N": [], "rates": []} for d in protocol.directions}
        active = list(protocol.directions)
        for f in protocol.forces:
            if not active:
                break
            tasks = [task(d, f, ph, s) for d in active for ph in protocol.phase_values()
                     for s in protocol.seeds]
            records = run_all(tasks)
            out.runs.extend(records)
            for d in list(active):
                mine = [r for r in records if r["direction"] == d]
                rate = sum(r["survived"] for r in mine) / len(mine)
                curves[d]["forces_N"].append(float(f))
                curves[d]["rates"].append(rate)
                if rate == 0.0 or (not protocol.full_curves and rate < 0.9 - 1e-12):
                    active.remove(d)
            if progress is not None:
                progress(f"{controller} {f:g} N: " + ", ".join(
                    f"{d} {curves[d]['rates'][-1]:.0%}" for d in protocol.directions
                    if curves[d]["forces_N"] and curves[d]["forces_N"][-1] == f))
    out.curves = curves
    for d, c in curves.items():
        out.largest_100_N[d] = largest_force(c["forces_N"], c["rates"], 1.0)
        out.largest_90_N[d] = largest_force(c["forces_N"], c["rates"], 0.9)
        out.at_cap[d] = out.largest_100_N[d] >= protocol.cap
    return out


# -- the scenario --------------------------------------------------------------------------------
def _push_search(run, *, max_force: float = 500.0, tolerance: float = 25.0, phases: int = 4,
                 seeds: int = 2, push_duration: float = 0.2) -> PushRates:
    if run.spec is None:
        raise ScenarioError("push-search rebuilds the controller for every push: describe the "
                            "run (mjchar.controllers.run or RunSpec)")
    protocol = PushProtocol.grid(max_force, min(tolerance, max_force), phases=phases,
                                 seeds=tuple(range(seeds)), push_duration=push_duration)
    return survival_rates(run.spec, protocol, processes=0, progress=run.progress)


register(ScenarioSpec(
    name="push-search",
    measures="push survival rates per direction over stride phases, seeds and a force grid",
    procedure=_push_search, needs=("stand", "walk"),
    options=(MAX_FORCE, TOLERANCE, PHASES, SEEDS, PUSH_DURATION), protocol=True))
