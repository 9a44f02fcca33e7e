"""Performance measurements for ``mjchar bench``: every figure is a ratio or a rate measured in
the same run, on the same machine load, so that the numbers compare with each other.

- :func:`raw_step_rate`: bare ``mujoco.mj_step`` throughput on the bundled humanoid (a C loop,
  ``mj_step(m, d, nstep)``, and a Python loop calling ``mj_step`` once per step).
- :func:`step_cost`: a controller's cost per physics step (``act`` + ``Character.step``) over a
  bare ``mj_step`` on a pristine copy of the same model at the same time step, in interleaved
  blocks timed with the process CPU clock (load from other processes affects both alike).
- :func:`rollout_throughput`: batched open-loop rollouts
  (:mod:`mjchar.controllers.sampling.rollout`, in C
  on a thread pool) against a Python ``mj_step`` loop over the same samples.
- :func:`env_throughput`: mjchar's Gymnasium envs against Gymnasium's ``Humanoid-v5``, random
  actions, interleaved rounds.
- :func:`bvh_parse_speed`: ``bvh.load`` against ``bvhio.readAsBvh`` on the same files, in
  alternating rounds.
- :func:`stability_envelope`: the largest time step at which each PD variant holds the standing
  pose (:func:`mjchar.controllers.core.scenarios.hold_pose`) per gain.

The scripts in ``benchmarks/`` measure the same things at greater length and write their tables
into the docs; these functions are the measurement done once, importable (``bench_pd.py`` could
call :func:`step_cost` and :func:`stability_envelope`, ``bench_envs.py`` :func:`env_throughput`,
``bench_rollout.py`` :func:`rollout_throughput`, ``bench_bvh.py`` :func:`bvh_parse_speed`).

Optional pieces (Gymnasium's MuJoCo envs, the project's envs, ``bvhio``) raise
:class:`PerfUnavailable` with the reason when they cannot be used.
"""

from __future__ import annotations

import copy
import gc
import math
import statistics
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from mjchar.bvh.errors import MjcharError
from mjchar.controllers.core.character import Character
from mjchar.controllers.core.errors import SimulationDiverged

__all__ = [
    "PerfError", "PerfUnavailable", "StepCost", "raw_step_rate", "step_cost",
    "rollout_throughput", "env_throughput", "bvh_parse_speed", "stability_envelope",
    "ENVELOPE_KPS", "ENVELOPE_VARIANTS", "ENVELOPE_GRID", "ENVELOPE_FINER", "ENV_IDS",
]

#: the gains (kp, N m/rad; kd = kp/10), PD variants and time steps (as 1/dt, Hz) of the envelope
ENVELOPE_KPS = (300.0, 1000.0, 3000.0)
ENVELOPE_VARIANTS = ("pd", "spd", "native_pd")
ENVELOPE_GRID = (2000, 1500, 1000, 750, 500, 360, 240, 180, 120, 90, 60, 45, 30)
#: smaller steps scanned only for a variant that fails at the grid's smallest step
ENVELOPE_FINER = (8000, 6000, 4000, 3000, 2500)
#: envs compared by :func:`env_throughput` (the last one is the yardstick)
ENV_IDS = ("mjchar/Imitation-v0", "mjchar/Stand-v0", "Humanoid-v5")


class PerfError(MjcharError):
    """A performance measurement was given impossible settings."""


class PerfUnavailable(PerfError):
    """An optional measurement cannot run here (missing package or module); the message says
    why and what to install."""


def _positive_int(n, what: str) -> int:
    if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 1:
        raise PerfError(f"{what} must be a positive integer, got {n!r}")
    return int(n)


