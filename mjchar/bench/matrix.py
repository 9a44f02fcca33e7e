"""The bench matrix: every registered controller in every bench scenario it declares.

The rows, their scenarios and the runs that must not fall come from the controller registry
(:mod:`mjchar.controllers.core.registry`: each spec's ``bench`` and ``expected``), so a newly
registered controller appears here with no other edit; any other cell a controller runs (a
newly registered scenario) can be selected. Every run is described as a
:class:`~mjchar.controllers.core.builder.RunSpec` and built by the run builder, and each cell's runs
(seeds, slopes, durations) come from its scenario's ``bench`` settings, so each number is
measured the way the tests and ``mjchar run`` measure it.

The built-in scenarios:

- ``stand``: the standing pose, no disturbance.
- ``random-push``: 10 N on the pelvis, new random direction every second, once per seed.
- ``push-search``: the push protocol (:mod:`~mjchar.controllers.core.scenarios.push_search`): per
  direction
  (forward, left, backward, right) the survival rate of 0.2 s pushes over ``push_phases``
  phases of the stride (walkers, on the chest) or moments (standing controllers, on the pelvis)
  x ``push_seeds`` seeds, on a force grid; the figures are the largest forces with rate 100 %
  and >= 90 %. One more run, filmed, at the weakest direction's 100 % figure.
- ``walk``: walkers from their own start state (seeded perturbation) on level ground.
- ``track``: follow ``walk60`` (``../shared/data/bvh``) or the bundled walk; replays play a
  saved SAMCON / CMA-ES trajectory against its stored reference.
- ``slopes``: walk up and down a ``slope_degrees`` slope.
- any other registered scenario: the runs its ``bench`` settings give (by default one run at
  its own defaults).

Replays without a saved trajectory get a "not available" row instead of a crash.

The cells run in parallel (:func:`run_matrix`, ``jobs`` worker processes of a
:class:`~mjchar.bench.parallel.JobPool`): an ordinary cell is one job, a push-search cell one
job per run of its protocol (its force levels one after another, each level's runs at once),
the most expensive cells first (:func:`cell_cost`). The results do not depend on ``jobs``.
"""

from __future__ import annotations

import math
import os
import sys
import threading
import time
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import Future, as_completed
from dataclasses import asdict
from pathlib import Path

import numpy as np

from mjchar.bvh.bundled.assets import TRAJECTORIES, find_trajectory
from mjchar.bvh.errors import MjcharError
from mjchar.controllers import registry
from mjchar.controllers.core.builder import RunSpec, execute
from mjchar.controllers.core.registry import ControllerSpec
from mjchar.controllers.core.scenarios import registry as scenario_registry
from mjchar.controllers.core.scenarios.push_search import (
    PushTask,
    simulate_push,
    survival_rates,
)

from .config import SHARED_BVH, BenchConfig, BenchError, relative_path
from .parallel import JobPool, default_jobs
from .progress import advance, expected_cost, progress_bar


# -- the matrix: read from the controller registry -----------------------------------------------
def bench_specs() -> dict[str, ControllerSpec]:
    """The registered controllers that run in the bench (a non-empty ``bench``), in
    registration order: the rows of the table."""
    return {s.name: s for s in registry.specs() if s.bench}


def matrix() -> dict[str, tuple[str, ...]]:
    """``{controller: its bench scenarios}``: the cells that make sense, from the registry."""
    return {n: s.bench for n, s in bench_specs().items()}


def expected_cells() -> tuple[tuple[str, str], ...]:
    """The ``(controller, scenario)`` runs that must not fall (each spec's ``expected``); a fall
    (or an error) there makes ``mjchar bench`` exit with status 1."""
    return tuple((n, s) for n, spec in bench_specs().items() for s in spec.expected)


