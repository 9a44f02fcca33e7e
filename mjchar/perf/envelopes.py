"""The walkers' envelopes on converted bodies: ``python -m mjchar.perf.envelopes [FILE.bvh ...]``.

Each file (default: every ``*.bvh`` of ``../shared/data/real``) is converted at the defaults
(as ``mjchar convert FILE -o body.xml``) and run as a user's runs do. ``--what bar``: the bar's
runs (:data:`BAR`: static balance 30 s, SIMBICON 60 s, IPM 60 s at 1.0 m/s, as ``mjchar run``
runs them). ``--what envelopes``: both walkers on the body
(their calibration included: ``MJCHAR_CALIBRATION`` and the calibration cache apply, so a body
without a stored calibration is checked, and calibrated where the check fails, first, once per
body and walker on every core before the runs start):

- **walks**: ``walk`` from the walker's seeded start state at each of ``--speeds`` (m/s) x
  ``--seeds`` seeds, ``--duration`` s; a fall, and the mean speed over the last
  ``--steady-window`` s;
- **chest pushes**: walking at ``--push-speed``, ``--push`` N for 0.2 s on the chest at
  ``--phases`` phases of a stride after a 4 s warm-up, towards each of the four directions
  (heading frame), then ``--after`` s; a fall, or no walk afterwards, counts against it
  (:func:`~mjchar.controllers.core.scenarios.terrain.push_walk`).

The runs go to ``--jobs`` worker processes (default: every core). Printed: the calibrations
(per body and walker: the defaults' check, the outcome, its cost and what it changed:
:func:`calibration_table`), then per body and walker the falls (of the runs) and the mean
steady speeds (:func:`table`); ``--json`` writes every run.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
from pathlib import Path

from mjchar.bench.config import SHARED_BVH
from mjchar.controllers.core.scenarios.shared import DIRECTIONS
from mjchar.controllers.core.workers import process_pool

from .report import markdown_table, write_json

SHARED_REAL = SHARED_BVH.parent / "real"
WALKERS = ("simbicon", "ipm")
#: the bar's runs per body (issue's must-show, as a user runs them with the calibrations):
#: static balance 30 s, SIMBICON 60 s at its own speed, IPM 60 s at 1.0 m/s
BAR = ("static_balance", "simbicon", "ipm")


def walk_run(job: tuple) -> dict:
    """One walk: ``(body, xml, walker, speed, seed, duration, window)``."""
    from mjchar.controllers import run

    body, xml, walker, speed, seed, duration, window = job
    r = run(walker, "walk", model=xml, duration=duration, speed=speed, seed=seed,
            steady_window=window)
    return {"kind": "walk", "body": body, "walker": walker, "speed": speed, "seed": seed,
            "fell": bool(r.fell), "fall_time_s": r.fall_time_s,
            "steady_speed_mps": r.extra.get("steady_speed_mps"),
            "root_force_max_N": r.root_force_max_N}


def push_run(job: tuple) -> dict:
    """One chest push while walking: ``(body, xml, walker, speed, force, phase, direction,
    after)``."""
    from mjchar.controllers.core.builder import RunSpec
    from mjchar.controllers.core.character import Character
    from mjchar.controllers.core.scenarios.terrain import push_walk

    body, xml, walker, speed, force, phase, direction, after = job
    spec = RunSpec(walker, "walk", model=xml, options={"speed": speed})
    ch = Character(xml)
    r = push_walk(ch, spec.make_controller(ch), force=force, direction=DIRECTIONS[direction],
                  phase=phase, push_duration=0.2, warmup=4.0, after=after, seed=0)
    return {"kind": "push", "body": body, "walker": walker, "speed": speed, "force_N": force,
            "phase": phase, "direction": direction, "fell": bool(r.fell),
            "walking_after": bool(r.extra["walking_after"]),
            "root_force_max_N": r.root_force_max_N}


def calibrate_first(bodies: list[tuple[str, str, str]]) -> list[tuple[str, object]]:
    """Make each ``(body, xml, walker)``'s calibration once, here, before the runs (a run's
    worker would otherwise calibrate a body the other workers are calibrating too, and on one
    core: a pool's workers have no children); returns ``(body, Calibration)`` of those made or
    found in the cache (not of the bundled humanoid, nor with ``MJCHAR_CALIBRATION`` set)."""
    from mjchar.controllers.core.character import Character
    from mjchar.controllers.walking import calibration as cal_mod

    out = []
    for body, xml, walker in bodies:
        ch = Character(xml)
        cal_mod.overrides_for(ch, walker, announce=lambda line, b=body: print(
            f"{b}: {line}", file=sys.stderr))
        path = cal_mod.cache_path(ch.model, walker)
        if path.exists() and not os.environ.get("MJCHAR_CALIBRATION"):
            out.append((body, cal_mod.load(path)))
    return out


def changes(cal, least: float = 0.1) -> str:
    """What a calibration changed: each knob moved from its default by at least ``least`` of
    its search step (a scaled gain pair as a factor), ``-`` for none."""
    from mjchar.controllers.walking.calibration import KNOBS, _gain_pairs

    out, pairs = [], _gain_pairs(cal.walker)
    for knob in KNOBS[cal.walker]:
        if knob.name.endswith("*"):
            name, d = pairs[knob.name[:-1]][0]
            if name not in cal.overrides:
                continue
            v = cal.overrides[name]
            factor = (v[0] / d[0]) if isinstance(v, list) else v / d
            if abs(math.log(factor)) >= least * knob.step:
                out.append(f"{knob.name[:-1]} gains x{factor:.2f}")
        elif knob.name in cal.overrides:
            v, d = cal.overrides[knob.name], knob.default
            moved = abs(math.log(v / d)) if knob.how == "scale" else abs(v - d)
            if moved >= least * knob.step:
                out.append(f"{knob.name} {d:g} -> {v:.3g}")
    return "; ".join(out) or "-"


def _walks(rows: list[dict]) -> str:
    """Per speed, the steady speed or the fall; the walks from rest (``seed`` ``None``, in the
    long walks of calibrations made since protocol 3) after the seeded ones."""
    def one(r):
        rest_own = r["speed"] is None and r.get("seed", 0) is None  # no steady speed measured
        return (f"{'own' if r['speed'] is None else format(r['speed'], 'g')}: "
                + (f"fell {r['fall_time_s']:.1f} s" if r["fell"] else "held"
                   if rest_own or r["steady_speed_mps"] is None
                   else f"{r['steady_speed_mps']:.2f}"))
    seeded = [one(r) for r in rows if r.get("seed", 0) is not None]
    rest = [one(r) for r in rows if r.get("seed", 0) is None]
    return ", ".join(seeded) + (f"; from rest: {', '.join(rest)}" if rest else "")


def _long_walks(cal) -> str:
    """The stored candidate's long walks and how many were ruled out by theirs."""
    held = _walks(cal.confirmed) if cal.confirmed else "-"
    return held + (f" ({len(cal.rejected)} ruled out)" if cal.rejected else "")


