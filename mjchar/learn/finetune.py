"""RL fine-tuning of a distilled policy: PPO (stable-baselines3) on ``mjchar/Imitation-v0``,
starting from the network DAgger learned (:mod:`.dagger`).

The policy network becomes the PPO actor's mean (Schulman et al. 2017, "Proximal Policy
Optimization Algorithms"; a distilled actor as PPO's start, as in Peng et al. 2018's DeepMimic
fine-tuning of pre-trained policies):

- its hidden layers are stable-baselines3's ``mlp_extractor.policy_net`` (ELU) and its output
  layer the ``action_net``; the input normalisation is folded into the first layer
  (``W' = W / std``, ``b' = b - W' mean``), so PPO sees the env's raw observation, and unfolded
  again when the actor is written as a policy file (:func:`actor_mlp`: the same outputs);
- the critic starts untrained: for ``critic_warmup`` steps only the critic learns (the actor
  frozen), so the first policy updates do not follow a random value function;
- the action noise starts at ``init_std`` (the DART noise the network was distilled with), and
  the step size is small (``lr`` 1e-5, 3 epochs per rollout): with stable-baselines3's usual
  3e-4 and 10 epochs the first updates wreck the distilled actor (docs/learning.md);
- the training episodes are DAgger's (:class:`Perturbations`): random phases of the clip, some
  from a perturbed start, some with one push, ``episode_seconds`` long, so the reward the actor
  climbs includes recovering;
- an episode ends past ``max_tracking_error`` of mean joint error; with ``recovery_seconds``
  (0 by default) not for that long from a perturbed start or from a push's start, where only a
  fall ends it: a recovery passes through larger errors (the bundled walk60 policy's did:
  15-48 cm after the 100 N pushes it survived, past 12 cm within 0.1-0.7 s of every perturbed
  start), and a 12 cm end there cuts every recovering episode before it recovers. An hour of
  ``mjchar learn`` with 3 s of it made no more robust a policy (docs/learning.md);
- with ``curriculum_steps`` (0 by default) the disturbances grow: the perturbed starts' noise
  and the pushes' forces are ``curriculum_start`` of DAgger's at the first episode and reach
  them linearly after ``curriculum_steps`` PPO steps (a curriculum, Bengio et al. 2009), so
  early PPO updates see recoveries that can succeed; the rates of perturbed and pushed episodes
  stay DAgger's. An episode's size is set at its reset; the count starts again when a
  fine-tuning is resumed. An hour with it made no more robust a policy (docs/learning.md);
- with ``bc_steps`` (0 by default) the MPC's labels stay in the objective: after each rollout,
  before PPO's update, ``bc_steps`` minibatches of ``bc_batch`` (observation, label) pairs of
  DAgger's data set (perturbed and pushed episodes included) step the actor's mean towards the
  labels (mean squared error, Adam at ``lr``), so PPO climbs the reward near the planner's
  actions instead of drifting from them (the behaviour-cloning term of Rajeswaran et al.
  2018's DAPG, applied between PPO's updates). An hour with it tracked closer and recovered
  less (docs/learning.md).

PyTorch and stable-baselines3 are imported here only (the ``rl`` extra).
"""

from __future__ import annotations

import functools
import math
import os
from dataclasses import dataclass, field, replace

import gymnasium
import numpy as np

from mjchar.controllers.learned.mlp import MLP

from .collect import LearnSetup, make_env
from .train import LearnError, import_torch

__all__ = ["FinetuneOptions", "Finetuner", "Perturbations", "actor_mlp", "import_sb3",
           "load_actor"]


