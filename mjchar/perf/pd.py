"""The PD family: stability envelope and per-step cost (the tables of docs/controllers.md).

    python -m mjchar.perf.pd                  # both tables, printed
    python -m mjchar.perf.pd --only cost      # or: --only envelope
    python -m mjchar.perf.pd --limits --write # also with torque limits; update docs/controllers.md

1. **Stability envelope** (:func:`stability_envelope`). For kp in {300, 1000, 3000} (kd = kp/10,
   uniform on every actuated dof) and each PD variant (explicit ``pd``, stable ``spd``,
   ``native_pd``): the largest time step at which
   :func:`mjchar.controllers.core.scenarios.hold_pose` holds the bundled humanoid's standing
   pose with the root welded (0.2 rad random initial error, 5 s), scanning 1/2000 s .. 1/30 s; a
   variant that fails at 1/2000 s is scanned further down (to 1/8000 s). "Largest" means every
   step of the grid up to it holds. Torque limits are lifted (the default) so that the table is
   about integrating the PD law; ``--limits`` also measures with the model's torque limits.
2. **Per-step cost** (:func:`cost_cases` with :func:`mjchar.perf.physics.step_cost`). Each
   controller's cost per physics step (``act`` + ``Character.step``) over a bare ``mj_step``
   loop on a pristine copy of the same model, interleaved in the same run (median of repeats),
   standing; one more row tracks the bundled walk (its bare loop holds the clip's first pose).
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Sequence

from mjchar.controllers.core.character import Character

from .errors import PerfError, positive_int
from .physics import step_cost
from .report import DOCS, entry_parser, machine_line, markdown_table, write_block
from .timing import timed

__all__ = ["ENVELOPE_KPS", "ENVELOPE_VARIANTS", "ENVELOPE_GRID", "ENVELOPE_FINER",
           "stability_envelope", "cost_cases", "controller_costs", "envelope_table",
           "cost_table", "main"]

#: the gains (kp, N m/rad; kd = kp/10), PD variants and time steps (as 1/dt, Hz) of the envelope
ENVELOPE_KPS = (300.0, 1000.0, 3000.0)
ENVELOPE_VARIANTS = ("pd", "spd", "native_pd")
ENVELOPE_GRID = (2000, 1500, 1000, 750, 500, 360, 240, 180, 120, 90, 60, 45, 30)
#: smaller steps scanned only for a variant that fails at the grid's smallest step
ENVELOPE_FINER = (8000, 6000, 4000, 3000, 2500)
#: physics steps per timing block of the cost measurement
BLOCK = 100


def stability_envelope(*, kps: Sequence[float] = ENVELOPE_KPS,
                       variants: Sequence[str] = ENVELOPE_VARIANTS,
                       grid: Sequence[int] = ENVELOPE_GRID,
                       finer: Sequence[int] = ENVELOPE_FINER, duration: float = 5.0,
                       torque_limits: bool = False, model=None,
                       progress: Callable[[str], None] | None = None) -> dict:
    """Largest time step at which each PD variant holds the standing pose, per gain.

    For each ``kp`` (kd = kp/10, uniform) and variant,
    :func:`mjchar.controllers.core.scenarios.hold_pose` (root welded, 0.2 rad seeded initial
    errors, ``duration`` s) at every step ``1/hz`` of ``grid``; a variant that does not hold at
    the grid's smallest step is scanned further down ``finer``. "Largest held" = the largest
    step such that it and every smaller step scanned held.

    Returns:
        ``{"duration_s", "torque_limits", "kps", "variants", "rows": [{"variant", "kp",
        "largest_held_hz" (None if none), "status": {hz: "held" | "oscillates" |
        "diverged"}}]}`` (status keys are strings of the step rate in Hz).
    """
    from mjchar.controllers.core.scenarios import hold_pose

    if not (math.isfinite(duration) and duration > 1.0):
        raise PerfError(f"envelope duration must be more than 1 s (the last second is judged), "
                        f"got {duration}")
    grid = sorted({positive_int(h, "grid rate") for h in grid}, reverse=True)
    ch = Character(model)
    rows = []
    for kp in kps:
        for v in variants:
            status: dict[int, str] = {}

            def run(hz: int, v=v, kp=kp, status=status) -> None:
                r = hold_pose(ch, v, kp=float(kp), timestep=1.0 / hz, duration=duration,
                              torque_limits=torque_limits)
                status[hz] = "held" if r.held else ("diverged" if r.diverged else "oscillates")

            for hz in grid:
                run(hz)
            if status[grid[0]] != "held":
                for hz in sorted(finer):
                    if hz > grid[0]:
                        run(hz)
            best = None
            for hz in sorted(status, reverse=True):  # small steps first
                if status[hz] != "held":
                    break
                best = hz
            rows.append({"variant": v, "kp": float(kp), "largest_held_hz": best,
                         "status": {str(hz): status[hz] for hz in sorted(status, reverse=True)}})
            if progress is not None:
                progress(f"envelope kp {kp:g} {v}: largest held step "
                         + (f"1/{best} s" if best else "none"))
    return {"duration_s": float(duration), "torque_limits": bool(torque_limits),
            "kps": [float(k) for k in kps], "variants": list(variants), "rows": rows}


def envelope_table(env: dict, title: str) -> str:
    """Markdown tables of a :func:`stability_envelope` result: the largest step per variant and
    gain, then every scanned step's outcome."""
    kps = env["kps"]
    rows = {(r["variant"], r["kp"]): r for r in env["rows"]}
    lines = [f"**{title}** (largest time step that holds; every smaller step of the grid holds "
             f"too)", "", "| variant | " + " | ".join(f"kp {kp:g}" for kp in kps) + " |",
             "|---|" + "---|" * len(kps)]
    for v in env["variants"]:
        cells = []
        for kp in kps:
            r = rows[(v, kp)]
            best, status = r["largest_held_hz"], {int(h): s for h, s in r["status"].items()}
            cell = f"1/{best} s" if best else "< 1/8000 s"
            bigger = sorted((hz for hz, s in status.items() if best and hz < best and s == "held"),
                            reverse=True)
            if bigger:  # isolated larger steps that hold beyond the first failure
                cell += " (also holds at " + ", ".join(f"1/{h}" for h in bigger) + " s)"
            cells.append(cell)
        lines.append(f"| {v} | " + " | ".join(cells) + " |")
    lines += ["", "Per step (H held, o oscillates: no divergence but the RMS joint velocity over "
              "the last second stays above 0.5 rad/s or the RMS error above 0.05 rad, "
              "D diverged):", ""]
    hzs = sorted({int(h) for r in env["rows"] for h in r["status"]}, reverse=True)
    lines.append("| variant, kp | " + " | ".join(f"1/{hz}" for hz in hzs) + " |")
    lines.append("|---|" + "---|" * len(hzs))
    mark = {"held": "H", "oscillates": "o", "diverged": "D"}
    for kp in kps:
        for v in env["variants"]:
            st = rows[(v, kp)]["status"]
            lines.append(f"| {v}, {kp:g} | " + " | ".join(mark[st[str(hz)]] if str(hz) in st
                                                           else "" for hz in hzs) + " |")
    return "\n".join(lines)


