"""Rollout throughput on the bundled humanoid: a Python mj_step loop vs batched rollouts.

Measures, in one run and on one model (``assets/mjcf/humanoid.xml``, dt 2 ms, native
``<position>`` PD actuators, ``implicitfast``):

- ``mj_step`` in a single-threaded Python loop over the same samples (``mj_setState``, ctrl,
  ``mj_step`` x 50), on the plain model and on the model with the rollout sensors (their cost);
- bare ``mujoco.rollout`` calls (plain model, states only) with 1 and 2 threads;
- :class:`mjchar.controllers.sampling.executors.LocalExecutor` (sensors, contacts, divergence
  checks,
  result assembly) with 1 and 2 threads, and optionally the Ray executor.

Every batch is B samples of one 0.1 s SAMCON slice (one PD-target vector held for 50 steps) from
the rest pose with Gaussian target offsets. Throughput is physics steps per second (the executor's
extra sensing step is not counted) and slices per second, best of ``--repeat`` interleaved rounds;
with the process CPU time of the same run, whose ratios (steps per CPU-second, cores busy = CPU /
wall time) stay meaningful when other processes share the cores.

    python benchmarks/bench_rollout.py                 # print the table
    python benchmarks/bench_rollout.py --write         # also update docs/rollouts.md
    python benchmarks/bench_rollout.py --ray           # add the Ray executor (2 workers)
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import mujoco  # noqa: E402
import mujoco.rollout  # noqa: E402
import numpy as np  # noqa: E402

from mjchar.bvh.bundled.assets import humanoid_path  # noqa: E402
from mjchar.controllers.sampling.executors import LocalExecutor, make_executor  # noqa: E402
from mjchar.controllers.sampling.rollout import RolloutModel, RolloutRequest  # noqa: E402
from mjchar.perf import python_rollout_loop  # noqa: E402

DOC = ROOT / "docs" / "rollouts.md"
START, END = "<!-- bench_rollout:start -->", "<!-- bench_rollout:end -->"


def best_time(fn, repeat: int) -> float:
    """Smallest wall time of ``repeat`` calls of ``fn`` (after one warm-up call), s."""
    fn()
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=256, help="samples per batch (B)")
    parser.add_argument("--steps", type=int, default=50, help="physics steps per slice")
    parser.add_argument("--repeat", type=int, default=5, help="timed runs per case (best kept)")
    parser.add_argument("--ray", action="store_true", help="also time the Ray executor")
    parser.add_argument("--write", action="store_true", help=f"update {DOC.relative_to(ROOT)}")
    args = parser.parse_args(argv)

    load = os.getloadavg()[0]
    rm = RolloutModel.from_source(humanoid_path())
    plain = mujoco.MjModel.from_xml_path(str(humanoid_path()))
    m = rm.model
    b, k = args.samples, args.steps
    rng = np.random.default_rng(0)
    rest = m.qpos0[m.jnt_qposadr[m.actuator_trnid[:, 0]]]
    targets = rest + rng.normal(0.0, 0.1, (b, 1, m.nu))
    s0 = rm.initial_state()
    request = RolloutRequest(rm, s0, targets, k)
    cases: list[tuple[str, int, object]] = []  # (label, physics steps per call, call)
    closers = []

    for label, model in (("Python mj_step loop, 1 thread (plain model)", plain),
                         ("Python mj_step loop, 1 thread (model with rollout sensors)", m)):
        data = mujoco.MjData(model)

        def loop(model=model, data=data):  # the same B slices, one after the other
            python_rollout_loop(model, data, s0, targets, k)

        cases.append((label, b * k, loop))

    control = np.ascontiguousarray(np.repeat(targets, k, axis=1))
    states0 = np.repeat(s0[None], b, axis=0)
    for threads in (1, 2):
        datas = [mujoco.MjData(plain) for _ in range(threads)]
        pool = mujoco.rollout.Rollout(nthread=threads if threads > 1 else 0)
        closers.append(pool)

        def bare(pool=pool, datas=datas):
            pool.rollout(plain, datas, states0, control)

        cases.append((f"bare mujoco.rollout, {threads} thread(s)", b * k, bare))
    for threads in (1, 2):
        ex = LocalExecutor(threads=threads)
        closers.append(ex)
        cases.append((f"LocalExecutor, {threads} thread(s)", b * k,
                      lambda ex=ex: ex.evaluate(request)))
    if args.ray:
        ex = make_executor("ray", num_workers=2)
        closers.append(ex)
        cases.append(("RayExecutor, 2 workers (local Ray)", b * k,
                      lambda ex=ex: ex.evaluate(request)))

    # rounds over all cases, best time per case: other load on the machine drifts, and
    # interleaving spreads it evenly over the cases
    best = [(np.inf, np.nan)] * len(cases)  # (wall s, process CPU s of that run)
    for _, _, call in cases:
        call()  # warm-up
    for r in range(args.repeat):
        for i, (_, _, call) in enumerate(cases):
            cpu, wall = time.process_time(), time.perf_counter()
            call()
            wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
            if wall < best[i][0]:
                best[i] = (wall, cpu)
        print(f"round {r + 1}/{args.repeat} done", file=sys.stderr, flush=True)
    for closer in closers:
        closer.close()
    rows = []  # (case, steps per wall second, steps per CPU second of this process)
    for (label, steps, _), (wall, cpu) in zip(cases, best, strict=True):
        per_cpu = steps / cpu if "Ray" not in label else np.nan  # Ray works in other processes
        rows.append((label, steps / wall, per_cpu, cpu / wall))
        print(f"{label:<60s} {steps / wall:>10,.0f} steps/s {steps / wall / k:>8,.0f} slices/s"
              f"  {per_cpu:>10,.0f} steps/CPU-s")

    loop_rate = rows[0][1]
    lines = [
        f"Measured by `python benchmarks/bench_rollout.py{' --ray' if args.ray else ''}` on "
        f"{platform.machine()}, {os.cpu_count()} cores, MuJoCo {mujoco.__version__}; humanoid "
        f"nq={plain.nq} nv={plain.nv} nu={plain.nu}, dt {plain.opt.timestep * 1e3:g} ms; "
        f"B={b} samples of one {k * plain.opt.timestep:g} s slice; best of {args.repeat} "
        f"interleaved rounds; load average before the run {load:.2f} (other processes).",
        "",
        "| case | steps/s (wall) | 0.1 s slices/s | vs Python loop | steps per CPU-s | cores "
        "busy |",
        "| --- | ---: | ---: | ---: | ---: | ---: |",
    ]
    for case, rate, per_cpu, busy in rows:
        cpu_cols = ("n/a (other processes)", "n/a") if np.isnan(per_cpu) else (
            f"{per_cpu:,.0f}", f"{busy:.2f}")
        lines.append(f"| {case} | {rate:,.0f} | {rate / k:,.0f} | {rate / loop_rate:.2f}x | "
                     f"{cpu_cols[0]} | {cpu_cols[1]} |")
    table = "\n".join(lines)
    print()
    print(table)
    if args.write:
        text = DOC.read_text() if DOC.is_file() else f"# Rollouts\n\n{START}\n{END}\n"
        if START not in text or END not in text:
            text = text.rstrip() + f"\n\n{START}\n{END}\n"
        head, rest_ = text.split(START, 1)
        _, tail = rest_.split(END, 1)
        DOC.write_text(f"{head}{START}\n{table}\n{END}{tail}")
        print(f"\nwrote {DOC.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