@dataclass(frozen=True)
class FinetuneOptions:
    """PPO's settings for fine-tuning (module docstring).

    Attributes:
        lr: Adam's step size; epochs: passes over each rollout.
        init_std: the actor's initial action noise (standard deviation, scaled action units).
        critic_warmup: steps in which only the critic learns.
        critic_hidden: the critic's hidden layer widths.
        n_steps: env steps per rollout (over all envs); batch: minibatch size.
        envs: training environments (more than 1: one process each; ``None``: one per core).
        episode_seconds: length of a training episode (s).
        max_tracking_error: the training env's early termination (m): an episode ends when
            the mean joint error passes it, so the actor learns to stay near the clip (with
            the env's default, 0.3 m, a policy drifting 15 cm from the clip still scores).
        recovery_seconds: for this long from a perturbed start or from a push's start, only
            a fall ends an episode (module docstring); 0: the error ends it there too.
        reward_weights, reward_scales: the training env's reward terms
            (:class:`~mjchar.envs.imitation.ImitationEnv`; evaluations use the tracking error,
            not the reward): DeepMimic's, with more weight on the centre of mass and a sharper
            scale, as the tracking error counts the root's drift that the pose term ignores.
        curriculum_steps, curriculum_start: PPO steps (over all envs) over which the
            disturbances grow from ``curriculum_start`` of their size to all of it (module
            docstring); 0: full size from the start.
        bc_steps, bc_batch: behaviour-cloning minibatches on the MPC's labels after each
            rollout, and their size (module docstring); 0: PPO alone.
    """

    lr: float = 1e-5
    epochs: int = 3
    init_std: float = 0.1
    critic_warmup: int = 4096
    critic_hidden: tuple[int, ...] = (256, 256)
    n_steps: int = 2048
    batch: int = 64
    envs: int | None = None
    episode_seconds: float = 10.0
    max_tracking_error: float = 0.12
    recovery_seconds: float = 0.0
    reward_weights: dict = field(default_factory=lambda: {
        "pose": 0.55, "velocity": 0.1, "end_effector": 0.15, "com": 0.2})
    reward_scales: dict = field(default_factory=lambda: {"com": 40.0})
    curriculum_steps: int = 0
    curriculum_start: float = 0.25
    bc_steps: int = 0
    bc_batch: int = 256


def import_sb3():
    """``stable_baselines3``, or a one-line :class:`LearnError` saying how to install it."""
    import_torch()
    try:
        import stable_baselines3
    except ImportError:
        raise LearnError("RL fine-tuning needs stable-baselines3 (the rl extra): pip install "
                         "stable-baselines3; or learn without it (--rl-share 0)") from None
    return stable_baselines3


class Perturbations(gymnasium.Wrapper):
    """Wraps an Imitation-v0 env so its episodes are DAgger's training episodes: with
    probability ``perturb_rate`` a reset starts perturbed by ``perturb`` (joint noise rad, root
    velocity noise m/s); with probability ``push_rate`` one horizontal push on the root of
    ``push_force`` N (uniform in the range) in a random direction for ``push_duration`` s,
    starting uniformly in ``[0.2, episode_seconds - push_duration - 0.5]`` s. The draws come
    from ``numpy.random.default_rng(seed)``. For ``recovery`` s from a perturbed start or a
    push's start the env's ``max_tracking_error`` is lifted (only a fall ends the episode).
    With ``ramp`` steps, the perturbation's noise and the push's force are scaled by
    ``ramp_start`` at the first reset, growing linearly with this env's steps to 1 after
    ``ramp`` of them (:meth:`scale`, read at each reset).
    """

    def __init__(self, env, opts, seconds: float, seed: int, recovery: float = 0.0,
                 ramp: int = 0, ramp_start: float = 1.0):
        super().__init__(env)
        self.opts, self.seconds, self.recovery = opts, float(seconds), float(recovery)
        self.ramp, self.ramp_start, self.steps = int(ramp), float(ramp_start), 0
        self.rng = np.random.default_rng(seed)
        ch = env.unwrapped.character
        self.root = ch.model.body(ch.root_body).name
        self.max_error = env.unwrapped.max_tracking_error
        self.windows: list[tuple[float, float]] = []

    def scale(self) -> float:
        """The disturbances' size at the next reset, as a fraction of DAgger's."""
        if self.ramp <= 0:
            return 1.0
        x = min(self.steps / self.ramp, 1.0)
        return self.ramp_start + (1.0 - self.ramp_start) * x

    def reset(self, *, seed=None, options=None):
        o, rng = self.opts, self.rng
        k = self.scale()
        options = dict(options or {})
        self.windows = []
        self.env.unwrapped.max_tracking_error = self.max_error
        if rng.random() < o.perturb_rate:
            options["perturb"] = tuple(k * float(x) for x in o.perturb)
            self._recover_from(0.0)
        out = self.env.reset(seed=seed, options=options)
        if rng.random() < o.push_rate:
            f, ang = k * rng.uniform(*o.push_force), rng.uniform(0.0, 2.0 * math.pi)
            t0 = rng.uniform(0.2, max(0.3, self.seconds - o.push_duration - 0.5))
            self.env.unwrapped.character.pushes.add(
                self.root, (f * math.cos(ang), f * math.sin(ang), 0.0), o.push_duration,
                start=t0)
            self._recover_from(t0)
        return out

    def _recover_from(self, t: float) -> None:
        if self.recovery > 0:  # (none: the env's error end holds throughout, untouched)
            self.windows.append((t, t + self.recovery))

    def step(self, action):
        self.steps += 1
        if self.windows:
            env = self.env.unwrapped
            t = env.character.time
            recovering = any(a <= t < b for a, b in self.windows)
            env.max_tracking_error = None if recovering else self.max_error
        return self.env.step(action)


