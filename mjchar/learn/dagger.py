"""Distil the sampling MPC into a policy network: DAgger with DART noise.

The loop (Ross, Gordon and Bagnell 2011, "A Reduction of Imitation Learning and Structured
Prediction to No-Regret Online Learning"; Laskey, Lee, Fox, Dragan and Goldberg 2017, "DART:
Noise Injection for Robust Imitation Learning"; Mordatch and Todorov 2014 for an optimiser as
the expert), iteration ``i = 0, 1, ...`` until the wall-clock budget ends:

1. **Roll out** ``episodes`` short episodes on the workers (:mod:`.collect`), each from a random
   phase of the clip, some from perturbed starts, some with a push, executing the mixture
   ``pi_i = beta_i pi* + (1 - beta_i) pi_hat`` (``beta_i = beta_decay^i``: the MPC alone first)
   plus Gaussian action noise (DART);
2. **label** every visited state with the MPC (``MpcController.plan``), aggregate the pairs
   into one data set ``D``;
3. **train** the network on all of ``D`` (:class:`~.train.Trainer`: normalised inputs, mean
   squared error in the env's scaled action space), continuing from the last weights;
4. **evaluate** the learner alone (no noise, no expert) from ``eval_phases`` phases for
   ``eval_seconds`` each: mean tracking error and fall rate, against wall time (the learning
   curve); write the policy file (:mod:`mjchar.controllers.learned.policy_file`), the curve and
   the resumable state.

Outputs beside the policy ``POLICY.npz``: ``POLICY.curve.png`` (the curve),
``POLICY.curve.json`` (its numbers) and ``POLICY.learn.pt`` (data set, network and optimiser
state, curve: ``resume=True`` continues from it). Every file is written atomically after every
iteration, so a run stopped at any time leaves a usable policy.
"""

from __future__ import annotations

import json
import math
import os
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from mjchar.controllers.learned.policy_file import clip_hash, save_policy

from .collect import Episode, LearnSetup, make_env
from .train import LearnError, Trainer, import_torch
from .workers import episode_pool

__all__ = ["LearnOptions", "learn", "policy_metadata", "outputs"]


@dataclass
class LearnOptions:
    """DAgger's settings (module docstring).

    Attributes:
        minutes: wall-clock budget.
        seed: random seed (episodes, network initialisation, minibatches).
        workers: labelling workers (``None``: every core, or every CPU of the Ray cluster).
        executor: where they run: ``"local"`` (worker processes) or ``"ray"`` (Ray actors,
            :mod:`.workers`).
        ray_address: the Ray cluster (``None``: a local Ray instance).
        episodes: episodes per iteration (``None``: one per worker).
        episode_seconds: simulated seconds per training episode.
        beta_decay: ``beta_i = beta_decay^i``.
        noise: DART's action noise (standard deviation, scaled action units).
        perturb_rate, perturb: fraction of episodes from a perturbed start, and its
            ``(joint_noise rad, root_velocity_noise m/s)``.
        push_rate, push_force, push_duration: fraction of episodes with one horizontal push on
            the root in a random direction, its force range (N) and duration (s).
        hidden: hidden layer widths; lr: Adam's learning rate; epochs: passes over the data
            set per iteration (at most ``max_steps`` minibatches of ``batch``).
        eval_phases, eval_seconds: the evaluation episodes.
        threads: torch threads while training.
    """

    minutes: float = 60.0
    seed: int = 0
    workers: int | None = None
    executor: str = "local"
    ray_address: str | None = None
    episodes: int | None = None
    episode_seconds: float = 1.5
    beta_decay: float = 0.5
    noise: float = 0.1
    perturb_rate: float = 0.3
    perturb: tuple[float, float] = (0.1, 0.2)
    push_rate: float = 0.3
    push_force: tuple[float, float] = (60.0, 150.0)
    push_duration: float = 0.2
    hidden: tuple[int, ...] = (512, 512)
    lr: float = 1e-3
    batch: int = 256
    epochs: float = 30.0
    max_steps: int = 3000
    eval_phases: int = 4
    eval_seconds: float = 10.0
    threads: int = 1


