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
   curve); with ``eval_perturbed`` or ``eval_pushes`` (none by default), also on a fixed
   validation set of disturbed episodes (perturbed starts; pushes of ``eval_push_force`` in
   eight directions at spread phases): their fall rate. The policy file
   (:mod:`mjchar.controllers.learned.policy_file`) keeps the best network evaluated
   (:func:`_score`: fewest falls on the clip, then fewest falls of the disturbed episodes, then
   longest up, then the smaller tracking error); the curve and the resumable state are written
   after every iteration.

For the last ``rl_share`` of the budget (half by default) the best network is then fine-tuned
with PPO (:mod:`.finetune`), evaluated and written the same way.

Outputs beside the policy ``POLICY.npz``: ``POLICY.curve.png`` (the curve),
``POLICY.curve.json`` (its numbers), ``POLICY.learn.pt`` (data set, network and optimiser
state, curve: ``resume=True`` continues from it) and, once fine-tuning has started,
``POLICY.ppo.zip`` (the PPO model). Every file is written atomically after every
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
from .curve import plot_curve
from .finetune import FinetuneOptions
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
        eval_phases, eval_seconds: the evaluation episodes on the clip (undisturbed).
        eval_perturbed, eval_pushes, eval_push_force: the disturbed validation episodes
            (:func:`_eval_jobs`; none by default, docs/learning.md "Where it fails"): perturbed
            starts (``perturb``, ``eval_seconds`` long) and pushes (``eval_push_force`` N for
            ``push_duration`` s, 1 s in, 3 s after it).
        threads: torch threads while training.
        rl_share: the share of the budget spent on RL fine-tuning after DAgger
            (:mod:`.finetune`: PPO from the best distilled network; 0: DAgger only).
        rl_chunk: PPO steps between two evaluations of the fine-tuned actor.
        finetune: PPO's settings (:class:`~.finetune.FinetuneOptions`).
    """

    minutes: float = 60.0
    seed: int = 0
    workers: int | None = None
    executor: str = "local"
    ray_address: str | None = None
    episodes: int | None = None
    episode_seconds: float = 4.0
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
    eval_perturbed: int = 0
    eval_pushes: int = 0
    eval_push_force: float = 100.0
    threads: int = 1
    rl_share: float = 0.5
    rl_chunk: int = 20_000
    finetune: FinetuneOptions = field(default_factory=FinetuneOptions)


def outputs(policy: str | os.PathLike) -> dict[str, Path]:
    """The files a learn run writes for policy path ``policy``."""
    p = Path(policy)
    stem = p.with_suffix("")
    return {"policy": p, "curve": Path(f"{stem}.curve.png"), "numbers": Path(f"{stem}.curve.json"),
            "state": Path(f"{stem}.learn.pt"), "rl_state": Path(f"{stem}.ppo.zip")}


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


def _eval_jobs(opts: LearnOptions, policy) -> tuple[list[Episode], list[Episode]]:
    """The evaluation episodes, the same at every iteration: ``(on the clip, disturbed)``.

    On the clip: ``eval_phases`` starts at evenly spaced phases. Disturbed (a validation set
    whose seeds, phases and directions are not the training episodes' draws): perturbed starts
    at the phases between those; pushes at ``eval_pushes`` evenly spaced phases, 1 s in, their
    directions stepping by 135 degrees (eight different directions in eight pushes)."""
    def job(seed, phase, seconds, **kw):
        return Episode(seed=seed, phase=phase, seconds=seconds, beta=0.0, noise=0.0,
                       policy=policy, label=False, **kw)

    clip = [job(1000 + i, i / opts.eval_phases, opts.eval_seconds)
            for i in range(opts.eval_phases)]
    n, m = opts.eval_perturbed, opts.eval_pushes
    disturbed = [job(2000 + i, (i + 0.5) / n, opts.eval_seconds, perturb=tuple(opts.perturb))
                 for i in range(n)]
    f, dur = opts.eval_push_force, opts.push_duration
    for i in range(m):
        ang = math.radians(22.5 + 135.0 * i)
        disturbed.append(job(3000 + i, i / m, 1.0 + dur + 3.0,
                             push=(1.0, f * math.cos(ang), f * math.sin(ang), dur)))
    return clip, disturbed


def learn(setup: LearnSetup, out, opts: LearnOptions | None = None, *, resume: bool = False,
          progress=None, log=None) -> dict:
    """Run DAgger (module docstring) for ``1 - opts.rl_share`` of ``opts.minutes`` of wall
    time, then fine-tune the best network with PPO for the rest (:mod:`.finetune`); returns a
    summary (iterations, labels, data set size, wall time, the last evaluation).

    Args:
        setup: the clip, model and labeller settings (:class:`~.collect.LearnSetup`).
        out: the policy file to write (``.npz``); the other outputs sit beside it.
        resume: continue from ``out``'s ``.learn.pt`` state (data set, network, curve; the
            PPO model ``.ppo.zip`` once fine-tuning has started).
        progress: a :class:`~mjchar.progress.Progress` (a bar over the budget).
        log: ``log(line)`` after each iteration (``None``: silent).
    """
    opts = opts or LearnOptions()
    if not 0.0 <= opts.rl_share < 1.0:
        raise LearnError(f"rl_share must be in [0, 1) (fine-tuning starts from a distilled "
                         f"network), got {opts.rl_share:g}")
    if opts.rl_share > 0:
        from .finetune import import_sb3

        import_sb3()  # before anything long: the one-line install hint
    run = _LearnRun(setup, out, opts, resume)
    if progress is not None:
        progress.start(opts.minutes, unit="min", desc="learning")
    with episode_pool(setup, opts.workers, executor=opts.executor,
                      address=opts.ray_address) as pool:
        if run.stage == "dagger":
            run.dagger(pool, 60.0 * opts.minutes * (1.0 - opts.rl_share), progress, log)
        if opts.rl_share > 0 and run.left() > 0:
            run.finetune(pool, progress, log)
    if progress is not None:
        progress.close()
    summary = dict(run.summary)
    summary.update(outputs={k: str(v) for k, v in run.files.items() if v.exists()})
    return summary


class _LearnRun:
    """One ``learn`` call: its outputs, data set, network, curve and clock."""

    def __init__(self, setup: LearnSetup, out, opts: LearnOptions, resume: bool):
        self.torch = import_torch()
        self.setup, self.opts, self.files = setup, opts, outputs(out)
        self.t_start = time.perf_counter()
        env = make_env(setup)
        self.meta = policy_metadata(setup, env)
        self.clip_text = Path(setup.clip).read_text() if os.path.isfile(setup.clip) else None
        n_in, nu = env.observation_space.shape[0], env.action_space.shape[0]
        env.close()
        self.trainer = Trainer(n_in, nu, opts.hidden, lr=opts.lr, batch=opts.batch,
                               seed=opts.seed, threads=opts.threads)
        self.X = np.zeros((0, n_in), np.float32)
        self.Y = np.zeros((0, nu), np.float32)
        self.curve, self.it, self.elapsed0, self.labels, self.label_s = _Curve(), 0, 0.0, 0, 0.0
        self.best = None  # the evaluation score of the network in the policy file (_score)
        self.stage, self.rl_steps, self.summary = "dagger", 0, {}
        if resume:
            self._resume()
        self.rng = np.random.default_rng([opts.seed, self.it])

    def _resume(self) -> None:
        files = self.files
        if not files["state"].is_file():
            raise LearnError(f"{files['state']}: nothing to resume (no learn state beside "
                             f"{files['policy']}); run without --resume")
        st = self.torch.load(files["state"], weights_only=False)
        meta = self.meta
        if st["meta"]["clip"]["hash"] != meta["clip"]["hash"] or (
                st["meta"]["model"]["fingerprint"] != meta["model"]["fingerprint"]):
            raise LearnError(f"{files['state']} was learned on another clip or model; give "
                             "another -o or run without --resume")
        self.X, self.Y = st["X"], st["Y"]
        self.trainer.load_state(st["trainer"])
        self.best = st.get("best")
        if self.best is not None and len(self.best) == 3:  # written before the disturbed
            self.best = (self.best[0], 0.0, *self.best[1:])  # episodes: none of them fell
        self.curve.rows = st["curve"]
        self.it, self.elapsed0 = st["iteration"], st["elapsed_s"]
        self.labels, self.label_s = st["labels"], st["label_seconds"]
        self.stage, self.rl_steps = st.get("stage", "dagger"), st.get("rl_steps", 0)
        if self.stage == "rl" and not files["rl_state"].is_file():
            raise LearnError(f"{files['rl_state']}: the fine-tuning state is missing; run "
                             "without --resume")

    def wall(self) -> float:
        """Seconds of learning so far (this call and the runs it resumes)."""
        return self.elapsed0 + time.perf_counter() - self.t_start

    def left(self) -> float:
        """Seconds of this call's budget left."""
        return 60.0 * self.opts.minutes - (time.perf_counter() - self.t_start)

    def dagger(self, pool, budget: float, progress, log) -> None:
        """DAgger iterations until ``budget`` seconds of this call have passed (one at least,
        unless the budget is none)."""
        opts = self.opts
        policy = self.trainer.mlp() if len(self.X) else None
        n_episodes = opts.episodes or pool.parallelism
        last = 0.0  # the last iteration's wall time: one that would not end in time is not begun
        while budget > 0:
            if time.perf_counter() - self.t_start + last > budget and self.summary:
                break
            began = time.perf_counter()
            beta = opts.beta_decay ** self.it
            w = time.perf_counter()
            results = pool.map(_episodes(opts, self.rng, n_episodes, beta, policy))
            collect_s = time.perf_counter() - w
            new = sum(len(r.obs) for r in results)
            self.X = np.concatenate([self.X] + [r.obs for r in results])
            self.Y = np.concatenate([self.Y] + [r.labels for r in results])
            self.labels += new
            self.label_s += sum(r.label_seconds for r in results)
            w = time.perf_counter()
            before, after = self.trainer.fit(self.X, self.Y, opts.epochs, opts.max_steps)
            train_s = time.perf_counter() - w
            policy = self.trainer.mlp()
            self._record(pool, policy, progress, log, stage="dagger", beta=beta,
                         loss_before=before, loss_after=after, collect_s=collect_s,
                         train_s=train_s, labels_per_s=new / max(collect_s, 1e-9),
                         clipped=float(np.mean([r.clipped for r in results])),
                         expert_falls=int(sum(r.fell for r in results)))
            last = time.perf_counter() - began

    def finetune(self, pool, progress, log) -> None:
        """PPO from the best network so far (the policy file's) until the budget ends."""
        from mjchar.controllers.learned.policy_file import load_policy

        from .finetune import Finetuner

        opts = self.opts
        # the policy file holds the network fine-tuning starts from (the best distilled one),
        # and every fine-tuned network written keeps its input normalisation
        start = load_policy(self.files["policy"]).net
        saved = self.files["rl_state"] if self.stage == "rl" else None
        tuner = Finetuner(self.setup, start, opts, opts.finetune, saved=saved,
                          data=(self.X, self.Y))
        self.stage = "rl"
        try:
            last = 0.0  # as in DAgger: a chunk that would not end in time is not begun
            while self.left() > last:
                w = time.perf_counter()
                tuner.train(opts.rl_chunk)
                train_s = time.perf_counter() - w
                self.rl_steps = tuner.steps
                tuner.save(self.files["rl_state"])
                loss = tuner.label_loss()
                extra = {} if loss is None else {"label_loss": loss}
                self._record(pool, tuner.mlp(), progress, log, stage="rl", beta=0.0,
                             train_s=train_s, rl_steps=tuner.steps, **extra)
                last = time.perf_counter() - w
        finally:
            tuner.close()

    def _record(self, pool, policy, progress, log, **numbers) -> None:
        """Evaluate ``policy`` alone, add the curve's row, write the policy file when it is
        the best so far, the state and the curve."""
        opts = self.opts
        w = time.perf_counter()
        clip, disturbed = _eval_jobs(opts, policy)
        results = pool.map(clip + disturbed)
        ev, dist = results[:len(clip)], results[len(clip):]
        eval_s = time.perf_counter() - w
        self.it += 1
        wall = self.wall()
        row = {"iteration": self.it, "wall_s": wall, "labels": self.labels,
               "data": int(len(self.X)), **numbers,
               "eval_error_m": float(np.mean([r.tracking_error_m for r in ev])),
               "eval_fall_rate": float(np.mean([r.fell for r in ev])),
               "eval_survived_s": float(np.mean([r.sim_seconds for r in ev])),
               "eval_return": float(np.mean([r.episode_return for r in ev])),
               "eval_s": eval_s}
        if dist:
            row["disturbed_fall_rate"] = float(np.mean([r.fell for r in dist]))
        score = _score(row)
        row["written"] = self.best is None or score <= self.best
        self.curve.add(**row)
        if row["written"]:  # the policy file holds the best network evaluated so far
            self.best = score
            method = "DAgger + DART, MPC labels"
            if row["stage"] == "rl":
                method += f", then PPO fine-tuning ({row['rl_steps']} steps)"
            meta_now = dict(self.meta, training={
                "method": method, "iteration": self.it, "iterations": self.it,
                "labels": self.labels, "wall_s": wall, "label_seconds": self.label_s,
                "rl_steps": self.rl_steps,
                "setup": _jsonable(_named(asdict(self.setup))), "options": _jsonable(asdict(opts)),
                "eval": {k: row[k] for k in ("eval_error_m", "eval_fall_rate",
                                             "eval_survived_s", "disturbed_fall_rate")
                         if k in row}})
            save_policy(self.files["policy"], policy, meta_now, self.clip_text)
        _save_state(self.torch, self.files["state"], X=self.X, Y=self.Y,
                    trainer=self.trainer.state(), curve=self.curve.rows, iteration=self.it,
                    elapsed_s=wall, labels=self.labels, label_seconds=self.label_s,
                    meta=self.meta, best=self.best, stage=self.stage, rl_steps=self.rl_steps)
        _save_curve(self.files, self.curve.rows)
        self.summary = dict(row)
        if log is not None:
            log(_line(row))
        if progress is not None:
            progress.update(min(opts.minutes, (time.perf_counter() - self.t_start) / 60.0))