def cost_cases() -> dict[str, Callable[[], dict]]:
    """``{row label: setup}`` of the per-step cost table; ``setup()`` returns the keyword
    arguments of :func:`~mjchar.perf.physics.step_cost` on a fresh character (``character``,
    ``make_controller``, ``qpos``, ``qvel``, ``control_dt``)."""
    from mjchar import bvh
    from mjchar.bvh.bundled.assets import motion_path
    from mjchar.bvh.reference.reference_motion import ReferenceMotion
    from mjchar.controllers.core.registry import make_controller
    from mjchar.controllers.core.scenarios import standing_pose

    def standing(name: str, control_dt: float | None = None) -> Callable[[], dict]:
        def setup() -> dict:
            ch = Character()
            pose = standing_pose(ch)
            return {"character": ch, "make_controller": lambda: make_controller(name, ch, pose),
                    "qpos": pose, "qvel": None, "control_dt": control_dt}
        return setup

    def tracking() -> dict:
        ch = Character()
        ref = ReferenceMotion(ch.model, bvh.load(motion_path("walk")))
        return {"character": ch, "make_controller": lambda: make_controller("spd", ch, ref),
                "qpos": ref.qpos(0.0), "qvel": ref.qvel(0.0), "control_dt": None}

    return {"native_pd": standing("native_pd"),
            "native_pd, control every 1/60 s": standing("native_pd", 1 / 60),
            "pd": standing("pd"), "spd": standing("spd"),
            "hand_of_god (spd)": standing("hand_of_god"),
            "spd tracking the bundled walk": tracking,
            "static_balance": standing("static_balance")}