def calibration_table(cals: list[tuple[str, object]]) -> str:
    """Markdown: per ``(body, Calibration)``, the defaults' check walks (per commanded speed:
    the steady speed in m/s, or the fall), the outcome, the candidates and CPU seconds it took,
    the calibrated walks, the long walks that confirmed it and what it changed."""
    head = ["body", "walker", "defaults' check", "outcome", "candidates", "CPU s",
            "calibrated walks", "long walks", "changed"]
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for body, cal in cals:
        outcome = {"defaults": "defaults pass", "unimproved": "unimproved (defaults kept)",
                   "optimised": f"optimised (cost {cal.cost_defaults:.2f} -> {cal.cost:.2f})"
                   }[cal.status]
        out.append(f"| {body} | {cal.walker} | {_walks(cal.check)} | {outcome} | "
                   f"{cal.evaluations} | {cal.cpu_seconds:.0f} | "
                   f"{_walks(cal.calibrated) if cal.calibrated else '-'} | "
                   f"{_long_walks(cal)} | {changes(cal)} |")
    return "\n".join(out)


def bar_run(job: tuple) -> dict:
    """One of the bar's runs on a body: ``(body, xml, what)``, ``what`` one of :data:`BAR`."""
    from mjchar.controllers import run

    body, xml, what = job
    if what == "static_balance":
        r = run("static_balance", model=xml, duration=30.0)
    elif what == "simbicon":
        r = run("simbicon", "walk", model=xml, duration=60.0)
    else:
        r = run("ipm", "walk", model=xml, duration=60.0, speed=1.0, steady_window=10.0)
    return {"kind": "bar", "body": body, "run": what, "fell": bool(r.fell),
            "fall_time_s": r.fall_time_s, "sim_time_s": r.sim_time_s, "distance_m": r.distance_m,
            "steady_speed_mps": r.extra.get("steady_speed_mps"),
            "root_force_max_N": r.root_force_max_N}


def bar_table(rows: list[dict]) -> str:
    """Markdown: per body, the bar's runs (:data:`BAR`): the time stood or walked (the fall's
    time), the distance of SIMBICON's walk, IPM's steady speed over the last 10 s."""
    out = []
    for body in dict.fromkeys(r["body"] for r in rows if r["kind"] == "bar"):
        cells = []
        for what in BAR:
            r = next((r for r in rows if r["kind"] == "bar" and r["body"] == body
                      and r["run"] == what), None)
            if r is None:
                cells.append("-")
            elif r["fell"]:
                cells.append(f"fell {r['fall_time_s']:.1f} s")
            elif what == "simbicon":
                cells.append(f"{r['sim_time_s']:.0f} s, {r['distance_m']:.0f} m")
            elif what == "ipm":
                cells.append(f"{r['sim_time_s']:.0f} s, {r['steady_speed_mps']:.2f} m/s")
            else:
                cells.append(f"{r['sim_time_s']:.0f} s")
        out.append((body, *cells))
    return markdown_table(("body", "static balance 30 s", "SIMBICON 60 s", "IPM 60 s at 1.0 m/s"),
                          out)