def find_trajectories(directory: str | os.PathLike | None = None) -> dict[str, Path]:
    """Saved trajectories for the replay rows: ``{controller name: path}``.

    Looks in ``directory`` (default: the bundled ``assets/trajectories``) for ``*.npz`` files
    whose name starts with one of a replay spec's ``trajectory_prefixes`` (``samcon...npz``,
    ``cmaes...npz``); the first in sorted order wins.
    """
    out: dict[str, Path] = {}
    for spec in bench_specs().values():
        path = find_trajectory(spec.trajectory_prefixes, directory)
        if path is not None:
            out[spec.name] = path
    return out


def availability(name: str, trajectories: dict[str, Path] | None = None
                 ) -> tuple[bool, str | None]:
    """``(available, reason)`` for controller ``name``: always available unless it is a replay
    without a saved trajectory or a learned policy without its bundled policy file."""
    spec = _spec(name)
    if spec.kind == "replay":
        path = (trajectories or {}).get(name)
        if path is None:
            return False, (f"no saved trajectory (give one with --{name.split('_')[0]}-"
                           f"trajectory FILE or put {spec.trajectory_prefixes[0]}*.npz in "
                           f"{relative_path(TRAJECTORIES)})")
        if not Path(path).is_file():
            return False, f"trajectory file {path} not found"
    if "policy" in spec.options:
        from mjchar.controllers.learned import bundled_policies
        from mjchar.controllers.learned.controller import DEFAULT_POLICY

        if DEFAULT_POLICY not in bundled_policies():
            return False, f"no bundled policy {DEFAULT_POLICY!r} (learn one with mjchar learn)"
    return True, None


def _spec(name: str) -> ControllerSpec:
    specs = bench_specs()
    if name not in specs:
        raise BenchError(f"unknown controller {name!r}; choose from {', '.join(specs)}")
    return specs[name]


def select_cells(controllers: Iterable[str] | None = None,
                 scenarios: Iterable[str] | None = None) -> list[tuple[str, str]]:
    """The ``(controller, scenario)`` cells of :func:`matrix` among the chosen ones (default:
    all), in matrix order; a scenario named explicitly also selects the cells of controllers
    that run it outside their default bench list. Unknown names raise :class:`BenchError`."""
    table = matrix()
    known = scenario_registry.names()
    cs = list(table) if controllers is None else list(dict.fromkeys(controllers))
    ss = list(known) if scenarios is None else list(dict.fromkeys(scenarios))
    for c in cs:
        _spec(c)
    for s in ss:
        if s not in known:
            raise BenchError(f"unknown scenario {s!r}; choose from {', '.join(known)}")
    cells = [(c, s) for c in table for s in table[c] if c in cs and s in ss]
    if scenarios is not None:
        extra = [s for s in ss if not any(s == cell[1] for cell in cells)]
        cells += [(c, s) for c in cs for s in extra if _spec(c).runs(s)]
    if not cells:
        raise BenchError(f"no cell of the matrix has controller(s) {', '.join(cs)} and "
                         f"scenario(s) {', '.join(ss)}; the matrix: "
                         + "; ".join(f"{c}: {', '.join(v)}" for c, v in table.items()))
    return cells


# -- running the cells ---------------------------------------------------------------------------
class _Probe:
    """A frame callback sampling time, centre of mass and (with a reference) joint positions at
    ``rate`` Hz, for the plots; :meth:`series` turns them into JSON-ready lists."""

    def __init__(self, rate: float, reference=None):
        self.dt = 1.0 / rate
        self.reference = reference
        self._next = -math.inf
        self.t: list[float] = []
        self.com: list[list[float]] = []
        self.joints: list[np.ndarray] = []

    def __call__(self, ch) -> None:
        if ch.time + 1e-9 < self._next:
            return
        self._next = ch.time + self.dt
        self.t.append(float(ch.time))
        self.com.append([float(x) for x in ch.state.com()])
        if self.reference is not None:
            self.joints.append(ch.state.joint_positions())

    def series(self) -> dict:
        err = None
        if self.reference is not None and self.t:
            t = np.asarray(self.t)
            ref = self.reference.body_positions(t)[:, self.reference.joint_body_ids]
            err = np.linalg.norm(np.asarray(self.joints) - ref, axis=-1).mean(axis=1).tolist()
        return {"t_s": [round(x, 6) for x in self.t], "com_m": self.com,
                "tracking_error_m": err}


