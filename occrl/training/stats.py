"""Statistics of collected batches: the finished episodes the logs and the curriculum read."""

from __future__ import annotations

import numpy as np
import torch
from tensordict import TensorDictBase

__all__ = ["episode_stats", "successful_episode_frames", "task_success_weights"]


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


def task_success_weights(data: TensorDictBase, task_copies: int) -> torch.Tensor:
    """Per frame of a [B, T] batch whose consecutive groups of ``task_copies`` rows run the same
    tasks (``ShelfEnv(task_copies=...)``): 1 / (the successes among the group's episodes of the
    same ordinal, i.e. the same task) for the frames of an episode that ends in success within
    the batch, 0 elsewhere: a solved task's successful episodes share one episode's weight,
    however many copies solved it.

    Examples:
        >>> from tensordict import TensorDict
        >>> from occrl.training.stats import task_success_weights
        >>> done = torch.tensor([[0, 1], [0, 1], [0, 1], [0, 1]], dtype=torch.bool).unsqueeze(-1)
        >>> success = torch.tensor([[0, 1], [0, 1], [0, 1], [0, 0]], dtype=torch.bool).unsqueeze(-1)
        >>> is_init = torch.tensor([[1, 0]] * 4, dtype=torch.bool).unsqueeze(-1)
        >>> data = TensorDict({"is_init": is_init, "next": {"done": done, "success": success}}, batch_size=[4, 2])
        >>> task_success_weights(data, 2)  # task 1: two successes; task 2: one
        tensor([[0.5000, 0.5000],
                [0.5000, 0.5000],
                [1.0000, 1.0000],
                [0.0000, 0.0000]])
    """
    if isinstance(task_copies, bool) or not isinstance(task_copies, (int, np.integer)) or task_copies < 1:
        raise ValueError(f"task_copies must be an int >= 1, got {task_copies!r}")
    if data.batch_dims != 2:
        raise ValueError(f"expected a [worlds, time] batch, got batch shape {tuple(data.shape)} (flatten the workers first)")
    B, T = data.shape
    task_copies = int(task_copies)
    if B % task_copies:
        raise ValueError(f"the batch's {B} rows are not groups of task_copies={task_copies}")
    succeeded = successful_episode_frames(data)
    starts = data.get("is_init").reshape(B, T).clone()
    starts[:, 0] = True
    ordinal = starts.long().cumsum(-1) - 1  # the episode each frame belongs to, counted along its row
    rows = torch.arange(B).unsqueeze(-1).expand(B, T)
    episode_success = torch.zeros(B, int(ordinal.max()) + 1)
    episode_success.index_put_((rows, ordinal), succeeded.float(), accumulate=True)
    episode_success = (episode_success > 0).float()
    per_task = episode_success.reshape(B // task_copies, task_copies, -1).sum(1, keepdim=True)
    per_task = per_task.expand(-1, task_copies, -1).reshape(B, -1)
    weight = torch.where(episode_success > 0, 1.0 / per_task.clamp_min(1.0), torch.zeros(()))
    return weight.gather(1, ordinal)
