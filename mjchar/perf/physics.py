"""Bare ``mj_step`` and a controller's cost per physics step over it: the yardstick every speed
figure of the project is a ratio to.

- :func:`raw_step_rate`: bare ``mujoco.mj_step`` throughput on a model (a C loop,
  ``mj_step(m, d, nstep)``, and a Python loop calling ``mj_step`` once per step).
- :func:`step_cost`: a controller's cost per physics step (``act`` + ``Character.step``) over
  a bare ``mj_step`` on a pristine copy of the same model at the same time step, in interleaved
  blocks timed with the process CPU clock (load from other processes affects both alike).
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

from .errors import positive_int
from .timing import Timing, rounds, timed

__all__ = ["StepCost", "hold_ctrl", "raw_step_rate", "step_cost"]


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
