"""Train PPO (stable-baselines3) on an mjchar environment, then evaluate and optionally film it.

Needs the optional RL packages, CPU torch first (any other torch spec pulls GBs of CUDA wheels)::

    pip install torch==2.13.0 && pip install stable-baselines3

Usage::

    python examples/train_ppo.py                                  # Imitation-v0, 200k steps
    python examples/train_ppo.py --env mjchar/Stand-v0 --steps 1000000 --envs 2
    python examples/train_ppo.py --steps 20000 --save ppo_walk.zip --video walk.mp4

``--envs N`` collects experience from N worker processes (``gymnasium.make_vec``, async).
DeepMimic-style imitation needs tens of millions of steps to walk; short runs only show the
return rising.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import gymnasium as gym  # noqa: E402
import numpy as np  # noqa: E402

from mjchar import envs  # noqa: E402, F401  (registers mjchar/...)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description="Train PPO on an mjchar environment.")
    ap.add_argument("--env", default="mjchar/Imitation-v0", choices=sorted(envs.ENV_IDS))
    ap.add_argument("--steps", type=int, default=200_000, help="environment steps to train")
    ap.add_argument("--envs", type=int, default=1, help="parallel worker processes")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--save", type=Path, help="write the trained model (.zip)")
    ap.add_argument("--eval-episodes", type=int, default=5)
    ap.add_argument("--threads", type=int, default=1,
                    help="torch threads (1 is fastest for this small MLP on a busy CPU)")
    ap.add_argument("--video", type=Path, help="film one evaluation episode to this .mp4")
    a = ap.parse_args(argv)
    try:
        import torch
        from stable_baselines3 import PPO
        from stable_baselines3.common.env_util import make_vec_env
        from stable_baselines3.common.evaluation import evaluate_policy
        from stable_baselines3.common.monitor import Monitor
        from stable_baselines3.common.vec_env import SubprocVecEnv
    except ImportError:
        print("stable-baselines3 is not installed: pip install torch==2.13.0 && "
              "pip install stable-baselines3", file=sys.stderr)
        return 2

    torch.set_num_threads(max(1, a.threads))
    if a.envs > 1:
        # "mjchar.envs:<id>" makes each fresh worker process import the registration itself
        train_env = make_vec_env(f"mjchar.envs:{a.env}", n_envs=a.envs, seed=a.seed,
                                 vec_env_cls=SubprocVecEnv)
    else:
        train_env = gym.make(a.env)
    model = PPO("MlpPolicy", train_env, seed=a.seed, device="cpu", verbose=1)
    t0 = time.perf_counter()
    model.learn(total_timesteps=a.steps, progress_bar=False)
    print(f"trained {model.num_timesteps} steps in {time.perf_counter() - t0:.0f} s")
    if a.save:
        model.save(a.save)
        print(f"saved {a.save}")

    eval_env = Monitor(gym.make(a.env))
    mean, std = evaluate_policy(model, eval_env, n_eval_episodes=a.eval_episodes,
                                deterministic=True)
    print(f"evaluation over {a.eval_episodes} episodes: return {mean:.2f} +- {std:.2f}")
    if a.video:
        import imageio.v2 as imageio

        film = gym.make(a.env, render_mode="rgb_array")
        obs, _ = film.reset(seed=a.seed)
        frames = [film.render()]
        for _ in range(int(10 * film.unwrapped.metadata["render_fps"])):
            obs, _, term, trunc, _ = film.step(model.predict(obs, deterministic=True)[0])
            frames.append(film.render())
            if term or trunc:
                break
        imageio.mimwrite(a.video, np.asarray(frames), fps=film.unwrapped.metadata["render_fps"],
                         macro_block_size=8)
        print(f"wrote {a.video} ({len(frames)} frames)")
        film.close()
    train_env.close()
    eval_env.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
