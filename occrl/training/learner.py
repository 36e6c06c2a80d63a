"""The network's update in each phase of training: imitation (DAgger on an aggregate of labelled
batches), the value head's warm-up, and PPO with the heat-map loss (the paper's objective).

:class:`~occrl.training.Trainer` owns one :class:`Learner`; the learner owns the network on its
device, the loss, the optimiser and the DAgger aggregate.
"""

from __future__ import annotations

from contextlib import contextmanager
from typing import Iterator

import torch
from tensordict import TensorDictBase
from torchrl.modules import set_recurrent_mode

from occrl.modules import OccNet
from occrl.objectives import PPOHeatmapLoss, heatmap_loss, imitation_nll
from occrl.training.config import ImitationConfig, TrainConfig
from occrl.training.dagger_buffer import DaggerBuffer

__all__ = ["Learner", "PPO_DIAGNOSTICS", "recurrent_layers_training"]

PPO_DIAGNOSTICS = ("kl_approx", "clip_fraction", "entropy")  # ClipPPOLoss outputs logged (mean over the minibatches seen)


@contextmanager
def recurrent_layers_training(net: torch.nn.Module) -> Iterator[None]:
    """Put the network's recurrent layers (``torch.nn.RNNBase``) in training mode inside the block,
    everything else as it is, and restore their modes after.

    The net stays in eval mode during the update (batch norm on its running statistics, the same
    function as collection), but cuDNN refuses the backward pass of an LSTM in eval mode ("cudnn RNN
    backward can only be called in training mode"). An LSTM without dropout computes the same
    function in both modes, so this changes nothing on the CPU and lets the update run on CUDA.

    Examples:
        >>> from occrl.modules import make_occnet
        >>> net = make_occnet("paper")
        >>> with recurrent_layers_training(net):
        ...     net.lstm.lstm.training, net.encoder.training
        (True, False)
        >>> net.lstm.lstm.training
        False
    """
    layers = [m for m in net.modules() if isinstance(m, torch.nn.RNNBase)]
    for layer in layers:
        if layer.dropout:
            raise ValueError(f"recurrent_layers_training needs recurrent layers without dropout, got dropout={layer.dropout}")
    modes = [layer.training for layer in layers]
    for layer in layers:
        layer.train()
    try:
        yield
    finally:
        for layer, mode in zip(layers, modes):
            layer.train(mode)