class _LazyVideo:
    """A :class:`~mjchar.render.VideoRecorder` created on the first frame (so it can film
    a Character built inside a scenario function)."""

    def __init__(self, path: Path, fps: float):
        self.path, self.fps = path, fps
        self.recorder = None

    def capture(self, ch) -> None:
        if self.recorder is None:
            from ..render import VideoRecorder

            self.recorder = VideoRecorder(ch, self.path, fps=self.fps)
        self.recorder.capture(ch)

    def close(self, keep: bool = True) -> int:
        if self.recorder is None:
            return 0
        self.recorder.close(keep)
        return self.recorder.frames if keep else 0


class BenchContext:
    """What the cells share: the pristine model, the trajectories, the settings, videos."""

    def __init__(self, config: BenchConfig, trajectories: dict[str, Path],
                 video_dir: Path | None, log: Callable[[str], None],
                 threads: int | None = None):
        from mjchar.controllers.core.character import Character

        self.config = config
        self.threads = threads  # for controllers with threads of their own (None: their default)
        self.settings = asdict(config)  # what the scenarios' bench settings read
        self.base_model = Character().model  # pristine; every run copies it
        self.trajectories = trajectories
        self.video_dir = video_dir
        self.log = log
        self.track_motion = default_track_motion()
        self._trajs: dict[str, object] = {}
        self._policy = None
        self._track_seconds: float | None = None
        self.videos: list[dict] = []

    def describe(self, name: str, scenario: str, options: dict | None = None,
                 seed: int | None = None) -> RunSpec:
        """A bench run of controller ``name`` in ``scenario`` (the bundled humanoid; the track
        clip; the bench's walking speed for walkers that can also stand)."""
        spec = _spec(name)
        factory = factory_options(spec, scenario, self.config)
        if self.threads is not None and takes_threads(spec):
            factory["threads"] = self.threads
        if spec.kind == "replay":
            factory["trajectory"] = self.trajectories[name]
        motion, loop, scenario_options = self.track_motion, False, dict(options or {})
        if "policy" in spec.options:
            factory["policy"] = self.policy()
        if spec.own_clip is not None:  # a learned policy follows its own clip, as trained
            motion, loop = spec.own_clip(factory)
            if loop and scenario_options.get("duration") is None and scenario == "track":
                scenario_options["duration"] = self.track_seconds()
        return RunSpec(name, scenario, model=self.base_model, motion=motion, loop=loop,
                       seed=seed, options=factory, scenario_options=scenario_options)

    def policy(self):
        """The bundled default policy (loaded once) the ``policy`` row runs."""
        if self._policy is None:
            from mjchar.controllers.learned import find_policy

            self._policy = find_policy(None)
        return self._policy

    def clip_label(self, name: str) -> str:
        """The clip a tracking run of controller ``name`` follows (a policy: its own)."""
        if "policy" not in _spec(name).options:
            return self.track_motion.name
        clip = self.policy().meta["clip"]
        return Path(clip["name"]).name + (" (looped)" if clip.get("loop") else "")

    def track_seconds(self) -> float:
        """How long the track cell runs: ``track_duration``, else the track clip's length (a
        looped clip then runs as long as the other rows' unlooped one)."""
        if self.config.track_duration:
            return float(self.config.track_duration)
        if self._track_seconds is None:
            from mjchar.bvh.io import load

            self._track_seconds = float(load(self.track_motion).duration)
        return self._track_seconds

    def character(self, timestep: float | None = None):
        """A fresh Character of the bundled humanoid (for the performance measurements)."""
        from mjchar.controllers.core.character import Character

        return Character(self.base_model, timestep=timestep)

    def trajectory(self, name: str):
        if name not in self._trajs:
            from mjchar.controllers.sampling.trajectory import load_trajectory

            self._trajs[name] = load_trajectory(self.trajectories[name])
        return self._trajs[name]

    def video(self, controller: str, scenario: str) -> _LazyVideo | None:
        if self.video_dir is None:
            return None
        return _LazyVideo(self.video_dir / f"{controller}_{scenario}.mp4", self.config.fps)