def training_env(setup: LearnSetup, opts, ft: FinetuneOptions, seed: int, n_envs: int = 1):
    """One of ``n_envs`` training envs: Imitation-v0 on the setup's clip with ``ft``'s
    episodes, termination and reward, and DAgger's perturbations (``opts``: a
    :class:`~.dagger.LearnOptions`; the curriculum's steps shared among the envs, which step
    together), in a Monitor."""
    from stable_baselines3.common.monitor import Monitor

    env = make_env(replace(setup, max_tracking_error=ft.max_tracking_error),
                   episode_seconds=ft.episode_seconds, reward_weights=dict(ft.reward_weights),
                   reward_scales=dict(ft.reward_scales))
    return Monitor(Perturbations(env, opts, ft.episode_seconds, seed, ft.recovery_seconds,
                                 ramp=math.ceil(ft.curriculum_steps / n_envs),
                                 ramp_start=ft.curriculum_start))


def load_actor(model, net: MLP, init_std: float) -> None:
    """Copy ``net``'s layers into the PPO ``model``'s actor, the input normalisation folded
    into the first layer (module docstring); the action noise set to ``init_std``."""
    import torch

    lin = _actor_layers(model)
    if [tuple(m.weight.shape) for m in lin] != [w.shape for w in net.weights[:-1]]:
        raise LearnError("the PPO actor's layers do not match the policy's network")
    W0 = net.weights[0] / net.std
    b0 = net.biases[0] - W0 @ net.mean
    layers = [(W0, b0)] + list(zip(net.weights[1:-1], net.biases[1:-1], strict=True))
    with torch.no_grad():
        for m, (w, b) in zip(lin, layers, strict=True):
            m.weight.copy_(torch.as_tensor(w))
            m.bias.copy_(torch.as_tensor(b))
        model.policy.action_net.weight.copy_(torch.as_tensor(net.weights[-1]))
        model.policy.action_net.bias.copy_(torch.as_tensor(net.biases[-1]))
        model.policy.log_std.fill_(math.log(init_std))


def actor_mlp(model, like: MLP) -> MLP:
    """The PPO ``model``'s actor mean as an :class:`MLP` with ``like``'s input normalisation
    (the inverse of :func:`load_actor`'s folding: the same outputs as the actor)."""
    def arr(t):
        return t.detach().double().numpy().copy()

    lin = [*_actor_layers(model), model.policy.action_net]
    W, B = [arr(m.weight) for m in lin], [arr(m.bias) for m in lin]
    W[0], B[0] = W[0] * like.std, B[0] + W[0] @ like.mean
    return MLP(W, B, like.mean.copy(), like.std.copy())


def _actor_mean(model, obs):
    """The PPO ``model``'s actor mean for a batch of raw observations (a torch tensor)."""
    policy = model.policy
    return policy.action_net(policy.mlp_extractor.forward_actor(policy.extract_features(obs)))


def _label_cloning(model, data, ft: FinetuneOptions, seed: int):
    """A stable-baselines3 callback that, at each rollout's end (before PPO's update), takes
    ``ft.bc_steps`` Adam steps of the actor mean's squared error on minibatches of ``data``."""
    import torch
    from stable_baselines3.common.callbacks import BaseCallback

    X = torch.as_tensor(np.asarray(data[0]), dtype=torch.float32)
    Y = torch.as_tensor(np.asarray(data[1]), dtype=torch.float32)
    opt = torch.optim.Adam(_actor_parameters(model), lr=ft.lr)
    rng = np.random.default_rng(seed)

    class LabelCloning(BaseCallback):
        def _on_step(self) -> bool:
            return True

        def _on_rollout_end(self) -> None:
            for _ in range(ft.bc_steps):
                idx = torch.from_numpy(rng.integers(0, len(X), min(ft.bc_batch, len(X))))
                loss = torch.mean((_actor_mean(model, X[idx]) - Y[idx]) ** 2)
                opt.zero_grad()
                loss.backward()
                opt.step()

        def loss(self) -> float:
            with torch.no_grad():
                return float(torch.mean((_actor_mean(model, X) - Y) ** 2))

    return LabelCloning()


