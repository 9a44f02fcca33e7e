"""The closed-loop sampling MPC tracker (controllers/sampling/mpc.py): the figures of docs/mpc.md.

The load average is recorded with every part (the machine may be shared); tracking, pushes and
falls do not depend on it, nor on the thread count (same seed, same trajectory).

- ``--clips``: the four shared clips tracked at the default settings (fall, mean joint error,
  root force).
- ``--loop``: walk60 made cyclic (``mjchar.bvh.editing.clips.make_cyclic``) and tracked for
  ``--loop-duration`` (60) s.
- ``--pushes``: 100 N x 0.2 s at the pelvis, at 4 moments of the gait cycle x 4 directions, while
  tracking cyclic walk60 (MPC, hand-of-god) and on the SAMCON replay of walk60: falls, and the
  time after the push until the joint error is back below 8 cm (``--push-moments``,
  ``--push-directions`` choose other cells).
- ``--perturbed``: starts with 0.1 rad joint noise and 0.2 m/s root velocity noise, 5 seeds.
- ``--curve``: tracking error and planning-model steps per simulated second against samples x
  horizon on walk60.
- ``--sweep NAME=V1,V2``: one option varied at a time around the defaults (repeatable), each
  variant run through the parts ``--sweep-parts`` names (default clips, pushes, loop).
- ``--determinism``: the same seed twice, and with 1 and 2 threads: bit-identical trajectories.
- ``--speed``: the real-time factor on walk60 with every core (the options' ``threads``
  otherwise), beside bare ``mj_step`` of the bundled humanoid on one core measured in the same
  run, before and after. Printed: the measured factor ``rtf`` (simulated / wall seconds); the
  same normalised to a core doing :data:`REFERENCE_STEPS` bare steps per second, ``rtf_30k =
  rtf x 30,000 / bare steps per wall second``; a load-robust projection from CPU clocks,
  ``rtf_cpu_30k = sim / (main-thread CPU + rollout-thread CPU / threads) x 30,000 / bare steps
  per CPU second`` (what the run would reach on idle cores of that speed); and the planning-model
  steps per simulated second the run took (machine-independent).

``--jobs N`` runs the tracking parts (clips, loop, pushes, perturbed starts, curve, sweep) as
``N`` processes of one rollout thread each: the same trajectories (thread count does not change
them), their real-time factors are not the controller's (use ``--speed`` alone for that).

    python -m mjchar.perf.mpc --all          # everything (about an hour on 2 cores)
    python -m mjchar.perf.mpc --speed        # the real-time factor, normalised
"""

from __future__ import annotations

import dataclasses
import json
import os

import numpy as np

from mjchar import bvh
from mjchar.bvh.bundled.assets import TRAJECTORIES
from mjchar.bvh.editing.clips import make_cyclic
from mjchar.bvh.reference.reference_motion import ReferenceMotion
from mjchar.controllers.core import scenarios as S
from mjchar.controllers.core.builder import RunSpec, execute
from mjchar.controllers.core.character import Character
from mjchar.controllers.core.workers import process_pool
from mjchar.controllers.sampling.mpc import MpcOptions, plan_timestep
from mjchar.controllers.sampling.trajectory import (
    StoredReference,
)

from .physics import raw_step_rate
from .report import entry_parser, shared_clip, write_json
from .timing import load_average, timed

CLIPS = ("walk60", "walk_forward", "walk_and_turn_right", "idle")
DIRECTIONS = S.DIRECTIONS  # the scenarios' push directions (name -> degrees)
RECOVERED = 0.08  # m: the joint error a pushed tracker must return below
RECOVERY_WINDOW = 2.0  # s after the push's end
SETTLE = 4.0  # s simulated after the push's end (the error must stay low once recovered)
#: bare ``mj_step`` of the bundled humanoid per second on the core the real-time factors are
#: normalised to
REFERENCE_STEPS = 30_000.0


def load() -> float | None:
    a = load_average()
    return None if a is None else round(a, 2)


def reference(ch: Character, name: str, cyclic: bool = False) -> ReferenceMotion:
    motion = bvh.load(shared_clip(name))
    if cyclic:
        motion = make_cyclic(motion)
    return ReferenceMotion(ch.model, motion, info=ch.info, cyclic=True if cyclic else None)


