"""PD-family benchmark: stability envelope and per-step cost, written into docs/controllers.md.

Usage::

    python benchmarks/bench_pd.py                 # both tables, updates docs/controllers.md
    python benchmarks/bench_pd.py --only cost     # or: --only envelope
    python benchmarks/bench_pd.py --no-write      # print only

1. **Stability envelope.** For kp in {300, 1000, 3000} (kd = kp/10, uniform on every actuated dof)
   and each PD variant (explicit ``pd``, stable ``spd``, ``native_pd``): the largest time step at
   which :func:`mjchar.controllers.core.scenarios.hold_pose` holds the bundled humanoid's standing
   pose with the root welded (0.2 rad random initial error, 5 s), scanning 1/2000 s .. 1/30 s; a
   variant that fails at 1/2000 s is scanned further down (to 1/8000 s). "Largest" means every step
   of the grid up to it holds. Torque limits are lifted (the default) so that the table is about
   integrating the PD law; ``--limits`` also measures with the model's torque limits.
2. **Per-step cost.** Each controller's cost per physics step (``act`` + ``Character.step``),
   divided by the cost of a bare ``mujoco.mj_step`` loop on the same model, measured interleaved in
   the same run (median of repeats), standing; one more row tracks the bundled walk (its bare
   loop still stands, so that row also reflects fewer contacts while walking).
"""

from __future__ import annotations

import argparse
import re
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import mujoco  # noqa: E402

from mjchar.controllers.core import scenarios as S  # noqa: E402
from mjchar.controllers.core.character import Character  # noqa: E402
from mjchar.controllers.core.registry import make_controller  # noqa: E402

DOC = ROOT / "docs" / "controllers.md"
KPS = (300.0, 1000.0, 3000.0)
VARIANTS = ("pd", "spd", "native_pd")
#: the scanned steps, as steps per second (1/dt), from small to large dt
GRID = (2000, 1500, 1000, 750, 500, 360, 240, 180, 120, 90, 60, 45, 30)
FINER = (8000, 6000, 4000, 3000, 2500)
#: physics steps per timing block of the cost measurement
BLOCK = 100


def envelope(character: Character, limits: bool, log) -> dict:
    """{(variant, kp): (largest held 1/dt or None, {1/dt: 'held'|'oscillates'|'diverged'})}."""
    out = {}
    for kp in KPS:
        for v in VARIANTS:
            status = {}
            for hz in GRID:
                r = S.hold_pose(character, v, kp=kp, timestep=1.0 / hz, torque_limits=limits)
                status[hz] = "held" if r.held else ("diverged" if r.diverged else "oscillates")
            if status[GRID[0]] != "held":
                for hz in reversed(FINER):
                    r = S.hold_pose(character, v, kp=kp, timestep=1.0 / hz, torque_limits=limits)
                    status[hz] = "held" if r.held else ("diverged" if r.diverged else
                                                        "oscillates")
            best = None
            for hz in sorted(status, reverse=True):  # small dt first
                if status[hz] != "held":
                    break
                best = hz
            out[(v, kp)] = (best, status)
            log(f"  kp {kp:g} {v}: largest held step "
                f"{'1/' + str(best) + ' s' if best else 'none'}")
    return out


def envelope_table(env: dict, title: str) -> str:
    lines = [f"**{title}** (largest time step that holds; every smaller step of the grid holds "
             f"too)", "", "| variant | " + " | ".join(f"kp {kp:g}" for kp in KPS) + " |",
             "|---|" + "---|" * len(KPS)]
    for v in VARIANTS:
        cells = []
        for kp in KPS:
            best, status = env[(v, kp)]
            cell = f"1/{best} s" if best else "< 1/8000 s"
            bigger = [hz for hz in GRID if best and hz < best and status.get(hz) == "held"]
            if bigger:  # isolated larger steps that hold beyond the first failure
                cell += " (also holds at " + ", ".join(f"1/{h}" for h in bigger) + " s)"
            cells.append(cell)
        lines.append(f"| {v} | " + " | ".join(cells) + " |")
    lines.append("")
    lines.append("Per step (H held, o oscillates: no divergence but the RMS joint velocity over "
                 "the last second stays above 0.5 rad/s or the RMS error above 0.05 rad, "
                 "D diverged):")
    lines.append("")
    hzs = sorted({hz for _, (_, st) in env.items() for hz in st}, reverse=True)
    lines.append("| variant, kp | " + " | ".join(f"1/{hz}" for hz in hzs) + " |")
    lines.append("|---|" + "---|" * len(hzs))
    mark = {"held": "H", "oscillates": "o", "diverged": "D"}
    for kp in KPS:
        for v in VARIANTS:
            st = env[(v, kp)][1]
            lines.append(f"| {v}, {kp:g} | " + " | ".join(mark[st[hz]] if hz in st else ""
                                                           for hz in hzs) + " |")
    return "\n".join(lines)


