"""Stable-Baselines3 PPO on the Gymnasium shelf, for a few thousand steps.

    pip install -e ".[sb3]"
    python examples/sb3_ppo.py [--steps 4096] [--stage 1] [--envs 4]

``import occrl`` registers ``"occrl/ShelfRetrieval-v0"``; SB3 vectorises it itself and its
``MultiInputPolicy`` reads the Dict observation (a CNN on the 3x64x64 image, an MLP on the
gripper entries). A few thousand steps only show that the pieces fit; occrl's own trainer
(``occrl train``) is what learns the task.
"""

from __future__ import annotations

import argparse

import numpy as np
from stable_baselines3 import PPO
from stable_baselines3.common.env_util import make_vec_env

import occrl  # noqa: F401  (registers occrl/ShelfRetrieval-v0)


def train(steps: int = 4096, stage: int = 1, envs: int = 4, seed: int = 0) -> PPO:
    vec = make_vec_env("occrl/ShelfRetrieval-v0", n_envs=envs, seed=seed, env_kwargs={"stage": stage})
    model = PPO("MultiInputPolicy", vec, n_steps=max(8, min(256, steps // envs)), batch_size=64, n_epochs=2, seed=seed, verbose=0)
    model.learn(total_timesteps=steps)
    return model


def evaluate(model: PPO, episodes: int = 4, stage: int = 1, seed: int = 100) -> tuple[float, float]:
    """Success rate and mean return of the sampled policy on fresh shelves."""
    env = make_vec_env("occrl/ShelfRetrieval-v0", n_envs=1, seed=seed, env_kwargs={"stage": stage})
    successes, returns = [], []
    obs = env.reset()
    total = 0.0
    while len(returns) < episodes:
        action, _ = model.predict(obs)
        obs, reward, done, info = env.step(action)
        total += float(reward[0])
        if done[0]:
            successes.append(bool(info[0]["success"]))
            returns.append(total)
            total = 0.0
    return float(np.mean(successes)), float(np.mean(returns))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=4096)
    parser.add_argument("--stage", type=int, default=1)
    parser.add_argument("--envs", type=int, default=4)
    parser.add_argument("--episodes", type=int, default=4)
    args = parser.parse_args()
    model = train(args.steps, args.stage, args.envs)
    rate, ret = evaluate(model, args.episodes, args.stage)
    print(f"SB3 PPO after {args.steps} steps: success {rate:.0%}, mean return {ret:.1f} over {args.episodes} episodes")


if __name__ == "__main__":
    main()
