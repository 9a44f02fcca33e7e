"""The skeletons section of ``mjchar bench --skeletons``: the controllers on every rig of the zoo.

The rigs are :func:`mjchar.bvh.bundled.zoo.zoo_rigs`: the shared walks (``../shared/data/bvh``,
skipped when absent) re-expressed on real-world naming conventions, units, up axes and rest poses,
and the bundled humanoid's walk on its skeleton scaled to 1.5 m / 50 kg and 1.95 m / 100 kg. Each
rig is written as ``skeletons/NAME.bvh``, converted at the default (hinge) joint model with its mass
to ``skeletons/NAME.xml`` (so every figure can be reproduced with ``mjchar run ... --model``), and
measured:

- conversion: the ``full`` model's replay error (worst joint), the hinge model's worst end
  effector and worst joint, the mass;
- ``stand``: static balance holds the standing pose for ``stand_duration`` s;
- ``push``: static balance under ``push_force`` N x ``push_duration`` s on the pelvis, 1 s in,
  in the 4 directions (survived out of 4);
- ``simbicon``: SIMBICON walks ``walk_duration`` s at each commanded speed of
  ``simbicon_speeds`` and each seed, steady speed (over the last ``steady_window`` s) within
  ``speed_tolerance`` of the command;
- ``ipm``: IPM stepping walks ``walk_duration`` s at ``ipm_speed`` (steady speed);
- ``hand_of_god``: tracks the rig's own clip (mean joint error; the root force is the point of
  this controller);
- ``samcon``: SAMCON at its defaults reconstructs the first ``samcon_duration`` s of the rig's
  clip (the whole clip when it is shorter); the saved trajectory is replayed (no fall, mean
  joint error).

A check passes when nothing fell (and, where the issue sets a bar, the bar holds: IPM within
``speed_tolerance`` of the command, trackers below ``track_error`` / ``samcon_error``).
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

from .config import SHARED_BVH, BenchError, json_ready

#: the checks in the order of the table's columns
CHECKS = ("stand", "push", "simbicon", "ipm", "hand_of_god", "samcon")
#: degrees (heading frame) of the four pushes
PUSH_DIRECTIONS = (0.0, 90.0, 180.0, 270.0)


@dataclass(frozen=True)
class SkeletonConfig:
    """Durations and bars of the skeletons section (SI units)."""

    stand_duration: float = 30.0
    push_force: float = 50.0
    push_duration: float = 0.2
    walk_duration: float = 60.0
    steady_window: float = 10.0
    seeds: tuple[int, ...] = (0, 1, 2)
    simbicon_speeds: tuple[float, ...] = (0.7, 1.1, 1.5)  # empty: the gait's own speed
    ipm_speed: float = 1.0
    speed_tolerance: float = 0.15
    track_error: float = 0.03
    samcon_duration: float = 2.0
    samcon_samples: int | None = None  # None: SAMCON's defaults
    samcon_saved: int | None = None
    samcon_error: float = 0.05
    checks: tuple[str, ...] = CHECKS
    rigs: tuple[str, ...] | None = None  # zoo rig names; None: every rig

    @classmethod
    def quick(cls) -> SkeletonConfig:
        """Minutes instead of an hour: 5 s stands, 10 s walks at one seed (SIMBICON at 1.1 m/s),
        a 0.5 s SAMCON with 200 samples (the bars of the full run are not claimed)."""
        return cls(stand_duration=5.0, walk_duration=10.0, steady_window=4.0, seeds=(0,),
                   simbicon_speeds=(1.1,), samcon_duration=0.5, samcon_samples=200,
                   samcon_saved=50)

    def to_dict(self) -> dict:
        return json_ready(asdict(self))


def run_skeletons(config: SkeletonConfig, *, shared_bvh: Path | None = SHARED_BVH,
                  out_dir: Path | None = None,
                  progress: Callable[[str], None] | None = None) -> dict:
    """``config.checks`` on ``config.rigs`` of the zoo (the clip rigs need ``shared_bvh``);
    returns the section (``rigs``: one record per rig)."""
    from mjchar.bvh.bundled.zoo import zoo_rigs

    checks = tuple(config.checks)
    bad = [c for c in checks if c not in CHECKS]
    if bad or not checks:
        raise BenchError(f"unknown skeleton check(s) {', '.join(bad) or '(none given)'}; "
                         "choose from " + ", ".join(CHECKS))
    shared = shared_bvh if shared_bvh is not None and Path(shared_bvh).is_dir() else None
    rigs = zoo_rigs(shared)
    if config.rigs is not None:
        known = [r.name for r in rigs]
        missing = [n for n in config.rigs if n not in known]
        if missing:
            raise BenchError(f"unknown zoo rig(s) {', '.join(missing)}; the zoo has "
                             + ", ".join(known))
        rigs = [r for r in rigs if r.name in config.rigs]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(out_dir) / "skeletons" if out_dir is not None else Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        records = []
        for rig in rigs:
            t0 = time.perf_counter()
            rec = _convert(rig, folder)
            for check in checks:
                rec["checks"][check] = _CHECKS[check](rig, rec, config)
                if progress:
                    progress(f"  {rig.name} / {check}: {rec['checks'][check]['summary']}")
            rec["wall_s"] = time.perf_counter() - t0
            records.append(rec)
    return {"config": config.to_dict(), "checks": list(checks), "rigs": records,
            "shared_clips": shared is not None}


# -- conversion -----------------------------------------------------------------------------------
def _convert(rig, folder: Path) -> dict:
    from mjchar import bvh
    from mjchar.bvh.mjcf import convert
    from mjchar.bvh.reference.reference_motion import replay_errors

    motion = bvh.loads(bvh.dumps(rig.motion))  # as the file reads back
    bvh_path = folder / f"{rig.name}.bvh"
    bvh.save(rig.motion, bvh_path)
    full = convert(motion, joint_model="full", total_mass=rig.mass_kg)
    e_full = replay_errors(full, motion)
    hinge = convert(motion, total_mass=rig.mass_kg)
    e = replay_errors(hinge, motion)
    xml = folder / f"{rig.name}.xml"
    hinge.save(xml)
    model = hinge.compile()
    return {
        "rig": rig.name, "convention": rig.convention, "unit": rig.unit, "up": rig.up,
        "height_m": rig.height_m, "mass_kg": rig.mass_kg, "source": rig.source,
        "features": list(rig.features), "bvh": bvh_path.name, "model": xml.name,
        "_paths": (str(bvh_path), str(xml)),
        "conversion": {
            "full_worst_joint_mm": e_full["max_mm"],
            "hinge_worst_end_effector_mm": e["end_effector_max_mm"],
            "hinge_worst_joint_mm": e["max_mm"],
            "model_mass_kg": float(model.body_mass.sum()),
            "unit_guessed": hinge.info.unit_scale, "up_guessed": hinge.info.up_axis,
        },
        "checks": {},
    }


def _spec(rec: dict, controller: str, scenario: str, **kw):
    """The run of ``controller`` on the rig's model, as ``mjchar run CONTROLLER SCENARIO
    --model RIG.xml`` builds it (``kw``: further :class:`RunSpec` fields)."""
    from mjchar.controllers.core.builder import RunSpec

    return RunSpec(controller, scenario, model=rec["_paths"][1], **kw)


def _run(result) -> dict:
    d = result.to_dict()
    return {k: d.get(k) for k in ("fell", "fall_time_s", "sim_time_s", "distance_m",
                                  "mean_speed_mps", "tracking_error_m", "root_force_mean_N")} | {
        "steady_speed_mps": d.get("extra", {}).get("steady_speed_mps")}


# -- the checks -----------------------------------------------------------------------------------
def _stand(rig, rec, cfg: SkeletonConfig) -> dict:
    r = _run(_spec(rec, "static_balance", "stand",
                   scenario_options={"duration": cfg.stand_duration}).execute())
    ok = not r["fell"]
    return {"ok": ok, "run": r,
            "summary": ("stands " if ok else f"falls at {r['fall_time_s']:.1f} s of ")
                       + f"{cfg.stand_duration:g} s, moved {r['distance_m']:.3f} m"}


def _push(rig, rec, cfg: SkeletonConfig) -> dict:
    runs = {}
    for d in PUSH_DIRECTIONS:
        runs[f"{d:g}"] = _run(_spec(rec, "static_balance", "push", scenario_options={
            "force": cfg.push_force, "direction": d,
            "push_duration": cfg.push_duration}).execute())
    n = sum(not r["fell"] for r in runs.values())
    return {"ok": n == len(runs), "runs": runs,
            "summary": f"{n}/{len(runs)} survive {cfg.push_force:g} N x {cfg.push_duration:g} s"}


def _walker(name: str, speeds: Callable[[SkeletonConfig], tuple[float, ...]]) -> Callable:
    """A walking check: ``name`` walks at every commanded speed of ``speeds(cfg)`` (none: its
    own speed) and every seed; it passes with no fall and, under a command, every steady speed
    within the tolerance of it. ``runs`` keys: the seed, or ``"SPEED/SEED"`` under commands."""

    def check(rig, rec, cfg: SkeletonConfig) -> dict:
        runs, falls, off = {}, [], []
        for v in speeds(cfg) or (None,):
            for s in cfg.seeds:
                r = _run(_spec(rec, name, "walk", seed=int(s),
                               options={} if v is None else {"speed": v},
                               scenario_options={"duration": cfg.walk_duration,
                                                 "steady_window": cfg.steady_window}).execute())
                key = str(s) if v is None else f"{v:g}/{s}"
                runs[key] = r
                where = f"seed {s}" if v is None else f"{v:g} m/s seed {s}"
                if r["fell"]:
                    falls.append(f"{where} fell at {r['fall_time_s']:.1f} s")
                elif v is not None and abs(r["steady_speed_mps"] - v) > cfg.speed_tolerance:
                    off.append(f"{where} at {r['steady_speed_mps']:.2f} m/s")
        walked = [r["steady_speed_mps"] for r in runs.values() if not r["fell"]]
        goals = speeds(cfg)
        text = (f"{len(walked)}/{len(runs)} walk {cfg.walk_duration:g} s"
                + (f" at {', '.join(f'{v:g}' for v in goals)} m/s" if goals else "")
                + (f", steady {min(walked):.2f}-{max(walked):.2f} m/s" if walked else "")
                + "".join(f", {x}" for x in falls + off))
        return {"ok": not falls and not off, "runs": runs, "summary": text}

    return check


def _hand_of_god(rig, rec, cfg: SkeletonConfig) -> dict:
    from mjchar import bvh
    from mjchar.bvh.reference.reference_motion import ReferenceMotion
    from mjchar.controllers import registry
    from mjchar.controllers.core.character import Character

    # the rig's clip as it is (no conditioning: the converter's replay is what is measured)
    ch = Character(rec["_paths"][1])
    ref = ReferenceMotion(ch.model, bvh.load(rec["_paths"][0]), info=ch.info,
                          floor=registry.get("hand_of_god").floor)
    r = _run(_spec(rec, "hand_of_god", "track", motion=ref).execute())
    ok = not r["fell"] and r["tracking_error_m"] < cfg.track_error
    return {"ok": ok, "run": r,
            "summary": f"{r['tracking_error_m'] * 100:.1f} cm over {r['sim_time_s']:.1f} s"
                       + (", fell" if r["fell"] else "")}


def _samcon(rig, rec, cfg: SkeletonConfig) -> dict:
    from mjchar import bvh
    from mjchar.bvh.reference.reference_motion import ReferenceMotion
    from mjchar.controllers.sampling.samcon import RECONSTRUCTION_OPTIONS, Samcon, SamconOptions

    bvh_path, xml = rec["_paths"]
    from mjchar.controllers.core.character import Character

    ch = Character(xml)
    ref = ReferenceMotion(ch.model, bvh.load(bvh_path), info=ch.info)
    opts = dict(RECONSTRUCTION_OPTIONS, duration=min(cfg.samcon_duration, ref.duration))
    if cfg.samcon_samples is not None:
        opts["samples"] = cfg.samcon_samples
    if cfg.samcon_saved is not None:
        opts["saved"] = cfg.samcon_saved
    t0 = time.perf_counter()
    with Samcon(ref, model=xml, options=SamconOptions(**opts), source_motion=bvh_path) as s:
        result = s.run(progress=False)
    r = _run(_spec(rec, "replay", "track",
                   options={"trajectory": result.trajectory}).execute())
    ok = not r["fell"] and r["tracking_error_m"] < cfg.samcon_error
    return {"ok": ok, "run": r, "wall_s": time.perf_counter() - t0,
            "summary": f"{r['tracking_error_m'] * 100:.1f} cm over {r['sim_time_s']:.1f} s"
                       + (", fell" if r["fell"] else "")}


_CHECKS: dict[str, Callable] = {
    "stand": _stand,
    "push": _push,
    "simbicon": _walker("simbicon", lambda cfg: tuple(cfg.simbicon_speeds)),
    "ipm": _walker("ipm", lambda cfg: (cfg.ipm_speed,)),
    "hand_of_god": _hand_of_god,
    "samcon": _samcon,
}


# -- report ---------------------------------------------------------------------------------------
def public(section: dict) -> dict:
    """The section without the private paths (what goes into ``results.json``)."""
    out = dict(section)
    out["rigs"] = [{k: v for k, v in r.items() if not k.startswith("_")} for r in section["rigs"]]
    return out


def skeletons_markdown(section: dict | None) -> str:
    """The rig x check table (markdown), empty without a section."""
    if not section or not section.get("rigs"):
        return ""
    checks = section["checks"]
    head = ["rig", "convention / unit / up", "height, mass", "full / hinge ends / joints mm",
            *checks]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in section["rigs"]:
        cv = r["conversion"]
        cells = [r["rig"], f"{r['convention']} / {r['unit']} / {r['up']}",
                 f"{r['height_m']:.2f} m, {r['mass_kg']:g} kg",
                 f"{cv['full_worst_joint_mm']:.3f} / {cv['hinge_worst_end_effector_mm']:.2f} / "
                 f"{cv['hinge_worst_joint_mm']:.1f}"]
        for c in checks:
            x = r["checks"].get(c)
            cells.append("-" if x is None else ("ok: " if x["ok"] else "**FAIL**: ")
                         + x["summary"])
        lines.append("| " + " | ".join(cells) + " |")
    cfg = section["config"]
    return ("Skeletons (`mjchar bench --skeletons`; rigs from mjchar.bvh.bundled.zoo, models in "
            "skeletons/; "
            f"stand {cfg['stand_duration']:g} s, pushes {cfg['push_force']:g} N x "
            f"{cfg['push_duration']:g} s in 4 directions, walks {cfg['walk_duration']:g} s at "
            f"seeds {', '.join(map(str, cfg['seeds']))}, SIMBICON at "
            f"{', '.join(f'{v:g}' for v in cfg.get('simbicon_speeds') or ()) or 'its own speed'}"
            f" m/s, IPM at {cfg['ipm_speed']:g} m/s "
            f"(+-{cfg['speed_tolerance']:g}), SAMCON first {cfg['samcon_duration']:g} s; "
            "docs/bench.md):\n\n" + "\n".join(lines))
