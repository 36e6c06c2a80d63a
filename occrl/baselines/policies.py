"""Policy baselines of the paper (Sec. VI-C): the network's policy head alone, no planning.

* **Greedy**: the mean action of the policy head (``stochastic=False``);
* **Stochastic**: an action sampled from the policy head (``stochastic=True``).

Either runs on the net with heat-map head (``stochastic-gen`` / ``greedy-gen`` in the tables) or
without (``stochastic`` / ``greedy``: the paper's baselines, trained without the heat-map loss).

Sampling is reproducible per task: :meth:`NetPolicy.reseed_worlds` gives every world of a batch
its own generator, seeded by that world's task seed, so an episode does not depend on which
other tasks share its batch (a sweep point extended by more seeds equals the point run at once).
"""

from __future__ import annotations

import math
from typing import Sequence

import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase
from torchrl.envs.utils import ExplorationType, set_exploration_type

from occrl.modules.occnet import OccNet, require_recurrent_state

__all__ = ["NetPolicy"]


class NetPolicy(TensorDictModuleBase):
    """Greedy (mean) or Stochastic (sampled) action of an :class:`~occrl.modules.OccNet`.

    Args:
        net: the network (with or without heat-map head); its recurrent state travels through
            the tensordict as for ``net.policy`` (append ``net.make_primer()`` to the env).
        stochastic: sample ``loc + scale * eps`` (the policy's Normal) instead of taking ``loc``.
        seed: seeds the sampling until :meth:`reseed_worlds` or :meth:`reseed` is called.
        spread: multiplies the standard deviation of the sampled actions, a temperature (1: the
            policy's own; 0: its mean, drawn from the same generators). Stochastic only.

    Examples:
        >>> import torch
        >>> from occrl.baselines import NetPolicy
        >>> from occrl.envs import make_env
        >>> from occrl.modules import make_occnet
        >>> net = make_occnet("paper", heatmap=False).eval()
        >>> policy = NetPolicy(net, stochastic=True)
        >>> def actions(seeds):
        ...     env = make_env(batch_size=len(seeds), seed=seeds).append_transform(net.make_primer())
        ...     policy.reseed_worlds(seeds)
        ...     with torch.no_grad():
        ...         return env.rollout(3, policy)["action"]
        >>> a, b = actions([5, 6]), actions([6])  # task 6's actions whatever shares its batch
        >>> a.shape, torch.allclose(a[1], b[0], atol=1e-6)  # (batched convolutions: float rounding)
        (torch.Size([2, 3, 4]), True)
    """

    def __init__(self, net: OccNet, stochastic: bool, seed: int = 0, spread: float = 1.0) -> None:
        super().__init__()
        if not isinstance(net, OccNet):
            raise TypeError(f"net must be an occrl OccNet (make_occnet / load_pretrained), got {type(net).__name__}")
        if not isinstance(stochastic, bool):
            raise TypeError(f"stochastic must be a bool (True: sample the action, False: its mean), got {stochastic!r}")
        if isinstance(spread, bool) or not isinstance(spread, (int, float)) or not math.isfinite(spread) or spread < 0:
            raise ValueError(f"spread must be a finite number >= 0 (1: the policy's own standard deviation), got {spread!r}")
        if spread != 1.0 and not stochastic:
            raise ValueError(f"spread applies to sampled actions only (stochastic=True), got spread={spread!r} with stochastic=False")
        self.net = net
        self.stochastic = stochastic
        self.spread = float(spread)
        self.in_keys = list(net.policy.in_keys)
        self.out_keys = list(net.policy.out_keys)
        self._generators: list[torch.Generator] = []
        self.reseed(seed)

    def reseed(self, seed: int) -> None:
        """One generator for the whole batch (used when the batch size is not that of
        :meth:`reseed_worlds`)."""
        self._shared = torch.Generator().manual_seed(int(seed))
        self._generators = []

    def reseed_worlds(self, seeds: Sequence[int]) -> None:
        """World ``i`` of the next batches samples from a generator seeded by ``seeds[i]``."""
        self._generators = [torch.Generator().manual_seed(int(s)) for s in seeds]

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        require_recurrent_state(tensordict, type(self).__name__)
        with set_exploration_type(ExplorationType.DETERMINISTIC):
            tensordict = self.net.policy(tensordict)
        if not self.stochastic:
            return tensordict
        loc, scale = tensordict.get("loc"), tensordict.get("scale")
        worlds, dim = int(loc.shape[:-1].numel()), loc.shape[-1]
        if len(self._generators) == worlds:
            eps = torch.stack([torch.randn(dim, generator=g) for g in self._generators])
        else:
            eps = torch.randn((worlds, dim), generator=self._shared)
        if self.spread != 1.0:
            scale = scale * self.spread
        tensordict.set("action", loc + scale * eps.reshape(loc.shape).to(loc.dtype))
        return tensordict