def outputs(policy: str | os.PathLike) -> dict[str, Path]:
    """The files a learn run writes for policy path ``policy``."""
    p = Path(policy)
    stem = p.with_suffix("")
    return {"policy": p, "curve": Path(f"{stem}.curve.png"), "numbers": Path(f"{stem}.curve.json"),
            "state": Path(f"{stem}.learn.pt")}


def policy_metadata(setup: LearnSetup, env) -> dict:
    """The policy file's metadata (:mod:`~mjchar.controllers.learned.policy_file`) for a policy
    acting in ``env`` (the setup's ImitationEnv)."""
    from mjchar.controllers.sampling.trajectory import model_fingerprint

    ch, obs = env.character, env.observer
    k = obs.n_bodies
    layout, at = [], 0
    for name, n in (("root_height", 1), ("body_positions", 3 * (k - 1)), ("body_x_axes", 3 * k),
                    ("body_z_axes", 3 * k), ("body_linear_velocities", 3 * k),
                    ("body_angular_velocities", 3 * k), ("phase_cos_sin", 2)):
        layout.append([name, at, at + n])
        at += n
    for s in env.future_steps:
        layout.append([f"reference_pose_{s}_ahead", at, at + 9 * k])
        at += 9 * k
    clip = setup.clip
    name = clip if not os.path.exists(clip) else Path(clip).name
    return {
        "clip": {"name": name, "hash": clip_hash(env.reference), "loop": bool(setup.loop),
                 "duration_s": float(env.reference.duration),
                 "cyclic": bool(env.reference.cyclic)},
        "model": {"fingerprint": model_fingerprint(ch.model), "nq": int(ch.nq),
                  "nu": int(ch.nu)},
        "observation": {"size": int(env.observation_space.shape[0]),
                        "future_steps": list(env.future_steps), "layout": layout},
        "action": {"size": int(ch.nu), "scale_rad": [float(x) for x in env.action_scale_rad],
                   "base": "native PD set-points of the reference one control step ahead, "
                           "u = q_bar + (kd/kp) qdot_bar"},
        "env": {"control_freq": 1.0 / env.control_dt, "n_substeps": int(env.n_substeps),
                "timestep": float(ch.timestep)},
    }


@dataclass
class _Curve:
    """The learning curve: one row per iteration."""

    rows: list = field(default_factory=list)

    def add(self, **row) -> None:
        self.rows.append(row)


def _episodes(opts: LearnOptions, rng: np.random.Generator, n: int, beta: float,
              policy) -> list[Episode]:
    jobs = []
    for _ in range(n):
        perturb = opts.perturb if rng.random() < opts.perturb_rate else None
        push = None
        if rng.random() < opts.push_rate:
            f = rng.uniform(*opts.push_force)
            ang = rng.uniform(0, 2 * math.pi)
            t0 = rng.uniform(0.2, max(0.3, opts.episode_seconds - opts.push_duration - 0.5))
            push = (t0, f * math.cos(ang), f * math.sin(ang), opts.push_duration)
        jobs.append(Episode(seed=int(rng.integers(2**31)), phase=float(rng.random()),
                            seconds=opts.episode_seconds, beta=beta, noise=opts.noise,
                            perturb=perturb, push=push, policy=policy))
    return jobs


def _eval_jobs(opts: LearnOptions, policy) -> list[Episode]:
    return [Episode(seed=1000 + i, phase=i / opts.eval_phases, seconds=opts.eval_seconds,
                    beta=0.0, noise=0.0, policy=policy, label=False)
            for i in range(opts.eval_phases)]