# -- raw physics ---------------------------------------------------------------------------------
def raw_step_rate(model: mujoco.MjModel, qpos: np.ndarray | None = None, *, steps: int = 2000,
                  repeats: int = 3) -> dict:
    """Bare ``mj_step`` throughput on a copy of ``model`` from ``qpos`` (default ``qpos0``), the
    position actuators holding that pose.

    Args:
        model: the model (copied; its own time step is used).
        qpos: ``(nq,)`` start pose.
        steps: physics steps per timed run; repeats: timed runs (the best is kept).
    Returns:
        ``{"timestep_s", "steps", "repeats", "c_loop_steps_per_s", "python_loop_steps_per_s",
        "c_loop_steps_per_cpu_s", "python_loop_steps_per_cpu_s"}`` (wall and process-CPU rates).
    """
    steps, repeats = _positive_int(steps, "steps"), _positive_int(repeats, "repeats")
    m = copy.deepcopy(model)
    d = mujoco.MjData(m)
    q0 = m.qpos0.copy() if qpos is None else np.asarray(qpos, dtype=float)
    ctrl = _hold_ctrl(m, q0)

    def reset() -> None:
        mujoco.mj_resetData(m, d)
        d.qpos[:] = q0
        d.ctrl[:] = ctrl

    def c_loop() -> None:
        mujoco.mj_step(m, d, steps)

    def py_loop() -> None:
        for _ in range(steps):
            mujoco.mj_step(m, d)

    best: dict[str, tuple[float, float]] = {}
    for name, fn in (("c_loop", c_loop), ("python_loop", py_loop)):
        walls, cpus = [], []
        for _ in range(repeats):
            reset()
            w, c = time.perf_counter(), time.process_time()
            fn()
            walls.append(time.perf_counter() - w)
            cpus.append(time.process_time() - c)
        best[name] = (min(walls), max(min(cpus), 1e-9))
    return {"timestep_s": float(m.opt.timestep), "steps": steps, "repeats": repeats,
            "c_loop_steps_per_s": steps / best["c_loop"][0],
            "python_loop_steps_per_s": steps / best["python_loop"][0],
            "c_loop_steps_per_cpu_s": steps / best["c_loop"][1],
            "python_loop_steps_per_cpu_s": steps / best["python_loop"][1]}


def _hold_ctrl(m: mujoco.MjModel, qpos: np.ndarray) -> np.ndarray:
    """``(nu,)`` position-actuator set-points holding ``qpos`` (joint actuators only)."""
    ctrl = np.zeros(m.nu)
    for a in range(m.nu):
        if m.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT:
            ctrl[a] = qpos[m.jnt_qposadr[m.actuator_trnid[a, 0]]]
    return ctrl


# -- controller step cost ------------------------------------------------------------------------
@dataclass
class StepCost:
    """A controller's cost per physics step relative to a bare ``mj_step``.

    Attributes:
        ratio: median over repeats of (controller CPU time) / (bare ``mj_step`` CPU time) for the
            same number of physics steps.
        controller_us: median controller cost per physics step (us, process CPU time).
        raw_us: median bare ``mj_step`` cost per physics step (us, process CPU time).
        timestep_s: physics time step of both loops (s).
        steps: physics steps per repeat; repeats: how many; resets: how often the controlled
            character fell or diverged and was put back at its start state.
    """

    ratio: float
    controller_us: float
    raw_us: float
    timestep_s: float
    steps: int
    repeats: int
    resets: int = 0

    def to_dict(self) -> dict:
        return {"ratio": self.ratio, "controller_us": self.controller_us, "raw_us": self.raw_us,
                "timestep_s": self.timestep_s, "steps": self.steps, "repeats": self.repeats,
                "resets": self.resets}