def takes_threads(spec: ControllerSpec) -> bool:
    """Whether the controller runs threads of its own, sized by a ``threads`` option (the
    MPC's rollouts); results do not depend on it."""
    return spec.tunables is not None and any(t.name == "threads" for t in spec.tunables())


def default_track_motion() -> Path:
    """``../shared/data/bvh/walk60.bvh`` when present, else the bundled walk."""
    shared = SHARED_BVH / "walk60.bvh"
    if shared.is_file():
        return shared
    from mjchar.bvh.bundled.assets import motion_path

    return motion_path("walk")


def _result_run(variant: str, seed, r, probe: _Probe, frames: int | None = None) -> dict:
    run = {"variant": variant, "seed": None if seed is None else int(seed),
           "survived": not r.fell, "result": r.to_dict(), "series": probe.series()}
    extra = run["result"].get("extra") or {}
    if Path(extra.get("source_motion") or "").is_absolute():  # a replay's clip: no machine path
        extra["source_motion"] = relative_path(extra["source_motion"])
    if frames:
        run["video_frames"] = frames
    return run


def _run_one(ctx: BenchContext, cell_video: list, variant: str, seed, reference,
             fn: Callable[[Callable], object]) -> dict:
    """Run ``fn(frame_callback)`` with a probe (and, for the cell's first run, a video)."""
    probe = _Probe(ctx.config.sample_rate, reference)
    video = cell_video.pop() if cell_video else None

    def callback(ch) -> None:
        probe(ch)
        if video is not None:
            video.capture(ch)

    frames = None
    try:
        r = fn(callback)
    except BaseException:
        if video is not None:
            video.close(keep=False)  # a failed run leaves no half video
        raise
    if video is not None:
        frames = video.close()
    run = _result_run(variant, seed, r, probe, frames)
    if video is not None and frames:
        run["video"] = video.path.name
        ctx.videos.append({"file": video.path.name, "frames": frames,
                           "controller": r.controller, "scenario": r.scenario})
    return run


def _run_cell(ctx: BenchContext, name: str, scenario: str) -> list[dict]:
    """All runs of one ordinary cell (a list of run records, see docs/bench.md): the
    scenario's bench settings give the runs, the run builder builds each (a protocol's cell
    runs through :func:`_push_search`)."""
    vid = ctx.video(name, scenario)
    cell_video = [vid] if vid is not None else []
    sspec = scenario_registry.get(scenario)
    probe = ctx.describe(name, scenario).build()
    bench_runs = sspec.bench(ctx.settings, probe.controller)
    runs = []
    for br in bench_runs:
        built = ctx.describe(name, scenario, {k: v for k, v in br.options.items()
                                              if k != "seed" and v is not None},
                             br.options.get("seed", br.seed)).build()
        label = (ctx.trajectories[name].name if _spec(name).kind == "replay"
                 else ctx.clip_label(name) if built.reference is not None else br.label)
        reference = built.reference if built.reference is not None else _stored(built)

        def go(cb, built=built):
            built.frame_callback = cb
            return execute(built)

        runs.append(_run_one(ctx, cell_video, label, br.seed, reference, go))
    for run in runs:
        run["result"]["controller"] = name  # e.g. "replay" -> the row's name
    return runs