class ErrorTrace:
    """Frame callback: the mean joint error (m) against ``ref`` every ``dt`` s."""

    def __init__(self, ref, dt: float = 0.02):
        self.ref, self.dt, self.t, self.pos = ref, dt, [], []

    def __call__(self, ch: Character) -> None:
        if not self.t or ch.time >= self.t[-1] + self.dt - 1e-9:
            self.t.append(ch.time)
            self.pos.append(ch.state.joint_positions())

    def errors(self) -> tuple[np.ndarray, np.ndarray]:
        t = np.array(self.t)
        ref = self.ref.body_positions(t)[:, self.ref.joint_body_ids]
        return t, np.linalg.norm(np.array(self.pos) - ref, axis=-1).mean(axis=1)


def track_spec(controller: str, ref, options=None, *, push: S.PushEvent | None = None,
               seed: int | None = None, duration=None) -> RunSpec:
    """The run of ``controller`` tracking the prepared reference ``ref`` (as ``mjchar run
    CONTROLLER track`` builds it); ``options``: the controller's (the MPC's
    :class:`MpcOptions` fields); ``seed``: a perturbed start (``track --seed``)."""
    scenario = {"duration": duration}
    if push is not None:
        scenario.update(force=push.force, direction=push.direction, push_time=push.time,
                        push_duration=push.duration)
    return RunSpec(controller, "track", motion=ref, options=dict(options or {}), seed=seed,
                   scenario_options=scenario)


def run_mpc(ref, duration=None, options=None, *, seed=None, push=None, frame_callback=None):
    """``(ScenarioResult, Timing, controller stats)`` of the MPC tracking ``ref`` (``seed``: a
    perturbed start; ``push``: one push while tracking)."""
    run = track_spec("mpc", ref, options, push=push, seed=seed,
                     duration=duration).build(frame_callback=frame_callback)
    try:
        r, t = timed(execute, run)
    finally:
        run.controller.close()
    return r, t, run.controller.stats


def summary(r, timing, stats=None) -> dict:
    out = {"fell": r.fell, "fall_time_s": r.fall_time_s, "tracking_error_m": r.tracking_error_m,
           "root_error_m": r.root_error_m, "root_force_mean_N": r.root_force_mean_N,
           "sim_s": r.sim_time_s, "wall_s": timing.wall_s, "cpu_s": timing.cpu_s,
           "rtf": r.sim_time_s / timing.wall_s, "load": load()}
    if stats:
        out["replans"], out["rollouts"] = stats["replans"], stats["rollouts"]
        out["plan_steps_per_sim_s"] = stats["physics_steps"] / max(r.sim_time_s, 1e-9)
    return out


# -- the parts, as items that can run in worker processes ----------------------------------------
def _clip(name: str, options: dict) -> dict:
    r, t, st = run_mpc(reference(Character(), name), options=options)
    return summary(r, t, st)


def _loop(duration: float, options: dict) -> dict:
    ref = reference(Character(), "walk60", cyclic=True)
    r, t, st = run_mpc(ref, duration=duration, options=options)
    return {**summary(r, t, st), "cycle_s": ref.duration}


def _perturbed(seed: int, options: dict) -> dict:
    r, t, st = run_mpc(reference(Character(), "walk60"), options=options, seed=seed)
    return summary(r, t, st)


def _curve_point(n_h: tuple, options: dict) -> dict:
    n, h = n_h
    return _clip("walk60", {**options, "samples": n, "horizon": h})