def step_cost(character: Character, make_controller: Callable[[], object], *,
              qpos: np.ndarray, qvel: np.ndarray | None = None, control_dt: float | None = None,
              steps: int = 2000, repeats: int = 5, block: int = 100) -> StepCost:
    """Cost per physics step of a controller on ``character`` over a bare ``mj_step``.

    The bare loop runs on a deep copy of ``character.model`` taken before any controller touches
    it (so: native ``<position>`` actuators holding ``qpos``, same time step), from ``qpos``. The
    controlled loop is ``controller.act`` + ``character.step`` from ``(qpos, qvel)``, acting every
    ``control_dt`` s (default: every physics step). The two alternate in blocks of ``block``
    physics steps, each timed with ``time.process_time``; a fall or a divergence of the
    controlled character puts it back at its start state.

    Args:
        character: a fresh character (time step already set).
        make_controller: builds a new controller (called once per repeat).
        qpos: ``(nq,)`` start pose; qvel: ``(nv,)`` start velocity (default zero).
        control_dt: seconds between control steps.
        steps: physics steps per repeat; repeats: repeats (the median ratio is reported).
        block: physics steps per timing block (rounded to whole control steps).
    """
    from mjchar.controllers.core.metrics import FallDetector

    steps, repeats = _positive_int(steps, "steps"), _positive_int(repeats, "repeats")
    block = _positive_int(block, "block")
    raw_model = copy.deepcopy(character.model)
    raw_data = mujoco.MjData(raw_model)
    qpos = np.asarray(qpos, dtype=float)
    ctrl = _hold_ctrl(raw_model, qpos)
    dt = character.timestep
    k = 1 if control_dt is None else max(1, int(round(control_dt / dt)))
    block = max(k, block // k * k)
    clock = time.process_time
    ratios, ctl_us, raw_us = [], [], []
    resets = 0
    for _ in range(repeats):
        c = make_controller()
        character.reset(qpos, qvel)
        c.reset(character)
        fall = FallDetector(character)
        mujoco.mj_resetData(raw_model, raw_data)
        raw_data.qpos[:] = qpos
        raw_data.ctrl[:] = ctrl
        t_raw = t_ctl = 0.0
        done = 0
        while done < steps:
            t0 = clock()
            mujoco.mj_step(raw_model, raw_data, block)
            t_raw += clock() - t0
            t0 = clock()
            try:
                for _ in range(block // k):
                    character.step(c.act(character, character.time), k)
            except SimulationDiverged:
                pass
            t_ctl += clock() - t0
            done += block
            if not np.all(np.isfinite(character.qpos)) or fall.check(character) is not None:
                resets += 1
                character.reset(qpos, qvel)
                c.reset(character)
        t_raw = max(t_raw, 1e-9)
        ratios.append(t_ctl / t_raw)
        ctl_us.append(t_ctl / done * 1e6)
        raw_us.append(t_raw / done * 1e6)
    return StepCost(statistics.median(ratios), statistics.median(ctl_us),
                    statistics.median(raw_us), dt, steps, repeats, resets)


# -- batched rollouts ----------------------------------------------------------------------------
def python_rollout_loop(model: mujoco.MjModel, data: mujoco.MjData, state: np.ndarray,
                        targets: np.ndarray, steps: int) -> None:
    """The plain-Python baseline of a batched rollout: for each sample ``b``, restore ``state``
    (full physics, cleared warm start), hold ``targets[b, 0]`` and ``mj_step`` ``steps`` times."""
    from mjchar.controllers.sampling.rollout import FULLPHYSICS

    for b in range(len(targets)):
        mujoco.mj_setState(model, data, state, FULLPHYSICS)
        data.qacc_warmstart[:] = 0.0
        data.ctrl[:] = targets[b, 0]
        for _ in range(steps):
            mujoco.mj_step(model, data)


def random_env_steps(env, steps: int, seed: int) -> tuple[float, int]:
    """``(wall seconds, episodes ended)`` for ``steps`` uniformly random actions in a Gymnasium
    ``env`` (seeded ``reset`` and action space; resets when an episode ends, timed too)."""
    env.action_space.seed(seed)
    env.reset(seed=seed)
    ended = 0
    t0 = time.perf_counter()
    for _ in range(steps):
        _, _, term, trunc, _ = env.step(env.action_space.sample())
        if term or trunc:
            ended += 1
            env.reset()
    return time.perf_counter() - t0, ended


def rollout_throughput(model_path: str | Path | None = None, *, samples: int = 256,
                       steps: int = 50, repeats: int = 3, threads: Sequence[int] = (1, 2),
                       seed: int = 0) -> dict:
    """Physics steps per second of batched rollouts against a Python ``mj_step`` loop.

    Every case simulates the same ``samples`` slices of ``steps`` physics steps (one PD-target
    vector per slice, the rest pose plus seeded Gaussian offsets of 0.1 rad) from the rest pose:
    a single-threaded Python loop (``mj_setState``, ``ctrl``, ``mj_step`` x ``steps``) and
    :func:`mjchar.controllers.sampling.rollout.rollout` with each thread count in ``threads``. Cases
    take turns in ``repeats`` rounds; the best wall time per case is kept, with the process CPU time
    of that run.

    Returns:
        ``{"samples", "steps_per_sample", "timestep_s", "repeats", "cases": [{"case", "threads",
        "steps_per_s", "steps_per_cpu_s", "cores_busy", "speedup_vs_python_loop"}]}``.
    """
    from mjchar.bvh.bundled.assets import humanoid_path
    from mjchar.controllers.sampling.rollout import RolloutModel, RolloutRequest, RolloutRunner

    samples, steps = _positive_int(samples, "samples"), _positive_int(steps, "steps")
    repeats = _positive_int(repeats, "repeats")
    path = humanoid_path() if model_path is None else model_path
    rm = RolloutModel.from_source(path)
    m = rm.model
    rng = np.random.default_rng(seed)
    rest = _hold_ctrl(m, m.qpos0)
    targets = rest + rng.normal(0.0, 0.1, (samples, 1, m.nu))
    s0 = rm.initial_state()
    request = RolloutRequest(rm, s0, targets, steps)
    data = mujoco.MjData(m)

    def loop() -> None:
        python_rollout_loop(m, data, s0, targets, steps)

    cases: list[tuple[str, int, Callable[[], object]]] = [("Python mj_step loop", 1, loop)]
    runners = []
    try:
        for n in threads:
            r = RolloutRunner(rm, threads=_positive_int(n, "threads"))
            runners.append(r)
            cases.append((f"mjchar.controllers.sampling.rollout, {n} thread(s)", n,
                          lambda r=r: r.run(request)))
        for _, _, fn in cases:
            fn()  # warm-up
        best = [(math.inf, math.nan)] * len(cases)
        for _ in range(repeats):
            for i, (_, _, fn) in enumerate(cases):
                w, c = time.perf_counter(), time.process_time()
                fn()
                w, c = time.perf_counter() - w, time.process_time() - c
                if w < best[i][0]:
                    best[i] = (w, c)
    finally:
        for r in runners:
            r.close()
    total = samples * steps
    loop_rate = total / best[0][0]
    out = []
    for (label, n, _), (w, c) in zip(cases, best, strict=True):
        out.append({"case": label, "threads": n, "steps_per_s": total / w,
                    "steps_per_cpu_s": total / max(c, 1e-9), "cores_busy": c / w,
                    "speedup_vs_python_loop": total / w / loop_rate})
    return {"samples": samples, "steps_per_sample": steps, "timestep_s": float(m.opt.timestep),
            "repeats": repeats, "cases": out}


# -- Gymnasium envs ------------------------------------------------------------------------------
def env_throughput(env_ids: Sequence[str] = ENV_IDS, *, steps: int = 1000, repeats: int = 3,
                   seed: int = 0) -> dict:
    """Env steps per second with uniform random actions (seeded), resetting when an episode
    ends, for each env id; the envs take turns in ``repeats`` rounds and the median round is
    reported. Physics steps per second = env steps/s x physics steps per env step.

    Returns:
        ``{"steps", "repeats", "envs": {id: {"env_steps_per_s", "physics_steps_per_s",
        "physics_steps_per_env_step", "timestep_s", "episodes_per_round", "obs_dim",
        "act_dim"}}, "reference": id, "ratios": {id: {"env_steps": x, "physics_steps": y}}}``
        where ratios are against the last id (``Humanoid-v5``).
    Raises:
        PerfUnavailable: Gymnasium, its MuJoCo envs or the project's envs do not load.
    """
    steps, repeats = _positive_int(steps, "steps"), _positive_int(repeats, "repeats")
    try:
        import gymnasium as gym  # importing mjchar registered the mjchar/... ids
    except Exception as e:  # a broken Gymnasium: report, do not crash the bench
        raise PerfUnavailable(f"gymnasium does not import ({type(e).__name__}: {e})") from None
    made = {}
    try:
        for eid in env_ids:
            try:
                made[eid] = gym.make(eid)
            except Exception as e:
                raise PerfUnavailable(f"gymnasium.make({eid!r}) failed ({type(e).__name__}: "
                                      f"{str(e).splitlines()[0] if str(e) else ''})") from None
        rounds: dict[str, list[tuple[float, int]]] = {eid: [] for eid in env_ids}
        for r in range(repeats):
            for eid, env in made.items():
                wall, ended = random_env_steps(env, steps, seed + r)
                rounds[eid].append((steps / wall, ended))
        out = {}
        for eid, env in made.items():
            rates = sorted(rounds[eid])
            rate, ended = rates[len(rates) // 2]
            u = env.unwrapped
            sub = int(getattr(u, "n_substeps", None) or getattr(u, "frame_skip", 1))
            dt = (u.character.timestep if hasattr(u, "character")
                  else float(u.model.opt.timestep))
            out[eid] = {"env_steps_per_s": rate, "physics_steps_per_s": rate * sub,
                        "physics_steps_per_env_step": sub, "timestep_s": float(dt),
                        "episodes_per_round": ended,
                        "obs_dim": int(np.prod(env.observation_space.shape)),
                        "act_dim": int(np.prod(env.action_space.shape))}
    finally:
        for env in made.values():
            env.close()
    ref = env_ids[-1]
    ratios = {eid: {"env_steps": v["env_steps_per_s"] / out[ref]["env_steps_per_s"],
                    "physics_steps": v["physics_steps_per_s"] / out[ref]["physics_steps_per_s"]}
              for eid, v in out.items()}
    return {"steps": steps, "repeats": repeats, "envs": out, "reference": ref, "ratios": ratios}


# -- BVH parsing ---------------------------------------------------------------------------------
def _paired_best(ours: Callable[[], object], theirs: Callable[[], object], budget: float,
                 min_rounds: int = 3, inner: int = 3) -> tuple[float, float]:
    """Best wall times (s) of ``ours()`` and ``theirs()`` in alternating rounds (one ``theirs``
    then ``inner`` ``ours``), at least ``min_rounds`` rounds and about ``budget`` s, with
    garbage collection off while timing."""
    ta: list[float] = []
    tb: list[float] = []
    start = time.perf_counter()
    gc.collect()
    gc.disable()
    try:
        r = 0
        while True:
            t0 = time.perf_counter()
            theirs()
            tb.append(time.perf_counter() - t0)
            for _ in range(inner):
                t0 = time.perf_counter()
                ours()
                ta.append(time.perf_counter() - t0)
            r += 1
            if r >= min_rounds and time.perf_counter() - start > budget:
                break
    finally:
        gc.enable()
    return min(ta), min(tb)


def bvh_parse_speed(paths: Sequence[str | Path], *, budget: float = 1.0) -> dict:
    """Parse time of ``bvh.load`` (channels to quaternion ``Motion``) against
    ``bvhio.readAsBvh`` (bvhio's lowest-level reader) on each file, best of alternating rounds
    within about ``budget`` s per file.

    Returns:
        ``{"bvhio_version", "budget_s", "files": [{"file", "frames", "joints", "bvh_load_ms",
        "bvhio_ms", "speedup"}]}`` (speedup = bvhio time / bvh time).
    Raises:
        PerfUnavailable: ``bvhio`` is not installed (``pip install 'mjchar[bench]'``).
    """
    from mjchar import bvh

    try:
        import bvhio
    except ImportError:
        raise PerfUnavailable("bvhio is not installed (pip install 'mjchar[bench]')") from None
    from importlib.metadata import PackageNotFoundError, version

    try:
        bvhio_version = version("bvhio")
    except PackageNotFoundError:
        bvhio_version = None
    if not (math.isfinite(budget) and budget > 0):
        raise PerfError(f"budget must be positive seconds, got {budget}")
    rows = []
    for p in paths:
        p = Path(p)
        motion = bvh.load(p)
        ours, theirs = _paired_best(lambda p=p: bvh.load(p),
                                    lambda p=p: bvhio.readAsBvh(str(p)), budget)
        rows.append({"file": p.name, "frames": int(motion.n_frames),
                     "joints": int(motion.skeleton.n_joints), "bvh_load_ms": ours * 1e3,
                     "bvhio_ms": theirs * 1e3, "speedup": theirs / ours})
    return {"bvhio_version": bvhio_version, "budget_s": float(budget), "files": rows}


# -- PD stability envelope -----------------------------------------------------------------------
def stability_envelope(*, kps: Sequence[float] = ENVELOPE_KPS,
                       variants: Sequence[str] = ENVELOPE_VARIANTS,
                       grid: Sequence[int] = ENVELOPE_GRID,
                       finer: Sequence[int] = ENVELOPE_FINER, duration: float = 5.0,
                       torque_limits: bool = False, model=None,
                       progress: Callable[[str], None] | None = None) -> dict:
    """Largest time step at which each PD variant holds the standing pose, per gain.

    For each ``kp`` (kd = kp/10, uniform) and variant,
    :func:`mjchar.controllers.core.scenarios.hold_pose` (root welded, 0.2 rad seeded initial errors,
    ``duration`` s) at every step ``1/hz`` of ``grid``; a variant that does not hold at the grid's
    smallest step is scanned further down ``finer``. "Largest held" = the largest step such that it
    and every smaller step scanned held.

    Returns:
        ``{"duration_s", "torque_limits", "kps", "variants", "rows": [{"variant", "kp",
        "largest_held_hz" (None if none), "status": {hz: "held" | "oscillates" |
        "diverged"}}]}`` (status keys are strings of the step rate in Hz).
    """
    from mjchar.controllers.core.scenarios import hold_pose

    if not (math.isfinite(duration) and duration > 1.0):
        raise PerfError(f"envelope duration must be more than 1 s (the last second is judged), "
                        f"got {duration}")
    grid = sorted({_positive_int(h, "grid rate") for h in grid}, reverse=True)
    ch = Character(model)
    rows = []
    for kp in kps:
        for v in variants:
            status: dict[int, str] = {}

            def run(hz: int, v=v, kp=kp, status=status) -> None:
                r = hold_pose(ch, v, kp=float(kp), timestep=1.0 / hz, duration=duration,
                              torque_limits=torque_limits)
                status[hz] = "held" if r.held else ("diverged" if r.diverged else "oscillates")

            for hz in grid:
                run(hz)
            if status[grid[0]] != "held":
                for hz in sorted(finer):
                    if hz > grid[0]:
                        run(hz)
            best = None
            for hz in sorted(status, reverse=True):  # small steps first
                if status[hz] != "held":
                    break
                best = hz
            rows.append({"variant": v, "kp": float(kp), "largest_held_hz": best,
                         "status": {str(hz): status[hz] for hz in sorted(status, reverse=True)}})
            if progress is not None:
                progress(f"envelope kp {kp:g} {v}: largest held step "
                         + (f"1/{best} s" if best else "none"))
    return {"duration_s": float(duration), "torque_limits": bool(torque_limits),
            "kps": [float(k) for k in kps], "variants": list(variants), "rows": rows}
