"""``mjchar bench``: every controller in every scenario that makes sense for it, one report.

The matrix is data: :data:`CONTROLLERS` (how to build each controller and which module it needs),
:data:`MATRIX` (which scenarios each one runs) and :data:`EXPECTATIONS` (which runs must not
fall: the exit status CI gates on). Every run goes through the shared scenarios
(:mod:`controllers.scenarios`, :mod:`controllers.terrain`, :func:`controllers.trajectory.replay`),
so each number is measured the way the tests and ``mjchar run`` measure it.

Scenarios (:data:`SCENARIOS`):

- ``stand``: the standing pose, no disturbance.
- ``random-push``: 10 N on the pelvis, new random direction every second, once per seed.
- ``push-search``: per direction (forward, left, backward, right) the largest 0.2 s push
  survived, by bisection. Standing controllers: pushes on the pelvis 1 s in, no fall (and no
  step unless the controller is a stepping one). Walking controllers: pushes on the chest at
  ``walk_push_phases`` phases of the stride, still walking afterwards.
- ``walk``: walkers from their own start state (seeded perturbation) on level ground.
- ``track``: follow ``walk60`` (``../shared/data/bvh``) or the bundled walk; replays play a
  saved SAMCON / CMA-ES trajectory against its stored reference.
- ``slopes``: walk up and down a ``slope_degrees`` slope.

Controllers whose module does not import (or lacks what the bench needs), and replays without
a saved trajectory, get a "not available" row instead of a crash.

Use :func:`run_bench` (or the pieces: :func:`run_matrix`, :func:`run_performance`,
:func:`table_rows`, :func:`format_table`, :func:`check_expectations`, :func:`write_json`); the
CLI is :mod:`controllers.commands.bench`. The JSON document is described in ``docs/bench.md``
and ``docs/bench_schema.json`` (:func:`validate` checks a document against the schema).
"""

from __future__ import annotations

import copy
import importlib
import json
import math
import os
import platform
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from bvh.errors import MjcharError

ROOT = Path(__file__).resolve().parents[1]
SCHEMA_PATH = ROOT / "docs" / "bench_schema.json"
SHARED_BVH = ROOT.parent / "shared" / "data" / "bvh"
#: where saved trajectories are looked for by default (``samcon*.npz``, ``cmaes*.npz``)
TRAJECTORY_DIR = ROOT / "assets" / "trajectories"
SCHEMA_NAME = "mjchar-bench"
SCHEMA_VERSION = 1

SCENARIOS = ("stand", "random-push", "push-search", "walk", "track", "slopes")
#: scenarios whose runs count in the survival column (push-search is a measurement)
SURVIVAL_SCENARIOS = ("stand", "random-push", "walk", "track", "slopes")
DIRECTION_NAMES = ("forward", "left", "backward", "right")
#: keys of a run's result that are timings (the rest is physics, identical for equal seeds)
TIMING_KEYS = ("wall_s", "steps_per_s")


class BenchError(MjcharError):
    """The benchmark was asked for something impossible (unknown controller or scenario, bad
    option, an output folder that cannot be written)."""


# -- the matrix, as data -------------------------------------------------------------------------
@dataclass(frozen=True)
class ControllerSpec:
    """How the bench builds one controller.

    Attributes:
        name: the bench's name for it (a row of the table).
        label: a readable description.
        module: the module that must import.
        needs: attributes that module must expose.
        kind: ``"pd"`` (PD trackers: hold the standing pose or follow the reference),
            ``"balance"``, ``"walker"`` (walks from its own start state), ``"replay"`` (plays a
            saved trajectory).
        steps: recovers from pushes by stepping (push-search then allows foot motion).
        push: how push-search pushes it: ``"standing"`` (from the standing pose, on the pelvis)
            or ``"walking"`` (at phases of the stride, on the chest; needs FSM ``transitions``).
        trajectory_prefixes: for replays, saved-trajectory file names it accepts.
    """

    name: str
    label: str
    module: str
    needs: tuple[str, ...]
    kind: str
    steps: bool = False
    push: str = "standing"
    trajectory_prefixes: tuple[str, ...] = ()


CONTROLLERS: dict[str, ControllerSpec] = {s.name: s for s in (
    ControllerSpec("pd", "explicit PD (1/2000 s)", "controllers.pd", ("PDController",), "pd"),
    ControllerSpec("spd", "stable PD", "controllers.pd", ("StablePDController",), "pd"),
    ControllerSpec("native_pd", "MuJoCo <position> PD", "controllers.pd",
                   ("NativePDController",), "pd"),
    ControllerSpec("hand_of_god", "stable PD + root force", "controllers.hand_of_god",
                   ("HandOfGod",), "pd"),
    ControllerSpec("static_balance", "stable PD + COM virtual force",
                   "controllers.static_balance", ("StaticBalance",), "balance"),
    ControllerSpec("simbicon", "SIMBICON walk", "controllers.simbicon",
                   ("make_simbicon", "DEFAULT_TIMESTEP"), "walker", push="walking"),
    ControllerSpec("ipm", "IPM stepping", "controllers.ipm", ("make_ipm",), "walker",
                   steps=True),
    ControllerSpec("samcon_replay", "SAMCON trajectory replay", "controllers.trajectory",
                   ("load_trajectory", "replay", "StoredReference"), "replay",
                   trajectory_prefixes=("samcon",)),
    ControllerSpec("cmaes_replay", "CMA-ES trajectory replay", "controllers.trajectory",
                   ("load_trajectory", "replay", "StoredReference"), "replay",
                   trajectory_prefixes=("cmaes", "cma-es", "cma_es", "trajopt")),
)}

#: which scenarios each controller runs (the combinations that make sense)
MATRIX: dict[str, tuple[str, ...]] = {
    "pd": ("stand", "random-push", "push-search", "track"),
    "spd": ("stand", "random-push", "push-search", "track"),
    "native_pd": ("stand", "random-push", "push-search", "track"),
    "hand_of_god": ("stand", "track"),
    "static_balance": ("stand", "random-push", "push-search"),
    "simbicon": ("walk", "push-search", "slopes"),
    "ipm": ("stand", "random-push", "push-search", "walk", "slopes"),
    "samcon_replay": ("track",),
    "cmaes_replay": ("track",),
}

#: (controller, scenario) runs that must not fall; a fall (or an error) makes the exit status 1.
#: The PD trackers alone are not expected to stand: holding the T-pose stiffly, they tip over
#: after about 5 s (measured: spd and native_pd fall at 5.2 s of the 10 s stand).
EXPECTATIONS: tuple[tuple[str, str], ...] = (
    ("hand_of_god", "stand"), ("hand_of_god", "track"),
    ("static_balance", "stand"), ("static_balance", "random-push"),
    ("simbicon", "walk"),
    ("ipm", "stand"), ("ipm", "walk"),
)