def _stored(built):
    """A replay's stored reference (its tracking-error series), else ``None``."""
    from mjchar.controllers.core.scenarios.replay import plays_itself

    if not plays_itself(built.controller):
        return None
    tr = built.controller.trajectory
    if tr.reference_qpos is None:
        return None
    from mjchar.controllers.sampling.trajectory import StoredReference

    ch = built.character
    return StoredReference(ch.model, tr.reference_qpos, tr.control_dt, ch.joint_bodies)


def build_controller(ctx: BenchContext, name: str, scenario: str):
    """A fresh ``(character, controller)`` of a bench run (built as every run is)."""
    built = ctx.describe(name, scenario).build()
    return built.character, built.controller


def factory_options(spec, scenario: str, config: BenchConfig) -> dict:
    """Factory options of a bench run: walkers that take a speed and can also stand (IPM) walk
    at ``ipm_speed`` where they move (the run builder makes them stand still elsewhere);
    walkers that only walk (SIMBICON) walk at their own gait's speed."""
    moving = scenario_registry.get(scenario).moving
    if "speed" in spec.options and "stand" in spec.abilities and moving:
        return {"speed": config.ipm_speed}
    return {}


def _push_search(pool: JobPool, priority: float, job: tuple, name: str, progress) -> tuple:
    """The push protocol's survival rates for ``name`` (``run["push"]``, every run recorded),
    plus one filmed run at the weakest direction's largest force with rate 100 % (phase 0,
    the first seed); every run is a job of ``pool``. Returns ``(runs, videos)``."""
    cfg = job[0]
    spec = _spec(name)
    protocol = cfg.push_protocol(spec.push)
    run = RunSpec(name, "push-search", options=factory_options(spec, "push-search", cfg))
    tag = f"{name} / push-search"
    rates = survival_rates(run, protocol, progress=progress,
                           mapper=pool.mapper(priority, tag))
    weakest = min(protocol.directions, key=lambda d: rates.largest_100_N.get(d, 0.0))
    force = 0.0 if rates.falls_unpushed else rates.largest_100_N[weakest]
    task = PushTask(run, weakest, force, 0.0, protocol.seeds[0], protocol)
    largest = None if rates.falls_unpushed else dict(rates.largest_100_N)
    record, videos = pool.submit(priority, film_push, job, name, task, largest,
                                 tag=tag).result()
    record["push"] = rates.to_dict()
    return [record], videos


def film_push(job: tuple, name: str, task: PushTask, largest: dict | None) -> tuple:
    """A push-search cell's filmed run (a job: runs in a worker); ``(record, videos)``."""
    ctx = _job_context(job)
    cell_video = [v] if (v := ctx.video(name, "push-search")) is not None else []

    def film(cb):
        r, _ = simulate_push(task, frame_callback=cb)
        r.scenario = "push-search"
        r.max_push_by_direction_N = largest
        return r

    record = _run_one(ctx, cell_video, f"{task.direction} {task.force:g} N, phase 0 (filmed)",
                      task.seed, None, film)
    record["result"]["controller"] = name
    return record, ctx.videos


def _job_context(job: tuple) -> BenchContext:
    """The context of a job, ``job`` = ``(config, trajectories, video_dir, threads)``."""
    config, trajectories, video_dir, threads = job
    return BenchContext(config, trajectories, video_dir, lambda msg: None, threads)


def run_cell(job: tuple, name: str, scenario: str) -> tuple:
    """One ordinary cell (a job: runs in a worker): ``(runs, videos, wall_s, error)``, where
    ``error`` is ``None`` or the exception's text."""
    t0 = time.perf_counter()
    ctx = _job_context(job)
    try:
        runs, error = _run_cell(ctx, name, scenario), None
    except Exception as e:  # reported in the table; the other cells still run
        runs, error = [], f"{type(e).__name__}: {e}"
    return runs, ctx.videos, time.perf_counter() - t0, error


#: rough cost per physics step over a bare mj_step (the bench's measured step-cost ratios) of
#: the controllers far from the PD trackers' 1.5-2: only orders the cells (longest first)
STEP_COST_HINTS = {"mpc": 400.0, "ipm": 9.0, "simbicon": 3.3, "static_balance": 2.9}


