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

Every run is built as ``mjchar run policy POLICY --motion CLIP [--loop]`` builds it (the run
builder, ``RunSpec``): a perturbed start is ``track --seed S``, a push ``--push 100 --direction
90 --push-time T``. The load average is printed with every part (the machine may be shared).

    python -m mjchar.perf.policy POLICY --loop --pushes --perturbed --speed
"""

from __future__ import annotations

import argparse
import json

from mjchar.controllers.core.builder import RunSpec, execute
from mjchar.controllers.learned import find_policy
from mjchar.controllers.learned.controller import own_clip

from .timing import load_average, timed

SIDEWAYS = {"left": 90.0, "right": 270.0}


def policy_spec(policy, controller: str = "policy", **scenario_options) -> RunSpec:
    """The run of ``controller`` tracking ``policy``'s own clip (as ``mjchar run``);
    ``scenario_options``: the track scenario's (``duration``, ``force``, ``seed``...)."""
    p = find_policy(policy)
    seed = scenario_options.pop("seed", None)
    motion, loop = own_clip({"policy": p})
    return RunSpec(controller, "track", motion=motion, loop=loop,
                   options={"policy": p} if controller == "policy" else {}, seed=seed,
                   scenario_options=scenario_options)


def _summary(r, t) -> dict:
    return {"fell": r.fell, "fall_time_s": r.fall_time_s, "tracking_error_m": r.tracking_error_m,
            "root_error_m": r.root_error_m, "root_force_max_N": r.root_force_max_N,
            "sim_s": r.sim_time_s, "wall_s": t.wall_s, "cpu_s": t.cpu_s,
            "load": load_average()}


def _timed(spec: RunSpec):
    """``(result, timing)`` of the run (building it is not timed)."""
    run = spec.build()
    try:
        return timed(execute, run)
    finally:
        close = getattr(run.controller, "close", None)
        if close is not None:
            close()


def loop(policy, duration: float = 20.0) -> dict:
    r, t = _timed(policy_spec(policy, duration=duration))
    return _summary(r, t)


def pushes(policy, after: float = 2.0, force: float = 100.0, settle: float = 3.0) -> dict:
    cycle = _cycle(policy)
    out = {}
    for name, deg in SIDEWAYS.items():
        rows = []
        for k in range(8):
            at = after + k * cycle / 8
            r, _ = _timed(policy_spec(policy, duration=at + 0.2 + settle, force=force,
                                      direction=deg, push_time=at, push_duration=0.2))
            rows.append({"phase": k / 8, "time_s": round(at, 3), "fell": r.fell,
                         "tracking_error_m": r.tracking_error_m})
        out[name] = {"survived": sum(not x["fell"] for x in rows), "of": 8, "runs": rows}
    out["load"] = load_average()
    return out


def _cycle(policy) -> float:
    """The length of the cycle ``policy`` tracks (s): the reference its runs follow."""
    return float(policy_spec(policy, duration=0.1).build().reference.duration)


def perturbed(policy, duration: float = 20.0, seeds=range(5)) -> dict:
    rows = []
    for seed in seeds:
        r, t = _timed(policy_spec(policy, duration=duration, seed=seed))
        rows.append({"seed": seed, **_summary(r, t)})
    return {"no_fall": sum(not x["fell"] for x in rows), "of": len(rows), "runs": rows}


def speed(policy, duration: float = 20.0, mpc_seconds: float | None = None) -> dict:
    r, tp = _timed(policy_spec(policy, duration=duration))
    sim = duration if mpc_seconds is None else mpc_seconds
    rm, tm = _timed(policy_spec(policy, "mpc", duration=sim))
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
