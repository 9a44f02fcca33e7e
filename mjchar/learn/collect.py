"""Episodes for imitation learning: roll out a mixture of the MPC and the learner, label the
visited states with the MPC.

One :class:`Collector` per worker process holds an ``mjchar/Imitation-v0`` environment on the
clip (:class:`~mjchar.envs.imitation.ImitationEnv`, the policy's observation and action) and a
sampling MPC on its own :class:`~mjchar.controllers.core.character.Character` of the same model
(:class:`~mjchar.controllers.sampling.mpc.MpcController`, the expert). An :class:`Episode` job
says where to start (phase, perturbed start), what to push, which policy drives and with how much
noise; :meth:`Collector.run` returns the visited observations, the expert's labels and what
happened (:class:`EpisodeResult`).

At each control step ``n`` of an episode (DAgger, Ross, Gordon and Bagnell 2011; DART, Laskey et
al. 2017):

1. the observation ``o_n`` and the state are read;
2. the expert labels the state: :meth:`MpcController.plan` from the state at the clip time, warm
   started from its previous plan in this episode (``nominal="plan"``) or from the learner's own
   PD targets (``nominal="learner"``); the label ``a*_n`` is the plan's PD targets averaged over
   the coming control period, expressed in the env's scaled action space
   (``(u - base) / s``, clipped to [-1, 1]);
3. the executed action is ``a*_n`` with probability ``beta``, else the learner's ``pi(o_n)``,
   plus Gaussian noise of ``noise`` (DART), clipped to [-1, 1].
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from mjchar.controllers.core.character import Character
from mjchar.controllers.learned.mlp import MLP
from mjchar.controllers.sampling.mpc import Plan, make_mpc

__all__ = ["LearnSetup", "Episode", "EpisodeResult", "Collector", "plan_average", "make_env"]

NOMINALS = ("plan", "learner")


@dataclass(frozen=True)
class LearnSetup:
    """What every worker builds (picklable).

    Attributes:
        clip: the clip (a bundled name or a BVH path).
        loop: track a seamless cycle cut from the clip (as ``mjchar run --loop``).
        model: ``None`` (the bundled humanoid) or an MJCF path.
        future_steps: reference poses in the observation, control steps ahead
            (:class:`~mjchar.envs.imitation.ImitationEnv`).
        label_samples: the expert's candidates per label (``None``: the MPC's default).
        label_nominal: what labels are warm started from: ``"plan"`` (the expert's previous
            plan in the episode) or ``"learner"`` (the learner's PD targets, once there is one).
        mpc_options: further :class:`~mjchar.controllers.sampling.mpc.MpcOptions`.
        max_tracking_error: the env's early termination (m).
    """

    clip: str
    loop: bool = True
    model: str | None = None
    future_steps: tuple[int, ...] = (1,)
    label_samples: int | None = None
    label_nominal: str = "plan"
    mpc_options: dict = field(default_factory=dict)
    max_tracking_error: float = 0.3


@dataclass(frozen=True)
class Episode:
    """One rollout to collect (picklable).

    Attributes:
        seed: the episode's random stream (env reset, noise, mixture draws, labels).
        phase: start phase in [0, 1].
        seconds: simulated length.
        beta: probability that the expert's label is executed at a step (1: the expert drives).
        noise: standard deviation of the Gaussian noise added to the executed action.
        perturb: ``(joint_noise rad, root_velocity_noise m/s)`` of a perturbed start, or ``None``.
        push: ``(start s, fx N, fy N, duration s)`` on the root, or ``None``.
        policy: the learner (:class:`~mjchar.controllers.learned.mlp.MLP`), ``None`` before the
            first training.
        label: label the visited states (``False``: only roll out, e.g. to evaluate).
    """

    seed: int
    phase: float
    seconds: float
    beta: float = 1.0
    noise: float = 0.0
    perturb: tuple[float, float] | None = None
    push: tuple[float, float, float, float] | None = None
    policy: MLP | None = None
    label: bool = True


@dataclass
class EpisodeResult:
    """What an episode gave: ``obs (n, d)`` and ``labels (n, nu)`` (float32; empty when not
    labelled), ``steps`` control steps, ``fell`` (a fall or the tracking limit ended it),
    ``tracking_error_m`` (the env's mean joint error over the episode), ``clipped`` (fraction of
    label entries clipped to [-1, 1]), ``label_seconds`` (wall time spent labelling),
    ``seconds`` (wall time in all), ``sim_seconds`` (simulated time reached), ``reason`` (why
    it ended early), ``episode_return`` (the env's summed reward)."""

    obs: np.ndarray
    labels: np.ndarray
    steps: int
    fell: bool
    tracking_error_m: float
    clipped: float
    label_seconds: float
    seconds: float
    sim_seconds: float
    reason: str | None = None
    episode_return: float = 0.0


def make_env(setup: LearnSetup, **env_options):
    """The ``mjchar/Imitation-v0`` environment of ``setup``: the clip prepared as ``mjchar run``
    prepares it for a tracker (placed on the floor, looped with ``loop``); ``env_options``:
    further :class:`~mjchar.envs.imitation.ImitationEnv` options (default: no time limit)."""
    from mjchar.controllers.core.builder import RunSpec, load_reference
    from mjchar.envs.imitation import ImitationEnv

    env_options.setdefault("episode_seconds", 1e6)
    return ImitationEnv(_reference(setup, load_reference, RunSpec), model=setup.model,
                        future_steps=setup.future_steps,
                        max_tracking_error=setup.max_tracking_error, **env_options)


def _reference(setup: LearnSetup, load_reference, RunSpec):
    spec = RunSpec("mpc", "track", model=setup.model, motion=setup.clip, loop=setup.loop,
                   floor="contact")
    return load_reference(spec, Character(setup.model))


def plan_average(plan: Plan, t: float, dt: float) -> np.ndarray:
    """``(nu,)`` the plan's PD targets averaged over ``[t, t + dt)`` (s; the controls' overlap
    with the interval as weights): what one held action of ``dt`` seconds best replaces."""
    c, n = plan.control_dt, len(plan.targets)
    start = plan.time + c * np.arange(n)
    end = np.append(start[1:], np.inf)  # the last control held past the horizon
    w = np.maximum(np.minimum(end, t + dt) - np.maximum(start, t), 0.0)
    if not w.sum() > 0:
        return plan.target(t)
    return w @ plan.targets / w.sum()


class Collector:
    """A worker's environment and expert (see the module docstring)."""

    def __init__(self, setup: LearnSetup):
        if setup.label_nominal not in NOMINALS:
            raise ValueError(f"label_nominal must be one of {NOMINALS}")
        self.setup = setup
        self.env = make_env(setup)
        options = dict(setup.mpc_options)
        if setup.label_samples is not None:
            options["samples"] = int(setup.label_samples)
        options.setdefault("threads", 1)
        self._mpc_character = Character(setup.model)
        self.mpc = make_mpc(self._mpc_character, self.env.reference, **options)
        self.mpc.reset(self._mpc_character)
        self.scale = self.env.action_scale_rad
        m = self.env.character.model
        self.root_name = m.body(self.env.character.root_body).name

    def close(self) -> None:
        self.mpc.close()
        self.env.close()

    def snap(self, phase: float) -> float:
        """``phase`` moved to the nearest start on the expert's control grid: the clip times an
        episode visits then fall on a few offsets from that grid (three at 30 Hz against 0.02
        s), whose reference grids the expert computes once and keeps."""
        T, c = self.env.reference.duration, self.mpc.options.control_dt
        n = int(round(float(phase) * T / c))
        while n * c > T and n > 0:
            n -= 1
        return min(1.0, n * c / T)

    def label(self, nominal) -> np.ndarray:
        """``(nu,)`` the expert's action (scaled, not yet clipped) at the env's current state,
        warm started from ``nominal`` (a Plan, PD targets or ``None``)."""
        env = self.env
        t = env.reference_time
        plan = self.mpc.plan(env.character.state.get_physics(), t, nominal)
        self._plan = plan
        u = plan_average(plan, t, env.control_dt)
        return (u - env.base_action().target) / self.scale

    def run(self, job: Episode) -> EpisodeResult:
        """Roll ``job`` out (module docstring); the expert's plans start cold."""
        w0 = time.perf_counter()
        env, rng = self.env, np.random.default_rng(job.seed)
        # the labeller restarts from the job too (its random stream, its noise boost): an
        # episode depends on nothing the worker ran before it, local or on Ray
        self.mpc.restart(seed=int(job.seed))
        options = {"phase": self.snap(job.phase)}
        if job.perturb is not None:
            options["perturb"] = tuple(float(x) for x in job.perturb)
        obs, info = env.reset(seed=int(rng.integers(2**31)), options=options)
        if job.push is not None:
            t0, fx, fy, dur = job.push
            env.character.pushes.add(self.root_name, (fx, fy, 0.0), dur, start=t0)
        self._plan = None
        n_steps = int(round(job.seconds / env.control_dt))
        X, Y = [], []
        label_s, clipped, fell, reason, ret = 0.0, 0, False, None, 0.0
        for _ in range(n_steps):
            pred = None if job.policy is None else np.clip(job.policy(obs), -1.0, 1.0)
            a_star = None
            if job.label:
                w = time.perf_counter()
                nominal = self._plan
                if self.setup.label_nominal == "learner" and pred is not None:
                    nominal = env.base_action().target + self.scale * pred
                a_star = self.label(nominal)
                label_s += time.perf_counter() - w
                clipped += int(np.count_nonzero(np.abs(a_star) > 1.0))
                a_star = np.clip(a_star, -1.0, 1.0)
                X.append(obs)
                Y.append(a_star.astype(np.float32))
            if pred is None or (a_star is not None and rng.random() < job.beta):
                a = a_star if a_star is not None else np.zeros(env.action_space.shape)
            else:
                a = pred
            if job.noise > 0:
                a = a + rng.normal(0.0, job.noise, a.shape)
            obs, reward, terminated, truncated, info = env.step(np.clip(a, -1.0, 1.0))
            ret += reward
            if terminated:
                fell, reason = True, info["termination_reason"]
                break
            if truncated:
                break
        nu = env.action_space.shape[0]
        n = len(X)
        return EpisodeResult(
            obs=np.asarray(X, dtype=np.float32).reshape(n, env.observation_space.shape[0]),
            labels=np.asarray(Y, dtype=np.float32).reshape(n, nu),
            steps=int(round(env.sim_time / env.control_dt)), fell=fell,
            tracking_error_m=float(info["tracking_error_m"]),
            clipped=clipped / max(n * nu, 1), label_seconds=label_s,
            seconds=time.perf_counter() - w0, sim_seconds=float(env.sim_time), reason=reason,
            episode_return=ret)


# -- the worker processes' side ---------------------------------------------------------------
_COLLECTOR: Collector | None = None


def init_worker(setup: LearnSetup) -> None:
    """Process-pool initializer: one :class:`Collector` per worker."""
    global _COLLECTOR
    _COLLECTOR = Collector(setup)


def run_episode(job: Episode) -> EpisodeResult:
    """Process-pool task: run ``job`` on this worker's collector."""
    return _COLLECTOR.run(job)