def _pushed(controller: str, push: S.PushEvent, options: dict) -> dict:
    """One pushed run; the recovery time is measured from the push's end."""
    if controller == "samcon_replay":
        spec = RunSpec("samcon_replay", "track",
                       options={"trajectory": TRAJECTORIES / "samcon_walk60.npz"},
                       scenario_options={"force": push.force, "direction": push.direction,
                                         "push_time": push.time,
                                         "push_duration": push.duration})
        run = spec.build()
        tr = run.controller.trajectory
        trace = ErrorTrace(StoredReference(run.character.model, tr.reference_qpos,
                                           tr.control_dt, run.character.joint_bodies))
        r = execute(dataclasses.replace(run, frame_callback=trace))
    else:
        ref = reference(Character(), "walk60", cyclic=True)
        trace = ErrorTrace(ref)
        if controller == "mpc":
            r, _, _ = run_mpc(ref, push.end + SETTLE, options, push=push, frame_callback=trace)
        else:
            r = track_spec(controller, ref, push=push, duration=push.end + SETTLE).execute(
                frame_callback=trace)
    t, e = trace.errors()
    after = t >= push.end
    high = np.flatnonzero(after & (e >= RECOVERED))
    # recovered: from some moment on (within the window) the error stays below the bound
    recovery = None if r.fell else (float(t[high[-1]] - push.end) if len(high) else 0.0)
    window = r.sim_time_s - push.end
    return {"fell": r.fell, "fall_time_s": r.fall_time_s, "peak_error_m": float(e[after].max())
            if after.any() else None, "recovery_s": recovery, "window_s": window,
            "recovered": bool(recovery is not None and recovery <= RECOVERY_WINDOW
                              and window >= RECOVERY_WINDOW),
            "final_error_m": float(e[-1]), "sim_s": r.sim_time_s,
            "root_force_mean_N": r.root_force_mean_N}


def _push_item(args: tuple, options: dict) -> dict:
    controller, force, moment, direction = args
    return _pushed(controller, S.PushEvent(force, DIRECTIONS[direction], moment, 0.2), options)


_ITEMS = {"clip": _clip, "loop": _loop, "perturbed": _perturbed, "curve": _curve_point,
          "push": _push_item}


def _run_item(item: tuple) -> dict:
    kind, arg, options = item
    return _ITEMS[kind](arg, options)


def run_items(items: list[tuple], jobs: int = 1, label: str = "") -> list[dict]:
    """Run ``(kind, arg, options)`` items in order (``jobs`` > 1: in that many worker
    processes, one rollout thread each), printing each result as it comes."""
    if jobs > 1:
        items = [(k, a, {**o, "threads": 1}) for k, a, o in items]
        with process_pool(jobs, start_method=None) as ex:
            results = list(ex.map(_run_item, items))
    else:
        results = [_run_item(i) for i in items]
    for (kind, arg, _), out in zip(items, results, strict=True):
        print(label or kind, json.dumps(arg), json.dumps(out), flush=True)
    return results


def clips(options: dict, jobs: int = 1) -> dict:
    res = run_items([("clip", name, options) for name in CLIPS], jobs, "clip")
    return dict(zip(CLIPS, res, strict=True))


def loop(duration: float, options: dict, jobs: int = 1) -> dict:
    return run_items([("loop", duration, options)], jobs, "loop")[0]


def pushes(options: dict, controllers=("mpc", "hand_of_god", "samcon_replay"),
           force: float = 100.0, moments=None, directions=None, jobs: int = 1) -> dict:
    period = reference(Character(), "walk60", cyclic=True).duration
    moments = moments or [round(0.5 + k * period / 4, 3) for k in range(4)]
    directions = [d for d in DIRECTIONS if not directions or d in directions]
    out = {"force_N": force, "moments_s": moments, "cycle_s": period}
    for name in controllers:
        cells = [(m, d) for m in moments for d in directions]
        res = run_items([("push", (name, force, m, d), options) for m, d in cells], jobs,
                        "push")
        rows = {f"{m}/{d}": r for (m, d), r in zip(cells, res, strict=True)}
        ok = [r["recovered"] for r in rows.values()]
        rows["summary"] = {"recovered": int(sum(ok)), "of": len(ok),
                           "falls": int(sum(r["fell"] for r in rows.values())),
                           "slowest_s": max((r["recovery_s"] for r in rows.values()
                                             if r["recovery_s"] is not None), default=None),
                           "highest_peak_m": max(r["peak_error_m"] or 0 for r in rows.values())}
        print(name, "pushes", json.dumps(rows["summary"]), flush=True)
        out[name] = rows
    return out


def perturbed(options: dict, seeds=range(5), jobs: int = 1) -> dict:
    res = run_items([("perturbed", s, options) for s in seeds], jobs, "perturbed")
    return {str(s): r for s, r in zip(seeds, res, strict=True)}


def curve(options: dict, samples=(16, 32, 48), horizons=(0.5, 0.6, 0.7), jobs: int = 1) -> dict:
    cells = [(n, h) for n in samples for h in horizons]
    res = run_items([("curve", c, options) for c in cells], jobs, "curve")
    return {f"{n}x{h}": r for (n, h), r in zip(cells, res, strict=True)}


