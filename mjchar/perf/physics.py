"""Bare ``mj_step`` and a controller's cost per physics step over it: the yardstick every speed
figure of the project is a ratio to.

- :func:`raw_step_rate`: bare ``mujoco.mj_step`` throughput on a model (a C loop,
  ``mj_step(m, d, nstep)``, and a Python loop calling ``mj_step`` once per step).
- :func:`step_cost`: a controller's cost per physics step (``act`` + ``Character.step``) over
  a bare ``mj_step`` on a pristine copy of the same model at the same time step, in interleaved
  blocks timed with the process CPU clock (load from other processes affects both alike).
- :func:`run_cost`: what ``mjchar run`` costs per physics step (the controller, the Character's
  step and the scenario loop's own bookkeeping: metrics, fall test) over bare ``mj_step`` from
  the states that run visited, on the same model and time step, in the same process.
"""

from __future__ import annotations

import copy
import statistics
from collections.abc import Callable
from dataclasses import dataclass

import mujoco
import numpy as np

from mjchar.controllers.core.character import Character
from mjchar.controllers.core.errors import SimulationDiverged

from .errors import PerfError, positive_int
from .timing import Laps, Timing, rounds, timed

__all__ = ["RunCost", "StepCost", "hold_ctrl", "raw_step_rate", "run_cost", "step_cost"]


def hold_ctrl(m: mujoco.MjModel, qpos: np.ndarray) -> np.ndarray:
    """``(nu,)`` position-actuator set-points holding ``qpos`` (joint actuators only)."""
    ctrl = np.zeros(m.nu)
    for a in range(m.nu):
        if m.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT:
            ctrl[a] = qpos[m.jnt_qposadr[m.actuator_trnid[a, 0]]]
    return ctrl


