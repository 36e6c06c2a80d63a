"""DAgger-style warm start: the learner acts, the privileged scripted retriever labels.

Behaviour cloning on expert trajectories compounds errors once the learner drifts; DAgger labels
the states the *learner* visits (Ross et al., 2011). Early on, the expert itself acts with
probability ``beta`` so the learner sees successful endings too; ``beta`` decays to 0.
"""

from __future__ import annotations

import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase

from occrl.baselines.scripted import ScriptedRetriever

__all__ = ["ExpertMixPolicy", "label_with_expert"]


class ExpertMixPolicy(TensorDictModuleBase):
    """Run the learner's policy (keeping its recurrent state and log-prob) and replace its action
    by the expert's with probability ``beta`` per step."""

    def __init__(self, policy: TensorDictModuleBase, expert: ScriptedRetriever, beta: float = 1.0) -> None:
        super().__init__()
        self.policy = policy
        self.expert = expert
        # a buffer, so that collectors' weight updates carry it to worker processes
        self.register_buffer("_beta", torch.tensor(float(beta)))
        self.in_keys = list(policy.in_keys) + ["privileged", "gripper_closed"]
        self.out_keys = list(policy.out_keys)

    @property
    def beta(self) -> float:
        return float(self._beta)

    @beta.setter
    def beta(self, value: float) -> None:
        self._beta.fill_(float(value))

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        tensordict = self.policy(tensordict)
        if self.beta > 0:  # with beta = 0 the trainer labels the whole batch afterwards
            learner = tensordict.get("action")
            expert = self.expert(tensordict.copy()).get("action")
            take = torch.rand(learner.shape[:-1] + (1,)) < self.beta
            tensordict.set("action", torch.where(take, expert, learner))
        return tensordict


@torch.no_grad()
def label_with_expert(data: TensorDictBase, expert: ScriptedRetriever) -> TensorDictBase:
    """Write ``"expert_action"`` for every step of a collected batch (expert reads privileged keys)."""
    flat = data.reshape(-1)
    labels = expert(flat.select("gripper_pose", "gripper_opening", "gripper_closed", "privileged").copy()).get("action")
    data.set("expert_action", labels.reshape(*data.shape, -1))
    return data
