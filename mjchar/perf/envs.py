"""Gymnasium env throughput: mjchar's envs against Gymnasium's ``Humanoid-v5`` (the table of
docs/envs.md; the bench's ``envs`` part is :func:`env_throughput`).

    python -m mjchar.perf.envs                         # measure and print
    python -m mjchar.perf.envs --steps 2000 --repeats 5 --write   # update docs/envs.md

Each env (``gymnasium.make``, default options, so the same checker/order wrappers for all) runs
uniform random actions (``action_space.sample()``, seeded) for ``steps`` env steps, resetting
whenever an episode ends (random actions end episodes within about a second, so resets are part
of the cost, as in training). The envs take turns within each of ``repeats`` rounds and the
median round is reported, so all rows share the machine's load. Columns:

- env steps/s: policy steps per wall second;
- physics steps/s: env steps/s x physics steps per env step (17 for the mjchar envs at 30 Hz with
  1.96 ms steps, ``frame_skip`` = 5 for Humanoid-v5 at 3 ms);
- bare mj_step/s (with ``bare=True``): plain ``mujoco.mj_step(m, d, n_substeps)`` calls from the
  physics states the same seeded run visited (every 5th env step, controls as the env set them),
  timed in the same round: the ceiling of the physics column for that state distribution;
- physics share: the process CPU time bare ``mj_step`` takes for the round's physics steps
  over the CPU time of the round's env loop, both in this process (the rest is Python:
  observation, reward, termination, resets, the wrappers). The actions are drawn before the
  timed loop (the sampler is the policy's cost, not the env's).
"""

from __future__ import annotations

import statistics
import sys
from collections.abc import Sequence

import mujoco
import numpy as np

from .errors import PerfUnavailable, positive_int
from .report import DOCS, entry_parser, machine_line, markdown_table, spread, write_block
from .timing import PhysicsClock, Timing, timed

__all__ = ["ENV_IDS", "random_actions", "random_env_steps", "visited_states", "bare_step_time",
           "bare_step_rate", "bare_threads_speedup", "env_throughput", "vector_throughput",
           "threaded_throughput",
           "THREADED_COUNTS", "main"]

#: envs compared by :func:`env_throughput` (the last one is the yardstick)
ENV_IDS = ("mjchar/Imitation-v0", "mjchar/Stand-v0", "Humanoid-v5")
#: sub-env counts of :func:`threaded_throughput`
THREADED_COUNTS = (1, 2, 4, 8, 16)


def random_actions(env, steps: int, seed: int) -> list:
    """``steps`` uniformly random actions of ``env``'s action space (``action_space.sample()``,
    seeded): drawn before a timed loop, so that the loop times the env, not the sampler."""
    env.action_space.seed(seed)
    return [env.action_space.sample() for _ in range(steps)]


def _stepping_modules(env) -> tuple:
    """The modules whose ``mujoco.mj_step*`` calls step ``env``'s physics (the Character's for
    the mjchar envs, Gymnasium's ``MujocoEnv`` for its own)."""
    import importlib

    u = env.unwrapped
    if hasattr(u, "character"):
        return (importlib.import_module(type(u.character).__module__),)
    return tuple(importlib.import_module(c.__module__) for c in type(u).__mro__
                 if c.__module__.startswith("gymnasium.envs.mujoco")
                 and hasattr(importlib.import_module(c.__module__), "mujoco"))


def random_env_steps(env, steps: int, seed: int, *,
                     physics: PhysicsClock | None = None) -> tuple[Timing, int]:
    """``(Timing, episodes ended)`` of ``steps`` uniformly random actions in a Gymnasium ``env``
    (seeded ``reset`` and actions, :func:`random_actions`, drawn before the timed loop; resets
    when an episode ends, timed too). With ``physics`` (a :class:`PhysicsClock` not yet
    entered), the time inside MuJoCo's stepping functions during the loop is counted in it."""
    actions = random_actions(env, steps, seed)
    env.reset(seed=seed)

    def run() -> int:
        ended = 0
        for a in actions:
            _, _, term, trunc, _ = env.step(a)
            if term or trunc:
                ended += 1
                env.reset()
        return ended

    if physics is None:
        ended, t = timed(run)
    else:
        with physics:
            ended, t = timed(run)
    return t, ended