def sweep(options: dict, variations: dict, parts=("clips", "pushes", "loop"),
          loop_duration: float = 60.0, jobs: int = 1) -> dict:
    """Each option of ``variations`` (name -> values) varied alone around ``options``, every
    variant through ``parts``; a line per variant."""
    out = {}
    for name, values in variations.items():
        for v in values:
            o = {**options, name: v}
            row = {}
            if "clips" in parts:
                row["clips"] = {k: _short(r) for k, r in clips(o, jobs).items()}
            if "pushes" in parts:
                row["pushes"] = pushes(o, ("mpc",), jobs=jobs)["mpc"]["summary"]
            if "loop" in parts:
                row["loop"] = _short(loop(loop_duration, o, jobs))
            if "perturbed" in parts:
                row["perturbed"] = {k: _short(r) for k, r in perturbed(o, jobs=jobs).items()}
            row["plan_steps_per_sim_s"] = nominal_steps(o)
            out[f"{name}={v}"] = row
            print("sweep", f"{name}={v}", json.dumps(row), flush=True)
    return out


def _short(r: dict) -> dict:
    return {"fell": r["fell"], "fall_time_s": r["fall_time_s"],
            "error_cm": round(100 * r["tracking_error_m"], 2),
            "plan_steps_per_sim_s": round(r.get("plan_steps_per_sim_s", 0))}


def nominal_steps(options: dict, model=None) -> float:
    """Planning-model steps per simulated second the options take at most on ``model`` (an
    ``MjModel``; default the bundled humanoid's): every candidate over the whole horizon, or
    with ``near`` every candidate over the near part and the ``keep`` fraction over the tail at
    ``tail_timestep``; candidates that diverge in the near part cut the measured figure below
    this."""
    o = MpcOptions.from_kwargs(**options)
    plan_dt = plan_timestep(o, Character().model if model is None else model)
    if 0 < o.near < o.horizon:
        tail_dt = plan_dt if o.tail_timestep is None else float(o.tail_timestep)
        kept = min(o.samples, max(2, int(np.ceil(o.keep * o.samples))))
        return (o.samples * o.near / plan_dt + kept * (o.horizon - o.near) / tail_dt) / o.replan
    return o.samples * o.horizon / o.replan / plan_dt


def determinism(options: dict) -> dict:
    ref = reference(Character(), "walk60")
    rows = {}
    for key, o in (("a", {}), ("b", {}), ("threads1", {"threads": 1})):
        q = []
        run_mpc(ref, 1.0, {**options, **o},
                frame_callback=lambda ch, q=q: q.append(ch.state.qpos.copy()))
        rows[key] = np.array(q)
    out = {"same_seed": bool(np.array_equal(rows["a"], rows["b"])),
           "one_vs_all_threads": bool(np.array_equal(rows["a"], rows["threads1"]))}
    print("determinism", json.dumps(out), flush=True)
    return out


