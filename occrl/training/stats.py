"""Statistics of collected batches: the finished episodes the logs and the curriculum read."""

from __future__ import annotations

import numpy as np
import torch
from tensordict import TensorDictBase

__all__ = ["episode_stats", "successful_episode_frames"]


def episode_stats(data: TensorDictBase) -> dict:
    """The first episode of each row of a [B, T] batch that starts with a reset, if it finished:
    success flag, return and length.

    Only the first: an episode that follows a finished one has T minus that one's length steps
    left, so it is counted only when it is short, and short episodes are mostly successes; with
    them the training success of stage 2 read ~15 points above the held-out figure of the same
    policy. With ``steps_per_env`` at the 50-action limit (every preset but ``tiny``) every row's
    first episode finishes in the batch, so the rate is unbiased.

    Examples:
        >>> from occrl.baselines import ScriptedRetriever
        >>> from occrl.envs import Scene, make_env
        >>> from occrl.training.stats import episode_stats
        >>> env = make_env(batch_size=1, scenes=[Scene.sample(1, seed=0, num_objects=1)], heatmap_target=False)
        >>> stats = episode_stats(env.rollout(50, ScriptedRetriever()))
        >>> stats["success"], stats["returns"][0] == -stats["lengths"][0]
        ([True], True)
    """
    done = data.get(("next", "done")).squeeze(-1).numpy()
    success = data.get(("next", "success")).squeeze(-1).numpy()
    reward = data.get(("next", "reward")).squeeze(-1).numpy()
    succ, rets, lens = [], [], []
    for b in range(done.shape[0]):
        ends = np.flatnonzero(done[b])
        if len(ends):
            t = int(ends[0])
            succ.append(bool(success[b, t]))
            rets.append(float(reward[b, : t + 1].sum()))
            lens.append(t + 1)
    return {"success": succ, "returns": rets, "lengths": lens}


def successful_episode_frames(data: TensorDictBase) -> torch.Tensor:
    """Per frame of a collected [B, T] batch: whether the frame's episode ends in success within
    the batch. An episode runs from a frame flagged ``"is_init"`` (or the row's first frame) to
    its ``("next", "done")``; the frames of an episode the batch cuts off are False. Shape: the
    batch's.

    Examples:
        >>> from occrl.baselines import ScriptedRetriever
        >>> from occrl.envs import Scene, make_env
        >>> from occrl.training.stats import successful_episode_frames
        >>> env = make_env(batch_size=1, scenes=[Scene.sample(1, seed=0, num_objects=1)], heatmap_target=False)
        >>> data = env.rollout(50, ScriptedRetriever(), break_when_any_done=False)
        >>> length = episode_stats(data)["lengths"][0]
        >>> frames = successful_episode_frames(data[:, : length + 2])[0]  # a success, then an episode cut off
        >>> bool(frames[:length].all()), bool(frames[length:].any())
        (True, False)
    """
    done = data.get(("next", "done")).reshape(data.shape)
    success = data.get(("next", "success")).reshape(data.shape)
    starts = data.get("is_init").reshape(data.shape)
    out = torch.zeros(data.shape, dtype=torch.bool)
    ending = torch.zeros(data.shape[:-1], dtype=torch.bool)  # the outcome of the episode the frame belongs to
    for t in reversed(range(data.shape[-1])):
        ending = torch.where(done[..., t], success[..., t], ending)
        out[..., t] = ending
        ending = ending & ~starts[..., t]  # the frame before a start belongs to another episode
    return out
