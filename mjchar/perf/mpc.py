"""The closed-loop sampling MPC tracker (controllers/sampling/mpc.py): the figures of docs/mpc.md.

Everything runs sequentially (2 cores shared with other processes: the load average is recorded
with every part; the real-time factor is simulated seconds per wall second of the whole run).

- ``--clips``: the four shared clips tracked at the default settings (fall, mean joint error,
  root force, real-time factor).
- ``--loop``: walk60 made cyclic (``mjchar.bvh.editing.clips.make_cyclic``) and tracked for
  ``--loop-duration``
  (60) s.
- ``--pushes``: 100 N x 0.2 s at the pelvis, at 4 moments of the gait cycle x 4 directions, while
  tracking cyclic walk60 (MPC, hand-of-god) and on the SAMCON replay of walk60: falls, and the
  time after the push until the joint error is back below 8 cm.
- ``--perturbed``: starts with 0.1 rad joint noise and 0.2 m/s root velocity noise, 5 seeds.
- ``--curve``: tracking error and real-time factor against samples x horizon on walk60.
- ``--determinism``: the same seed twice, and with 1 and 2 threads: bit-identical trajectories.
- ``--speed``: the real-time factor on walk60 with every core (the options' ``threads``
  otherwise), beside bare ``mj_step`` throughput measured in the same run: the physics steps the
  settings simulate per simulated second give the factor the cores could reach if rollouts
  were all the work (``bound``), and ``efficiency`` = factor / bound.

    python -m mjchar.perf.mpc --all          # everything (about half an hour)
    python -m mjchar.perf.mpc --clips        # one part
"""

from __future__ import annotations

import argparse
import json
import os

import numpy as np

from mjchar import bvh
from mjchar.bvh.bundled.assets import TRAJECTORIES
from mjchar.bvh.editing.clips import make_cyclic
from mjchar.bvh.reference.reference_motion import ReferenceMotion
from mjchar.controllers.core import scenarios as S
from mjchar.controllers.core.character import Character
from mjchar.controllers.core.registry import make_controller
from mjchar.controllers.sampling.mpc import MpcOptions, make_mpc, plan_timestep
from mjchar.controllers.sampling.trajectory import (
    ReplayController,
    StoredReference,
    load_trajectory,
)

from .physics import raw_step_rate
from .report import shared_clip, write_json
from .timing import load_average, timed

CLIPS = ("walk60", "walk_forward", "walk_and_turn_right", "idle")
DIRECTIONS = {"forward": 0.0, "left": 90.0, "backward": 180.0, "right": 270.0}
RECOVERED = 0.08  # m: the joint error a pushed tracker must return below
RECOVERY_WINDOW = 2.0  # s after the push's end
SETTLE = 4.0  # s simulated after the push's end (the error must stay low once recovered)


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


def run_mpc(ref, duration=None, options=None, **kw):
    ch = Character()
    c = make_mpc(ch, ref, progress=False, **(options or {}))
    r, t = timed(S.track, ch, c, ref, duration=duration, **kw)
    c.close()
    return r, t.wall_s, c.stats


def summary(r, wall: float, stats=None) -> dict:
    out = {"fell": r.fell, "fall_time_s": r.fall_time_s, "tracking_error_m": r.tracking_error_m,
           "root_error_m": r.root_error_m, "root_force_mean_N": r.root_force_mean_N,
           "sim_s": r.sim_time_s, "wall_s": wall, "rtf": r.sim_time_s / wall, "load": load()}
    if stats:
        out["replans"], out["rollouts"] = stats["replans"], stats["rollouts"]
    return out


def clips(options: dict) -> dict:
    out = {}
    for name in CLIPS:
        ref = reference(Character(), name)
        r, wall, st = run_mpc(ref, options=options)
        out[name] = summary(r, wall, st)
        print(name, json.dumps(out[name]), flush=True)
    return out


def loop(duration: float, options: dict) -> dict:
    ref = reference(Character(), "walk60", cyclic=True)
    r, wall, st = run_mpc(ref, duration=duration, options=options)
    out = summary(r, wall, st)
    out["cycle_s"] = ref.duration
    print("loop", json.dumps(out), flush=True)
    return out


def _pushed(controller: str, push: S.PushEvent, options: dict) -> dict:
    """One pushed run; the recovery time is measured from the push's end."""
    ch = Character()
    if controller == "samcon_replay":
        tr = load_trajectory(TRAJECTORIES / "samcon_walk60.npz")
        ref = StoredReference(ch.model, tr.reference_qpos, tr.control_dt, ch.joint_bodies)
        ch.set_timestep(tr.timestep)
        c = ReplayController(tr)
        trace = ErrorTrace(ref)
        duration = tr.duration
        kw = {"qpos": tr.initial_qpos, "qvel": tr.initial_qvel, "control_dt": tr.control_dt}
        r = S.simulate(ch, c, duration=duration, scenario="track", reference=ref,
                       **S.with_push(push, {"frame_callback": trace, **kw}))
    else:
        ref = reference(ch, "walk60", cyclic=True)
        duration = push.end + SETTLE
        trace = ErrorTrace(ref)
        if controller == "mpc":
            c = make_mpc(ch, ref, progress=False, **options)
        else:
            c = make_controller(controller, ch, ref)
        r = S.track(ch, c, ref, duration=duration, push=push, frame_callback=trace)
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


