"""SAMCON and CMA-ES on the bundled humanoid: throughput, reconstructions, tracking, the jump.

Everything runs sequentially on this machine (2 cores shared with other processes: the load
average is printed with each part; read ratios rather than absolute timings).

- ``--throughput``: SAMCON samples/s (slices of 0.1 s, the default options, on the first second
  of walk60) against raw batched-rollout throughput on the same model and batch size: bare
  ``mujoco.rollout`` (plain model, states only) and the ``LocalExecutor`` that SAMCON calls.
  Rounds are interleaved and the best of each case kept; process CPU time is reported too.
- ``--reconstruct CLIP ...``: full SAMCON reconstructions (default options
  :data:`mjchar.controllers.sampling.samcon.RECONSTRUCTION_OPTIONS`) of shared clips; each
  trajectory is saved, replayed open-loop twice (determinism) and its metrics reported.
- ``--cmaes``: CMA-ES tracking of walk60's first 1.5 s vs plain native PD of the raw reference
  (mean tracking cost and the replays' tracking error).
- ``--jump``: the CMA-ES standing vertical jump (clearance, landing).

    python -m mjchar.perf.samcon --all --write     # everything, update docs/sampling.md
    python -m mjchar.perf.samcon --throughput      # one part
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import mujoco
import mujoco.rollout
import numpy as np

from mjchar import bvh
from mjchar.bvh.bundled.assets import humanoid_path
from mjchar.bvh.reference.reference_motion import ReferenceMotion
from mjchar.controllers.core.character import Character
from mjchar.controllers.sampling.executors import LocalExecutor
from mjchar.controllers.sampling.rollout import FULLPHYSICS, RolloutRequest
from mjchar.controllers.sampling.samcon import RECONSTRUCTION_OPTIONS, Samcon, SamconOptions
from mjchar.controllers.sampling.tracking import CostWeights
from mjchar.controllers.sampling.trajectory import replay
from mjchar.controllers.sampling.trajopt import (
    JUMP_OPTIONS,
    TrajoptOptions,
    optimise_jump,
    plain_pd_trajectory,
    track_clip,
    trajectory_cost,
)

from .report import entry_parser, machine_line, markdown_table, publish, write_json
from .report import shared_clip as clip
from .timing import load_average, rounds, timed


def load() -> float:
    a = load_average()
    return float("nan") if a is None else a


# ------------------------------------------------------------------------------------------------
def throughput(samples: int, n_rounds: int, threads: int) -> dict:
    """SAMCON slice throughput vs bare mujoco.rollout and the LocalExecutor, interleaved."""
    ch = Character()
    ref = ReferenceMotion(ch.model, bvh.load(clip("walk60")), info=ch.info)
    opts = dict(RECONSTRUCTION_OPTIONS, samples=samples, duration=1.0, seed=0, iterations=1)
    ex = LocalExecutor(threads=threads)
    s = Samcon(ref, options=SamconOptions(**opts), executor=ex)
    n_slices = len(s.slices)
    k = s.k
    c = s.slices[0][1] - s.slices[0][0]
    rng = np.random.default_rng(0)
    targets = s.base[None, :c] + rng.normal(0.0, 0.05, (samples, c, ch.nu))
    state0 = np.repeat(s.state0[None], samples, axis=0)
    request = RolloutRequest(s.rmodel, state0, targets, k)
    plain = mujoco.MjModel.from_xml_path(str(humanoid_path()))
    datas = [mujoco.MjData(plain) for _ in range(threads)]
    pool = mujoco.rollout.Rollout(nthread=threads if threads > 1 else 0)
    bare_state = np.empty((samples, mujoco.mj_stateSize(plain, FULLPHYSICS)))
    dd = mujoco.MjData(plain)
    dd.qpos[:], dd.qvel[:] = s.q0, s.v0
    mujoco.mj_getState(plain, dd, bare_state[0], FULLPHYSICS)
    bare_state[:] = bare_state[0]
    control = np.ascontiguousarray(np.repeat(targets, k, axis=1))

    def run_samcon():
        return s.run(progress=False).samples_simulated

    def run_executor():
        for _ in range(n_slices):
            ex.evaluate(request)
        return n_slices * samples

    def run_bare():
        for _ in range(n_slices):
            pool.rollout(plain, datas, bare_state, control)
        return n_slices * samples

    cases = {"samcon": run_samcon, "executor": run_executor, "bare": run_bare}
    load0 = load()
    runs = rounds(cases, repeats=n_rounds, warmup=True, keep_results=True)
    best = {}
    for name, r in runs.items():  # the run with the least wall time per sample-slice
        i = min(range(len(r.timings)), key=lambda i, r=r: r.timings[i].wall_s / r.results[i])
        best[name] = (r.timings[i].wall_s, r.timings[i].cpu_s, r.results[i])
    pool.close()
    s.close()
    ex.close()
    out = {"samples": samples, "slices": n_slices, "steps_per_slice": c * k, "threads": threads,
           "rounds": n_rounds, "load_avg": load0}
    for name, (w, cc, per) in best.items():  # per: sample-slices simulated by the case
        out[name] = {"wall_s": w, "cpu_s": cc, "samples_per_s": per / w,
                     "steps_per_s": per * c * k / w, "samples_per_cpu_s": per / cc}
    out["fraction_of_bare"] = out["samcon"]["samples_per_s"] / out["bare"]["samples_per_s"]
    out["fraction_of_executor"] = (out["samcon"]["samples_per_s"]
                                   / out["executor"]["samples_per_s"])
    out["cpu_fraction_of_bare"] = (out["samcon"]["samples_per_cpu_s"]
                                   / out["bare"]["samples_per_cpu_s"])
    return out


#: per-clip cost-weight overrides: with the default root-orientation weight (3) the reconstruction
#: of walk_and_turn_right lags the 90-degree turn, drifts and falls at 3.0 s; 20 keeps it up
CLIP_WEIGHTS = {"walk_and_turn_right": {"root": 20.0}}


def reconstruct(name: str, outdir: Path, threads: int, seed: int,
                weights: dict | None = None) -> dict:
    ch = Character()
    ref = ReferenceMotion(ch.model, bvh.load(clip(name)), info=ch.info)
    weights = CLIP_WEIGHTS.get(name, {}) if weights is None else weights
    opts = SamconOptions(**dict(RECONSTRUCTION_OPTIONS, seed=seed,
                                weights=CostWeights(**weights)))
    load0 = load()
    with LocalExecutor(threads=threads) as ex, Samcon(ref, options=opts, executor=ex,
                                                       source_motion=str(clip(name))) as s:
        res, t = timed(s.run, progress=True)
    wall, cpu_s = t.wall_s, t.cpu_s
    path = res.trajectory.save(outdir / f"samcon_{name}.npz")
    r1 = replay(path)
    r2 = replay(path)
    same = (r1.tracking_error_m == r2.tracking_error_m
            and r1.extra.get("final_root_error_m") == r2.extra.get("final_root_error_m"))
    return {"clip": name, "duration_s": ref.duration, "slices": len(s.slices),
            "wall_s": wall, "cpu_s": cpu_s, "load_avg": load0,
            "samples_per_s": res.samples_per_s, "total_cost": res.total_cost,
            "fell": r1.fell, "fall_time_s": r1.fall_time_s,
            "tracking_error_m": r1.tracking_error_m, "root_error_m": r1.root_error_m,
            "final_root_error_m": r1.extra.get("final_root_error_m"),
            "root_force_mean_N": r1.root_force_mean_N, "deterministic": same,
            "trajectory": str(path),
            "options": dict(RECONSTRUCTION_OPTIONS, seed=seed, weights=weights)}


def cmaes(outdir: Path, threads: int, seed: int) -> dict:
    ch = Character()
    ref = ReferenceMotion(ch.model, bvh.load(clip("walk60")), info=ch.info)
    o = TrajoptOptions(duration=1.5, seed=seed)
    load0 = load()
    with LocalExecutor(threads=threads) as ex:
        res, t = timed(track_clip, ref, options=o, executor=ex,
                       source_motion=str(clip("walk60")))
    wall = t.wall_s
    path = res.trajectory.save(outdir / "cmaes_walk60_1.5s.npz")
    pd = plain_pd_trajectory(ref, duration=1.5)
    c_pd, c_opt = trajectory_cost(pd, ref), trajectory_cost(res.trajectory, ref)
    r_pd = replay(pd, stop_on_fall=False)
    r_pd_fall = replay(pd)
    r_opt = replay(res.trajectory)
    return {"wall_s": wall, "load_avg": load0, "evaluations": res.evaluations,
            "windows": len(res.window_costs), "cost_plain_pd": c_pd, "cost_cmaes": c_opt,
            "reduction": 1.0 - c_opt / c_pd, "plain_pd_fell": r_pd_fall.fell,
            "plain_pd_fall_time_s": r_pd_fall.fall_time_s,
            "plain_pd_tracking_error_m": r_pd.tracking_error_m,
            "cmaes_fell": r_opt.fell, "cmaes_tracking_error_m": r_opt.tracking_error_m,
            "cmaes_final_root_error_m": r_opt.extra.get("final_root_error_m"),
            "trajectory": str(path), "options": {"duration": 1.5, "seed": seed}}


def jump(outdir: Path, threads: int, seed: int) -> dict:
    o = TrajoptOptions(**dict(JUMP_OPTIONS, seed=seed))
    load0 = load()
    with LocalExecutor(threads=threads) as ex:
        res, t = timed(optimise_jump, options=o, executor=ex)
    wall = t.wall_s
    tr = res.trajectory
    path = tr.save(outdir / "cmaes_jump.npz")
    r = replay(tr, duration=tr.duration + 1.0)
    return {"wall_s": wall, "load_avg": load0, "evaluations": res.evaluations,
            "objective": res.window_costs[-1], "fell": r.fell,
            "max_clearance_m": r.extra["max_clearance_m"],
            "final_root_height_m": r.extra["final_root_height_m"],
            "standing_root_height_m": float(tr.initial_qpos[2]),
            "horizontal_travel_m": r.distance_m, "trajectory": str(path),
            "options": dict(JUMP_OPTIONS, seed=seed)}


# ------------------------------------------------------------------------------------------------
def fell(flag: bool, when) -> str:
    return f"yes at {when:.2f} s" if flag else "no"


#: the throughput table's rows: (key in the results, label)
_THROUGHPUT_CASES = (("bare", "bare `mujoco.rollout` (plain model)"),
                     ("executor", "`LocalExecutor.evaluate` (sensors, checks)"),
                     ("samcon", "SAMCON (sampling, cost, selection, bookkeeping)"))


def _reconstruction_row(r: dict) -> tuple[str, ...]:
    """A row of the reconstructions' table: the clip (and its cost weights), its length, the
    run's wall and CPU time, the replay's fall and errors and whether it was deterministic."""
    w = r["options"].get("weights") or {}
    note = "".join(f", {k} weight {v:g}" for k, v in w.items())
    return (f"{r['clip']}{note}", f"{r['duration_s']:.2f} s",
            f"{r['wall_s']:.0f} s (load {r['load_avg']:.1f})", f"{r['cpu_s']:.0f} s",
            fell(r["fell"], r["fall_time_s"]), f"{100 * r['tracking_error_m']:.1f} cm",
            f"{100 * r['final_root_error_m']:.1f} cm", "yes" if r["deterministic"] else "NO")


def table(results: dict) -> str:
    lines = [f"Measured by `python -m mjchar.perf.samcon` on {machine_line()}.", ""]
    t = results.get("throughput")
    if t:
        rows = [(label, f"{t[name]['samples_per_s']:.0f}", f"{t[name]['steps_per_s']:.0f}",
                 f"{t[name]['samples_per_cpu_s']:.0f}") for name, label in _THROUGHPUT_CASES]
        lines += [f"Throughput ({t['samples']} samples x {t['slices']} slices of "
                  f"{t['steps_per_slice']} steps, {t['threads']} threads, best of {t['rounds']}"
                  f" interleaved rounds, load average {t['load_avg']:.1f}):", "",
                  markdown_table(("case", "samples/s", "steps/s", "samples per CPU-s"), rows)]
        lines += ["", f"SAMCON runs at **{100 * t['fraction_of_bare']:.0f} %** of bare batched-"
                      f"rollout throughput ({100 * t['fraction_of_executor']:.0f} % of the "
                      f"executor's; {100 * t['cpu_fraction_of_bare']:.0f} % per CPU-second).",
                  ""]
    rec = results.get("reconstruct") or []
    if rec:
        header = ("clip", "length", "wall", "CPU", "fell", "tracking error", "final root error",
                  "deterministic")
        lines += ["SAMCON reconstructions (open-loop replay, no root force):", "",
                  markdown_table(header, [_reconstruction_row(r) for r in rec])]
        lines += ["", f"Options: `{RECONSTRUCTION_OPTIONS}`, seed "
                      f"{rec[0]['options'].get('seed')}, default cost weights unless noted.", ""]
    c = results.get("cmaes")
    if c:
        lines += [f"CMA-ES tracking of walk60's first 1.5 s ({c['evaluations']} rollouts, "
                  f"{c['wall_s']:.0f} s, load {c['load_avg']:.1f}): mean tracking cost "
                  f"{c['cost_cmaes']:.2f} vs {c['cost_plain_pd']:.2f} for plain native PD of the"
                  f" raw reference (**{100 * c['reduction']:.0f} % lower**); plain PD falls: "
                  f"{fell(c['plain_pd_fell'], c['plain_pd_fall_time_s'])}"
                  f", CMA-ES {'falls' if c['cmaes_fell'] else 'does not fall'}; tracking error "
                  f"{100 * c['cmaes_tracking_error_m']:.1f} cm vs "
                  f"{100 * c['plain_pd_tracking_error_m']:.1f} cm.", ""]
    j = results.get("jump")
    if j:
        lines += [f"CMA-ES jump ({j['evaluations']} rollouts, {j['wall_s']:.0f} s, load "
                  f"{j['load_avg']:.1f}): the lowest point of the body rises "
                  f"**{100 * j['max_clearance_m']:.1f} cm** above the floor; after the landing "
                  f"and 1 s more it {'FELL' if j['fell'] else 'stands'} with the root at "
                  f"{j['final_root_height_m']:.3f} m (standing {j['standing_root_height_m']:.3f}"
                  f" m), {100 * j['horizontal_travel_m']:.0f} cm from where it started.", ""]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    p = entry_parser("samcon", __doc__)
    p.add_argument("--all", action="store_true", help="every part")
    p.add_argument("--throughput", action="store_true")
    p.add_argument("--reconstruct", nargs="*", metavar="CLIP",
                   help="shared clips to reconstruct (default with --all: walk60 idle "
                        "walk_and_turn_right)")
    p.add_argument("--cmaes", action="store_true")
    p.add_argument("--jump", action="store_true")
    p.add_argument("--samples", type=int, default=1000, help="throughput batch size")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--threads", type=int, default=os.cpu_count() or 1)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", default="perf_samcon",
                   help="folder for the trajectories and the JSON (default perf_samcon)")
    p.add_argument("--write", action="store_true", help="update docs/sampling.md")
    args = p.parse_args(argv)
    outdir = Path(args.out)
    outdir.mkdir(parents=True, exist_ok=True)
    results_path = outdir / "results.json"
    results = json.loads(results_path.read_text()) if results_path.is_file() else {}
    clips = args.reconstruct
    if args.all and not clips:
        clips = ["walk60", "idle", "walk_and_turn_right"]
    if args.throughput or args.all:
        results["throughput"] = throughput(args.samples, args.rounds, args.threads)
        print(json.dumps(results["throughput"], indent=1), flush=True)
    if clips:
        done = {r["clip"]: r for r in results.get("reconstruct", [])}
        for name in clips:
            done[name] = reconstruct(name, outdir, args.threads, args.seed)
            print(json.dumps(done[name], indent=1), flush=True)
        results["reconstruct"] = list(done.values())
    if args.cmaes or args.all:
        results["cmaes"] = cmaes(outdir, args.threads, args.seed)
        print(json.dumps(results["cmaes"], indent=1), flush=True)
    if args.jump or args.all:
        results["jump"] = jump(outdir, args.threads, args.seed)
        print(json.dumps(results["jump"], indent=1), flush=True)
    write_json(results_path, results)
    text = table(results)
    publish(text, "sampling.md", "samcon", args.write)
    return 0


if __name__ == "__main__":
    sys.exit(main())
