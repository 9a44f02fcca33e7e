"""The bench's performance section: raw ``mj_step`` throughput, each controller's step cost as a
ratio over ``mj_step``, batched-rollout and env throughput, BVH parse speed and the PD stability
envelope, all measured now on this machine (the measurements are :mod:`mjchar.perf`'s; a new
figure there becomes a part here: one more key in ``parts`` and one more branch below)."""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from mjchar.controllers import registry
from mjchar.controllers.core import scenarios as S
from mjchar.controllers.core.scenarios.terrain import place_on_floor
from mjchar.perf.bvh import SHARED_CLIPS, bvh_parse_speed
from mjchar.perf.envs import env_throughput
from mjchar.perf.errors import PerfUnavailable
from mjchar.perf.pd import stability_envelope
from mjchar.perf.physics import raw_step_rate, step_cost
from mjchar.perf.rollouts import rollout_throughput
from mjchar.perf.timing import load_average, timed

from .config import SHARED_BVH, BenchConfig, BenchError, PerfConfig
from .matrix import BenchContext, availability, build_controller
from .progress import advance, progress_bar


def _start_state(ctx: BenchContext, name: str, ch, controller):
    """Start pose/velocity for the step-cost measurement (the controller's own start state when
    it has one, e.g. SIMBICON's, else the standing pose)."""
    if hasattr(controller, "start_state"):
        controller.reset(ch)
        q, v = controller.start_state(ch, None)
        return place_on_floor(ch, q), v
    return S.standing_pose(ch), None


def run_performance(controllers: Sequence[str], config: BenchConfig, *,
                    trajectories: dict[str, Path] | None = None, progress: bool = True,
                    parts: Sequence[str] = ("raw", "cost", "rollout", "envs", "bvh",
                                            "envelope")) -> dict:
    """The performance section (all measured now, on this machine's current load).

    Each part is ``{"available": bool, "reason": str | None, "wall_s": s, ...numbers}``;
    ``cost`` has one entry per available controller. See docs/bench.md.
    """
    cfg = config.perf
    trajectories = dict(trajectories or {})
    bar = progress_bar([1.0] * len(parts), progress, "performance")
    log = (lambda msg: bar.write(msg, file=sys.stderr)) if progress else (lambda msg: None)
    ctx = BenchContext(config, trajectories, None, log)
    out: dict = {"load_average": load_average()}

    def part(key: str, fn: Callable[[], dict]) -> None:
        bar.set_description(f"performance: {key}")

        def run() -> dict:
            try:
                return {"available": True, "reason": None, **fn()}
            except PerfUnavailable as e:
                return {"available": False, "reason": str(e)}
            except Exception as e:  # a broken optional part must not lose the rest of the report
                return {"available": False, "reason": f"error: {type(e).__name__}: {e}"}

        rec, t = timed(run)
        rec["wall_s"] = t.wall_s
        out[key] = rec
        advance(bar, 1.0)

    for key in parts:
        if key == "raw":
            def raw():
                ch = ctx.character()
                return raw_step_rate(ch.model, S.standing_pose(ch), steps=cfg.raw_steps,
                                     repeats=cfg.raw_repeats)
            part("raw", raw)
        elif key == "cost":
            part("cost", lambda: {"controllers": _costs(ctx, controllers, cfg, log)})
        elif key == "rollout":
            part("rollout", lambda: rollout_throughput(
                samples=cfg.rollout_samples, steps=cfg.rollout_steps,
                repeats=cfg.rollout_repeats, threads=cfg.rollout_threads))
        elif key == "envs":
            part("envs", lambda: env_throughput(steps=cfg.env_steps,
                                                repeats=cfg.env_repeats))
        elif key == "bvh":
            part("bvh", lambda: bvh_parse_speed(_bvh_files(), budget=cfg.bvh_budget_s))
        elif key == "envelope":
            part("envelope", lambda: stability_envelope(
                kps=cfg.envelope_kps, grid=cfg.envelope_grid, finer=cfg.envelope_finer,
                duration=cfg.envelope_duration_s, model=ctx.base_model, progress=log))
        else:
            raise BenchError(f"unknown performance part {key!r}")
    bar.close()
    return out


def _costs(ctx: BenchContext, controllers: Sequence[str], cfg: PerfConfig, log) -> dict:
    out = {}
    for name in controllers:
        ok, why = availability(name, ctx.trajectories)
        if not ok:
            out[name] = {"available": False, "reason": why}
            continue
        try:
            if registry.get(name).kind == "replay":
                from mjchar.controllers.sampling.trajectory import ReplayController

                tr = ctx.trajectory(name)
                ch = ctx.character(tr.timestep)
                c = step_cost(ch, lambda tr=tr: ReplayController(tr), qpos=tr.initial_qpos,
                                   qvel=tr.initial_qvel, control_dt=tr.control_dt,
                                   steps=cfg.cost_steps, repeats=cfg.cost_repeats)
            else:
                spec = registry.get(name)
                scenario = ("walk" if spec.kind == "walker" else "stand" if spec.runs("stand")
                            else spec.default_scenario)  # a learned policy: tracking its clip
                built = ctx.describe(name, scenario).build()
                if built.reference is not None:
                    q, v = built.reference.qpos(0.0), built.reference.qvel(0.0)
                else:
                    q, v = _start_state(ctx, name, built.character, built.controller)
                # fresh: the raw loop copies its model
                ch = ctx.character(float(built.character.model.opt.timestep))
                c = step_cost(ch, lambda n=name, s=scenario: build_controller(ctx, n, s)[1],
                                   qpos=q, qvel=v, steps=cfg.cost_steps,
                                   repeats=cfg.cost_repeats)
            out[name] = {"available": True, "reason": None, **c.to_dict()}
            log(f"  step cost {name}: {c.ratio:.2f} x mj_step ({c.controller_us:.0f} vs "
                f"{c.raw_us:.0f} us per step)")
        except Exception as e:
            out[name] = {"available": False, "reason": f"error: {type(e).__name__}: {e}"}
    return out


def _bvh_files() -> list[Path]:
    shared = [SHARED_BVH / n for n in SHARED_CLIPS]
    files = [p for p in shared if p.is_file()]
    if not files:
        from mjchar.bvh.bundled.assets import motion_path

        files = [motion_path("walk"), motion_path("idle")]
    return files