@dataclass
class PerfConfig:
    """Settings of the performance section (see :mod:`controllers.perf`).

    Attributes:
        raw_steps, raw_repeats: bare ``mj_step`` throughput run length and repeats.
        cost_steps, cost_repeats: physics steps and repeats of each controller's step cost.
        rollout_samples, rollout_steps, rollout_repeats, rollout_threads: batched rollouts.
        env_steps, env_repeats: env throughput (env steps per env per round, rounds).
        bvh_budget_s: seconds of timing per BVH file.
        envelope_duration_s, envelope_grid, envelope_finer, envelope_kps: the PD stability
            envelope (:func:`controllers.perf.stability_envelope`).
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
    push_duration: float = 4.0
    push_max_force: float = 1000.0
    push_tolerance: float = 5.0
    push_directions: tuple[str, ...] = DIRECTION_NAMES
    walk_duration: float = 30.0
    steady_window: float = 10.0
    walk_push_phases: int = 4
    walk_push_max_force: float = 600.0
    walk_push_tolerance: float = 25.0
    walk_push_warmup: float = 4.0
    walk_push_after: float = 8.0
    slope_degrees: float = 5.0
    slope_distance: float = 10.0
    slope_duration: float = 20.0
    ipm_speed: float = 1.0
    track_duration: float | None = None
    sample_rate: float = 20.0
    fps: float = 30.0
    perf: PerfConfig = field(default_factory=PerfConfig)

    def check(self) -> BenchConfig:
        """Raise :class:`BenchError` on impossible settings; returns self."""
        if not self.seeds or any(not isinstance(s, int | np.integer) or s < 0
                                 for s in self.seeds):
            raise BenchError(f"seeds must be non-negative integers, got {self.seeds!r}")
        for name in ("stand_duration", "random_push_duration", "push_duration", "walk_duration",
                     "slope_duration", "push_max_force", "push_tolerance", "walk_push_max_force",
                     "walk_push_tolerance", "sample_rate", "fps", "random_push_force",
                     "ipm_speed", "walk_push_after"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise BenchError(f"{name} must be a positive number, got {v!r}")
        if self.push_duration <= 1.2:
            raise BenchError("push_duration must exceed 1.2 s (the push is at 1 s for 0.2 s)")
        if not (0 < abs(self.slope_degrees) < 45):
            raise BenchError(f"slope_degrees must be in (0, 45), got {self.slope_degrees}")
        bad = [d for d in self.push_directions if d not in DIRECTION_NAMES]
        if bad or not self.push_directions:
            raise BenchError(f"push directions must be among {', '.join(DIRECTION_NAMES)}, "
                             f"got {self.push_directions!r}")
        if self.walk_push_phases < 1:
            raise BenchError("walk_push_phases must be at least 1")
        return self

    def to_dict(self) -> dict:
        return _clean(asdict(self))


def full_config(seeds: int | None = None) -> BenchConfig:
    """The full benchmark (tens of minutes on two cores); ``seeds`` = how many (default 3)."""
    c = BenchConfig()
    return c if seeds is None else replace(c, seeds=tuple(range(_count(seeds))))


def quick_config(seeds: int | None = None) -> BenchConfig:
    """Short durations, coarse push searches, quick performance runs, 2 seeds by default: a
    few minutes on two cores (``mjchar bench --quick``)."""
    perf = PerfConfig(raw_steps=2000, raw_repeats=3, cost_steps=600, cost_repeats=3,
                      rollout_samples=64, rollout_steps=50, rollout_repeats=2,
                      env_steps=300, env_repeats=2, bvh_budget_s=0.15,
                      envelope_duration_s=2.0,
                      envelope_grid=(2000, 1000, 500, 240, 120, 60, 30),
                      envelope_finer=(8000, 4000))
    c = BenchConfig(quick=True, seeds=(0, 1), stand_duration=10.0, random_push_duration=10.0,
                    push_duration=3.0, push_max_force=500.0, push_tolerance=25.0,
                    walk_duration=10.0, steady_window=4.0, walk_push_phases=1,
                    walk_push_max_force=400.0, walk_push_tolerance=100.0, walk_push_warmup=3.0,
                    walk_push_after=3.0, slope_distance=3.0, slope_duration=8.0, perf=perf)
    return c if seeds is None else replace(c, seeds=tuple(range(_count(seeds))))


def _count(n) -> int:
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise BenchError(f"the number of seeds must be a positive integer, got {n!r}")
    return n


# -- availability --------------------------------------------------------------------------------
def find_trajectories(directory: str | os.PathLike | None = None) -> dict[str, Path]:
    """Saved trajectories for the replay rows: ``{controller name: path}``.

    Looks in ``directory`` (default :data:`TRAJECTORY_DIR`) for ``*.npz`` files whose name
    starts with one of a replay spec's ``trajectory_prefixes`` (``samcon...npz``,
    ``cmaes...npz``); the first in sorted order wins.
    """
    d = Path(TRAJECTORY_DIR if directory is None else directory)
    out: dict[str, Path] = {}
    if not d.is_dir():
        return out
    files = sorted(d.glob("*.npz"))
    for spec in CONTROLLERS.values():
        for f in files:
            if spec.trajectory_prefixes and f.name.lower().startswith(spec.trajectory_prefixes):
                out[spec.name] = f
                break
    return out


def availability(name: str, trajectories: dict[str, Path] | None = None
                 ) -> tuple[bool, str | None]:
    """``(available, reason)`` for controller ``name``: its module imports and exposes what the
    bench needs (and, for a replay, a saved trajectory is known)."""
    spec = _spec(name)
    try:
        mod = importlib.import_module(spec.module)
    except Exception as e:  # a module still being written may fail in any way
        return False, f"{spec.module} does not import ({type(e).__name__}: {e})"
    missing = [a for a in spec.needs if not hasattr(mod, a)]
    if missing:
        return False, f"{spec.module} has no {', '.join(missing)}"
    if spec.kind == "replay":
        path = (trajectories or {}).get(name)
        if path is None:
            return False, (f"no saved trajectory (give one with --{name.split('_')[0]}-"
                           f"trajectory FILE or put {spec.trajectory_prefixes[0]}*.npz in "
                           f"{_rel(TRAJECTORY_DIR)})")
        if not Path(path).is_file():
            return False, f"trajectory file {path} not found"
    return True, None


def _spec(name: str) -> ControllerSpec:
    if name not in CONTROLLERS:
        raise BenchError(f"unknown controller {name!r}; choose from {', '.join(CONTROLLERS)}")
    return CONTROLLERS[name]


def select_cells(controllers: Iterable[str] | None = None,
                 scenarios: Iterable[str] | None = None) -> list[tuple[str, str]]:
    """The ``(controller, scenario)`` cells of :data:`MATRIX` among the chosen ones (default:
    all), in matrix order. Unknown names raise :class:`BenchError`."""
    cs = list(CONTROLLERS) if controllers is None else list(dict.fromkeys(controllers))
    ss = list(SCENARIOS) if scenarios is None else list(dict.fromkeys(scenarios))
    for c in cs:
        _spec(c)
    for s in ss:
        if s not in SCENARIOS:
            raise BenchError(f"unknown scenario {s!r}; choose from {', '.join(SCENARIOS)}")
    cells = [(c, s) for c in CONTROLLERS for s in MATRIX[c] if c in cs and s in ss]
    if not cells:
        raise BenchError(f"no cell of the matrix has controller(s) {', '.join(cs)} and "
                         f"scenario(s) {', '.join(ss)}; the matrix: "
                         + "; ".join(f"{c}: {', '.join(v)}" for c, v in MATRIX.items()))
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
        self.com.append([float(x) for x in ch.com()])
        if self.reference is not None:
            self.joints.append(ch.joint_positions())

    def series(self) -> dict:
        err = None
        if self.reference is not None and self.t:
            t = np.asarray(self.t)
            ref = self.reference.body_positions(t)[:, self.reference.joint_body_ids]
            err = np.linalg.norm(np.asarray(self.joints) - ref, axis=-1).mean(axis=1).tolist()
        return {"t_s": [round(x, 6) for x in self.t], "com_m": self.com,
                "tracking_error_m": err}


class _LazyVideo:
    """A :class:`~controllers.render.VideoRecorder` created on the first frame (so it can film
    a Character built inside a scenario function)."""

    def __init__(self, path: Path, fps: float):
        self.path, self.fps = path, fps
        self.recorder = None

    def capture(self, ch) -> None:
        if self.recorder is None:
            from .render import VideoRecorder

            self.recorder = VideoRecorder(ch, self.path, fps=self.fps)
        self.recorder.capture(ch)

    def close(self) -> int:
        if self.recorder is None:
            return 0
        self.recorder.close()
        return self.recorder.frames


class _Context:
    """What the cells share: the pristine model, the references, the trajectories, videos."""

    def __init__(self, config: BenchConfig, trajectories: dict[str, Path],
                 video_dir: Path | None, log: Callable[[str], None]):
        from .character import Character

        self.config = config
        self.base_model = Character().model  # pristine; every run copies it
        self.trajectories = trajectories
        self.video_dir = video_dir
        self.log = log
        self.track_motion = default_track_motion()
        self._refs: dict[str, object] = {}
        self._trajs: dict[str, object] = {}
        self.videos: list[dict] = []

    def character(self, timestep: float | None = None):
        from .character import Character

        return Character(self.base_model, timestep=timestep)

    def reference(self, path: Path):
        key = str(path)
        if key not in self._refs:
            import bvh
            from bvh.reference import ReferenceMotion

            ch = self.character()
            self._refs[key] = ReferenceMotion(ch.model, bvh.load(path), info=ch.info)
        return self._refs[key]

    def trajectory(self, name: str):
        if name not in self._trajs:
            from .trajectory import load_trajectory

            self._trajs[name] = load_trajectory(self.trajectories[name])
        return self._trajs[name]

    def video(self, controller: str, scenario: str) -> _LazyVideo | None:
        if self.video_dir is None:
            return None
        return _LazyVideo(self.video_dir / f"{controller}_{scenario}.mp4", self.config.fps)


def default_track_motion() -> Path:
    """``../shared/data/bvh/walk60.bvh`` when present, else the bundled walk."""
    shared = SHARED_BVH / "walk60.bvh"
    if shared.is_file():
        return shared
    from bvh.assets import motion_path

    return motion_path("walk")


def _timestep(name: str) -> float | None:
    """Physics time step the controller runs at (``None``: the model's)."""
    from . import scenarios as S

    return S.default_timestep(name)


def _build(ctx: _Context, name: str, scenario: str, reference=None):
    """A fresh ``(character, controller)`` for one run (as ``mjchar run`` builds them: PD
    trackers follow the reference in track/walk and hold the standing pose otherwise)."""
    from . import scenarios as S

    ch = ctx.character(_timestep(name))
    spec = CONTROLLERS[name]
    if spec.kind in ("pd", "balance"):
        target = reference if reference is not None else S.standing_pose(ch)
        return ch, S.make_controller(name, ch, target)
    if name == "simbicon":
        return ch, S.make_controller(name, ch, gait="walk")
    if name == "ipm":
        speed = ctx.config.ipm_speed if scenario in ("walk", "slopes") else 0.0
        return ch, S.make_controller(name, ch, speed=speed)
    raise BenchError(f"{name} is not built by _build")  # replays go through trajectory.replay


def _result_run(variant: str, seed, r, probe: _Probe, frames: int | None = None) -> dict:
    run = {"variant": variant, "seed": None if seed is None else int(seed),
           "survived": not r.fell, "result": r.to_dict(), "series": probe.series()}
    if frames:
        run["video_frames"] = frames
    return run


def _run_one(ctx: _Context, cell_video: list, variant: str, seed, reference,
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
    finally:
        if video is not None:
            frames = video.close()
    run = _result_run(variant, seed, r, probe, frames)
    if video is not None and frames:
        run["video"] = video.path.name
        ctx.videos.append({"file": video.path.name, "frames": frames,
                           "controller": r.controller, "scenario": r.scenario})
    return run


def _run_cell(ctx: _Context, name: str, scenario: str) -> list[dict]:
    """All runs of one cell (a list of run records, see docs/bench.md)."""
    from . import scenarios as S

    cfg = ctx.config
    spec = CONTROLLERS[name]
    vid = ctx.video(name, scenario)
    cell_video = [vid] if vid is not None else []
    runs: list[dict] = []

    def progress(msg: str) -> None:
        ctx.log(f"  {name} / {scenario}: {msg}")

    if scenario == "stand":
        ch, c = _build(ctx, name, scenario)
        runs.append(_run_one(ctx, cell_video, "stand", None, None, lambda cb: S.stand(
            ch, c, duration=cfg.stand_duration, frame_callback=cb)))
    elif scenario == "random-push":
        for s in cfg.seeds:
            ch, c = _build(ctx, name, scenario)
            runs.append(_run_one(ctx, cell_video, f"seed {s}", s, None, lambda cb, ch=ch, c=c,
                                 s=s: S.random_push(ch, c, seed=int(s),
                                                    force=cfg.random_push_force,
                                                    duration=cfg.random_push_duration,
                                                    frame_callback=cb)))
    elif scenario == "push-search":
        directions = {d: S.DIRECTIONS[d] for d in cfg.push_directions}
        if spec.push == "walking":
            runs.append(_walking_push_search(ctx, cell_video, name, directions, progress))
        else:
            ch, c = _build(ctx, name, scenario)
            runs.append(_run_one(ctx, cell_video, "weakest direction", None, None,
                                 lambda cb: S.push_search(
                                     ch, c, directions=directions, max_force=cfg.push_max_force,
                                     tolerance=cfg.push_tolerance, allow_steps=spec.steps,
                                     duration=cfg.push_duration, progress=progress,
                                     frame_callback=cb)))
        runs[-1]["push_protocol"] = push_protocol(name, cfg)
    elif scenario == "walk":
        from .terrain import walk

        for s in _walk_seeds(ctx, name, scenario):
            ch, c = _build(ctx, name, scenario)
            runs.append(_run_one(ctx, cell_video, _seed_label(s), s, None, lambda cb, ch=ch, c=c,
                                 s=s: walk(ch, c, duration=cfg.walk_duration, seed=s,
                                           steady_window=cfg.steady_window,
                                           frame_callback=cb)))
    elif scenario == "slopes":
        from .terrain import slope_walk

        for deg in (abs(cfg.slope_degrees), -abs(cfg.slope_degrees)):
            for s in _walk_seeds(ctx, name, scenario):
                ch, c = _build(ctx, name, scenario)
                runs.append(_run_one(
                    ctx, cell_video, f"{deg:+g} deg, {_seed_label(s)}", s, None,
                    lambda cb, ch=ch, c=c, s=s, deg=deg: slope_walk(
                        ch, c, degrees=deg, distance=cfg.slope_distance,
                        duration=cfg.slope_duration, seed=s, frame_callback=cb)))
    elif scenario == "track":
        if spec.kind == "replay":
            runs.append(_replay_run(ctx, cell_video, name))
        else:
            ref = ctx.reference(ctx.track_motion)
            ch, c = _build(ctx, name, scenario, ref)
            runs.append(_run_one(ctx, cell_video, ctx.track_motion.name, None, ref,
                                 lambda cb: S.track(ch, c, ref, duration=cfg.track_duration,
                                                    frame_callback=cb)))
    else:
        raise BenchError(f"unknown scenario {scenario!r}")
    for run in runs:
        run["result"]["controller"] = name  # e.g. "replay" -> the row's name
    return runs


def _walk_seeds(ctx: _Context, name: str, scenario: str) -> list[int | None]:
    """The seeds of a walk: every seed for a controller whose start state is perturbed from the
    seed (it has ``start_state``), else one run without a seed (every seed would give the same
    run)."""
    _, c = _build(ctx, name, scenario)
    return [int(s) for s in ctx.config.seeds] if hasattr(c, "start_state") else [None]


def _seed_label(seed) -> str:
    return "no seed (deterministic start)" if seed is None else f"seed {seed}"


def push_protocol(name: str, cfg: BenchConfig) -> str:
    """One line: how push-search measured ``name``'s largest push."""
    spec = CONTROLLERS[name]
    if spec.push == "walking":
        return (f"walking: 0.2 s on the chest at {cfg.walk_push_phases} phase(s) of the stride "
                f"after {cfg.walk_push_warmup:g} s, still walking {cfg.walk_push_after:g} s "
                f"later; bisection to {cfg.walk_push_tolerance:g} N, max "
                f"{cfg.walk_push_max_force:g} N")
    return (f"standing: 0.2 s on the pelvis 1 s in, no fall in {cfg.push_duration:g} s"
            + ("" if spec.steps else " and no step") + f"; bisection to {cfg.push_tolerance:g} "
            f"N, max {cfg.push_max_force:g} N")


def _walking_push_search(ctx: _Context, cell_video: list, name: str, directions: dict,
                         progress) -> dict:
    """Largest push survived while walking at every phase (terrain.push_search), then one
    filmed run at the weakest direction's value."""
    from .terrain import push_search, push_walk

    cfg = ctx.config
    ch, c = _build(ctx, name, "push-search")
    kw = {"warmup": cfg.walk_push_warmup, "after": cfg.walk_push_after, "seed": cfg.seeds[0]}
    best = push_search(ch, c, directions=list(directions), phases=cfg.walk_push_phases,
                       max_force=cfg.walk_push_max_force, tolerance=cfg.walk_push_tolerance,
                       progress=progress, **kw)
    weakest = min(best, key=best.get)

    def final(cb):
        ch2, c2 = _build(ctx, name, "push-search")
        r = push_walk(ch2, c2, force=best[weakest], direction=directions[weakest], phase=0.0,
                      frame_callback=cb, **kw)
        r.scenario = "push-search"
        r.max_push_N = best[weakest]
        r.max_push_by_direction_N = best
        return r

    return _run_one(ctx, cell_video, "weakest direction", cfg.seeds[0], None, final)


def _replay_run(ctx: _Context, cell_video: list, name: str) -> dict:
    from .trajectory import StoredReference, replay

    tr = ctx.trajectory(name)
    ref = None
    if tr.reference_qpos is not None:
        ch = ctx.character(tr.timestep)
        ref = StoredReference(ch.model, tr.reference_qpos, tr.control_dt, ch.joint_bodies)
    path = ctx.trajectories[name]
    return _run_one(ctx, cell_video, path.name, None, ref,
                    lambda cb: replay(tr, model=ctx.base_model, frame_callback=cb,
                                      reference=ref))


def summarise_cell(runs: list[dict]) -> dict:
    """Per-cell aggregates over its runs (means; ``None`` where no run has the metric)."""
    def mean(values):
        v = [x for x in values if x is not None]
        return float(np.mean(v)) if v else None

    res = [r["result"] for r in runs]
    steady = [r["extra"].get("steady_speed_mps") for r in res]
    speed = mean(steady) if all(s is not None for s in steady) and res else \
        mean(r["mean_speed_mps"] for r in res)
    push = next((r["max_push_by_direction_N"] for r in res
                 if r.get("max_push_by_direction_N")), None)
    return {"runs": len(runs), "survived": sum(bool(r["survived"]) for r in runs),
            "fell": [r["variant"] for r in runs if not r["survived"]],
            "distance_m": mean(r["distance_m"] for r in res), "speed_mps": speed,
            "tracking_error_m": mean(r["tracking_error_m"] for r in res),
            "root_force_mean_N": mean(r["root_force_mean_N"] for r in res),
            "max_push_by_direction_N": push,
            "push_protocol": next((r["push_protocol"] for r in runs if "push_protocol" in r),
                                  None)}


def _progress_bar(total: int, enabled: bool, desc: str):
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit="cell", file=sys.stderr, disable=not enabled,
                dynamic_ncols=True, leave=True)


def run_matrix(cells: Sequence[tuple[str, str]], config: BenchConfig, *,
               trajectories: dict[str, Path] | None = None, video_dir: Path | None = None,
               progress: bool = True) -> tuple[dict, list[dict], list[dict]]:
    """Run every cell; returns ``(controllers, cells, videos)`` records of the JSON document.

    A controller that is not available gets cells with status ``"not available"``; a cell whose
    run raises gets status ``"error"`` (its message in ``reason``) and the others still run.
    """
    config.check()
    trajectories = dict(trajectories or {})
    bar = _progress_bar(len(cells), progress, "bench")
    log = (lambda msg: bar.write(msg, file=sys.stderr)) if progress else (lambda msg: None)
    ctx = _Context(config, trajectories, video_dir, log)
    names = list(dict.fromkeys(c for c, _ in cells))
    controllers = {}
    for n in names:
        ok, why = availability(n, trajectories)
        spec = CONTROLLERS[n]
        controllers[n] = {"label": spec.label, "available": ok, "reason": why,
                          "timestep_s": _timestep(n) if ok and spec.kind != "replay" else None,
                          "scenarios": [s for c, s in cells if c == n],
                          "trajectory": (str(trajectories[n]) if n in trajectories else None)}
        if ok and spec.kind == "replay":
            try:
                controllers[n]["timestep_s"] = ctx.trajectory(n).timestep
            except MjcharError as e:  # a damaged or foreign file: a row saying so
                controllers[n].update(available=False, reason=str(e))
        if ok and controllers[n]["timestep_s"] is None:
            controllers[n]["timestep_s"] = float(ctx.base_model.opt.timestep)
    out = []
    expected = set(EXPECTATIONS)
    for name, scenario in cells:
        bar.set_description(f"{name} / {scenario}")
        cell = {"controller": name, "scenario": scenario, "status": "ok", "reason": None,
                "expected_to_survive": (name, scenario) in expected, "wall_s": 0.0,
                "runs": [], "summary": summarise_cell([])}
        if not controllers[name]["available"]:
            cell["status"], cell["reason"] = "not available", controllers[name]["reason"]
        else:
            t0 = time.perf_counter()
            try:
                cell["runs"] = _run_cell(ctx, name, scenario)
            except Exception as e:  # report it in the table, keep benchmarking the rest
                cell["status"] = "error"
                cell["reason"] = f"{type(e).__name__}: {e}"
                log(f"  {name} / {scenario}: ERROR {cell['reason']}")
            cell["wall_s"] = time.perf_counter() - t0
            cell["summary"] = summarise_cell(cell["runs"])
            s = cell["summary"]
            if cell["status"] == "ok":
                log(f"{name} / {scenario}: {s['survived']}/{s['runs']} without a fall "
                    f"({cell['wall_s']:.1f} s)")
        out.append(cell)
        bar.update()
    bar.close()
    return controllers, out, ctx.videos


# -- performance ---------------------------------------------------------------------------------
def _start_state(ctx: _Context, name: str, ch, controller):
    """Start pose/velocity for the step-cost measurement (the controller's own start state when
    it has one, e.g. SIMBICON's, else the standing pose)."""
    from . import scenarios as S
    from .terrain import place_on_floor

    if hasattr(controller, "start_state"):
        controller.reset(ch)
        q, v = controller.start_state(ch, None)
        return place_on_floor(ch, q), v
    return S.standing_pose(ch), None


def run_performance(controllers: Sequence[str], config: BenchConfig, *,
                    trajectories: dict[str, Path] | None = None, progress: bool = True,
                    parts: Sequence[str] = ("raw", "cost", "rollout", "envs", "bvh",
                                            "envelope")) -> dict:
    """The performance section (all measured now, on this machine's current load).

    Each part is ``{"available": bool, "reason": str | None, "wall_s": s, ...numbers}``;
    ``cost`` has one entry per available controller. See docs/bench.md.
    """
    from . import perf

    cfg = config.perf
    trajectories = dict(trajectories or {})
    bar = _progress_bar(len(parts), progress, "performance")
    log = (lambda msg: bar.write(msg, file=sys.stderr)) if progress else (lambda msg: None)
    ctx = _Context(config, trajectories, None, log)
    out: dict = {"load_average": _load()}

    def part(key: str, fn: Callable[[], dict]) -> None:
        bar.set_description(f"performance: {key}")
        t0 = time.perf_counter()
        try:
            rec = {"available": True, "reason": None, **fn()}
        except perf.PerfUnavailable as e:
            rec = {"available": False, "reason": str(e)}
        except Exception as e:  # a broken optional part must not lose the rest of the report
            rec = {"available": False, "reason": f"error: {type(e).__name__}: {e}"}
        rec["wall_s"] = time.perf_counter() - t0
        out[key] = rec
        bar.update()

    for key in parts:
        if key == "raw":
            def raw():
                from . import scenarios as S

                ch = ctx.character()
                return perf.raw_step_rate(ch.model, S.standing_pose(ch), steps=cfg.raw_steps,
                                          repeats=cfg.raw_repeats)
            part("raw", raw)
        elif key == "cost":
            part("cost", lambda: {"controllers": _costs(ctx, controllers, cfg, log)})
        elif key == "rollout":
            part("rollout", lambda: perf.rollout_throughput(
                samples=cfg.rollout_samples, steps=cfg.rollout_steps,
                repeats=cfg.rollout_repeats, threads=cfg.rollout_threads))
        elif key == "envs":
            part("envs", lambda: perf.env_throughput(steps=cfg.env_steps,
                                                     repeats=cfg.env_repeats))
        elif key == "bvh":
            part("bvh", lambda: perf.bvh_parse_speed(_bvh_files(), budget=cfg.bvh_budget_s))
        elif key == "envelope":
            part("envelope", lambda: perf.stability_envelope(
                kps=cfg.envelope_kps, grid=cfg.envelope_grid, finer=cfg.envelope_finer,
                duration=cfg.envelope_duration_s, model=ctx.base_model, progress=log))
        else:
            raise BenchError(f"unknown performance part {key!r}")
    bar.close()
    return out


def _costs(ctx: _Context, controllers: Sequence[str], cfg: PerfConfig, log) -> dict:
    from . import perf

    out = {}
    for name in controllers:
        ok, why = availability(name, ctx.trajectories)
        if not ok:
            out[name] = {"available": False, "reason": why}
            continue
        try:
            if CONTROLLERS[name].kind == "replay":
                from .trajectory import ReplayController

                tr = ctx.trajectory(name)
                ch = ctx.character(tr.timestep)
                c = perf.step_cost(ch, lambda tr=tr: ReplayController(tr), qpos=tr.initial_qpos,
                                   qvel=tr.initial_qvel, control_dt=tr.control_dt,
                                   steps=cfg.cost_steps, repeats=cfg.cost_repeats)
            else:
                scenario = "walk" if CONTROLLERS[name].kind == "walker" else "stand"
                ch, probe_ctrl = _build(ctx, name, scenario)
                q, v = _start_state(ctx, name, ch, probe_ctrl)
                ch = ctx.character(_timestep(name))  # fresh: the raw loop copies its model
                c = perf.step_cost(ch, lambda n=name, s=scenario: _build(ctx, n, s)[1], qpos=q,
                                   qvel=v, steps=cfg.cost_steps, repeats=cfg.cost_repeats)
            out[name] = {"available": True, "reason": None, **c.to_dict()}
            log(f"  step cost {name}: {c.ratio:.2f} x mj_step ({c.controller_us:.0f} vs "
                f"{c.raw_us:.0f} us per step)")
        except Exception as e:
            out[name] = {"available": False, "reason": f"error: {type(e).__name__}: {e}"}
    return out


def _bvh_files() -> list[Path]:
    shared = [SHARED_BVH / n for n in ("walk60.bvh", "idle.bvh", "walk_forward.bvh",
                                       "walk_and_turn_right.bvh")]
    files = [p for p in shared if p.is_file()]
    if not files:
        from bvh.assets import motion_path

        files = [motion_path("walk"), motion_path("idle")]
    return files


def _load() -> float | None:
    try:
        return float(os.getloadavg()[0])
    except (AttributeError, OSError):
        return None


# -- the report ----------------------------------------------------------------------------------
def table_rows(doc: dict) -> list[dict]:
    """One row per controller: survival, largest push per direction, distance, speed, tracking
    error, root-force effort, step cost ratio (see docs/bench.md for where each comes from)."""
    rows = []
    costs = (doc.get("performance") or {}).get("cost") or {}
    costs = costs.get("controllers", {}) if costs.get("available") else {}
    for name, info in doc["controllers"].items():
        cells = {c["scenario"]: c for c in doc["cells"] if c["controller"] == name}
        row = {"controller": name, "label": info["label"], "available": info["available"],
               "reason": info["reason"], "survived": None, "runs": None, "fell": [],
               "errors": [f"{s}: {c['reason']}" for s, c in cells.items()
                          if c["status"] == "error"],
               "max_push_by_direction_N": None, "push_protocol": None, "distance_m": None,
               "speed_mps": None, "motion_source": None, "tracking_error_m": None,
               "root_force_mean_N": None, "step_cost_ratio": None}
        surv = [c for s, c in cells.items() if s in SURVIVAL_SCENARIOS and c["status"] == "ok"]
        if surv:
            row["survived"] = sum(c["summary"]["survived"] for c in surv)
            row["runs"] = sum(c["summary"]["runs"] for c in surv)
            row["fell"] = [f"{c['scenario']} ({v})" for c in surv for v in c["summary"]["fell"]]
            forces = [r["result"]["root_force_mean_N"] for c in surv for r in c["runs"]]
            row["root_force_mean_N"] = float(np.mean(forces)) if forces else None
        ps = cells.get("push-search")
        if ps is not None and ps["status"] == "ok":
            row["max_push_by_direction_N"] = ps["summary"]["max_push_by_direction_N"]
            row["push_protocol"] = ps["summary"]["push_protocol"]
        for src in ("walk", "track"):
            c = cells.get(src)
            if c is not None and c["status"] == "ok" and c["runs"]:
                row["distance_m"] = c["summary"]["distance_m"]
                row["speed_mps"] = c["summary"]["speed_mps"]
                row["motion_source"] = src
                break
        tr = cells.get("track")
        if tr is not None and tr["status"] == "ok":
            row["tracking_error_m"] = tr["summary"]["tracking_error_m"]
        cost = costs.get(name)
        if cost and cost.get("available"):
            row["step_cost_ratio"] = cost["ratio"]
        rows.append(row)
    return rows


def check_expectations(doc: dict) -> list[dict]:
    """Each :data:`EXPECTATIONS` entry among the run's controllers: ``{"controller",
    "scenario", "status": "pass" | "fail" | "skipped", "detail"}``. ``fail``: a run fell or the
    cell raised; ``skipped``: the controller is not available or the cell was not selected."""
    cells = {(c["controller"], c["scenario"]): c for c in doc["cells"]}
    out = []
    for name, scenario in EXPECTATIONS:
        c = cells.get((name, scenario))
        if c is None:
            status, detail = "skipped", "not selected"
        elif c["status"] == "not available":
            status, detail = "skipped", f"not available: {c['reason']}"
        elif c["status"] == "error":
            status, detail = "fail", f"error: {c['reason']}"
        elif c["summary"]["survived"] < c["summary"]["runs"]:
            fell = [r for r in c["runs"] if not r["survived"]]
            status = "fail"
            detail = "; ".join(f"{r['variant']}: fell at {_num(r['result']['fall_time_s'])} s "
                               f"({r['result']['fall_reason']})" for r in fell)
        else:
            status, detail = "pass", f"{c['summary']['runs']} run(s) without a fall"
        out.append({"controller": name, "scenario": scenario, "status": status,
                    "detail": detail})
    return out


def _num(x, fmt: str = ".2f") -> str:
    return "-" if x is None else format(x, fmt)


def _push_text(row: dict) -> str:
    p = row["max_push_by_direction_N"]
    if not p:
        return "-"
    text = "/".join(f"{p[d]:.0f}" if d in p else "-" for d in DIRECTION_NAMES)
    proto = row["push_protocol"] or ""
    if proto.startswith("walking"):
        text += " w"
    elif "no step" not in proto:
        text += " s"
    return text


TABLE_HEADER = ("controller", "survival", "push F/L/B/R (N)", "distance (m)", "speed (m/s)",
                "track err (m)", "root force (N)", "cost / mj_step")


def _cells(row: dict) -> list[str]:
    if not row["available"]:
        return [row["controller"], "not available", "", "", "", "", "", ""]
    surv = "-" if row["runs"] is None else f"{row['survived']}/{row['runs']}"
    if row["errors"]:
        surv += " (error)"
    dist = _num(row["distance_m"])
    if row["distance_m"] is not None and row["motion_source"] == "track":
        dist += " t"
    return [row["controller"], surv, _push_text(row), dist, _num(row["speed_mps"]),
            _num(row["tracking_error_m"], ".3f"), _num(row["root_force_mean_N"], ".0f"),
            _num(row["step_cost_ratio"])]


TABLE_NOTES = (
    "survival: runs without a fall over stand, random-push, walk, track and slopes runs.",
    "push: largest 0.2 s push survived per direction (forward/left/backward/right); standing "
    "on the pelvis without a step unless marked s (stepping allowed), w: while walking, on the "
    "chest at every tested phase.",
    "distance, speed: the walk scenario (steady speed over the last seconds), t: the track "
    "scenario instead. track err: mean joint position error against the reference.",
    "root force: mean external force on the root (hand of god) over the survival runs.",
    "cost / mj_step: controller + physics CPU time per physics step over a bare mj_step.",
)


def format_table(rows: list[dict]) -> str:
    """The terminal table (fixed-width columns), with the reasons of unavailable rows and the
    notes below it."""
    body = [list(TABLE_HEADER)] + [_cells(r) for r in rows]
    widths = [max(len(line[i]) for line in body) for i in range(len(TABLE_HEADER))]
    lines = []
    for k, line in enumerate(body):
        lines.append("  ".join(c.ljust(w) if i == 0 else c.rjust(w)
                               for i, (c, w) in enumerate(zip(line, widths, strict=True)))
                     .rstrip())
        if k == 0:
            lines.append("  ".join("-" * w for w in widths))
    for r in rows:
        if not r["available"]:
            lines.append(f"{r['controller']}: not available: {r['reason']}")
        for e in r["errors"]:
            lines.append(f"{r['controller']}: ERROR in {e}")
    lines.append("")
    lines.extend(TABLE_NOTES)
    return "\n".join(lines)


def markdown_table(rows: list[dict]) -> str:
    """The same table in Markdown (for the docs and the README)."""
    lines = ["| " + " | ".join(TABLE_HEADER) + " |", "|---" * len(TABLE_HEADER) + "|"]
    for r in rows:
        cells = _cells(r)
        if not r["available"]:
            cells[1] = f"not available ({r['reason']})"
        lines.append("| " + " | ".join(c.replace("|", "/") for c in cells) + " |")
    return "\n".join(lines)


def format_performance(perf: dict) -> str:
    """A few readable lines of the performance section."""
    lines = []
    raw = perf.get("raw") or {}
    if raw.get("available"):
        lines.append(f"raw mj_step (dt {raw['timestep_s'] * 1e3:g} ms): "
                     f"{raw['c_loop_steps_per_s']:,.0f} steps/s wall, "
                     f"{raw['c_loop_steps_per_cpu_s']:,.0f} per CPU-second (C loop); "
                     f"{raw['python_loop_steps_per_s']:,.0f} wall, "
                     f"{raw['python_loop_steps_per_cpu_s']:,.0f} per CPU-second (Python loop)")
    ro = perf.get("rollout") or {}
    if ro.get("available"):
        lines.append("batched rollouts (" + f"{ro['samples']} x {ro['steps_per_sample']} steps): "
                     + ", ".join(f"{c['case']} {c['steps_per_s']:,.0f} steps/s "
                                 f"({c['speedup_vs_python_loop']:.2f}x, {c['cores_busy']:.2f} "
                                 f"cores busy)" for c in ro["cases"]))
    elif ro:
        lines.append(f"batched rollouts: not available: {ro['reason']}")
    cost = perf.get("cost") or {}
    if cost.get("available"):
        parts = [f"{n} {c['ratio']:.2f}x" for n, c in cost["controllers"].items()
                 if c.get("available")]
        lines.append("step cost / mj_step: " + (", ".join(parts) or "none available"))
    env = perf.get("envs") or {}
    if env.get("available"):
        ref = env["reference"]
        lines.append("env steps/s: " + ", ".join(
            f"{e} {v['env_steps_per_s']:,.0f} ({v['physics_steps_per_s']:,.0f} physics/s, "
            f"{env['ratios'][e]['physics_steps']:.2f}x {ref}'s physics rate)"
            for e, v in env["envs"].items()))
    elif env:
        lines.append(f"env throughput: not available: {env['reason']}")
    bv = perf.get("bvh") or {}
    if bv.get("available"):
        lines.append("BVH parse vs bvhio.readAsBvh: " + ", ".join(
            f"{f['file']} {f['bvh_load_ms']:.2f} vs {f['bvhio_ms']:.2f} ms ({f['speedup']:.1f}x)"
            for f in bv["files"]))
    elif bv:
        lines.append(f"BVH parse speed: not available: {bv['reason']}")
    en = perf.get("envelope") or {}
    if en.get("available"):
        lines.append("PD stability envelope (largest held step): " + ", ".join(
            f"{r['variant']} kp {r['kp']:g}: "
            + (f"1/{r['largest_held_hz']} s" if r["largest_held_hz"] else "none")
            for r in en["rows"]))
    return "\n".join(lines)


def versions() -> dict:
    """Versions of mjchar, MuJoCo, numpy, Python (and Gymnasium when installed)."""
    import mujoco

    out = {"mjchar": _mjchar_version(), "mujoco": mujoco.__version__, "numpy": np.__version__,
           "python": platform.python_version()}
    try:
        from importlib.metadata import version

        out["gymnasium"] = version("gymnasium")
    except Exception:
        out["gymnasium"] = None
    return out


def _mjchar_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("mjchar")
    except PackageNotFoundError:
        pass
    try:
        import tomllib

        with open(ROOT / "pyproject.toml", "rb") as f:
            return str(tomllib.load(f)["project"]["version"])
    except (OSError, KeyError, ValueError):
        return "unknown"


def _clean(v):
    """JSON-ready copy: numpy scalars and arrays to Python, non-finite floats to ``None``,
    tuples to lists, paths to strings."""
    if isinstance(v, dict):
        return {str(k): _clean(x) for k, x in v.items()}
    if isinstance(v, list | tuple | np.ndarray):
        return [_clean(x) for x in v]
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


def _rel(p: Path) -> str:
    try:
        return str(Path(p).resolve().relative_to(ROOT))
    except ValueError:
        return str(p)


def run_bench(config: BenchConfig, *, controllers: Sequence[str] | None = None,
              scenarios: Sequence[str] | None = None, out_dir: str | os.PathLike | None = None,
              videos: bool = False, performance: bool = True, plots: bool = True,
              trajectories: dict[str, Path] | None = None, progress: bool = True,
              command: Sequence[str] | None = None) -> dict:
    """Run the matrix (and the performance section), write ``results.json``, the plots and the
    videos into ``out_dir`` (nothing is written when it is ``None``); returns the document.

    Args:
        config: :func:`quick_config` or :func:`full_config` (possibly replaced).
        controllers, scenarios: subsets (default: all); the cells are the matrix's among them.
        videos: one MP4 per cell (first run) plus a PNG still of its middle frame (needs
            ``MUJOCO_GL=egl`` and the video extra).
        performance: run the performance section (step-cost ratios of the selected
            controllers, raw and batched throughput, envs, BVH parsing, PD envelope).
        plots: write the PNG plots (needs matplotlib: the bench extra).
        trajectories: ``{"samcon_replay": path, "cmaes_replay": path}`` (default:
            :func:`find_trajectories`).
    """
    config.check()
    t_start = time.perf_counter()
    cells = select_cells(controllers, scenarios)
    trajectories = find_trajectories() if trajectories is None else dict(trajectories)
    out = None if out_dir is None else Path(out_dir)
    if out is not None:
        try:
            out.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise BenchError(f"cannot create the output folder {out}: {e}") from None
    if plots:
        from .bench_plots import require_matplotlib

        require_matplotlib()  # fail now, not after the whole run
    video_dir = None
    if videos:
        if out is None:
            raise BenchError("videos need an output folder")
        video_dir = out / "videos"
        video_dir.mkdir(exist_ok=True)
    doc: dict = {
        "schema": SCHEMA_NAME, "schema_version": SCHEMA_VERSION,
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "command": list(command) if command is not None else None,
        "versions": versions(),
        "machine": {"platform": platform.platform(), "machine": platform.machine(),
                    "cpu_count": os.cpu_count(), "load_average_start": _load()},
        "config": config.to_dict(), "seeds": [int(s) for s in config.seeds],
        "track_motion": _rel(default_track_motion()),
    }
    t0 = time.perf_counter()
    doc["controllers"], doc["cells"], vids = run_matrix(
        cells, config, trajectories=trajectories, video_dir=video_dir, progress=progress)
    timings = {"matrix_s": time.perf_counter() - t0}
    doc["performance"] = None
    if performance:
        t0 = time.perf_counter()
        names = [n for n in doc["controllers"]]
        doc["performance"] = run_performance(names, config, trajectories=trajectories,
                                             progress=progress)
        timings["performance_s"] = time.perf_counter() - t0
    doc["table"] = table_rows(doc)
    doc["expectations"] = check_expectations(doc)
    doc["videos"] = vids
    doc["stills"] = []
    doc["plots"] = []
    if out is not None:
        t0 = time.perf_counter()
        if videos and vids:
            doc["stills"] = write_stills(out, vids)
            if plots:
                from .bench_plots import plot_walk_strip

                strip = plot_walk_strip(out, vids, fps=config.fps)
                if strip is not None:
                    doc["stills"].append(strip.name)
        if plots:
            from .bench_plots import make_plots

            doc["plots"] = [p.name for p in make_plots(doc, out)]
        (out / "table.md").write_text(markdown_table(doc["table"]) + "\n\n"
                                      + "\n".join(f"- {n}" for n in TABLE_NOTES) + "\n")
        timings["outputs_s"] = time.perf_counter() - t0
    timings["cells"] = {f"{c['controller']} / {c['scenario']}": c["wall_s"]
                        for c in doc["cells"]}
    doc["timings"] = timings
    doc["wall_s"] = time.perf_counter() - t_start
    doc["machine"]["load_average_end"] = _load()
    if out is not None:
        write_json(doc, out / "results.json")
    return doc


#: cells whose video still becomes the README's ``still.png``, in order of preference
STILL_PREFERENCE = (("simbicon", "walk"), ("ipm", "walk"), ("hand_of_god", "track"),
                    ("static_balance", "stand"))


def write_stills(out: Path, videos: list[dict]) -> list[str]:
    """A PNG of the middle frame of every video (``stills/NAME.png``) and ``still.png`` from the
    preferred cell (:data:`STILL_PREFERENCE`); returns the files written (relative to ``out``)."""
    import shutil

    import imageio.v2 as imageio

    d = out / "stills"
    d.mkdir(exist_ok=True)
    written = {}
    for v in videos:
        path = out / "videos" / v["file"]
        reader = imageio.get_reader(path)
        try:
            frame = reader.get_data(max(0, v["frames"] // 2))
        except (IndexError, ValueError):
            frame = reader.get_data(0)
        finally:
            reader.close()
        png = d / (Path(v["file"]).stem + ".png")
        imageio.imwrite(png, frame)
        written[(v["controller"], v["scenario"])] = png
    files = [str(p.relative_to(out)) for p in written.values()]
    for key in STILL_PREFERENCE + tuple(written):
        if key in written:
            shutil.copyfile(written[key], out / "still.png")
            files.append("still.png")
            break
    return files


def write_json(doc: dict, path: str | os.PathLike) -> Path:
    """Write the document as JSON (non-finite numbers as ``null``)."""
    p = Path(path)
    p.write_text(json.dumps(_clean(doc), indent=1, allow_nan=False) + "\n")
    return p


def physics_view(doc: dict) -> dict:
    """The parts of a document that depend only on the physics (timings, dates, loads and the
    performance section removed): equal for equal seeds and settings."""
    cells = []
    for c in doc["cells"]:
        c = copy.deepcopy(c)
        c.pop("wall_s", None)
        for r in c["runs"]:
            for k in TIMING_KEYS:
                r["result"].pop(k, None)
        cells.append(c)
    rows = [{k: v for k, v in r.items() if k != "step_cost_ratio"} for r in doc["table"]]
    return _clean({"cells": cells, "table": rows, "expectations": doc["expectations"],
                   "seeds": doc["seeds"], "config": doc["config"]})


def exit_status(doc: dict) -> int:
    """0 when no expectation failed, else 1."""
    return 1 if any(e["status"] == "fail" for e in doc["expectations"]) else 0


# -- schema validation (a small subset of JSON Schema, enough for docs/bench_schema.json) ---------
def load_schema(path: str | os.PathLike | None = None) -> dict:
    """The documented schema (``docs/bench_schema.json``)."""
    p = Path(SCHEMA_PATH if path is None else path)
    try:
        return json.loads(p.read_text())
    except (OSError, ValueError) as e:
        raise BenchError(f"cannot read the bench schema {p}: {e}") from None


_TYPES = {"object": dict, "array": list, "string": str, "boolean": bool, "null": type(None)}


def _is_type(v, t: str) -> bool:
    if t == "integer":
        return isinstance(v, int) and not isinstance(v, bool)
    if t == "number":
        return isinstance(v, int | float) and not isinstance(v, bool)
    return isinstance(v, _TYPES[t])


def validate(doc, schema: dict | None = None) -> list[str]:
    """Errors of ``doc`` against ``schema`` (default :func:`load_schema`); empty when valid.

    Supports the keywords the bench schema uses: ``type`` (one or a list), ``properties``,
    ``required``, ``additionalProperties`` (bool or schema), ``items``, ``enum``, ``const``,
    ``minimum``, ``minItems``, ``anyOf`` and local ``$ref`` (``#/$defs/...``).
    """
    schema = load_schema() if schema is None else schema
    errors: list[str] = []

    def resolve(s: dict) -> dict:
        while "$ref" in s:
            ref = s["$ref"]
            if not ref.startswith("#/"):
                raise BenchError(f"only local $ref is supported, got {ref}")
            node = schema
            for part in ref[2:].split("/"):
                node = node[part]
            s = node
        return s

    def check(v, s: dict, where: str) -> None:
        s = resolve(s)
        if "anyOf" in s:
            if not any(not _collect(v, sub) for sub in s["anyOf"]):
                errors.append(f"{where}: matches none of the allowed forms")
            return
        t = s.get("type")
        if t is not None:
            ts = t if isinstance(t, list) else [t]
            if not any(_is_type(v, x) for x in ts):
                errors.append(f"{where}: expected {' or '.join(ts)}, got {type(v).__name__}")
                return
        if "enum" in s and v not in s["enum"]:
            errors.append(f"{where}: {v!r} not one of {s['enum']}")
        if "const" in s and v != s["const"]:
            errors.append(f"{where}: expected {s['const']!r}, got {v!r}")
        if "minimum" in s and _is_type(v, "number") and v < s["minimum"]:
            errors.append(f"{where}: {v} below the minimum {s['minimum']}")
        if isinstance(v, dict):
            for k in s.get("required", []):
                if k not in v:
                    errors.append(f"{where}: missing required key {k!r}")
            props = s.get("properties", {})
            extra = s.get("additionalProperties", True)
            for k, x in v.items():
                if k in props:
                    check(x, props[k], f"{where}.{k}")
                elif extra is False:
                    errors.append(f"{where}: unexpected key {k!r}")
                elif isinstance(extra, dict):
                    check(x, extra, f"{where}.{k}")
        if isinstance(v, list):
            if "minItems" in s and len(v) < s["minItems"]:
                errors.append(f"{where}: fewer than {s['minItems']} items")
            if "items" in s:
                for i, x in enumerate(v):
                    check(x, s["items"], f"{where}[{i}]")

    def _collect(v, s) -> list[str]:
        saved = len(errors)
        check(v, s, "")
        new = errors[saved:]
        del errors[saved:]
        return new

    check(doc, schema, "$")
    return errors