def _score(row: dict) -> tuple:
    """How an iteration's network ranks (smaller is better): fewer falls on the clip, then
    fewer falls of the disturbed episodes, then longer up on the clip, then a smaller tracking
    error."""
    return (round(row["eval_fall_rate"], 6), round(row.get("disturbed_fall_rate", 0.0), 6),
            -round(row["eval_survived_s"], 6), row["eval_error_m"])


def _line(row: dict) -> str:
    if row.get("stage") == "rl":
        head = (f"it {row['iteration']:3d}  {row['wall_s'] / 60:6.1f} min  PPO steps "
                f"{row['rl_steps']:8d} ({row['train_s']:.0f} s)")
        if "label_loss" in row:  # (fine-tuning with behaviour cloning on the labels)
            head += f"  label loss {row['label_loss']:.4f}"
    else:
        head = (f"it {row['iteration']:3d}  {row['wall_s'] / 60:6.1f} min  beta "
                f"{row['beta']:.3f}  labels {row['labels']:6d} ({row['labels_per_s']:.2f}/s)  "
                f"loss {row['loss_before']:.4f}->{row['loss_after']:.4f}")
    disturbed = ("" if "disturbed_fall_rate" not in row
                 else f"  disturbed falls {row['disturbed_fall_rate']:.2f}")
    return (f"{head}  eval error {100 * row['eval_error_m']:.1f} cm  falls "
            f"{row['eval_fall_rate']:.2f}  survived {row['eval_survived_s']:.1f} s{disturbed}"
            + ("  (written)" if row.get("written") else ""))


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
    plot_curve(rows, files["curve"])  # (nothing without matplotlib: the numbers suffice)


def with_options(opts: LearnOptions, **kw) -> LearnOptions:
    """``opts`` with fields replaced (unknown names: :class:`LearnError`)."""
    names = set(LearnOptions.__dataclass_fields__)
    bad = [k for k in kw if k not in names]
    if bad:
        raise LearnError(f"unknown learn option(s) {', '.join(bad)}; valid: "
                         f"{', '.join(sorted(names))}")
    return replace(opts, **kw)
