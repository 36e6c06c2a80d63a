"""Compose occrl's parts in your own script: swap the encoder, add a transform, train one step.

Every part reads and writes named tensordict entries, so a replacement only has to honour the
keys: the encoder reads ``"pixels"`` and writes ``"embed"``; the LSTM turns ``"embed"`` into
``"belief"``; the policy, value and heat-map heads read ``"belief"``.

    python examples/compose_components.py
"""

from __future__ import annotations

import torch
from tensordict.nn import TensorDictModule
from torch import nn
from torchrl.collectors import Collector
from torchrl.envs import RewardSum
from torchrl.envs.utils import ExplorationType

from occrl.envs import make_env
from occrl.modules import make_occnet
from occrl.objectives import PPOHeatmapLoss, compute_advantages


class AnyLeadingDims(nn.Module):
    """The trunk sees (B, 3, 64, 64) while acting and (B, T, 3, 64, 64) in the loss: fold the
    leading dims for a plain image network (occrl's ConvEncoder does this itself)."""

    def __init__(self, image_net: nn.Module) -> None:
        super().__init__()
        self.image_net = image_net

    def forward(self, pixels: torch.Tensor) -> torch.Tensor:
        lead = pixels.shape[:-3]
        return self.image_net(pixels.reshape(-1, *pixels.shape[-3:])).reshape(*lead, -1)


def main() -> None:
    torch.manual_seed(0)
    net = make_occnet("paper")

    # 1. swap the encoder: any module from "pixels" (B, 3, 64, 64) to "embed" (B, 1024)
    wider = nn.Sequential(
        nn.Conv2d(3, 16, 5, stride=2, padding=2), nn.ReLU(), nn.Conv2d(16, 16, 5, stride=4, padding=2), nn.ReLU(), nn.Flatten(-3)
    )  # 16 x 8 x 8 = 1024 features, like the paper's encoder
    net.trunk[0] = TensorDictModule(AnyLeadingDims(wider), in_keys=["pixels"], out_keys=["embed"])

    # 2. add a transform: TorchRL's RewardSum keeps each episode's return in "episode_reward"
    def make() -> object:
        return make_env(batch_size=4, stage=1, seed=0).append_transform(RewardSum()).append_transform(net.make_primer())

    # 3. collect with a TorchRL collector and take one PPO + heat-map step
    collector = Collector(
        make, net.policy, frames_per_batch=4 * 8, total_frames=4 * 8, reset_at_each_iter=True, exploration_type=ExplorationType.RANDOM
    )
    data = next(iter(collector))
    collector.shutdown()
    loss = PPOHeatmapLoss(net)
    compute_advantages(net, data)
    terms = loss(data)
    total = sum(v for k, v in terms.items() if k.startswith("loss_"))
    total.backward()
    print(f"batch {tuple(data.batch_size)}; losses:", {k: round(float(v.detach()), 3) for k, v in terms.items() if k.startswith("loss_")})
    grad = sum(float(q.grad.norm()) for q in wider.parameters())
    print(f"gradient reaches the swapped encoder: {grad > 0}")
    print("episode returns so far:", data["next", "episode_reward"][:, -1].flatten().tolist())


if __name__ == "__main__":
    main()
