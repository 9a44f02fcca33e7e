"""Fine-tune a distilled policy (``mjchar learn``) with PPO (stable-baselines3) on
``mjchar/Imitation-v0``, and print the return before, during and after.

``mjchar learn`` fine-tunes with PPO itself (``--rl-share``, :mod:`mjchar.learn.finetune`);
this example is the same start in a plain stable-baselines3 loop, for longer runs and for
experiments: the policy file's network becomes the PPO actor's mean
(:func:`mjchar.learn.finetune.load_actor`, the input normalisation folded into the first
layer), the critic starts untrained and learns alone for ``--critic-warmup`` steps (the actor
frozen), and the action noise starts at ``--init-std`` (the DART noise the policy was distilled
with). The env is the one the policy was distilled in: its clip (looped as in training),
``future_steps`` from the file, 10 s episodes, the env's own reward. ``--export`` writes the
fine-tuned actor as a policy file that ``mjchar run policy`` runs
(:func:`mjchar.learn.finetune.actor_mlp`).

Needs the rl extra, CPU torch first::

    pip install torch==2.13.0 && pip install stable-baselines3

Usage::

    python examples/finetune_ppo.py walk60.npz --steps 100000 --eval-every 20000
    python examples/finetune_ppo.py walk60 --steps 1000000 --eval-every 50000 \
        --save walk60_ppo.zip --export walk60_ppo.npz --curve walk60_ppo.png

``--curve`` writes the returns against PPO steps as a PNG (needs matplotlib, the bench extra).
"""

from __future__ import annotations

import argparse
import sys
import time


def make_env(policy):
    from mjchar.learn.collect import LearnSetup, make_env

    clip = policy.meta["clip"]
    setup = LearnSetup(clip=policy.clip_motion(), loop=clip["loop"],
                       future_steps=tuple(policy.meta["observation"]["future_steps"]))
    return make_env(setup, episode_seconds=10.0)


def zero_action_return(env, episodes: int) -> float:
    """Mean return of the zero action (plain PD on the clip) over ``episodes`` episodes."""
    import numpy as np

    total = 0.0
    for _ in range(episodes):
        env.reset()
        done = False
        while not done:
            _, r, term, trunc, _ = env.step(np.zeros(env.action_space.shape))
            total += float(r)
            done = term or trunc
    return total / episodes


def plot_returns(rows: list[tuple[int, float, float]], path: str, zero_action=None) -> None:
    """Write the evaluations ``(PPO steps, mean return, sd)`` as a PNG at ``path``;
    ``zero_action``: the zero action's return, drawn as a line for comparison."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from mjchar.bvh.io.files import atomic_path

    steps = [r[0] / 1000 for r in rows]
    mean = [r[1] for r in rows]
    sd = [r[2] for r in rows]
    fig, ax = plt.subplots(figsize=(6, 3.6), dpi=100)
    ax.errorbar(steps, mean, yerr=sd, fmt="o-", capsize=3, label="PPO from the distilled policy")
    if zero_action is not None:
        ax.axhline(zero_action, color="tab:gray", ls="--", label="zero action (plain PD)")
    ax.set_xlabel("PPO steps (thousands)")
    ax.set_ylabel("return (mean +- sd)")
    ax.set_title("mjchar/Imitation-v0: PPO fine-tuning of a distilled policy")
    ax.legend(loc="upper left")
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description="Fine-tune a distilled policy with PPO.")
    ap.add_argument("policy", help="policy file (mjchar learn) or bundled name")
    ap.add_argument("--steps", type=int, default=100_000)
    ap.add_argument("--eval-every", type=int, default=20_000)
    ap.add_argument("--eval-episodes", type=int, default=5)
    ap.add_argument("--init-std", type=float, default=0.1)
    ap.add_argument("--lr", type=float, default=1e-5)
    ap.add_argument("--epochs", type=int, default=3, help="PPO epochs per rollout")
    ap.add_argument("--critic-warmup", type=int, default=4096,
                    help="steps with the actor frozen while the critic learns")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--save", help="write the fine-tuned PPO model (.zip)")
    ap.add_argument("--export", help="write the fine-tuned actor as a policy file (.npz)")
    ap.add_argument("--curve", help="write the returns against PPO steps (.png)")
    a = ap.parse_args(argv)
    try:
        import torch
        from stable_baselines3 import PPO
        from stable_baselines3.common.evaluation import evaluate_policy
        from stable_baselines3.common.monitor import Monitor
    except ImportError:
        print("needs stable-baselines3: pip install torch==2.13.0 && pip install "
              "stable-baselines3", file=sys.stderr)
        return 2
    if a.curve:
        try:
            import matplotlib  # noqa: F401  (checked before the run, not after it)
        except ImportError:
            print("--curve needs matplotlib: pip install matplotlib (or the bench extra)",
                  file=sys.stderr)
            return 2
    from mjchar.controllers.learned import find_policy
    from mjchar.controllers.learned.policy_file import save_policy
    from mjchar.learn.finetune import actor_mlp, load_actor

    torch.set_num_threads(1)
    policy = find_policy(a.policy)
    env, eval_env = Monitor(make_env(policy)), Monitor(make_env(policy))
    hidden = list(policy.net.hidden)
    model = PPO("MlpPolicy", env, seed=a.seed, device="cpu", learning_rate=a.lr,
                n_epochs=a.epochs,
                policy_kwargs={"net_arch": {"pi": hidden, "vf": [256, 256]},
                               "activation_fn": torch.nn.ELU})
    load_actor(model, policy.net, a.init_std)

    rows: list[tuple[int, float, float]] = []

    def evaluate(label: str, steps: int | None = None) -> None:
        mean, std = evaluate_policy(model, eval_env, n_eval_episodes=a.eval_episodes,
                                    deterministic=True)
        print(f"{label:>10} steps: return {mean:.2f} +- {std:.2f}", flush=True)
        if steps is not None:
            rows.append((steps, float(mean), float(std)))

    zero = zero_action_return(eval_env, a.eval_episodes)
    print(f"zero action: return {zero:.2f}", flush=True)
    evaluate("0", 0)
    t0, done = time.perf_counter(), 0
    if a.critic_warmup > 0:
        actor = [*model.policy.mlp_extractor.policy_net.parameters(),
                 *model.policy.action_net.parameters(), model.policy.log_std]
        for p in actor:
            p.requires_grad_(False)
        model.learn(total_timesteps=a.critic_warmup, reset_num_timesteps=False,
                    progress_bar=False)
        for p in actor:
            p.requires_grad_(True)
        evaluate(f"{a.critic_warmup} (critic only)")
    while done < a.steps:
        n = min(a.eval_every, a.steps - done)
        model.learn(total_timesteps=n, reset_num_timesteps=False, progress_bar=False)
        done += n
        evaluate(f"{done}", done)
    print(f"fine-tuned {done} steps in {time.perf_counter() - t0:.0f} s")
    if a.save:
        model.save(a.save)
    if a.export:
        meta = dict(policy.meta, training={**policy.meta.get("training", {}),
                                           "ppo_steps_after": done})
        save_policy(a.export, actor_mlp(model, policy.net), meta,
                    str(policy.arrays["clip_bvh"]) if "clip_bvh" in policy.arrays else None)
    if a.curve:
        plot_returns(rows, a.curve, zero_action=zero)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