def learn(setup: LearnSetup, out, opts: LearnOptions | None = None, *, resume: bool = False,
          progress=None, log=None) -> dict:
    """Run DAgger (module docstring) until ``opts.minutes`` of wall time have passed; returns a
    summary (iterations, labels, data set size, wall time, the last evaluation).

    Args:
        setup: the clip, model and labeller settings (:class:`~.collect.LearnSetup`).
        out: the policy file to write (``.npz``); the other outputs sit beside it.
        resume: continue from ``out``'s ``.learn.pt`` state (data set, network, curve).
        progress: a :class:`~mjchar.controllers.core.progress.Progress` (a bar over the budget).
        log: ``log(line)`` after each iteration (``None``: silent).
    """
    opts = opts or LearnOptions()
    torch = import_torch()
    files = outputs(out)
    t_start = time.perf_counter()
    budget = 60.0 * float(opts.minutes)
    env = make_env(setup)
    meta = policy_metadata(setup, env)
    clip_text = Path(setup.clip).read_text() if os.path.isfile(setup.clip) else None
    n_in, nu = env.observation_space.shape[0], env.action_space.shape[0]
    env.close()
    trainer = Trainer(n_in, nu, opts.hidden, lr=opts.lr, batch=opts.batch, seed=opts.seed,
                      threads=opts.threads)
    X = np.zeros((0, n_in), np.float32)
    Y = np.zeros((0, nu), np.float32)
    curve, it, elapsed0, labels, label_s = _Curve(), 0, 0.0, 0, 0.0
    best = None  # the evaluation score of the network in the policy file (_score)
    if resume:
        if not files["state"].is_file():
            raise LearnError(f"{files['state']}: nothing to resume (no learn state beside "
                             f"{out}); run without --resume")
        st = torch.load(files["state"], weights_only=False)
        if st["meta"]["clip"]["hash"] != meta["clip"]["hash"] or (
                st["meta"]["model"]["fingerprint"] != meta["model"]["fingerprint"]):
            raise LearnError(f"{files['state']} was learned on another clip or model; give "
                             "another -o or run without --resume")
        X, Y = st["X"], st["Y"]
        trainer.load_state(st["trainer"])
        best = st.get("best")
        curve.rows = st["curve"]
        it, elapsed0 = st["iteration"], st["elapsed_s"]
        labels, label_s = st["labels"], st["label_seconds"]
    rng = np.random.default_rng([opts.seed, it])
    policy = trainer.mlp() if len(X) else None
    if progress is not None:
        progress.start(opts.minutes, unit="min", desc="learning")
    summary = {}
    with episode_pool(setup, opts.workers, executor=opts.executor,
                      address=opts.ray_address) as pool:
        n_episodes = opts.episodes or pool.parallelism
        while True:
            now = time.perf_counter() - t_start
            if now >= budget and summary:  # (one iteration at least)
                break
            beta = opts.beta_decay ** it
            w = time.perf_counter()
            results = pool.map(_episodes(opts, rng, n_episodes, beta, policy))
            collect_s = time.perf_counter() - w
            new = sum(len(r.obs) for r in results)
            X = np.concatenate([X] + [r.obs for r in results])
            Y = np.concatenate([Y] + [r.labels for r in results])
            labels += new
            label_s += sum(r.label_seconds for r in results)
            w = time.perf_counter()
            before, after = trainer.fit(X, Y, opts.epochs, opts.max_steps)
            train_s = time.perf_counter() - w
            policy = trainer.mlp()
            w = time.perf_counter()
            ev = pool.map(_eval_jobs(opts, policy))
            eval_s = time.perf_counter() - w
            it += 1
            wall = elapsed0 + time.perf_counter() - t_start
            row = {"iteration": it, "wall_s": wall, "beta": beta, "labels": labels,
                   "data": int(len(X)), "loss_before": before, "loss_after": after,
                   "eval_error_m": float(np.mean([r.tracking_error_m for r in ev])),
                   "eval_fall_rate": float(np.mean([r.fell for r in ev])),
                   "eval_survived_s": float(np.mean([r.sim_seconds for r in ev])),
                   "eval_return": float(np.mean([r.episode_return for r in ev])),
                   "collect_s": collect_s, "train_s": train_s, "eval_s": eval_s,
                   "labels_per_s": new / max(collect_s, 1e-9),
                   "clipped": float(np.mean([r.clipped for r in results])),
                   "expert_falls": int(sum(r.fell for r in results))}
            score = _score(row)
            row["written"] = best is None or score <= best
            curve.add(**row)
            if row["written"]:  # the policy file holds the best network evaluated so far
                best = score
                meta_now = dict(meta, training={
                    "method": "DAgger + DART, MPC labels", "iteration": it, "iterations": it,
                    "labels": labels, "wall_s": wall, "label_seconds": label_s,
                    "setup": _jsonable(_named(asdict(setup))), "options": _jsonable(asdict(opts)),
                    "eval": {k: row[k] for k in ("eval_error_m", "eval_fall_rate",
                                                 "eval_survived_s")}})
                save_policy(files["policy"], policy, meta_now, clip_text)
            _save_state(torch, files["state"], X=X, Y=Y, trainer=trainer.state(),
                        curve=curve.rows, iteration=it, elapsed_s=wall, labels=labels,
                        label_seconds=label_s, meta=meta, best=best)
            _save_curve(files, curve.rows)
            summary = dict(row)
            if log is not None:
                log(_line(row))
            if progress is not None:
                progress.update(min(opts.minutes, (time.perf_counter() - t_start) / 60.0))
    if progress is not None:
        progress.close()
    summary.update(outputs={k: str(v) for k, v in files.items()})
    return summary


