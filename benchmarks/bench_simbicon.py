"""SIMBICON benchmark: the long runs behind docs/simbicon.md (no root force anywhere).

    python benchmarks/bench_simbicon.py                      # everything (~13 min, 1 core)
    python benchmarks/bench_simbicon.py walk feedback-off    # only some parts
    python benchmarks/bench_simbicon.py pushes --gait crouch --json out.json

Parts:
  walk          60 s on level ground at 5 seeds: falls, steady speed (last 10 s), root force
  feedback-off  cd = cv = 0 (sagittal and coronal) at 5 seeds: time of the fall
  pushes        the push protocol at 200 N front/back, 150 N left/right: 0.2 s pushes to the
                chest at 8 phases x 5 seeds, 5 s of walking afterwards (survival rate)
  search        the push protocol over a 25 N grid to 800 N, 8 phases x 5 seeds: the largest
                forces with survival rate 100 % and >= 90 % per direction
  slopes        20 m up and 20 m down a 5 degree slope
  timing        controller + physics step cost relative to a bare mj_step
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from mjchar.controllers.core.character import Character  # noqa: E402
from mjchar.controllers.core.scenarios import slope_walk, walk  # noqa: E402
from mjchar.controllers.core.scenarios.push_search import PushProtocol, survival_rates  # noqa: E402
from mjchar.controllers.walking.simbicon import DEFAULT_TIMESTEP, make_simbicon  # noqa: E402

PARTS = ("walk", "feedback-off", "pushes", "search", "slopes", "timing")
SEEDS = (0, 1, 2, 3, 4)
PUSH_FORCES = {"forward": 200.0, "backward": 200.0, "left": 150.0, "right": 150.0}


def log(msg: str) -> None:
    print(msg, flush=True)


def character() -> Character:
    return Character(timestep=DEFAULT_TIMESTEP)


def bench_walk(gait: str, duration: float) -> dict:
    out = {}
    for seed in SEEDS:
        r = walk(character(), make_simbicon(gait=gait), duration=duration, seed=seed)
        out[seed] = {
            "fell": r.fell,
            "fall_time_s": r.fall_time_s,
            "steady_speed_mps": r.extra["steady_speed_mps"],
            "distance_m": r.distance_m,
            "root_force_max_N": r.root_force_max_N,
            "steps_per_s": r.steps_per_s,
        }
        log(
            f"walk seed {seed}: "
            + (f"FELL at {r.fall_time_s:.2f} s" if r.fell else f"{duration:g} s, no fall")
            + f", steady speed {r.extra['steady_speed_mps']:.3f} m/s, distance {r.distance_m:.1f} m"
            f", root force max {r.root_force_max_N:.1f} N, {r.steps_per_s:.0f} steps/s"
        )
    return out


def bench_feedback_off(gait: str) -> dict:
    out = {}
    for seed in SEEDS:
        r = walk(character(), make_simbicon(gait=gait, feedback=False), duration=10.0, seed=seed)
        out[seed] = {"fell": r.fell, "fall_time_s": r.fall_time_s}
        log(
            f"feedback off seed {seed}: "
            + (f"fell at {r.fall_time_s:.2f} s" if r.fell else "did NOT fall in 10 s")
        )
    return out


def bench_pushes(gait: str) -> dict:
    """The push protocol at the fixed forces of PUSH_FORCES: 8 phases x 5 seeds each."""
    out = {}
    for name, force in PUSH_FORCES.items():
        protocol = PushProtocol(forces=(force,), phases=8, seeds=tuple(SEEDS),
                                directions=(name,))
        r = survival_rates("simbicon", protocol, options={"gait": gait}, processes=0)
        out[name] = r.to_dict()
        rate = r.curves[name]["rates"][0] if r.curves.get(name) else None
        log(f"pushes {name} {force:.0f} N: "
            + ("falls unpushed" if r.falls_unpushed else f"survival rate {rate:.0%} over "
               f"{protocol.phases} phases x {len(SEEDS)} seeds"))
    return out


def bench_search(gait: str) -> dict:
    """The push protocol over a 25 N grid to 800 N, 8 phases x 5 seeds, every direction."""
    protocol = PushProtocol.grid(800.0, 25.0, phases=8, seeds=tuple(SEEDS))
    r = survival_rates("simbicon", protocol, options={"gait": gait}, processes=0, progress=log)
    log(r.summary())
    return r.to_dict()


def bench_slopes(gait: str) -> dict:
    out = {}
    for deg in (5.0, -5.0):
        r = slope_walk(
            character(), make_simbicon(gait=gait), degrees=deg, distance=20.0, duration=45.0, seed=0
        )
        out[f"{deg:+g}"] = {
            "reached_20m": r.extra["reached"],
            "fell": r.fell,
            "fall_time_s": r.fall_time_s,
            "slope_distance_m": r.extra["slope_distance_m"],
            "time_to_20m_s": r.extra["time_to_distance_s"],
            "steady_speed_mps": r.extra["steady_speed_mps"],
        }
        t20 = r.extra["time_to_distance_s"]
        log(
            f"slope {deg:+g} deg: "
            + (f"FELL at {r.fall_time_s:.2f} s" if r.fell else "no fall")
            + f", {r.extra['slope_distance_m']:.1f} m along the slope in 45 s"
            + (f" (20 m at {t20:.1f} s)" if t20 is not None else " (never 20 m)")
            + f", steady speed {r.extra['steady_speed_mps']:.3f} m/s"
        )
    return out


def bench_timing(gait: str) -> dict:
    import mujoco

    ch = character()
    c = make_simbicon(gait=gait)
    c.reset(ch)
    q, v = c.start_state(ch, np.random.default_rng(0))
    ch.reset(q, v)
    c.reset(ch)
    n = 3000
    t0 = time.perf_counter()
    for _ in range(n):
        ch.step(c.act(ch, ch.time))
    ctl = time.perf_counter() - t0
    m, d = ch.model, mujoco.MjData(ch.model)
    d.qpos[:] = q
    t0 = time.perf_counter()
    for _ in range(n):
        mujoco.mj_step(m, d)
    raw = time.perf_counter() - t0
    ratio = ctl / raw
    log(
        f"timing: SIMBICON step costs {ratio:.1f}x a bare mj_step "
        f"({n / ctl:.0f} vs {n / raw:.0f} steps/s at dt {ch.timestep * 1000:g} ms)"
    )
    return {"ratio": ratio, "steps_per_s": n / ctl, "raw_steps_per_s": n / raw}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "parts", nargs="*", default=[], help=f"parts to run: {', '.join(PARTS)} (default: all)"
    )
    ap.add_argument("--gait", default="walk", help="gait name (walk, crouch)")
    ap.add_argument("--duration", type=float, default=60.0, help="walk duration (s)")
    ap.add_argument("--json", help="write the numbers to this file")
    a = ap.parse_args(argv)
    parts = a.parts or list(PARTS)
    bad = [p for p in parts if p not in PARTS]
    if bad:
        ap.error(f"unknown part(s) {', '.join(bad)}; choose from {', '.join(PARTS)}")
    out: dict = {"gait": a.gait, "timestep_s": DEFAULT_TIMESTEP}
    t0 = time.time()
    for part in parts:
        log(f"== {part} ({a.gait})")
        if part == "walk":
            out[part] = bench_walk(a.gait, a.duration)
        elif part == "feedback-off":
            out[part] = bench_feedback_off(a.gait)
        elif part == "pushes":
            out[part] = bench_pushes(a.gait)
        elif part == "search":
            out[part] = bench_search(a.gait)
        elif part == "slopes":
            out[part] = bench_slopes(a.gait)
        elif part == "timing":
            out[part] = bench_timing(a.gait)
    out["wall_s"] = time.time() - t0
    log(f"done in {out['wall_s'] / 60:.1f} min")
    if a.json:

        def clean(x):
            if isinstance(x, float) and not math.isfinite(x):
                return None
            return x

        Path(a.json).write_text(json.dumps(out, indent=1, default=clean))
    return 0


if __name__ == "__main__":
    sys.exit(main())