def raw_step_rate(model: mujoco.MjModel, qpos: np.ndarray | None = None, *, steps: int = 2000,
                  repeats: int = 3) -> dict:
    """Bare ``mj_step`` throughput on a copy of ``model`` from ``qpos`` (default ``qpos0``), the
    position actuators holding that pose.

    Args:
        model: the model (copied; its own time step is used).
        qpos: ``(nq,)`` start pose.
        steps: physics steps per timed run; repeats: timed runs of each loop, taking turns (the
            best is kept).
    Returns:
        ``{"timestep_s", "steps", "repeats", "c_loop_steps_per_s", "python_loop_steps_per_s",
        "c_loop_steps_per_cpu_s", "python_loop_steps_per_cpu_s"}`` (wall and process-CPU rates).
    """
    steps, repeats = positive_int(steps, "steps"), positive_int(repeats, "repeats")
    m = copy.deepcopy(model)
    d = mujoco.MjData(m)
    q0 = m.qpos0.copy() if qpos is None else np.asarray(qpos, dtype=float)
    ctrl = hold_ctrl(m, q0)

    def reset(_: str) -> None:
        mujoco.mj_resetData(m, d)
        d.qpos[:] = q0
        d.ctrl[:] = ctrl

    def c_loop() -> None:
        mujoco.mj_step(m, d, steps)

    def py_loop() -> None:
        for _ in range(steps):
            mujoco.mj_step(m, d)

    runs = rounds({"c_loop": c_loop, "python_loop": py_loop}, repeats=repeats, before=reset)
    out = {"timestep_s": float(m.opt.timestep), "steps": steps, "repeats": repeats}
    for name, r in runs.items():
        out[f"{name}_steps_per_s"] = steps / r.best("wall_s").wall_s
    for name, r in runs.items():
        out[f"{name}_steps_per_cpu_s"] = steps / max(r.best("cpu_s").cpu_s, 1e-9)
    return out


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
    physics steps, each timed by :func:`~mjchar.perf.timing.timed` on the process CPU clock; a
    fall or a divergence of the controlled character puts it back at its start state.

    Args:
        character: a fresh character (time step already set).
        make_controller: builds a new controller (called once per repeat).
        qpos: ``(nq,)`` start pose; qvel: ``(nv,)`` start velocity (default zero).
        control_dt: seconds between control steps.
        steps: physics steps per repeat; repeats: repeats (the median ratio is reported).
        block: physics steps per timing block (rounded to whole control steps).
    """
    from mjchar.controllers.core.metrics import FallDetector

    steps, repeats = positive_int(steps, "steps"), positive_int(repeats, "repeats")
    block = positive_int(block, "block")
    raw_model = copy.deepcopy(character.model)
    raw_data = mujoco.MjData(raw_model)
    qpos = np.asarray(qpos, dtype=float)
    ctrl = hold_ctrl(raw_model, qpos)
    dt = character.timestep
    k = 1 if control_dt is None else max(1, int(round(control_dt / dt)))
    block = max(k, block // k * k)
    ratios, ctl_us, raw_us = [], [], []
    resets = 0

    def raw_block() -> None:
        mujoco.mj_step(raw_model, raw_data, block)

    for _ in range(repeats):
        c = make_controller()
        character.reset(qpos, qvel)
        c.reset(character)
        fall = FallDetector(character)
        mujoco.mj_resetData(raw_model, raw_data)
        raw_data.qpos[:] = qpos
        raw_data.ctrl[:] = ctrl

        def controlled_block(c=c) -> None:
            try:
                for _ in range(block // k):
                    character.step(c.act(character, character.time), k)
            except SimulationDiverged:
                pass

        t_raw = t_ctl = Timing()
        done = 0
        while done < steps:
            t_raw += timed(raw_block)[1]
            t_ctl += timed(controlled_block)[1]
            done += block
            if not np.all(np.isfinite(character.state.qpos)) or fall.check(character) is not None:
                resets += 1
                character.reset(qpos, qvel)
                c.reset(character)
        raw_s = max(t_raw.cpu_s, 1e-9)
        ratios.append(t_ctl.cpu_s / raw_s)
        ctl_us.append(t_ctl.cpu_s / done * 1e6)
        raw_us.append(raw_s / done * 1e6)
    return StepCost(statistics.median(ratios), statistics.median(ctl_us),
                    statistics.median(raw_us), dt, steps, repeats, resets)


@dataclass
class RunCost:
    """What a run costs per physics step relative to bare ``mj_step`` (:func:`run_cost`).

    Attributes:
        controller, scenario: the run.
        ratio: median over repeats of (run CPU s per physics step) / (bare ``mj_step`` CPU s
            per physics step); ratios: every repeat's (their spread is the noise).
        run_us: median CPU us per physics step of the run's loop.
        bare_us: median CPU us per physics step of bare ``mj_step`` from the visited states.
        timestep_s, control_dt_s: physics and control steps of the run (s).
        steps: physics steps of one run; fell: whether the run ended in a fall.
    """

    controller: str
    scenario: str
    ratio: float
    ratios: list[float]
    run_us: float
    bare_us: float
    timestep_s: float
    control_dt_s: float
    steps: int
    fell: bool

    def to_dict(self) -> dict:
        return {"controller": self.controller, "scenario": self.scenario, "ratio": self.ratio,
                "ratios": list(self.ratios), "run_us": self.run_us, "bare_us": self.bare_us,
                "timestep_s": self.timestep_s, "control_dt_s": self.control_dt_s,
                "steps": self.steps, "fell": self.fell}


def run_cost(spec, *, repeats: int = 3, segment: int = 20) -> RunCost:
    """What a run costs per physics step over bare ``mj_step``, in one process.

    The run is built and executed as ``mjchar run`` does (the run builder,
    :class:`~mjchar.controllers.core.builder.RunSpec`), with a frame callback that reads the
    process CPU clock after the reset and after every control step
    (:class:`~mjchar.perf.timing.Laps`): the time between the first and the last read is the
    scenario loop, the controller's ``act``, ``Character.step`` and the loop's bookkeeping
    (metrics recording, fall test) included, the clock reads excluded. The yardstick is bare
    ``mj_step`` on a copy of the same model (as the controller configured it: the same
    actuation and time step) from the states the run visited: one more run of the same spec
    (deterministic) saves its full state (``mjSTATE_INTEGRATION``: controls and applied forces
    included) every ``segment`` physics steps, and ``mj_step(m, d, segment)`` from each of them
    is timed. Timed runs and bare loops take turns, ``repeats`` times; both on the process CPU
    clock, so that load from other processes affects both alike.

    Args:
        spec: a :class:`~mjchar.controllers.core.builder.RunSpec` whose scenario returns one
            :class:`~mjchar.controllers.core.metrics.Result` (not a protocol of many runs).
        repeats: timed runs (and bare loops); the median ratio is reported.
        segment: physics steps between saved states.
    """
    from mjchar.controllers.core.builder import execute
    from mjchar.controllers.core.metrics import Result

    repeats, segment = positive_int(repeats, "repeats"), positive_int(segment, "segment")
    if spec.scenario_spec.protocol:
        raise PerfError(f"{spec.controller}/{spec.scenario_spec.name}: run_cost needs a scenario "
                        f"with one Result, not a protocol of many runs")
    sig = mujoco.mjtState.mjSTATE_INTEGRATION
    saved: list[tuple[np.ndarray, float]] = []
    built = spec.build()
    ch = built.character
    dt = ch.timestep
    every = [0.0]

    def save(c: Character) -> None:
        if c.data.time >= every[0] - 1e-9:
            s = np.empty(mujoco.mj_stateSize(c.model, sig))
            mujoco.mj_getState(c.model, c.data, s, sig)
            saved.append((s, float(c.data.time)))
            every[0] = float(c.data.time) + segment * dt

    built.frame_callback = save
    ref = execute(built)
    if not isinstance(ref, Result):
        raise PerfError(f"{spec.controller}/{spec.scenario}: run_cost needs a scenario with one "
                        f"Result, not a protocol")
    end = ch.data.time
    model = copy.deepcopy(ch.model)  # as the controller configured it
    data = mujoco.MjData(model)
    lengths = [max(1, int(round((t1 - t0) / dt)))
               for (_, t0), t1 in zip(saved, [t for _, t in saved[1:]] + [end], strict=True)]

    def bare() -> Timing:
        total = Timing()
        for (s, _), n in zip(saved, lengths, strict=True):
            mujoco.mj_setState(model, data, s, sig)
            total += timed(mujoco.mj_step, model, data, n)[1]
        return total

    bare_steps = sum(lengths)
    ratios, run_us, bare_us = [], [], []
    for _ in range(repeats):
        run = spec.build()
        laps = Laps()
        run.frame_callback = laps
        res = execute(run)
        if res.n_steps != ref.n_steps:
            raise PerfError(f"{spec.controller}: runs of the same spec took {ref.n_steps} and "
                            f"{res.n_steps} steps (not deterministic)")
        per_run = laps.span / max(res.n_steps, 1)
        per_bare = max(bare().cpu_s, 1e-12) / bare_steps
        ratios.append(per_run / per_bare)
        run_us.append(per_run * 1e6)
        bare_us.append(per_bare * 1e6)
    return RunCost(spec.controller, ref.scenario, statistics.median(ratios), ratios,
                   statistics.median(run_us), statistics.median(bare_us), dt,
                   float(ref.control_dt_s), int(ref.n_steps), bool(ref.fell))
