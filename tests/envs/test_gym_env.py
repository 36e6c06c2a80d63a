"""The Gymnasium interface: registered id, checker, vector env over the batched ShelfEnv, SB3."""

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

import occrl  # noqa: E402,F401  (registers the id)
from gymnasium.utils.env_checker import check_env  # noqa: E402


def test_single_env_passes_the_checker_and_is_seeded():
    env = gymnasium.make("occrl/ShelfRetrieval-v0", stage=2, noise=0.15)
    check_env(env.unwrapped, skip_render_check=False)
    a, _ = env.reset(seed=7)
    b, _ = env.reset(seed=7)
    c, _ = env.reset(seed=8)
    assert all(np.array_equal(a[k], b[k]) for k in a) and not np.array_equal(a["pixels"], c["pixels"])
    assert env.observation_space.contains(a) and a["pixels"].dtype == np.uint8
    rewards, steps = [], 0
    while True:
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        rewards.append(reward)
        steps += 1
        assert env.observation_space.contains(obs) and {"success", "dropped", "penetration"} <= info.keys()
        if terminated or truncated:
            break
    assert steps <= 50 and all(r <= -1.0 for r in rewards)
    with pytest.raises(ValueError, match="action must have shape"):
        env.unwrapped.step(np.zeros(3))
    with pytest.raises(ValueError, match="stage must be one of"):
        gymnasium.make("occrl/ShelfRetrieval-v0", stage=4)


def test_vector_env_batches_the_shelves_and_resets_finished_ones():
    envs = gymnasium.make_vec("occrl/ShelfRetrieval-v0", num_envs=3, vectorization_mode="vector_entry_point", stage=1)
    obs, _ = envs.reset(seed=0)
    assert envs.observation_space.contains(obs) and obs["pixels"].shape == (3, 3, 64, 64)
    single = gymnasium.make("occrl/ShelfRetrieval-v0", stage=1)
    assert envs.single_observation_space == single.observation_space
    ended = 0
    for _ in range(55):  # every episode ends within 50 actions
        obs, reward, terminated, truncated, info = envs.step(envs.action_space.sample())
        assert envs.observation_space.contains(obs) and reward.shape == (3,)
        done = terminated | truncated
        if done.any():
            assert np.array_equal(info["_final_obs"], done)
            ended += int(done.sum())
            # same-step autoreset: the returned observation is the start of the next episode
            assert not np.array_equal(obs["pixels"][done], info["final_obs"]["pixels"][done])
    assert ended >= 3
    again, _ = envs.reset(seed=0)
    first, _ = gymnasium.make_vec("occrl/ShelfRetrieval-v0", num_envs=3, vectorization_mode="vector_entry_point", stage=1).reset(seed=0)
    assert np.array_equal(again["pixels"], first["pixels"])


@pytest.mark.integration
def test_stable_baselines3_ppo_trains_on_it():
    pytest.importorskip("stable_baselines3")
    import runpy
    from pathlib import Path

    example = runpy.run_path(str(Path(__file__).resolve().parents[2] / "examples" / "sb3_ppo.py"))
    model = example["train"](steps=256, stage=1, envs=2)
    assert model.num_timesteps >= 256
    rate, ret = example["evaluate"](model, episodes=1)
    assert 0.0 <= rate <= 1.0 and -100.0 <= ret <= -1.0