def step_cost(character: Character, n: int, repeats: int, log) -> dict:
    """{controller: (median ratio to mj_step, median controller us/step, median raw us/step)}.

    The controlled character and a bare copy of the model's data (stepped with ``mj_step`` at
    the standing PD targets) alternate in blocks of ``BLOCK`` steps, timed with the process CPU
    clock, so that load from other processes affects both alike.
    """
    from mjchar import bvh
    from mjchar.bvh.bundled.assets import humanoid_path, motion_path
    from mjchar.bvh.reference.reference_motion import ReferenceMotion

    ref = ReferenceMotion(character.model, bvh.load(motion_path("walk")))
    pose = S.standing_pose(character)
    # the bare loop: its own copy of the model, native actuators at the standing targets
    raw_model = mujoco.MjModel.from_xml_path(str(humanoid_path()))
    raw_model.opt.timestep = character.timestep
    raw_data = mujoco.MjData(raw_model)
    cases = {
        "native_pd": (lambda: make_controller("native_pd", character, pose), False, None),
        "native_pd, control every 1/60 s": (
            lambda: make_controller("native_pd", character, pose), False, 1 / 60),
        "pd": (lambda: make_controller("pd", character, pose), False, None),
        "spd": (lambda: make_controller("spd", character, pose), False, None),
        "hand_of_god (spd)": (lambda: make_controller("hand_of_god", character, pose), False,
                              None),
        "spd tracking the bundled walk": (lambda: make_controller("spd", character, ref),
                                          True, None),
        "static_balance": (lambda: make_controller("static_balance", character, pose), False,
                           None),
    }
    clock = time.process_time
    out = {}
    for name, (make, tracking, control_dt) in cases.items():
        k = 1 if control_dt is None else max(1, round(control_dt / character.timestep))
        block = max(k, BLOCK // k * k)
        ratios, ctl_us, raw_us = [], [], []
        for _ in range(repeats):
            c = make()
            if tracking:
                character.reset(ref.qpos(0.0), ref.qvel(0.0))
            else:
                character.reset(pose)
            c.reset(character)
            mujoco.mj_resetData(raw_model, raw_data)
            raw_data.qpos[:] = pose
            raw_data.ctrl[:] = pose[character.actuator_qpos]
            t_raw = t_ctl = 0.0
            steps = 0
            while steps < n:
                t0 = clock()
                for _ in range(block):
                    mujoco.mj_step(raw_model, raw_data)
                t_raw += clock() - t0
                t0 = clock()
                for _ in range(block // k):
                    character.step(c.act(character, character.time), k)
                t_ctl += clock() - t0
                steps += block
            ratios.append(t_ctl / t_raw)
            ctl_us.append(t_ctl / steps * 1e6)
            raw_us.append(t_raw / steps * 1e6)
        out[name] = (statistics.median(ratios), statistics.median(ctl_us),
                     statistics.median(raw_us))
        log(f"  {name}: {out[name][0]:.2f} x mj_step ({out[name][1]:.1f} vs {out[name][2]:.1f} "
            f"us)")
    return out


def cost_table(cost: dict, n: int, repeats: int, dt: float) -> str:
    lines = [f"Time step {dt * 1000:g} ms, {n} steps per measurement in blocks of {BLOCK} "
             f"alternating with a bare `mj_step` loop on the same model (process CPU time), "
             f"median of {repeats} repeats.",
             "", "| controller | cost / mj_step | us per step | mj_step us |",
             "|---|---|---|---|"]
    for name, (r, c, raw) in cost.items():
        lines.append(f"| {name} | {r:.2f} | {c:.1f} | {raw:.1f} |")
    return "\n".join(lines)


def replace_section(text: str, key: str, body: str) -> str:
    start, end = f"<!-- bench_pd:{key} -->", f"<!-- /bench_pd:{key} -->"
    block = f"{start}\n{body}\n{end}"
    if start in text and end in text:
        return re.sub(re.escape(start) + r".*?" + re.escape(end), lambda _: block, text,
                      flags=re.S)
    return text.rstrip() + "\n\n" + block + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--only", choices=("envelope", "cost"))
    p.add_argument("--limits", action="store_true",
                   help="also measure the envelope with the model's torque limits")
    p.add_argument("--steps", type=int, default=2000, help="steps per cost measurement")
    p.add_argument("--repeats", type=int, default=7, help="cost repeats (median)")
    p.add_argument("--no-write", action="store_true", help="do not update docs/controllers.md")
    args = p.parse_args(argv)

    def log(msg: str) -> None:
        print(msg, file=sys.stderr, flush=True)

    character = Character()
    dt0 = character.timestep
    sections = {}
    if args.only in (None, "envelope"):
        log("stability envelope (torque limits lifted)")
        t0 = time.time()
        env = envelope(character, False, log)
        body = envelope_table(env, "Torque limits lifted")
        if args.limits:
            log("stability envelope (model torque limits)")
            env2 = envelope(character, True, log)
            body += "\n\n" + envelope_table(env2, "With the model's torque limits")
        sections["envelope"] = body
        log(f"  ({time.time() - t0:.0f} s)")
    character.set_timestep(dt0)
    if args.only in (None, "cost"):
        log("per-step cost")
        cost = step_cost(character, args.steps, args.repeats, log)
        sections["cost"] = cost_table(cost, args.steps, args.repeats, dt0)
    for key, body in sections.items():
        print(f"\n## {key}\n\n{body}")
    if not args.no_write:
        text = DOC.read_text() if DOC.is_file() else "# Controllers\n"
        for key, body in sections.items():
            text = replace_section(text, key, body)
        DOC.write_text(text)
        log(f"updated {DOC}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