class Learner:
    """Network, loss, optimiser and DAgger aggregate of a run, and the update of each phase.

    Args:
        net: the network being trained, already on ``device``.
        config: the run's settings (optimiser, PPO and imitation settings).
        device: where the network is; batches are moved there (the aggregate stays in CPU memory).
    """

    def __init__(self, net: OccNet, config: TrainConfig, device: torch.device) -> None:
        self.net = net
        self.config = config
        self.device = device
        self.loss = PPOHeatmapLoss(
            net,
            clip_epsilon=config.clip_epsilon,
            entropy_coeff=config.entropy_coeff,
            critic_coeff=config.critic_coeff,
            heatmap_coeff=config.heatmap_coeff,
            gamma=config.gamma,
            heatmap_fraction=config.heatmap_fraction,
        )
        params: list = list(net.parameters())
        if config.optimizer == "rmsprop":
            self.optimizer = torch.optim.RMSprop(params, lr=config.lr)
        elif config.optimizer == "adam":
            self.optimizer = torch.optim.Adam(params, lr=config.lr)
        else:
            raise ValueError(f"optimizer must be 'rmsprop' or 'adam', got {config.optimizer!r}")
        # the imitation settings (their defaults for a run without an imitation phase)
        self.imitation = config.imitation or ImitationConfig()
        self.dagger = DaggerBuffer(self.imitation.buffer_iters)

    def on_device(self, td: TensorDictBase) -> TensorDictBase:
        return td if self.device.type == "cpu" else td.to(self.device)

    def refresh_batch_norm(self, data: TensorDictBase) -> None:
        """Update the encoder's batch-norm running statistics on this batch (no gradients); the
        net otherwise stays in eval mode so collection and update see the same function."""
        if self.config.batch_norm_frames <= 0:  # statistics frozen
            return
        flat = data.reshape(-1)
        n = min(self.config.batch_norm_frames, flat.shape[0])
        frames = flat[torch.randperm(flat.shape[0])[:n]]
        self.net.encoder.train()
        with torch.no_grad():
            self.net.encoder(frames.select("pixels").copy())
        self.net.encoder.eval()

    def step(self, terms: dict) -> None:
        total = sum(terms.values())
        self.optimizer.zero_grad()
        total.backward()
        torch.nn.utils.clip_grad_norm_(self.net.parameters(), self.config.max_grad_norm)
        self.optimizer.step()

    def update(self, data: TensorDictBase, phase: str) -> dict:
        """One iteration's optimisation on a batch (on the device), by phase: "imitation" (with
        ``imitation.updates`` > 0: gradient steps on the DAgger aggregate, this batch added;
        else epochs over the batch), "critic_warmup" (the value head alone) or "ppo" (PPO +
        heat-map loss, stopped early past the KL target). Returns the mean of each loss term.
        """
        with recurrent_layers_training(self.net):
            return self.optimise(data, phase)

    def optimise(self, data: TensorDictBase, phase: str) -> dict:
        """:meth:`update`'s body, run with the recurrent layers in training mode."""
        c = self.config
        B = data.shape[0]
        sums: dict[str, float] = {}
        count = 0
        if phase == "imitation" and self.imitation.updates > 0:
            self.dagger.add(data if self.device.type == "cpu" else data.to("cpu"))  # the aggregate stays in CPU memory
            for _ in range(self.imitation.updates):
                terms = self.imitation_terms(self.on_device(self.dagger.sample(c.minibatch_envs)))
                self.step(terms)
                for k, v in terms.items():
                    sums[k] = sums.get(k, 0.0) + float(v.detach())
                count += 1
            return {k: v / count for k, v in sums.items()}
        stopped_early = False
        for _ in range(c.epochs):
            order = torch.randperm(B)
            for start in range(0, B, c.minibatch_envs):
                mb = data[order[start : start + c.minibatch_envs]]
                if phase == "ppo":
                    out = self.loss(mb)
                    terms = {k: v for k, v in out.items() if k.startswith("loss_")}
                    for k in PPO_DIAGNOSTICS:  # logged, not optimised
                        if k in out.keys():
                            sums[k] = sums.get(k, 0.0) + float(out.get(k))
                    if c.target_kl > 0 and count > 0 and float(out.get("kl_approx")) > 1.5 * c.target_kl:
                        stopped_early = True  # the policy moved far enough on this batch
                        break
                elif phase == "critic_warmup":
                    terms = self.critic_terms(mb)
                else:
                    terms = self.imitation_terms(mb)
                self.step(terms)
                for k, v in terms.items():
                    sums[k] = sums.get(k, 0.0) + float(v.detach())
                count += 1
            if stopped_early:
                break
        means = {k: v / max(count, 1) for k, v in sums.items()}
        if phase == "ppo":
            means["updates"] = count
        return means

    def critic_terms(self, mb: TensorDictBase) -> dict:
        """Value loss of the value head alone (the shared trunk is not trained: through it the
        critic's large early errors would move the policy before PPO starts)."""
        td = mb.copy()
        with torch.no_grad(), set_recurrent_mode(True):
            td = self.net.trunk(td)
        return {"loss_critic": self.value_loss(td)}

    def value_loss(self, td: TensorDictBase) -> torch.Tensor:
        """c1 x smooth-L1 value loss of the value head on ``td`` (which holds ``"belief"``)."""
        value = self.net.critic(td).get("state_value")
        return self.config.critic_coeff * torch.nn.functional.smooth_l1_loss(value, td.get("value_target"))

    def imitation_terms(self, mb: TensorDictBase) -> dict:
        c = self.config
        td = mb.copy()
        with set_recurrent_mode(True):
            td = self.net.trunk(td)
        terms = {"loss_imitation": imitation_nll(self.net, td, self.imitation.min_scale)}
        terms["loss_critic"] = self.value_loss(td)
        if self.net.heatmap_head is not None and c.heatmap_coeff > 0:
            terms["loss_heatmap"] = c.heatmap_coeff * heatmap_loss(self.net.heatmap_head, td, c.heatmap_fraction)
        return terms
