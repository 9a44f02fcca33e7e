"""Batched rollouts against a Python ``mj_step`` loop over the same samples (the table of
docs/rollouts.md; the bench's ``rollout`` part is :func:`rollout_throughput`).

    python -m mjchar.perf.rollouts                 # print the table
    python -m mjchar.perf.rollouts --ray --write   # add the Ray executor; update docs/rollouts.md

Every batch is B samples of one SAMCON-like slice (one PD-target vector, the rest pose plus
seeded Gaussian offsets of 0.1 rad, held for ``steps`` physics steps) from the rest pose of the
bundled humanoid (native ``<position>`` PD actuators, ``implicitfast``). Cases take turns in
rounds (:func:`mjchar.perf.timing.rounds`, after one warm-up call each); the best wall time per
case is kept with the process CPU time of that run, whose ratios (steps per CPU-second, cores
busy = CPU / wall time) stay meaningful when other processes share the cores. Throughput is
physics steps per second (an executor's extra sensing step is not counted).
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence
from pathlib import Path

import mujoco
import numpy as np

from .errors import positive_int
from .physics import hold_ctrl
from .report import entry_parser, machine_line, publish
from .timing import rounds

__all__ = ["python_rollout_loop", "compare_cases", "rollout_throughput", "main"]


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


def compare_cases(cases: Sequence[tuple[str, int, Callable[[], object]]], total_steps: int,
                  repeats: int) -> list[dict]:
    """Time ``(label, threads, call)`` cases that each simulate ``total_steps`` physics steps:
    one warm-up call each, ``repeats`` interleaved rounds, the best wall time per case with the
    process CPU time of that run. Rates are relative to the first case.

    Returns:
        ``[{"case", "threads", "steps_per_s", "steps_per_cpu_s", "cores_busy",
        "speedup_vs_python_loop"}]`` in the order of ``cases``.
    """
    runs = rounds({label: fn for label, _, fn in cases}, repeats=repeats, warmup=True)
    first = None
    out = []
    for label, n, _ in cases:
        t = runs[label].best("wall_s")
        rate = total_steps / t.wall_s
        first = rate if first is None else first
        out.append({"case": label, "threads": n, "steps_per_s": rate,
                    "steps_per_cpu_s": total_steps / max(t.cpu_s, 1e-9),
                    "cores_busy": t.cpu_s / t.wall_s, "speedup_vs_python_loop": rate / first})
    return out


def _batch(model_path, samples: int, seed: int):
    """``(RolloutModel, start state (S,), targets (B, 1, nu))`` of the slices every case runs."""
    from mjchar.bvh.bundled.assets import humanoid_path
    from mjchar.controllers.sampling.rollout import RolloutModel

    rm = RolloutModel.from_source(humanoid_path() if model_path is None else model_path)
    m = rm.model
    rng = np.random.default_rng(seed)
    targets = hold_ctrl(m, m.qpos0) + rng.normal(0.0, 0.1, (samples, 1, m.nu))
    return rm, rm.initial_state(), targets


def rollout_throughput(model_path: str | Path | None = None, *, samples: int = 256,
                       steps: int = 50, repeats: int = 3, threads: Sequence[int] = (1, 2),
                       seed: int = 0) -> dict:
    """Physics steps per second of batched rollouts against a Python ``mj_step`` loop.

    Every case simulates the same ``samples`` slices of ``steps`` physics steps from the rest
    pose: a single-threaded Python loop (:func:`python_rollout_loop`) and
    :class:`mjchar.controllers.sampling.rollout.RolloutRunner` with each thread count in
    ``threads`` (:func:`compare_cases`).

    Returns:
        ``{"samples", "steps_per_sample", "timestep_s", "repeats", "cases": [{"case", "threads",
        "steps_per_s", "steps_per_cpu_s", "cores_busy", "speedup_vs_python_loop"}]}``.
    """
    from mjchar.controllers.sampling.rollout import RolloutRequest, RolloutRunner

    samples, steps = positive_int(samples, "samples"), positive_int(steps, "steps")
    repeats = positive_int(repeats, "repeats")
    rm, s0, targets = _batch(model_path, samples, seed)
    m = rm.model
    request = RolloutRequest(rm, s0, targets, steps)
    data = mujoco.MjData(m)

    def loop() -> None:
        python_rollout_loop(m, data, s0, targets, steps)

    cases: list[tuple[str, int, Callable[[], object]]] = [("Python mj_step loop", 1, loop)]
    runners = []
    try:
        for n in threads:
            r = RolloutRunner(rm, threads=positive_int(n, "threads"))
            runners.append(r)
            cases.append((f"mjchar.controllers.sampling.rollout, {n} thread(s)", n,
                          lambda r=r: r.run(request)))
        out = compare_cases(cases, samples * steps, repeats)
    finally:
        for r in runners:
            r.close()
    return {"samples": samples, "steps_per_sample": steps, "timestep_s": float(m.opt.timestep),
            "repeats": repeats, "cases": out}


def main(argv: list[str] | None = None) -> int:
    import mujoco.rollout

    from mjchar.bvh.bundled.assets import humanoid_path
    from mjchar.controllers.sampling.executors import LocalExecutor, make_executor
    from mjchar.controllers.sampling.rollout import RolloutRequest

    p = entry_parser("rollouts", __doc__)
    p.add_argument("--samples", type=int, default=256, help="samples per batch (B)")
    p.add_argument("--steps", type=int, default=50, help="physics steps per slice")
    p.add_argument("--repeat", type=int, default=5, help="timed rounds (best kept)")
    p.add_argument("--ray", action="store_true", help="also time the Ray executor")
    p.add_argument("--write", action="store_true", help="update docs/rollouts.md")
    args = p.parse_args(argv)
    if min(args.samples, args.steps, args.repeat) < 1:
        p.error("--samples, --steps and --repeat must be positive")

    b, k = args.samples, args.steps
    rm, s0, targets = _batch(None, b, 0)
    m = rm.model
    plain = mujoco.MjModel.from_xml_path(str(humanoid_path()))
    request = RolloutRequest(rm, s0, targets, k)
    cases: list[tuple[str, int, Callable[[], object]]] = []
    closers = []
    for label, model in (("Python mj_step loop, 1 thread (plain model)", plain),
                         ("Python mj_step loop, 1 thread (model with rollout sensors)", m)):
        data = mujoco.MjData(model)
        cases.append((label, 1, lambda model=model, data=data:
                      python_rollout_loop(model, data, s0, targets, k)))
    control = np.ascontiguousarray(np.repeat(targets, k, axis=1))
    states0 = np.repeat(s0[None], b, axis=0)
    for threads in (1, 2):
        datas = [mujoco.MjData(plain) for _ in range(threads)]
        pool = mujoco.rollout.Rollout(nthread=threads if threads > 1 else 0)
        closers.append(pool)
        cases.append((f"bare mujoco.rollout, {threads} thread(s)", threads,
                      lambda pool=pool, datas=datas: pool.rollout(plain, datas, states0,
                                                                  control)))
    for threads in (1, 2):
        ex = LocalExecutor(threads=threads)
        closers.append(ex)
        cases.append((f"LocalExecutor, {threads} thread(s)", threads,
                      lambda ex=ex: ex.evaluate(request)))
    if args.ray:
        ex = make_executor("ray", num_workers=2)
        closers.append(ex)
        cases.append(("RayExecutor, 2 workers (local Ray)", 2, lambda ex=ex: ex.evaluate(request)))
    machine = machine_line()
    try:
        rows = compare_cases(cases, b * k, args.repeat)
    finally:
        for closer in closers:
            closer.close()
    lines = [
        f"Measured by `python -m mjchar.perf.rollouts{' --ray' if args.ray else ''}` on "
        f"{machine} (before the run); humanoid nq={plain.nq} nv={plain.nv} nu={plain.nu}, dt "
        f"{plain.opt.timestep * 1e3:g} ms; B={b} samples of one {k * plain.opt.timestep:g} s "
        f"slice; best of {args.repeat} interleaved rounds.",
        "",
        "| case | steps/s (wall) | slices/s | vs Python loop | steps per CPU-s | cores busy |",
        "| --- | ---: | ---: | ---: | ---: | ---: |",
    ]
    for r in rows:
        rate = r["steps_per_s"]
        if "Ray" in r["case"]:  # Ray works in other processes: this process's CPU says nothing
            cpu_cols = ("n/a (other processes)", "n/a")
        else:
            cpu_cols = (f"{r['steps_per_cpu_s']:,.0f}", f"{r['cores_busy']:.2f}")
        lines.append(f"| {r['case']} | {rate:,.0f} | {rate / k:,.0f} | "
                     f"{r['speedup_vs_python_loop']:.2f}x | {cpu_cols[0]} | {cpu_cols[1]} |")
    table = "\n".join(lines)
    publish(table, "rollouts.md", "rollouts", args.write, said="\nwrote")
    return 0


if __name__ == "__main__":
    sys.exit(main())
