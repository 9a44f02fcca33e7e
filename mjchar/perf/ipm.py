"""IPM stepping (controllers/walking/ipm.py) on the bundled humanoid, with no root force.

Long versions of what tests/test_ipm.py checks quickly:

- ``walk``: 60 s from standing at 0.5 and 1.0 m/s: fall, mean speed (whole run and after 5 s),
  speed error, steps and mean step time.
- ``stop``: walk (0.5 and 1.0 m/s) for 6 s, then a zero command: when it stands, residual speed.
- ``turn``: walk (0.5 and 1.0 m/s), heading command 90 degrees away at 3 s: final heading, time
  to get within 5 degrees of it.
- ``push``: 0.2 s pushes on the pelvis from standing (zero command), 8 directions x 2 push times
  x several forces: which are survived (stepping allowed); static balance on the same pushes for
  comparison.
- ``cost``: an IPM control + physics step over a bare ``mj_step``, walking at 1.0 m/s from
  standing, interleaved in the same run (:func:`mjchar.perf.physics.step_cost`).

Usage::

    python -m mjchar.perf.ipm                 # everything (~10 min on one core)
    python -m mjchar.perf.ipm walk push       # some sections
    python -m mjchar.perf.ipm --quick         # 20 s walks, fewer pushes
    python -m mjchar.perf.ipm --json out.json
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from mjchar.controllers.core.builder import RunSpec, execute
from mjchar.controllers.core.character import Character
from mjchar.controllers.core.geometry import heading_yaw
from mjchar.controllers.core.scenarios import standing_pose
from mjchar.controllers.walking.ipm import make_ipm

from .physics import step_cost
from .report import entry_parser, write_json

SECTIONS = ("walk", "stop", "turn", "push", "cost")
#: the commanded speeds (m/s) of the walk, stop and turn sections: a row each
SPEEDS = (0.5, 1.0)
DIRECTIONS = (0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0)


def log(msg: str) -> None:
    print(msg, flush=True)


def outcome(r) -> str:
    return f"FELL at {r.fall_time_s:.1f} s" if r.fell else "ok"


def run(duration: float, **options):
    """IPM walking from the standing pose at rest (the walk scenario) for ``duration`` s with
    the factory ``options`` (``speed``, ``heading``: numbers or functions of time); returns
    (Result, the controller, times (T,), COM xy (T, 2), pelvis yaw (T,))."""
    times, com, yaw = [], [], []

    def record(c: Character) -> None:
        times.append(c.time)
        com.append(c.state.com()[:2].copy())
        R = c.state.root_rotation
        yaw.append(heading_yaw(R))

    built = RunSpec("ipm", "walk", options=options,
                    scenario_options={"duration": duration}).build(frame_callback=record)
    r = execute(built)
    return r, built.controller, np.asarray(times), np.asarray(com), np.asarray(yaw)


def mean_speed(times, com, t0: float) -> float:
    i = int(np.searchsorted(times, t0))
    if i >= len(times) - 1:
        return float("nan")
    return float(np.linalg.norm(com[-1] - com[i]) / (times[-1] - times[i]))


def walk_at(speed: float, duration: float) -> dict:
    """The ``walk`` section's row at the commanded ``speed``: ``duration`` s from standing."""
    r, ctrl, times, com, _ = run(duration, speed=speed)
    steps = np.diff(ctrl.step_switches[1:]) if len(ctrl.step_switches) > 2 else np.zeros(1)
    row = {"speed_cmd": speed, "duration_s": duration, "fell": r.fell,
           "fall_time_s": r.fall_time_s, "mean_speed": mean_speed(times, com, 0.0),
           "mean_speed_after_5s": mean_speed(times, com, 5.0), "steps": ctrl.steps,
           "mean_step_time_s": float(steps.mean()), "root_force_max_N": r.root_force_max_N,
           "wall_s": r.wall_s, "steps_per_s": r.steps_per_s}
    row["speed_error"] = abs(row["mean_speed"] - speed)
    row["speed_error_after_5s"] = abs(row["mean_speed_after_5s"] - speed)
    log(f"walk {speed} m/s, {duration:g} s: {outcome(r)}, mean speed "
        f"{row['mean_speed']:.3f} (after 5 s {row['mean_speed_after_5s']:.3f}),"
        f" error {row['speed_error']:.3f} / {row['speed_error_after_5s']:.3f} m/s, "
        f"{ctrl.steps} steps of {row['mean_step_time_s']:.3f} s, root force max "
        f"{r.root_force_max_N:.1f} N, {r.wall_s:.0f} s wall")
    return row


