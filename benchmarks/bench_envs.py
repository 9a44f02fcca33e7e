"""Environment throughput: mjchar's envs against Gymnasium's Humanoid-v5, written into docs/envs.md.

Usage::

    python benchmarks/bench_envs.py              # measure, print, update docs/envs.md
    python benchmarks/bench_envs.py --no-write   # print only
    python benchmarks/bench_envs.py --steps 2000 --repeats 5

Each env (``gymnasium.make``, default options, so the same checker/order wrappers for all) runs
uniform random actions (``action_space.sample()``, seeded) for ``--steps`` env steps, resetting
whenever an episode ends (random actions end episodes within about a second, so resets are part of
the cost, as in training). The envs take turns within each of ``--repeats`` rounds and the median
round is reported, so all rows share the machine's load. Columns:

- env steps/s: policy steps per wall second;
- physics steps/s: env steps/s x physics steps per env step (17 for the mjchar envs at 30 Hz with
  1.96 ms steps, ``frame_skip`` = 5 for Humanoid-v5 at 3 ms);
- bare mj_step/s: plain ``mujoco.mj_step(m, d, n_substeps)`` calls from the physics states the
  same seeded run visited (every 5th env step, controls as the env set them), timed in the same
  round: the ceiling of the physics column for that state distribution;
- physics share: physics steps/s over bare mj_step/s (the rest is Python: observation, reward,
  termination, resets, the wrappers).
"""

from __future__ import annotations

import argparse
import platform
import re
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import gymnasium as gym  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

from mjchar import envs  # noqa: E402, F401  (registers mjchar/...)
from mjchar.perf import random_env_steps  # noqa: E402

DOC = ROOT / "docs" / "envs.md"
ENVS = ("mjchar/Imitation-v0", "mjchar/Stand-v0", "Humanoid-v5")
MARK = "bench_envs:throughput"


def substeps(env) -> int:
    """Physics steps per env step."""
    u = env.unwrapped
    return int(getattr(u, "n_substeps", None) or u.frame_skip)


def model_data(env) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """The env's MuJoCo model and data."""
    u = env.unwrapped
    if hasattr(u, "character"):
        return u.character.model, u.character.data
    return u.model, u.data


def visited_states(env, steps: int, seed: int, every: int = 5) -> list:
    """Full physics states (``mjSTATE_INTEGRATION``) after every ``every``-th env step of the
    same seeded random run as :func:`mjchar.perf.random_env_steps` (not timed)."""
    m, d = model_data(env)
    sig = mujoco.mjtState.mjSTATE_INTEGRATION
    env.action_space.seed(seed)
    env.reset(seed=seed)
    out = []
    for i in range(steps):
        _, _, term, trunc, _ = env.step(env.action_space.sample())
        if i % every == 0:
            s = np.empty(mujoco.mj_stateSize(m, sig))
            mujoco.mj_getState(m, d, s, sig)
            out.append(s)
        if term or trunc:
            env.reset()
    return out


def bare_steps(env, states: list) -> float:
    """mj_step/s of plain ``mujoco.mj_step(m, d, n_substeps)`` calls from the visited states
    (controls as the env left them) on a fresh MjData of the env's model."""
    m, _ = model_data(env)
    d = mujoco.MjData(m)
    sig = mujoco.mjtState.mjSTATE_INTEGRATION
    n = substeps(env)
    total = 0.0
    for s in states:
        mujoco.mj_setState(m, d, s, sig)
        t0 = time.perf_counter()
        mujoco.mj_step(m, d, n)
        total += time.perf_counter() - t0
    return len(states) * n / total


def measure(steps: int, repeats: int, log) -> dict:
    made = {eid: gym.make(eid) for eid in ENVS}
    rounds: dict[str, list] = {eid: [] for eid in ENVS}
    bar = tqdm(total=repeats * len(ENVS), desc="bench_envs", file=sys.stderr)
    for r in range(repeats):
        for eid, env in made.items():
            wall, ended = random_env_steps(env, steps, seed=r)
            bare = bare_steps(env, visited_states(env, steps, seed=r))
            rounds[eid].append((steps / wall, ended, bare))
            bar.update()
    bar.close()
    out = {}
    for eid, env in made.items():
        eps = [x[0] for x in rounds[eid]]
        med = sorted(range(repeats), key=lambda i: eps[i])[repeats // 2]
        env_sps, ended, _ = rounds[eid][med]
        bare = statistics.median(x[2] for x in rounds[eid])
        m, _ = model_data(env)
        out[eid] = {"env_sps": env_sps, "phys_sps": env_sps * substeps(env), "bare": bare,
                    "substeps": substeps(env), "dt": m.opt.timestep, "episodes": ended,
                    "nv": m.nv,
                    "obs": env.observation_space.shape[0], "act": env.action_space.shape[0]}
        log(f"{eid}: {env_sps:.0f} env steps/s, {env_sps * substeps(env):.0f} physics steps/s "
            f"(bare {bare:.0f}/s), {ended} episodes per {steps} steps")
        env.close()
    return out


def table(res: dict, steps: int, repeats: int) -> str:
    lines = [
        f"Measured by `python benchmarks/bench_envs.py` on {platform.machine()} "
        f"({platform.python_version()}, MuJoCo {mujoco.__version__}, Gymnasium "
        f"{gym.__version__}); random actions, {steps} env steps per round, median of "
        f"{repeats} interleaved rounds, one process.",
        "",
        "| env | obs / act | nv | physics dt | physics steps per env step | env steps/s | "
        "physics steps/s | bare mj_step/s | physics share | episodes per round |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for eid, r in res.items():
        lines.append(
            f"| {eid} | {r['obs']} / {r['act']} | {r['nv']} | {r['dt'] * 1000:.2f} ms | "
            f"{r['substeps']} | {r['env_sps']:.0f} | {r['phys_sps']:.0f} | {r['bare']:.0f} | "
            f"{r['phys_sps'] / r['bare']:.0%} | {r['episodes']} |")
    ours, ref = res["mjchar/Imitation-v0"], res["Humanoid-v5"]
    lines += ["", f"Imitation-v0 / Humanoid-v5: {ours['phys_sps'] / ref['phys_sps']:.2f}x the "
              f"physics steps per second, {ours['env_sps'] / ref['env_sps']:.2f}x the env steps "
              f"per second (it simulates {ours['substeps']} steps per action against "
              f"{ref['substeps']})."]
    return "\n".join(lines)


def replace_section(text: str, body: str) -> str:
    start, end = f"<!-- {MARK} -->", f"<!-- /{MARK} -->"
    if start not in text or end not in text:
        return text.rstrip() + f"\n\n{start}\n{body}\n{end}\n"
    return re.sub(re.escape(start) + ".*?" + re.escape(end),
                  lambda _: f"{start}\n{body}\n{end}", text, flags=re.S)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=3000, help="env steps per env per round")
    ap.add_argument("--repeats", type=int, default=3, help="interleaved rounds (median kept)")
    ap.add_argument("--no-write", action="store_true", help="print only, leave docs/envs.md")
    a = ap.parse_args(argv)
    if a.steps <= 0 or a.repeats <= 0:
        ap.error("--steps and --repeats must be positive")
    res = measure(a.steps, a.repeats, lambda s: print(s, file=sys.stderr))
    body = table(res, a.steps, a.repeats)
    print(body)
    if not a.no_write:
        DOC.write_text(replace_section(DOC.read_text() if DOC.exists() else "", body))
        print(f"updated {DOC}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