def _run(job: tuple) -> dict:
    kind, rest = job[0], job[1:]
    return walk_run(rest) if kind == "walk" else push_run(rest) if kind == "push" else (
        bar_run(rest))


def table(rows: list[dict], speeds: list[float]) -> str:
    """Markdown: per body and walker, falls per speed (of the seeds) with the mean steady speed,
    and the chest pushes not survived (of the pushes)."""
    head = ["body", "walker"] + [f"{v:g} m/s" for v in speeds] + ["chest pushes failed"]
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    keys = dict.fromkeys((r["body"], r["walker"]) for r in rows)
    for body, walker in keys:
        mine = [r for r in rows if r["body"] == body and r["walker"] == walker]
        cells = []
        for v in speeds:
            w = [r for r in mine if r["kind"] == "walk" and r["speed"] == v]
            up = [r["steady_speed_mps"] for r in w if not r["fell"] and r["steady_speed_mps"]]
            mean = f", {sum(up) / len(up):.2f}" if up else ""
            cells.append(f"{sum(r['fell'] for r in w)}/{len(w)} fell{mean}")
        p = [r for r in mine if r["kind"] == "push"]
        bad = sum(r["fell"] or not r["walking_after"] for r in p)
        cells.append(f"{bad}/{len(p)}")
        out.append(f"| {body} | {walker} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m mjchar.perf.envelopes", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("files", nargs="*", metavar="FILE.bvh",
                   help="captures (default: every file of ../shared/data/real)")
    p.add_argument("--walkers", nargs="+", choices=WALKERS, default=list(WALKERS))
    p.add_argument("--speeds", nargs="+", type=float, default=[0.8, 1.0, 1.2])
    p.add_argument("--seeds", type=int, default=5)
    p.add_argument("--duration", type=float, default=20.0)
    p.add_argument("--steady-window", type=float, default=8.0)
    p.add_argument("--push", type=float, default=100.0, metavar="N")
    p.add_argument("--push-speed", type=float, default=1.0)
    p.add_argument("--phases", type=int, default=4)
    p.add_argument("--after", type=float, default=5.0)
    p.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    p.add_argument("--what", nargs="+", choices=("bar", "envelopes"),
                   default=["bar", "envelopes"],
                   help="the bar's runs (static balance 30 s, SIMBICON 60 s, IPM 60 s at 1.0 m/s)"
                        " and/or the envelopes (default both)")
    p.add_argument("--json", metavar="OUT.json", help="also write every run as JSON")
    args = p.parse_args(argv)
    files = [Path(f) for f in args.files] or sorted(SHARED_REAL.glob("*.bvh"))
    if not files:
        p.error(f"no files given and none in {SHARED_REAL}")
    from mjchar import bvh
    from mjchar.bvh.mjcf import convert

    with tempfile.TemporaryDirectory() as tmp:
        jobs, walked = [], set()  # walked: (body, xml, walker) to calibrate first
        for f in files:
            xml = str(Path(tmp) / f"{f.stem}.xml")
            convert(bvh.load(f)).save(xml)
            if "bar" in args.what:
                jobs += [("bar", f.stem, xml, what) for what in BAR]
                walked |= {(f.stem, xml, w) for w in WALKERS}
            if "envelopes" in args.what:
                walked |= {(f.stem, xml, w) for w in args.walkers}
                for w in args.walkers:
                    jobs += [("walk", f.stem, xml, w, v, s, args.duration, args.steady_window)
                             for v in args.speeds for s in range(args.seeds)]
                    jobs += [("push", f.stem, xml, w, args.push_speed, args.push,
                              k / args.phases, d, args.after)
                             for k in range(args.phases) for d in DIRECTIONS]
        cals = calibrate_first(sorted(walked))
        rows = []
        with process_pool(args.jobs) as pool:
            for r in pool.map(_run, jobs):
                rows.append(r)
                what = (f"{r['walker']} {r['speed']:g} m/s seed {r['seed']}"
                        if r["kind"] == "walk" else
                        f"{r['walker']} push {r['direction']} at phase {r['phase']:g}"
                        if r["kind"] == "push" else r["run"])
                print(f"{r['body']} {what}: "
                      f"{'fell' if r['fell'] else 'up'}", file=sys.stderr, flush=True)
    if cals:
        print("Calibrations (in the cache, made first where missing):\n")
        print(calibration_table(cals) + "\n")
    if "bar" in args.what:
        print(bar_table(rows) + "\n")
    if "envelopes" in args.what:
        print(table([r for r in rows if r["kind"] != "bar"], args.speeds))
    if any(r["root_force_max_N"] for r in rows):
        print("root force in some run: see --json")
    if args.json:
        write_json(args.json, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
