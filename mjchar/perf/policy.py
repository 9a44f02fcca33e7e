"""A learned tracking policy against the bars of docs/learning.md: the looped clip for 20
s, sideways pushes at 8 phases of the stride, perturbed starts, and the wall time against the
MPC on the same run.

- ``--loop``: the policy tracks its looped clip for ``--duration`` (20) s: fall, mean joint
  error, root force, wall and CPU time.
- ``--pushes``: 100 N x 0.2 s on the pelvis, left and right, at 8 phases of one gait cycle
  starting ``--push-after`` (2) s in, each run 3 s past the push: falls.
- ``--perturbed``: 5 seeded perturbed starts (``scenarios.perturbed_start``: joints N(0, 0.1
  rad), root velocity N(0, 0.2 m/s)), ``--duration`` s each: falls and errors.
- ``--speed``: the same run with the policy (``--duration`` s, or until it falls) and with the
  MPC (``--mpc-seconds`` of it when given): wall and CPU seconds per simulated second of each,
  and their ratios.

The load average is printed with every part (the machine may be shared).

    python -m mjchar.perf.policy POLICY --loop --pushes --perturbed --speed
"""

from __future__ import annotations

import argparse
import json

from mjchar.controllers.core import scenarios as S
from mjchar.controllers.core.character import Character
from mjchar.controllers.core.registry import make_controller
from mjchar.controllers.core.runs import RunSpec, load_reference
from mjchar.controllers.learned import find_policy

from .timing import load_average, timed

SIDEWAYS = {"left": 90.0, "right": 270.0}


def _setup(policy, controller: str = "policy"):
    p = find_policy(policy)
    ch = Character()
    spec = RunSpec("policy", "track", motion=p.clip_motion(), loop=p.meta["clip"]["loop"])
    ref = load_reference(spec, ch)
    c = (make_controller("policy", ch, ref, policy=p) if controller == "policy"
         else make_controller(controller, ch, ref))
    return ch, ref, c


def _summary(r, t) -> dict:
    return {"fell": r.fell, "fall_time_s": r.fall_time_s, "tracking_error_m": r.tracking_error_m,
            "root_error_m": r.root_error_m, "root_force_max_N": r.root_force_max_N,
            "sim_s": r.sim_time_s, "wall_s": t.wall_s, "cpu_s": t.cpu_s,
            "load": load_average()}


def loop(policy, duration: float = 20.0) -> dict:
    ch, ref, c = _setup(policy)
    r, t = timed(S.track, ch, c, ref, duration=duration)
    return _summary(r, t)


def pushes(policy, after: float = 2.0, force: float = 100.0, settle: float = 3.0) -> dict:
    out = {}
    for name, deg in SIDEWAYS.items():
        rows = []
        for k in range(8):
            ch, ref, c = _setup(policy)
            at = after + k * ref.duration / 8
            push = S.PushEvent(force, deg, at, 0.2)
            r = S.track(ch, c, ref, duration=push.end + settle, push=push)
            rows.append({"phase": k / 8, "time_s": round(at, 3), "fell": r.fell,
                         "tracking_error_m": r.tracking_error_m})
        out[name] = {"survived": sum(not x["fell"] for x in rows), "of": 8, "runs": rows}
    out["load"] = load_average()
    return out


def perturbed(policy, duration: float = 20.0, seeds=range(5)) -> dict:
    rows = []
    for seed in seeds:
        ch, ref, c = _setup(policy)
        start = S.perturbed_start(ch, ref.qpos(0.0), ref.qvel(0.0), seed)
        r, t = timed(S.track, ch, c, ref, duration=duration, start=start)
        rows.append({"seed": seed, **_summary(r, t)})
    return {"no_fall": sum(not x["fell"] for x in rows), "of": len(rows), "runs": rows}


def speed(policy, duration: float = 20.0, mpc_seconds: float | None = None) -> dict:
    ch, ref, c = _setup(policy)
    r, tp = timed(S.track, ch, c, ref, duration=duration)
    ch, ref, m = _setup(policy, "mpc")
    sim = duration if mpc_seconds is None else mpc_seconds
    rm, tm = timed(S.track, ch, m, ref, duration=sim)
    m.close()
    # per simulated second (a run that falls ends early): wall and CPU seconds of each
    pw, pc = tp.wall_s / r.sim_time_s, tp.cpu_s / r.sim_time_s
    mw, mc = tm.wall_s / rm.sim_time_s, tm.cpu_s / rm.sim_time_s
    return {"policy_sim_s": r.sim_time_s, "policy_fell": r.fell, "policy_wall_per_sim_s": pw,
            "policy_cpu_per_sim_s": pc, "mpc_sim_s": rm.sim_time_s, "mpc_wall_per_sim_s": mw,
            "mpc_cpu_per_sim_s": mc, "wall_ratio": mw / pw, "cpu_ratio": mc / pc,
            "load": load_average()}


def main(argv=None) -> None:
    p = argparse.ArgumentParser(prog="python -m mjchar.perf.policy", description=__doc__)
    p.add_argument("policy", nargs="?", default=None, help="policy file or bundled name")
    for part in ("loop", "pushes", "perturbed", "speed"):
        p.add_argument(f"--{part}", action="store_true")
    p.add_argument("--duration", type=float, default=20.0)
    p.add_argument("--push-after", type=float, default=2.0)
    p.add_argument("--mpc-seconds", type=float, default=None)
    a = p.parse_args(argv)
    out = {}
    if a.loop:
        out["loop"] = loop(a.policy, a.duration)
        print(json.dumps({"loop": out["loop"]}), flush=True)
    if a.pushes:
        out["pushes"] = pushes(a.policy, a.push_after)
        print(json.dumps({"pushes": out["pushes"]}), flush=True)
    if a.perturbed:
        out["perturbed"] = perturbed(a.policy, a.duration)
        print(json.dumps({"perturbed": out["perturbed"]}), flush=True)
    if a.speed:
        out["speed"] = speed(a.policy, a.duration, a.mpc_seconds)
        print(json.dumps({"speed": out["speed"]}), flush=True)


if __name__ == "__main__":
    main()