def controller_costs(steps: int = 2000, repeats: int = 7,
                     log: Callable[[str], None] = lambda msg: None) -> dict:
    """``{row label: StepCost.to_dict()}`` for every row of :func:`cost_cases`."""
    out = {}
    for name, setup in cost_cases().items():
        c = step_cost(**setup(), steps=steps, repeats=repeats, block=BLOCK)
        out[name] = c.to_dict()
        log(f"  {name}: {c.ratio:.2f} x mj_step ({c.controller_us:.1f} vs {c.raw_us:.1f} us)")
    return out


def cost_table(costs: dict, steps: int, repeats: int) -> str:
    """Markdown table of :func:`controller_costs`."""
    dt = next(iter(costs.values()))["timestep_s"]
    intro = (f"Time step {dt * 1000:g} ms, {steps} steps per measurement in blocks of {BLOCK} "
             f"alternating with a bare `mj_step` loop on a pristine copy of the same model "
             f"(process CPU time), median of {repeats} repeats; {machine_line()}.")
    rows = [(name, f"{c['ratio']:.2f}", f"{c['controller_us']:.1f}", f"{c['raw_us']:.1f}")
            for name, c in costs.items()]
    header = ("controller", "cost / mj_step", "us per step", "mj_step us")
    return f"{intro}\n\n{markdown_table(header, rows)}"


def main(argv: list[str] | None = None) -> int:
    p = entry_parser("pd", __doc__)
    p.add_argument("--only", choices=("envelope", "cost"))
    p.add_argument("--limits", action="store_true",
                   help="also measure the envelope with the model's torque limits")
    p.add_argument("--steps", type=int, default=2000, help="steps per cost measurement")
    p.add_argument("--repeats", type=int, default=7, help="cost repeats (median)")
    p.add_argument("--write", action="store_true", help="update docs/controllers.md")
    args = p.parse_args(argv)

    def log(msg: str) -> None:
        print(msg, file=sys.stderr, flush=True)

    sections = {}
    if args.only in (None, "envelope"):
        log("stability envelope (torque limits lifted)")
        env, t = timed(stability_envelope, progress=log)
        body = envelope_table(env, "Torque limits lifted")
        if args.limits:
            log("stability envelope (model torque limits)")
            env2, t2 = timed(stability_envelope, torque_limits=True, progress=log)
            t = t + t2
            body += "\n\n" + envelope_table(env2, "With the model's torque limits")
        sections["pd-envelope"] = body
        log(f"  ({t.wall_s:.0f} s)")
    if args.only in (None, "cost"):
        log("per-step cost")
        costs = controller_costs(args.steps, args.repeats, log)
        sections["pd-cost"] = cost_table(costs, args.steps, args.repeats)
    for key, body in sections.items():
        print(f"\n## {key}\n\n{body}")
    if args.write:
        for key, body in sections.items():
            log(f"updated {write_block(DOCS / 'controllers.md', key, body)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