def cell_cost(name: str, scenario: str, config: BenchConfig) -> float:
    """A rough cost of a cell, in bare ``mj_step`` calls: its simulated time over its time step
    times the controller's step cost (:data:`STEP_COST_HINTS`, else 2); a push search counts
    half its grid in every direction. It only orders the cells, the longest first."""
    spec = _spec(name)
    c = config
    seeds = len(c.seeds)
    sim = {"stand": c.stand_duration, "random-push": c.random_push_duration * seeds,
           "walk": c.walk_duration * seeds, "slopes": 2 * c.slope_duration * seeds,
           "track": c.track_duration or 4.0}.get(scenario, c.stand_duration)
    if scenario_registry.get(scenario).protocol:
        p = c.push_protocol(spec.push)
        before = p.warmup + 3.0 if spec.push == "walking" else p.first_moment + 1.0
        runs = len(p.seeds) + len(p.directions) * p.phases * len(p.seeds) * len(p.forces) / 2
        sim = runs * (before + p.push_duration + p.after)
    dt = registry.default_timestep(name) or 0.002
    return sim / dt * STEP_COST_HINTS.get(name, 2.0)


def summarise_cell(runs: list[dict]) -> dict:
    """Per-cell aggregates over its runs (means; ``None`` where no run has the metric)."""
    def mean(values):
        v = [x for x in values if x is not None]
        return float(np.mean(v)) if v else None

    res = [r["result"] for r in runs]
    steady = [r["extra"].get("steady_speed_mps") for r in res]
    speed = mean(steady) if all(s is not None for s in steady) and res else \
        mean(r["mean_speed_mps"] for r in res)
    push = next((r["push"] for r in runs if "push" in r), None)
    return {"runs": len(runs), "survived": sum(bool(r["survived"]) for r in runs),
            "fell": [r["variant"] for r in runs if not r["survived"]],
            "distance_m": mean(r["distance_m"] for r in res), "speed_mps": speed,
            "tracking_error_m": mean(r["tracking_error_m"] for r in res),
            "root_force_mean_N": mean(r["root_force_mean_N"] for r in res),
            "max_push_by_direction_N": None if push is None or push["falls_unpushed"]
            else push["largest_100_N"],
            "push_90_by_direction_N": None if push is None or push["falls_unpushed"]
            else push["largest_90_N"],
            "push_at_cap": None if push is None else push["at_cap"],
            "falls_unpushed": None if push is None else push["falls_unpushed"],
            "push_protocol": None if push is None else push["description"]}