def speed(options: dict, duration: float | None = None) -> dict:
    """Real-time factor on walk60, measured and normalised to a core doing
    :data:`REFERENCE_STEPS` bare steps per second (module docstring)."""
    ch = Character()
    ref = reference(ch, "walk60")
    before = raw_step_rate(ch.model, ref.qpos(0.0), repeats=5)
    r, t, st = run_mpc(ref, duration=duration, options=options)
    after = raw_step_rate(ch.model, ref.qpos(0.0), repeats=5)
    o = MpcOptions(**options)
    threads = o.threads or os.cpu_count() or 1
    wall_rate = (before["c_loop_steps_per_s"] + after["c_loop_steps_per_s"]) / 2
    cpu_rate = (before["c_loop_steps_per_cpu_s"] + after["c_loop_steps_per_cpu_s"]) / 2
    sim = r.sim_time_s
    rtf = sim / t.wall_s
    # rollout threads run while the main thread waits (it spends no CPU then): the run on idle
    # cores would take the main thread's CPU plus the rollout threads' CPU spread over them
    serial = t.thread_s if threads > 1 else t.cpu_s
    projected = serial + max(t.cpu_s - t.thread_s, 0.0) / threads if threads > 1 else serial
    plan_steps = st["physics_steps"] / sim
    steps = plan_steps + 1.0 / float(ch.model.opt.timestep)  # and the character's own steps
    out = {**summary(r, t, st), "threads": threads,
           "bare_steps_per_s": wall_rate, "bare_steps_per_cpu_s": cpu_rate,
           "bare_steps_per_s_before_after": [before["c_loop_steps_per_s"],
                                             after["c_loop_steps_per_s"]],
           "rtf_30k": rtf * REFERENCE_STEPS / wall_rate,
           "rtf_cpu": sim / projected, "rtf_cpu_30k": sim / projected * REFERENCE_STEPS / cpu_rate,
           "main_thread_cpu_s": t.thread_s, "rollout_thread_cpu_s": t.cpu_s - t.thread_s,
           "planning_s": st["planning_s"], "plan_steps_per_sim_s": plan_steps,
           "nominal_plan_steps_per_sim_s": nominal_steps(options, ch.model),
           "bound": threads * wall_rate / steps}
    print("speed", json.dumps(out), flush=True)
    print(f"speed: {sim:.2f} sim s in {t.wall_s:.2f} s wall on {threads} threads, load "
          f"{out['load']}: real-time factor {rtf:.3f} measured, {out['rtf_30k']:.3f} at "
          f"{REFERENCE_STEPS:,.0f} bare steps/s per core (bare here {wall_rate:,.0f}/s); "
          f"from CPU clocks {out['rtf_cpu']:.3f}, {out['rtf_cpu_30k']:.3f} normalised (bare "
          f"{cpu_rate:,.0f} per CPU s); {plan_steps:,.0f} planning-model steps per simulated "
          f"second", flush=True)
    return out


def _variations(specs: list[str]) -> dict:
    out = {}
    for spec in specs:
        k, v = spec.split("=", 1)
        out[k] = [json.loads(x) for x in v.split(",")]
    return out


def main(argv=None) -> int:
    p = entry_parser("mpc", __doc__)
    for part in ("clips", "loop", "pushes", "perturbed", "curve", "determinism", "speed", "all"):
        p.add_argument(f"--{part}", action="store_true")
    p.add_argument("--loop-duration", type=float, default=60.0)
    p.add_argument("--speed-duration", type=float, default=None,
                   help="seconds of walk60 the speed run tracks (default: the whole clip)")
    p.add_argument("--push-controllers", nargs="+", default=["mpc", "hand_of_god",
                                                             "samcon_replay"])
    p.add_argument("--push-moments", nargs="+", type=float, help="push times (s)")
    p.add_argument("--push-directions", nargs="+", choices=list(DIRECTIONS))
    p.add_argument("--option", action="append", default=[], metavar="NAME=JSON",
                   help="an MpcOptions field (repeatable), e.g. samples=64")
    p.add_argument("--sweep", action="append", default=[], metavar="NAME=V1,V2",
                   help="vary one option around the others (repeatable), e.g. samples=24,48")
    p.add_argument("--sweep-parts", nargs="+", default=["clips", "pushes", "loop"],
                   choices=["clips", "pushes", "loop", "perturbed"])
    p.add_argument("--jobs", type=int, default=1,
                   help="worker processes for the tracking parts (one rollout thread each)")
    p.add_argument("--out", default="mpc_bench.json")
    args = p.parse_args(argv)
    options = {}
    for kv in args.option:
        k, v = kv.split("=", 1)
        options[k] = json.loads(v)
    MpcOptions.from_kwargs(**options)  # an unknown or impossible option fails here
    results = {"options": options, "cpus": os.cpu_count(), "load_start": load()}
    a, jobs = args.all, max(1, args.jobs)
    if a or args.determinism:
        results["determinism"] = determinism(options)
    if a or args.clips:
        results["clips"] = clips(options, jobs)
    if a or args.perturbed:
        results["perturbed"] = perturbed(options, jobs=jobs)
    if a or args.pushes:
        results["pushes"] = pushes(options, tuple(args.push_controllers),
                                   moments=args.push_moments, directions=args.push_directions,
                                   jobs=jobs)
    if a or args.loop:
        results["loop"] = loop(args.loop_duration, options, jobs)
    if a or args.curve:
        results["curve"] = curve(options, jobs=jobs)
    if args.sweep:
        results["sweep"] = sweep(options, _variations(args.sweep), tuple(args.sweep_parts),
                                 args.loop_duration, jobs)
    if a or args.speed:
        results["speed"] = speed(options, args.speed_duration)
    print(f"wrote {write_json(args.out, results)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
