"""Search with one decision maker, retrieve with another: a hand-over at the first detection.

:class:`SearchThenRetrieve` runs a searcher (e.g. the hybrid planner) until perception first
reports the target in a world's episode, and a retriever (e.g. the hierarchical OMPL planner)
from then on. Beyond the papers: a teacher for imitation (the hierarchical planner's search, then
the clearing retriever deciding from observations) and a way to tell where a method loses tasks,
in its search or its retrieval (the hybrid planner's search with the hierarchical planner's
retrieval did not beat the hierarchical planner alone: docs/lab/search.md).
"""

from __future__ import annotations

import numpy as np
import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase

from occrl.planners import recreate

__all__ = ["SearchThenRetrieve"]


class SearchThenRetrieve(TensorDictModuleBase):
    """The searcher acts until the target is first detected in a world's episode, the retriever
    after (until the episode ends; a new episode starts with the searcher again).

    The searcher keeps deciding after the hand-over (its decisions are discarded) so that a
    recurrent searcher's state follows the real history; the retriever sees the episode from
    the hand-over on, its first observation flagged as an episode start (``"is_init"``), so a
    planner with an episode memory (the hierarchical one) starts afresh there. ``reseed`` and
    ``reset`` go to both. Reads what its two parts read. In a batch of worlds the retriever
    decides for every world once any is handed over (the others' decisions are discarded);
    evaluations run planners one world per task.

    With ``retriever_follows=True`` the retriever decides at every step from the episode's
    start, on the same observations and its own recurrent state (a network's LSTM or a hybrid
    planner then retrieves with the memory of the whole search, as it would acting alone); its
    actions count from the hand-over on, and its first observation there is not flagged. The
    searcher is then asked only for the worlds still searching where it can be (a searcher with
    ``act_on_worlds``, such as the hierarchical planner), otherwise for every world on the same
    tensordict until all have been handed over.

    Examples:
        >>> from occrl.baselines import ScriptedRetriever
        >>> from occrl.baselines.handover import SearchThenRetrieve
        >>> from occrl.envs import make_env
        >>> from occrl.modules import make_occnet
        >>> from occrl.planners import HybridPlanner
        >>> net = make_occnet("paper").eval()
        >>> env = make_env(batch_size=1, stage=1, seed=3, heatmap_target=False).append_transform(net.make_primer())
        >>> policy = SearchThenRetrieve(HybridPlanner(net, m=2, h=2), ScriptedRetriever())
        >>> td = env.rollout(3, policy)
        >>> td["action"].shape, policy.handovers >= 0
        (torch.Size([1, 3, 4]), True)
    """

    def __init__(self, searcher: TensorDictModuleBase, retriever: TensorDictModuleBase, retriever_follows: bool = False) -> None:
        super().__init__()
        self.searcher, self.retriever = searcher, retriever
        self.retriever_follows = retriever_follows
        self.in_keys = list(dict.fromkeys(["is_init", *searcher.in_keys, *retriever.in_keys]))
        follower_keys = retriever.out_keys if retriever_follows else []
        self.out_keys = list(dict.fromkeys([*searcher.out_keys, *follower_keys, "action"]))
        self.handovers = 0  # hand-overs in the first episode of each world since the last reset
        self._handed = self._retrieving = self._first_episode = self._started = None

    def reseed(self, seed: int) -> None:
        for part in (self.searcher, self.retriever):
            if hasattr(part, "reseed"):
                part.reseed(seed)

    def reset(self) -> None:
        """Forget every world's episode (a new batch of tasks) and the hand-over count."""
        for part in (self.searcher, self.retriever):
            if hasattr(part, "reset"):
                part.reset()
        self.handovers = 0
        self._handed = None

    @property
    def handed(self) -> np.ndarray | None:
        """Per world: whether the retriever acts (None before the first step)."""
        return None if self._handed is None else self._handed.copy()

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        flat = tensordict.reshape(-1)
        n = flat.shape[0]
        is_init = flat.get("is_init").reshape(n).cpu().numpy()
        if self._handed is None or len(self._handed) != n:
            self._handed, self._retrieving = np.zeros(n, bool), np.zeros(n, bool)
            self._first_episode, self._started = np.ones(n, bool), np.zeros(n, bool)
        self._first_episode[is_init & self._started] = False  # a later episode of a world
        self._started[:] = True
        self._handed[is_init] = False
        for b in range(n):
            if not self._handed[b] and recreate(flat[b]).target_detected:
                self._handed[b] = True
                self.handovers += int(self._first_episode[b])
        if self.retriever_follows:
            return self._follow(tensordict, flat, n)
        out = self.searcher(tensordict)
        if self._handed.any():
            obs = tensordict.select(*self.retriever.in_keys).copy()
            obs.set("is_init", torch.from_numpy(self._handed & ~self._retrieving).reshape(tensordict.get("is_init").shape))
            retrieved = self.retriever(obs).get("action").reshape(n, -1)
            action = out.get("action").reshape(n, -1).clone()
            handed = torch.from_numpy(self._handed)
            action[handed] = retrieved[handed]
            out.set("action", action.reshape(out.get("action").shape))
        self._retrieving = self._handed.copy()
        return out

    def _follow(self, tensordict: TensorDictBase, flat: TensorDictBase, n: int) -> TensorDictBase:
        """``retriever_follows``: the retriever decides on every step, the searcher only where the
        search goes on (all worlds unless it can be asked for some: ``act_on_worlds``)."""
        searching = np.flatnonzero(~self._handed)
        searched = None
        if len(searching) and hasattr(self.searcher, "act_on_worlds"):
            searched = torch.as_tensor(self.searcher.act_on_worlds(flat, searching), dtype=torch.float32)
        elif len(searching):  # in place: a recurrent searcher's state follows as well
            searched = self.searcher(tensordict).get("action").reshape(n, -1)[searching].clone()
        out = self.retriever(tensordict)  # its recurrent state follows every step
        if searched is not None:
            action = out.get("action").reshape(n, -1).clone()
            action[torch.from_numpy(searching)] = searched
            out.set("action", action.reshape(out.get("action").shape))
        return out