def run_matrix(cells: Sequence[tuple[str, str]], config: BenchConfig, *,
               trajectories: dict[str, Path] | None = None, video_dir: Path | None = None,
               progress: bool = True, jobs: int | None = None, cpu: dict | None = None
               ) -> tuple[dict, list[dict], list[dict]]:
    """Run every cell; returns ``(controllers, cells, videos)`` records of the JSON document.

    The cells run on ``jobs`` worker processes (default: one per core), the most expensive
    first (:func:`cell_cost`); the records come back in the order of ``cells`` and do not depend
    on ``jobs``. A controller with threads of its own (the MPC) gets ``cores // jobs`` of them.
    ``cpu``, when given, receives the CPU seconds of each cell's jobs (``"controller /
    scenario"`` -> s).

    A controller that is not available gets cells with status ``"not available"``; a cell whose
    run raises gets status ``"error"`` (its message in ``reason``) and the others still run.
    """
    config.check()
    trajectories = dict(trajectories or {})
    jobs = default_jobs() if jobs is None else int(jobs)
    if jobs < 1:
        raise BenchError(f"jobs must be at least 1, got {jobs}")
    pool = JobPool(jobs)  # before the progress bar's thread: the workers are forked now
    costs = [expected_cost(c, s, config, cell_cost) for c, s in cells]
    bar = progress_bar(costs, progress, "bench")
    lock = threading.Lock()

    def log(msg: str) -> None:
        if progress:
            with lock:
                bar.write(msg, file=sys.stderr)

    ctx = BenchContext(config, trajectories, video_dir, log)
    names = list(dict.fromkeys(c for c, _ in cells))
    controllers = {}
    for n in names:
        ok, why = availability(n, trajectories)
        spec = _spec(n)
        controllers[n] = {"label": spec.label, "available": ok, "reason": why,
                          "timestep_s": (registry.default_timestep(n)
                                         if ok and spec.kind != "replay" else None),
                          "scenarios": [s for c, s in cells if c == n],
                          "trajectory": (relative_path(trajectories[n]) if n in trajectories
                                         else None)}
        if ok and spec.kind == "replay":
            try:
                controllers[n]["timestep_s"] = ctx.trajectory(n).timestep
            except MjcharError as e:  # a damaged or foreign file: a row saying so
                controllers[n].update(available=False, reason=str(e))
        if ok and controllers[n]["timestep_s"] is None:
            controllers[n]["timestep_s"] = float(ctx.base_model.opt.timestep)
    threads = max(1, default_jobs() // jobs)
    job = (config, trajectories, video_dir, threads)
    expected = set(expected_cells())
    out: list[dict] = []
    pending: dict[Future, int] = {}
    with pool:
        for i, (name, scenario) in enumerate(cells):
            out.append({"controller": name, "scenario": scenario, "status": "ok",
                        "reason": None, "expected_to_survive": (name, scenario) in expected,
                        "wall_s": 0.0, "runs": [], "summary": summarise_cell([])})
            if not controllers[name]["available"]:
                out[i]["status"], out[i]["reason"] = "not available", controllers[name]["reason"]
        order = sorted((i for i, c in enumerate(out) if c["status"] == "ok"),
                       key=lambda i: -cell_cost(cells[i][0], cells[i][1], config))
        for i in order:
            name, scenario = cells[i]
            cost = cell_cost(name, scenario, config)
            if scenario_registry.get(scenario).protocol:
                fut: Future = Future()

                def coordinate(fut=fut, name=name, scenario=scenario, cost=cost):
                    t0 = time.perf_counter()
                    try:
                        runs, vids = _push_search(
                            pool, cost, job, name,
                            lambda msg, n=name, s=scenario: log(f"  {n} / {s}: {msg}"))
                        fut.set_result((runs, vids, time.perf_counter() - t0, None))
                    except Exception as e:
                        fut.set_result(([], [], time.perf_counter() - t0,
                                        f"{type(e).__name__}: {e}"))

                threading.Thread(target=coordinate, daemon=True,
                                 name=f"bench-{name}-{scenario}").start()
            else:
                fut = pool.submit(cost, run_cell, job, name, scenario,
                                  tag=f"{name} / {scenario}")
            pending[fut] = i
        videos: dict[int, list] = {}
        for fut in as_completed(pending):
            i = pending[fut]
            cell = out[i]
            name, scenario = cells[i]
            try:
                runs, videos[i], cell["wall_s"], error = fut.result()
            except Exception as e:  # a worker that died
                runs, videos[i], error = [], [], f"{type(e).__name__}: {e}"
            for run in runs:
                run["result"]["controller"] = name  # e.g. "replay" -> the row's name
            cell["runs"] = runs
            if error is not None:
                cell["status"], cell["reason"] = "error", error
                log(f"  {name} / {scenario}: ERROR {error}")
            cell["summary"] = s = summarise_cell(runs)
            if cell["status"] == "ok":
                log(f"{name} / {scenario}: {s['survived']}/{s['runs']} without a fall "
                    f"({cell['wall_s']:.1f} s)")
            with lock:
                advance(bar, costs[i])
    bar.close()
    if cpu is not None:
        cpu.update(pool.cpu_seconds())
    vids = [v for i in sorted(videos) for v in videos[i]]
    return controllers, out, vids