def pushes(options: dict, controllers=("mpc", "hand_of_god", "samcon_replay"),
           force: float = 100.0, moments=None, directions=None) -> dict:
    ch = Character()
    period = reference(ch, "walk60", cyclic=True).duration
    moments = moments or [round(0.5 + k * period / 4, 3) for k in range(4)]
    out = {"force_N": force, "moments_s": moments, "cycle_s": period}
    for name in controllers:
        rows = {}
        for m in moments:
            for dname, deg in DIRECTIONS.items():
                if directions and dname not in directions:
                    continue
                rows[f"{m}/{dname}"] = _pushed(name, S.PushEvent(force, deg, m, 0.2), options)
                print(name, m, dname, json.dumps(rows[f"{m}/{dname}"]), flush=True)
        out[name] = rows
    return out


def perturbed(options: dict, seeds=range(5)) -> dict:
    out = {}
    ch = Character()
    ref = reference(ch, "walk60")
    for s in seeds:
        start = S.perturbed_start(ch, ref.qpos(0.0), ref.qvel(0.0), s)
        r, wall, st = run_mpc(ref, options=options, start=start)
        out[str(s)] = summary(r, wall, st)
        print("perturbed", s, json.dumps(out[str(s)]), flush=True)
    return out


def curve(options: dict, samples=(16, 48, 96), horizons=(0.3, 0.5, 0.7)) -> dict:
    out = {}
    ref = reference(Character(), "walk60")
    for n in samples:
        for h in horizons:
            o = {**options, "samples": n, "horizon": h}
            r, wall, st = run_mpc(ref, options=o)
            out[f"{n}x{h}"] = summary(r, wall, st)
            print("curve", n, h, json.dumps(out[f"{n}x{h}"]), flush=True)
    return out


def determinism(options: dict) -> dict:
    ref = reference(Character(), "walk60")
    rows = {}
    for key, o in (("a", {}), ("b", {}), ("threads1", {"threads": 1})):
        ch = Character()
        c = make_mpc(ch, ref, progress=False, **{**options, **o})
        q = []
        S.track(ch, c, ref, duration=1.0,
                frame_callback=lambda ch, q=q: q.append(ch.state.qpos.copy()))
        c.close()
        rows[key] = np.array(q)
    out = {"same_seed": bool(np.array_equal(rows["a"], rows["b"])),
           "one_vs_all_threads": bool(np.array_equal(rows["a"], rows["threads1"]))}
    print("determinism", json.dumps(out), flush=True)
    return out


def speed(options: dict) -> dict:
    """Real-time factor on walk60, against bare ``mj_step`` throughput on this machine now."""
    ch = Character()
    ref = reference(ch, "walk60")
    before = raw_step_rate(ch.model, ref.qpos(0.0))["c_loop_steps_per_s"]
    r, wall, st = run_mpc(ref, options=options)
    after = raw_step_rate(ch.model, ref.qpos(0.0))["c_loop_steps_per_s"]
    o = MpcOptions(**options)
    threads = o.threads or os.cpu_count() or 1
    plan_dt = plan_timestep(o, float(ch.model.opt.timestep))
    # physics steps per simulated second: the rollouts, plus the character's own steps
    steps = o.samples * o.horizon / o.replan / plan_dt + 1.0 / float(ch.model.opt.timestep)
    rate = (before + after) / 2
    bound = threads * rate / steps
    out = {**summary(r, wall, st), "threads": threads, "raw_steps_per_s": rate,
           "raw_steps_per_s_before_after": [before, after], "steps_per_sim_s": steps,
           "bound": bound, "efficiency": (r.sim_time_s / wall) / bound}
    print("speed", json.dumps(out), flush=True)
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m mjchar.perf.mpc",
                                description=__doc__.split("\n")[0])
    for part in ("clips", "loop", "pushes", "perturbed", "curve", "determinism", "speed", "all"):
        p.add_argument(f"--{part}", action="store_true")
    p.add_argument("--loop-duration", type=float, default=60.0)
    p.add_argument("--push-controllers", nargs="+", default=["mpc", "hand_of_god",
                                                             "samcon_replay"])
    p.add_argument("--push-moments", nargs="+", type=float, help="push times (s)")
    p.add_argument("--push-directions", nargs="+", choices=list(DIRECTIONS))
    p.add_argument("--option", action="append", default=[], metavar="NAME=JSON",
                   help="an MpcOptions field (repeatable), e.g. samples=64")
    p.add_argument("--out", default="mpc_bench.json")
    args = p.parse_args(argv)
    options = {}
    for kv in args.option:
        k, v = kv.split("=", 1)
        options[k] = json.loads(v)
    results = {"options": options, "cpus": os.cpu_count()}
    a = args.all
    if a or args.determinism:
        results["determinism"] = determinism(options)
    if a or args.clips:
        results["clips"] = clips(options)
    if a or args.perturbed:
        results["perturbed"] = perturbed(options)
    if a or args.pushes:
        results["pushes"] = pushes(options, tuple(args.push_controllers),
                                   moments=args.push_moments, directions=args.push_directions)
    if a or args.loop:
        results["loop"] = loop(args.loop_duration, options)
    if a or args.curve:
        results["curve"] = curve(options)
    if a or args.speed:
        results["speed"] = speed(options)
    print(f"wrote {write_json(args.out, results)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