def _substeps(env) -> int:
    """Physics steps per env step."""
    u = env.unwrapped
    return int(getattr(u, "n_substeps", None) or getattr(u, "frame_skip", 1))


def _model_data(env) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """The env's MuJoCo model and data."""
    u = env.unwrapped
    if hasattr(u, "character"):
        return u.character.model, u.character.data
    return u.model, u.data


def visited_states(env, steps: int, seed: int, every: int = 5) -> list[np.ndarray]:
    """Full physics states (``mjSTATE_INTEGRATION``) after every ``every``-th env step of the
    same seeded random run as :func:`random_env_steps` (not timed)."""
    m, d = _model_data(env)
    sig = mujoco.mjtState.mjSTATE_INTEGRATION
    actions = random_actions(env, steps, seed)
    env.reset(seed=seed)
    out = []
    for i, a in enumerate(actions):
        _, _, term, trunc, _ = env.step(a)
        if i % every == 0:
            s = np.empty(mujoco.mj_stateSize(m, sig))
            mujoco.mj_getState(m, d, s, sig)
            out.append(s)
        if term or trunc:
            env.reset()
    return out


def bare_step_time(env, states: Sequence[np.ndarray]) -> tuple[Timing, int]:
    """``(Timing, physics steps)`` of plain ``mujoco.mj_step(m, d, n_substeps)`` calls from
    ``states`` (controls as the env left them) on a fresh MjData of the env's model."""
    m, _ = _model_data(env)
    d = mujoco.MjData(m)
    sig = mujoco.mjtState.mjSTATE_INTEGRATION
    n = _substeps(env)
    total = Timing()
    for s in states:
        mujoco.mj_setState(m, d, s, sig)
        total += timed(mujoco.mj_step, m, d, n)[1]
    return total, len(states) * n


def bare_step_rate(env, states: Sequence[np.ndarray]) -> float:
    """``mj_step``/s (wall clock) of :func:`bare_step_time`."""
    t, n = bare_step_time(env, states)
    return n / t.wall_s


def bare_threads_speedup(env, states: Sequence[np.ndarray], threads: int) -> float:
    """The speed-up of plain ``mj_step(m, d, n_substeps)`` calls from ``states`` run in
    ``threads`` threads at once (each on its own MjData, all the states) over the same calls in
    one thread (wall clock, timed in turn): the ceiling of a threaded vector env on this machine,
    where only the physics runs in parallel and nothing else competes."""
    import threading

    threads = positive_int(threads, "threads")
    if threads == 1:
        return 1.0
    m, _ = _model_data(env)
    datas = [mujoco.MjData(m) for _ in range(threads)]
    sig = mujoco.mjtState.mjSTATE_INTEGRATION
    n = _substeps(env)

    def run(d):
        for s in states:
            mujoco.mj_setState(m, d, s, sig)
            mujoco.mj_step(m, d, n)

    one = timed(run, datas[0])[1].wall_s
    workers = [threading.Thread(target=run, args=(d,)) for d in datas]
    t = timed(lambda: [w.start() for w in workers] and [w.join() for w in workers])[1].wall_s
    return threads * one / t