def _actor_parameters(model) -> list:
    """The parameters of the PPO ``model``'s actor mean (hidden layers and action head)."""
    return [p for m in [*_actor_layers(model), model.policy.action_net] for p in m.parameters()]


def _actor_layers(model) -> list:
    import torch

    return [m for m in model.policy.mlp_extractor.policy_net if isinstance(m, torch.nn.Linear)]


class Finetuner:
    """PPO on the setup's clip from a distilled network (module docstring).

    Args:
        setup: the clip and model (:class:`~.collect.LearnSetup`).
        net: the distilled network (:class:`MLP`): the actor's start and, throughout, the
            input normalisation of the networks :meth:`mlp` returns.
        opts: DAgger's options (:class:`~.dagger.LearnOptions`): the perturbations, the seed,
            torch's threads.
        ft: PPO's settings.
        saved: a model written by :meth:`save` to continue from (``None``: start from ``net``).
        data: DAgger's data set ``(X, Y)`` (raw observations, labels in scaled action units)
            for ``ft.bc_steps``' behaviour cloning (``None``: none).
    """

    def __init__(self, setup: LearnSetup, net: MLP, opts, ft: FinetuneOptions | None = None,
                 *, saved=None, data=None):
        import_sb3()
        import torch
        from stable_baselines3 import PPO
        from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

        self.ft = ft = ft or FinetuneOptions()
        if not (0.0 < ft.curriculum_start <= 1.0 and ft.curriculum_steps >= 0
                and ft.bc_steps >= 0 and ft.bc_batch >= 1):
            raise LearnError(f"fine-tuning options out of range: curriculum_start "
                             f"{ft.curriculum_start:g} (in (0, 1]), curriculum_steps "
                             f"{ft.curriculum_steps} and bc_steps {ft.bc_steps} (>= 0), "
                             f"bc_batch {ft.bc_batch} (>= 1)")
        if ft.bc_steps > 0 and (data is None or len(data[0]) == 0):
            raise LearnError("bc_steps needs DAgger's data set (data=(X, Y)) to clone")
        self.net = net
        torch.set_num_threads(max(1, int(opts.threads)))
        n = int(ft.envs or os.cpu_count() or 1)
        makers = [functools.partial(training_env, setup, opts, ft, int(opts.seed) * 1000 + i, n)
                  for i in range(n)]
        self.env = SubprocVecEnv(makers) if n > 1 else DummyVecEnv(makers)
        self.env.seed(int(opts.seed))
        if saved is not None:
            self.model = PPO.load(saved, env=self.env, device="cpu")
        else:
            self.model = PPO(
                "MlpPolicy", self.env, seed=int(opts.seed), device="cpu", learning_rate=ft.lr,
                n_epochs=ft.epochs, n_steps=max(1, ft.n_steps // n), batch_size=ft.batch,
                policy_kwargs={"net_arch": {"pi": list(net.hidden),
                                            "vf": list(ft.critic_hidden)},
                               "activation_fn": torch.nn.ELU})
            load_actor(self.model, net, ft.init_std)
            if ft.critic_warmup > 0:
                params = _actor_parameters(self.model) + [self.model.policy.log_std]
                for p in params:
                    p.requires_grad_(False)
                self.model.learn(total_timesteps=ft.critic_warmup, reset_num_timesteps=False)
                for p in params:
                    p.requires_grad_(True)
        self.steps = int(self.model.num_timesteps) if saved is not None else 0
        self.cloning = (_label_cloning(self.model, data, ft, int(opts.seed))
                        if ft.bc_steps > 0 else None)

    def train(self, steps: int) -> None:
        """``steps`` more PPO steps (rounded up to whole rollouts), with the labels'
        behaviour cloning after each rollout when ``bc_steps`` asks for it."""
        self.model.learn(total_timesteps=int(steps), reset_num_timesteps=False,
                         callback=self.cloning)
        self.steps = int(self.model.num_timesteps)

    def label_loss(self) -> float | None:
        """The actor mean's squared error on the labels (``None`` without cloning)."""
        return None if self.cloning is None else self.cloning.loss()

    def mlp(self) -> MLP:
        """The actor's mean as a numpy network (:func:`actor_mlp`)."""
        return actor_mlp(self.model, self.net)

    def save(self, path) -> None:
        """Write the PPO model (actor, critic, optimiser) atomically to ``path`` (.zip)."""
        from mjchar.bvh.io.files import atomic_path

        with atomic_path(path) as tmp, open(tmp, "wb") as fh:
            self.model.save(fh)

    def close(self) -> None:
        self.env.close()
