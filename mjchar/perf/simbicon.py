"""SIMBICON: the long runs behind docs/simbicon.md (no root force anywhere).

    python -m mjchar.perf.simbicon                      # everything (~13 min, 1 core)
    python -m mjchar.perf.simbicon walk feedback-off    # only some parts
    python -m mjchar.perf.simbicon pushes --gait crouch --json out.json

Parts:
  walk          60 s on level ground at 5 seeds: falls, steady speed (last 10 s), root force
  feedback-off  cd = cv = 0 (sagittal and coronal) at 5 seeds: time of the fall
  pushes        the push protocol at 200 N front/back, 150 N left/right: 0.2 s pushes to the
                chest at 8 phases x 5 seeds, 5 s of walking afterwards (survival rate)
  search        the push protocol over a 25 N grid to 800 N, 8 phases x 5 seeds: the largest
                forces with survival rate 100 % and >= 90 % per direction
  slopes        20 m up and 20 m down a 5 degree slope
  timing        controller + physics step cost over a bare mj_step, interleaved in the same
                run (:func:`mjchar.perf.physics.step_cost`)
"""

from __future__ import annotations

import sys

import numpy as np

from mjchar.controllers.core.builder import RunSpec
from mjchar.controllers.core.character import Character
from mjchar.controllers.core.scenarios.push_search import PushProtocol, survival_rates
from mjchar.controllers.walking.simbicon import DEFAULT_TIMESTEP, make_simbicon

from .physics import step_cost
from .report import entry_parser, write_json
from .timing import timed

PARTS = ("walk", "feedback-off", "pushes", "search", "slopes", "timing")
SEEDS = (0, 1, 2, 3, 4)
PUSH_FORCES = {"forward": 200.0, "backward": 200.0, "left": 150.0, "right": 150.0}


def log(msg: str) -> None:
    print(msg, flush=True)


def simbicon_run(scenario: str, gait: str, seed: int, **options) -> RunSpec:
    """SIMBICON with ``gait`` in ``scenario`` (as ``mjchar run simbicon SCENARIO --gait GAIT
    --seed SEED`` builds it); ``options``: the scenario's, and ``feedback``."""
    factory = {"gait": gait}
    if "feedback" in options:
        factory["feedback"] = options.pop("feedback")
    return RunSpec("simbicon", scenario, options=factory, seed=seed, scenario_options=options)


def bench_walk(gait: str, duration: float) -> dict:
    out = {}
    for seed in SEEDS:
        r = simbicon_run("walk", gait, seed, duration=duration).execute()
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
        r = simbicon_run("walk", gait, seed, duration=10.0, feedback=False).execute()
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
        r = simbicon_run("slopes", gait, 0, degrees=deg, distance=20.0, duration=45.0).execute()
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


def bench_timing(gait: str, steps: int = 3000, repeats: int = 5) -> dict:
    """SIMBICON's cost per physics step over a bare ``mj_step`` (from its start state)."""
    ch = Character(timestep=DEFAULT_TIMESTEP)
    probe = make_simbicon(gait=gait)
    probe.reset(ch)
    q, v = probe.start_state(ch, np.random.default_rng(0))
    c = step_cost(ch, lambda: make_simbicon(gait=gait), qpos=q, qvel=v, steps=steps,
                  repeats=repeats)
    log(f"timing: SIMBICON step costs {c.ratio:.1f}x a bare mj_step ({c.controller_us:.0f} vs "
        f"{c.raw_us:.0f} us per step at dt {ch.timestep * 1000:g} ms, process CPU time)")
    return c.to_dict()


def main(argv: list[str] | None = None) -> int:
    ap = entry_parser("simbicon", __doc__)
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

    parts_fn = {"walk": lambda: bench_walk(a.gait, a.duration),
                "feedback-off": lambda: bench_feedback_off(a.gait),
                "pushes": lambda: bench_pushes(a.gait), "search": lambda: bench_search(a.gait),
                "slopes": lambda: bench_slopes(a.gait), "timing": lambda: bench_timing(a.gait)}

    def run() -> None:
        for part in parts:
            log(f"== {part} ({a.gait})")
            out[part] = parts_fn[part]()

    out["wall_s"] = timed(run)[1].wall_s
    log(f"done in {out['wall_s'] / 60:.1f} min")
    if a.json:
        write_json(a.json, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