def stop_from(speed: float) -> dict:
    """The ``stop`` section's row: 6 s at the commanded ``speed``, then a zero command."""
    r, ctrl, times, com, _ = run(14.0, speed=lambda t: speed if t < 6.0 else 0.0)
    stood = [t for t in ctrl.stand_switches if t > 6.0]
    final = mean_speed(times, com, 13.0)
    row = {"speed_cmd": speed, "fell": r.fell, "mode_at_end": ctrl.mode,
           "stood_at_s": stood[0] if stood else None, "stand_switches": len(stood),
           "final_speed": final}
    log(f"stop from {speed} m/s at 6 s: {'FELL' if r.fell else 'ok'}, stands at "
        f"{row['stood_at_s']}, mode at 14 s {ctrl.mode}, speed over the last second "
        f"{final:.3f} m/s")
    return row


def turn_at(speed: float) -> dict:
    """The ``turn`` section's row at the commanded ``speed``: heading 90 degrees away at 3 s."""
    r, _, times, com, yaw = run(15.0, speed=speed, heading=lambda t: 0.0 if t < 3.0 else 90.0)
    err = np.abs(np.degrees(yaw) - 90.0)
    within = np.flatnonzero((times > 3.0) & (err < 5.0))
    row = {"speed_cmd": speed, "fell": r.fell, "final_heading_deg": float(np.degrees(yaw[-1])),
           "time_to_5deg_s": float(times[within[0]] - 3.0) if len(within) else None}
    log(f"turn 90 deg at {speed} m/s: {outcome(r)}, "
        f"final heading {row['final_heading_deg']:.1f} deg, within 5 deg after "
        f"{row['time_to_5deg_s']} s")
    return row


def bench_push(forces, times_) -> dict:
    """Pushes from standing (IPM at a zero command, as the push scenario runs a walker)."""
    out: dict = {"ipm": {}, "static_balance": {}}
    for name in ("ipm", "static_balance"):
        for force in forces:
            ok = []
            for pt in times_:
                for d in DIRECTIONS:
                    if name == "static_balance" and d % 90:
                        continue
                    r = RunSpec(name, "push", scenario_options={
                        "force": force, "direction": d, "push_time": pt,
                        "duration": pt + 3.0, "allow_steps": True}).execute()
                    ok.append({"direction_deg": d, "push_time_s": pt, "survived": not r.fell,
                               "stepped": r.stepped})
            out[name][str(force)] = ok
            n = sum(o["survived"] for o in ok)
            log(f"push {name} {force:g} N, 0.2 s: survived {n}/{len(ok)} "
                + " ".join(f"{o['direction_deg']:g}@{o['push_time_s']:g}:"
                           f"{'ok' if o['survived'] else 'FELL'}" for o in ok))
    return out


def bench_cost(steps: int = 2500, repeats: int = 5) -> dict:
    """IPM's cost per physics step (walking at 1.0 m/s from standing) over a bare ``mj_step``."""
    ch = Character()
    pose = standing_pose(ch)
    c = step_cost(ch, lambda: make_ipm(ch, speed=1.0), qpos=pose, steps=steps, repeats=repeats)
    log(f"cost: IPM control + physics step {c.controller_us:.0f} us vs bare mj_step "
        f"{c.raw_us:.0f} us (x{c.ratio:.1f}, process CPU time); real-time factor "
        f"{ch.timestep / (c.controller_us * 1e-6):.1f} per core")
    return c.to_dict()


def main(argv=None) -> int:
    ap = entry_parser("ipm", __doc__)
    ap.add_argument("sections", nargs="*", metavar="SECTION",
                    help=f"any of {', '.join(SECTIONS)} (default: all)")
    ap.add_argument("--quick", action="store_true", help="20 s walks, fewer pushes")
    ap.add_argument("--json", type=Path, help="write the numbers to this file")
    args = ap.parse_args(argv)
    bad = [s for s in args.sections if s not in SECTIONS]
    if bad:
        ap.error(f"unknown section(s) {', '.join(bad)}; choose from {', '.join(SECTIONS)}")
    sections = args.sections or list(SECTIONS)
    results: dict = {}
    if "walk" in sections:
        results["walk"] = [walk_at(v, 20.0 if args.quick else 60.0) for v in SPEEDS]
    if "stop" in sections:
        results["stop"] = [stop_from(v) for v in SPEEDS]
    if "turn" in sections:
        results["turn"] = [turn_at(v) for v in SPEEDS]
    if "push" in sections:
        forces = (150.0, 200.0) if args.quick else (150.0, 200.0, 250.0, 300.0)
        results["push"] = bench_push(forces, (1.0,) if args.quick else (1.0, 1.3))
    if "cost" in sections:
        results["cost"] = bench_cost()
    if args.json:
        log(f"wrote {write_json(args.json, results)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