def _score(row: dict) -> tuple:
    """How an iteration's network ranks (smaller is better): fewer evaluation falls, then
    longer up before them, then a smaller tracking error."""
    return (round(row["eval_fall_rate"], 6), -round(row["eval_survived_s"], 6),
            row["eval_error_m"])


def _line(row: dict) -> str:
    return (f"it {row['iteration']:3d}  {row['wall_s'] / 60:6.1f} min  beta {row['beta']:.3f}  "
            f"labels {row['labels']:6d} ({row['labels_per_s']:.2f}/s)  loss "
            f"{row['loss_before']:.4f}->{row['loss_after']:.4f}  eval error "
            f"{100 * row['eval_error_m']:.1f} cm  falls {row['eval_fall_rate']:.2f}  survived "
            f"{row['eval_survived_s']:.1f} s" + ("  (written)" if row.get("written") else ""))


def _named(setup: dict) -> dict:
    """The setup with file paths reduced to file names (a policy file names no folder of the
    machine it was learned on)."""
    return {k: (Path(v).name if k in ("clip", "model") and isinstance(v, str) else v)
            for k, v in setup.items()}


def _jsonable(d):
    return json.loads(json.dumps(d, default=lambda o: list(o) if isinstance(o, tuple) else str(o)))


def _save_state(torch, path: Path, **state) -> None:
    from mjchar.bvh.io.files import atomic_path

    with atomic_path(path) as tmp:
        torch.save(state, tmp)


def _save_curve(files: dict, rows: list) -> None:
    from mjchar.bvh.io.files import write_text

    write_text(files["numbers"], json.dumps(rows, indent=1) + "\n")
    try:
        from .curve import plot_curve
    except ImportError:  # matplotlib absent: the numbers are written, the picture is not
        return
    plot_curve(rows, files["curve"])


def with_options(opts: LearnOptions, **kw) -> LearnOptions:
    """``opts`` with fields replaced (unknown names: :class:`LearnError`)."""
    names = set(LearnOptions.__dataclass_fields__)
    bad = [k for k in kw if k not in names]
    if bad:
        raise LearnError(f"unknown learn option(s) {', '.join(bad)}; valid: "
                         f"{', '.join(sorted(names))}")
    return replace(opts, **kw)