def env_throughput(env_ids: Sequence[str] = ENV_IDS, *, steps: int = 1000, repeats: int = 3,
                   seed: int = 0, bare: bool = False, log=None) -> dict:
    """Env steps per second with uniform random actions (seeded), resetting when an episode
    ends, for each env id; the envs take turns in ``repeats`` rounds and the median round is
    reported. Physics steps per second = env steps/s x physics steps per env step.

    With ``bare``, each round also times bare ``mj_step`` from the states that round visited
    (:func:`visited_states`, :func:`bare_step_time`), and each env gets ``"bare_steps_per_s"``
    (wall clock, median over rounds) and ``"physics_share"``: the process CPU time bare
    ``mj_step`` needs for the round's physics steps over the CPU time of the round's env loop
    (the share of the env's time that is physics; median over rounds, every round's in
    ``"physics_shares"``), and ``"time_in_mj_step"``: the CPU time spent inside MuJoCo's stepping
    functions during the round's env loop over the loop's CPU time (:class:`PhysicsClock`;
    median, every round's in ``"times_in_mj_step"``). The first credits the env with bare
    ``mj_step``'s hot-cache speed, so it is the lower of the two.

    Returns:
        ``{"steps", "repeats", "envs": {id: {"env_steps_per_s", "physics_steps_per_s",
        "physics_steps_per_env_step", "timestep_s", "episodes_per_round", "obs_dim",
        "act_dim"}}, "reference": id, "ratios": {id: {"env_steps": x, "physics_steps": y}}}``
        where ratios are against the last id (``Humanoid-v5``).
    Raises:
        PerfUnavailable: Gymnasium, its MuJoCo envs or the project's envs do not load.
    """
    steps, repeats = positive_int(steps, "steps"), positive_int(repeats, "repeats")
    try:
        import gymnasium as gym  # importing mjchar registered the mjchar/... ids
    except Exception as e:  # a broken Gymnasium: report, do not crash the bench
        raise PerfUnavailable(f"gymnasium does not import ({type(e).__name__}: {e})") from None
    made = {}
    try:
        for eid in env_ids:
            try:
                made[eid] = gym.make(eid)
            except Exception as e:
                raise PerfUnavailable(f"gymnasium.make({eid!r}) failed ({type(e).__name__}: "
                                      f"{str(e).splitlines()[0] if str(e) else ''})") from None
        rounds: dict[str, list[tuple[float, int]]] = {eid: [] for eid in env_ids}
        bares: dict[str, list[float]] = {eid: [] for eid in env_ids}
        shares: dict[str, list[float]] = {eid: [] for eid in env_ids}
        inside: dict[str, list[float]] = {eid: [] for eid in env_ids}
        for r in range(repeats):
            for eid, env in made.items():
                clock = PhysicsClock(*_stepping_modules(env)) if bare else None
                t, ended = random_env_steps(env, steps, seed + r, physics=clock)
                rounds[eid].append((steps / t.wall_s, ended))
                if bare:
                    inside[eid].append(clock.share(t.cpu_s))
                    bt, bn = bare_step_time(env, visited_states(env, steps, seed + r))
                    bares[eid].append(bn / bt.wall_s)
                    # CPU seconds bare mj_step takes for this round's physics steps, over the
                    # CPU seconds the env loop took (one process, the same clock)
                    physics_cpu = bt.cpu_s / bn * steps * _substeps(env)
                    shares[eid].append(physics_cpu / max(t.cpu_s, 1e-12))
                if log is not None:
                    log(f"round {r + 1}/{repeats} {eid}: {steps / t.wall_s:.0f} env steps/s"
                        + (f", in mj_step {inside[eid][-1]:.0%}, bare-equivalent "
                           f"{shares[eid][-1]:.0%}" if bare else ""))
        out = {}
        for eid, env in made.items():
            rates = sorted(rounds[eid])
            rate, ended = rates[len(rates) // 2]
            u = env.unwrapped
            sub = _substeps(env)
            dt = (u.character.timestep if hasattr(u, "character")
                  else float(u.model.opt.timestep))
            out[eid] = {"env_steps_per_s": rate, "physics_steps_per_s": rate * sub,
                        "physics_steps_per_env_step": sub, "timestep_s": float(dt),
                        "episodes_per_round": ended,
                        "obs_dim": int(np.prod(env.observation_space.shape)),
                        "act_dim": int(np.prod(env.action_space.shape))}
            if bare:
                b = statistics.median(bares[eid])
                out[eid].update(bare_steps_per_s=b, physics_share=statistics.median(shares[eid]),
                                physics_shares=shares[eid],
                                time_in_mj_step=statistics.median(inside[eid]),
                                times_in_mj_step=inside[eid], nv=int(_model_data(env)[0].nv))
    finally:
        for env in made.values():
            env.close()
    ref = env_ids[-1]
    ratios = {eid: {"env_steps": v["env_steps_per_s"] / out[ref]["env_steps_per_s"],
                    "physics_steps": v["physics_steps_per_s"] / out[ref]["physics_steps_per_s"]}
              for eid, v in out.items()}
    return {"steps": steps, "repeats": repeats, "envs": out, "reference": ref, "ratios": ratios}


def vector_throughput(env_ids: Sequence[str] = (ENV_IDS[0], ENV_IDS[-1]), *,
                      num_envs: int = 2, steps: int = 1000, repeats: int = 3, seed: int = 0,
                      log=None) -> dict:
    """Env steps per second of each env id run as one process and as a
    ``gymnasium.vector.AsyncVectorEnv`` of ``num_envs`` worker processes with shared memory
    (``gym.make_vec(id, num_envs, vectorization_mode="async", vector_kwargs={"shared_memory":
    True})``; episodes reset inside the workers, Gymnasium's autoreset), with uniform random
    actions drawn before the timed loop; the cases take turns in ``repeats`` rounds, the median
    round is reported (wall clock: the workers' time is not this process's CPU time).

    Returns:
        ``{"num_envs", "steps", "repeats", "cores", "envs": {id: {"single_steps_per_s",
        "vector_steps_per_s", "speedup"}}}``; a vector env's steps count every worker's.
    """
    import os

    steps, repeats = positive_int(steps, "steps"), positive_int(repeats, "repeats")
    num_envs = positive_int(num_envs, "num_envs")
    try:
        import gymnasium as gym
    except Exception as e:
        raise PerfUnavailable(f"gymnasium does not import ({type(e).__name__}: {e})") from None
    singles, vectors = {}, {}
    try:
        for eid in env_ids:
            try:
                singles[eid] = gym.make(eid)
                vectors[eid] = gym.make_vec(eid, num_envs=num_envs, vectorization_mode="async",
                                            vector_kwargs={"shared_memory": True})
            except Exception as e:
                raise PerfUnavailable(f"gymnasium.make_vec({eid!r}) failed ({type(e).__name__}:"
                                      f" {str(e).splitlines()[0] if str(e) else ''})") from None
        rates: dict[str, dict[str, list[float]]] = {eid: {"single": [], "vector": []}
                                                    for eid in env_ids}
        for r in range(repeats):
            for eid in env_ids:
                t, _ = random_env_steps(singles[eid], steps, seed + r)
                rates[eid]["single"].append(steps / t.wall_s)
                venv = vectors[eid]
                venv.action_space.seed(seed + r)
                acts = [venv.action_space.sample() for _ in range(steps // num_envs)]
                venv.reset(seed=seed + r)
                t = timed(lambda venv=venv, acts=acts: [venv.step(a) for a in acts] and None)[1]
                rates[eid]["vector"].append(len(acts) * num_envs / t.wall_s)
                if log is not None:
                    log(f"round {r + 1}/{repeats} {eid}: {rates[eid]['single'][-1]:.0f} env "
                        f"steps/s in one process, {rates[eid]['vector'][-1]:.0f} with "
                        f"{num_envs} workers")
    finally:
        for env in (*singles.values(), *vectors.values()):
            env.close()
    out = {}
    for eid in env_ids:
        one = statistics.median(rates[eid]["single"])
        vec = statistics.median(rates[eid]["vector"])
        out[eid] = {"single_steps_per_s": one, "vector_steps_per_s": vec, "speedup": vec / one,
                    "single_rounds": rates[eid]["single"], "vector_rounds": rates[eid]["vector"]}
    return {"num_envs": num_envs, "steps": steps, "repeats": repeats, "cores": os.cpu_count(),
            "envs": out}


def threaded_throughput(env_id: str = ENV_IDS[0], *, counts: Sequence[int] = THREADED_COUNTS,
                        steps: int = 1000, repeats: int = 3, seed: int = 0,
                        num_threads: int | None = None, log=None) -> dict:
    """Env steps per second of ``env_id``'s threaded vector env
    (``gym.make_vec(env_id, num_envs=N)``, :class:`mjchar.envs.vector.ThreadedVectorEnv`,
    autoreset inside) for each ``N`` in ``counts``, against one env in one process
    (``gym.make``, :func:`random_env_steps`) in the same rounds: each case runs ``steps`` env
    steps in all (``steps // N`` vector steps, at least one) of uniform random actions drawn
    before the timed loop; the cases take turns in ``repeats`` rounds, the median round is
    reported (wall clock).

    Returns:
        ``{"env", "steps", "repeats", "cores", "single_steps_per_s", "single_rounds",
        "single_cpu_s_per_step", "cases": [{"num_envs", "num_threads", "steps_per_s",
        "rounds", "speedup", "physics_ceiling", "cores_busy", "cpu_per_step_vs_one"}]}``: the
        speed-up over the single env's median; ``physics_ceiling`` the speed-up of bare
        ``mj_step`` in as many threads (:func:`bare_threads_speedup`, from states of the single
        env's random run, timed in the same rounds): what the machine allows; ``cores_busy``
        the process CPU time over the wall time of the
        vector loop (what the scheduler gave it: at most the free cores);
        ``cpu_per_step_vs_one`` its CPU time per env step over the single env's (the cost of
        the threading itself, independent of how busy the machine is).
    Raises:
        PerfUnavailable: Gymnasium or the env does not load.
    """
    import os

    steps, repeats = positive_int(steps, "steps"), positive_int(repeats, "repeats")
    counts = [positive_int(n, "num_envs") for n in counts]
    try:
        import gymnasium as gym
    except Exception as e:
        raise PerfUnavailable(f"gymnasium does not import ({type(e).__name__}: {e})") from None
    single, vectors = None, {}
    try:
        try:
            single = gym.make(env_id)
            for n in counts:
                vectors[n] = gym.make_vec(env_id, num_envs=n, num_threads=num_threads)
        except Exception as e:
            raise PerfUnavailable(f"gymnasium.make_vec({env_id!r}) failed ({type(e).__name__}:"
                                  f" {str(e).splitlines()[0] if str(e) else ''})") from None
        ones: list[float] = []
        one_cpu: list[float] = []
        rates: dict[int, list[float]] = {n: [] for n in counts}
        busy: dict[int, list[float]] = {n: [] for n in counts}
        cpu: dict[int, list[float]] = {n: [] for n in counts}
        ceiling: dict[int, list[float]] = {n: [] for n in counts}
        states = visited_states(single, min(steps, 500), seed)
        for r in range(repeats):
            t, _ = random_env_steps(single, steps, seed + r)
            ones.append(steps / t.wall_s)
            one_cpu.append(t.cpu_s / steps)
            for n, venv in vectors.items():
                venv.action_space.seed(seed + r)
                acts = [venv.action_space.sample() for _ in range(max(1, steps // n))]
                venv.reset(seed=seed + r)
                t = timed(lambda venv=venv, acts=acts: [venv.step(a) for a in acts] and None)[1]
                rates[n].append(len(acts) * n / t.wall_s)
                busy[n].append(t.cpu_s / t.wall_s)
                cpu[n].append(t.cpu_s / (len(acts) * n))
                ceiling[n].append(bare_threads_speedup(single, states, venv.num_threads))
            if log is not None:
                log(f"round {r + 1}/{repeats} {env_id}: one env {ones[-1]:.0f} env steps/s; "
                    + ", ".join(f"N={n} {rates[n][-1]:.0f}" for n in counts))
        threads = {n: v.num_threads for n, v in vectors.items()}
    finally:
        for env in (single, *vectors.values()):
            if env is not None:
                env.close()
    one, one_cpu_s = statistics.median(ones), statistics.median(one_cpu)
    cases = [{"num_envs": n, "num_threads": threads[n], "rounds": rates[n],
              "steps_per_s": statistics.median(rates[n]),
              "speedup": statistics.median(rates[n]) / one,
              "cores_busy": statistics.median(busy[n]),
              "cpu_per_step_vs_one": statistics.median(cpu[n]) / one_cpu_s,
              "physics_ceiling": statistics.median(ceiling[n])} for n in counts]
    return {"env": env_id, "steps": steps, "repeats": repeats, "cores": os.cpu_count(),
            "single_steps_per_s": one, "single_rounds": ones,
            "single_cpu_s_per_step": one_cpu_s, "cases": cases}


def table(res: dict, command: str = "python -m mjchar.perf.envs") -> str:
    """The Markdown table of docs/envs.md from ``env_throughput(..., bare=True)``."""
    import gymnasium as gym

    intro = (f"Measured by `{command}` on {machine_line(Gymnasium=gym.__version__)}"
             f"; random actions drawn before the timed loop, {res['steps']} env steps per round, "
             f"median of {res['repeats']} interleaved rounds, one process; shares on the process "
             f"CPU clock (spread: smallest and largest round).")
    header = ("env", "obs / act", "nv", "physics dt", "physics steps per env step", "env steps/s",
              "physics steps/s", "time in mj_step", "spread", "bare-equivalent share",
              "episodes per round")
    rows = [(eid, f"{r['obs_dim']} / {r['act_dim']}", r["nv"], f"{r['timestep_s'] * 1000:.2f} ms",
             r["physics_steps_per_env_step"], f"{r['env_steps_per_s']:.0f}",
             f"{r['physics_steps_per_s']:.0f}", f"{r['time_in_mj_step']:.0%}",
             spread(r["times_in_mj_step"], ".0%"), f"{r['physics_share']:.0%}",
             r["episodes_per_round"]) for eid, r in res["envs"].items()]
    first, ref = res["envs"][ENV_IDS[0]], res["envs"][res["reference"]]
    ratio = res["ratios"][ENV_IDS[0]]
    ratios = (f"{ENV_IDS[0].split('/')[-1]} / {res['reference']}: "
              f"{ratio['physics_steps']:.2f}x the physics steps per second, "
              f"{ratio['env_steps']:.2f}x the env steps per second (it simulates "
              f"{first['physics_steps_per_env_step']} steps per action against "
              f"{ref['physics_steps_per_env_step']}).")
    return "\n".join([intro, "", markdown_table(header, rows), "", ratios])


def vector_table(res: dict, command: str = "python -m mjchar.perf.envs") -> str:
    """The Markdown table of :func:`vector_throughput`."""
    n = res["num_envs"]
    intro = (f"Measured by `{command}` on {machine_line()}; random actions, "
             f"{res['steps']} env steps per case and round, median of {res['repeats']} "
             f"interleaved rounds (wall clock; spread: slowest and fastest round).")
    header = ("env", "env steps/s, one process", "spread",
              f"env steps/s, AsyncVectorEnv x {n} (shared memory, {res['cores']} cores)",
              "spread", "speed-up")
    rows = [(eid, f"{r['single_steps_per_s']:.0f}", spread(r["single_rounds"], ".0f"),
             f"{r['vector_steps_per_s']:.0f}", spread(r["vector_rounds"], ".0f"),
             f"{r['speedup']:.2f}") for eid, r in res["envs"].items()]
    return f"{intro}\n\n{markdown_table(header, rows)}"


def threaded_table(res: dict, command: str = "python -m mjchar.perf.envs") -> str:
    """The Markdown table of :func:`threaded_throughput`."""
    intro = (f"Measured by `{command}` on {machine_line()}; {res['env']}, random actions, "
             f"{res['steps']} env steps per case and round, median of {res['repeats']} "
             f"interleaved rounds (wall clock; spread: slowest and fastest round); speed-up over "
             f"one env in one process in the same rounds: "
             f"{res['single_steps_per_s']:.0f} env steps/s "
             f"({spread(res['single_rounds'], '.0f')}).")
    header = ("sub-envs N", "threads", "env steps/s", "spread", "speed-up over one env",
              "bare mj_step in as many threads (ceiling)", "cores busy",
              "CPU per env step over one env's")
    rows = [(c["num_envs"], c["num_threads"], f"{c['steps_per_s']:.0f}", spread(c["rounds"], ".0f"),
             f"{c['speedup']:.2f}", f"{c['physics_ceiling']:.2f}", f"{c['cores_busy']:.2f}",
             f"{c['cpu_per_step_vs_one']:.2f}") for c in res["cases"]]
    return f"{intro}\n\n{markdown_table(header, rows)}"


def main(argv: list[str] | None = None) -> int:
    ap = entry_parser("envs", __doc__)
    ap.add_argument("--steps", type=int, default=3000, help="env steps per env per round")
    ap.add_argument("--repeats", type=int, default=3, help="interleaved rounds (median kept)")
    ap.add_argument("--write", action="store_true", help="update docs/envs.md")
    a = ap.parse_args(argv)
    if a.steps <= 0 or a.repeats <= 0:
        ap.error("--steps and --repeats must be positive")
    try:
        res = env_throughput(steps=a.steps, repeats=a.repeats, bare=True,
                             log=lambda s: print(s, file=sys.stderr, flush=True))
        vec = vector_throughput(steps=a.steps, repeats=a.repeats,
                                log=lambda s: print(s, file=sys.stderr, flush=True))
        thr = threaded_throughput(steps=a.steps, repeats=a.repeats,
                                  log=lambda s: print(s, file=sys.stderr, flush=True))
    except PerfUnavailable as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    body, vbody, tbody = table(res), vector_table(vec), threaded_table(thr)
    print(body + "\n\n" + vbody + "\n\n" + tbody)
    if a.write:
        write_block(DOCS / "envs.md", "envs", body)
        write_block(DOCS / "envs.md", "envs-threads", tbody)
        print(f"updated {write_block(DOCS / 'envs.md', 'envs-vector', vbody)}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
