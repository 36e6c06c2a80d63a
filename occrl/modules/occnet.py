"""OccNet: the three-headed recurrent network of the paper, assembled from TorchRL modules.

Data flow (keys in the tensordict)::

    "pixels" --ConvEncoder--> "embed" --LSTMModule--> "belief" --+--PolicyHead--> "loc", "scale" -> "action"
                                                                 +--ValueHead---> "state_value"
                                                                 +--HeatmapHead-> "heatmap_logits", "heatmap"

Every piece is a TensorDict module, so users can swap one (another encoder writing ``"embed"``,
another head reading ``"belief"``) and keep the rest.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import torch
from tensordict.nn import TensorDictModule, TensorDictSequential
from torch import nn
from torchrl.envs import TensorDictPrimer
from torchrl.modules import IndependentNormal, LSTMModule, ProbabilisticActor, ValueOperator

from occrl.envs import world_constants as C
from occrl.modules.encoder import ConvEncoder
from occrl.modules.heads import HeatmapHead, PolicyHead, ValueHead

__all__ = [
    "OccNetConfig",
    "OccNet",
    "make_occnet",
    "with_remembered_detections",
    "PRESETS",
    "RECURRENT_KEYS",
    "POLICY_OUTPUTS",
    "require_recurrent_state",
]

# what a recurrent decision maker reads besides the observation: the LSTM's state entries (added by
# the net's primer) and the episode-start flag (added by TorchRL's InitTracker, which make_env adds)
RECURRENT_KEYS = ("recurrent_state_h", "recurrent_state_c", "is_init")
# what the policy head writes: the mean and standard deviation of the paper's Gaussian policy
POLICY_OUTPUTS = ("loc", "scale")


def require_recurrent_state(tensordict, who: str) -> None:
    """Raise ``KeyError`` saying how to fix it when ``tensordict`` lacks :data:`RECURRENT_KEYS`.

    Examples:
        >>> from tensordict import TensorDict
        >>> from occrl.modules.occnet import require_recurrent_state
        >>> require_recurrent_state(TensorDict({}, []), "HybridPlanner")
        Traceback (most recent call last):
        ...
        KeyError: "HybridPlanner needs the entries ['recurrent_state_h', 'recurrent_state_c', 'is_init'] ..."
    """
    keys = tensordict.keys()
    missing = [k for k in RECURRENT_KEYS if k not in keys]
    if missing:
        raise KeyError(
            f"{who} needs the entries {missing} in the tensordict: the LSTM's state comes from the network's "
            "primer, env = env.append_transform(net.make_primer()), and 'is_init' from TorchRL's InitTracker "
            "(occrl.envs.make_env adds it)"
        )


@dataclass(frozen=True)
class OccNetConfig:
    """Architecture of an OccNet. ``PRESETS["paper"]`` is the paper's (Sec. VI-B).

    Examples:
        >>> from occrl.modules import PRESETS, OccNetConfig
        >>> PRESETS["paper"] == OccNetConfig()
        True
        >>> cfg = OccNetConfig(heatmap=False)
        >>> cfg.lstm_hidden, cfg.to_dict()["heatmap"]
        (128, False)
    """

    conv_channels: tuple[int, ...] = (8, 8, 16)
    image_size: int = 64
    lstm_hidden: int = 128
    policy_hidden: tuple[int, ...] = (128, 128)
    value_hidden: tuple[int, ...] = (128, 64)
    heatmap_channels: tuple[int, ...] = (8, 8, 16)
    heatmap: bool = True
    batch_norm: bool = True
    action_dim: int = C.ACTION_DIM
    remembered_detections: bool = False
    """False: the paper's image, the objects detected now. True: the image also draws the objects
    detected earlier in the episode where they were last seen
    (:class:`~occrl.envs.remembered.RememberedDetections`; beyond the paper): the env that feeds
    the network must be made with ``make_env(remembered_detections=True)``, as training and
    ``occrl eval`` make it from this setting."""

    def __post_init__(self) -> None:
        factor = 2 ** len(self.conv_channels)
        if self.image_size < factor or self.image_size % factor:
            raise ValueError(f"image_size must be a multiple of {factor} (2 per conv stage), got {self.image_size}")

    def to_dict(self) -> dict:
        return asdict(self)


PRESETS: dict[str, OccNetConfig] = {
    "paper": OccNetConfig(),
    # beyond the paper: the image also draws the objects detected earlier in the episode
    # (occrl.envs.remembered); with_remembered_detections turns a trained paper network into one
    "remembered": OccNetConfig(remembered_detections=True),
}


class OccNet(nn.Module):
    """The assembled network. Attributes are TorchRL modules users can run or swap:

    * ``trunk``: encoder + LSTM, writes ``"belief"`` (recurrent; needs ``"is_init"``).
    * ``actor``: ``ProbabilisticActor`` head on ``"belief"`` writing ``"action"`` (and its log-prob).
    * ``critic``: ``ValueOperator`` head on ``"belief"`` writing ``"state_value"``.
    * ``heatmap_head``: writes ``"heatmap_logits"`` and ``"heatmap"`` (or None without a heat-map head).
    * ``policy``: trunk + actor, a recurrent ``ProbabilisticActor`` for ``env.rollout`` and collectors.
    * ``value``: trunk + critic.
    * ``heatmap``: trunk + heat-map head.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from occrl.modules import OccNet, OccNetConfig
        >>> net = OccNet(OccNetConfig()).eval()
        >>> td = TensorDict({"pixels": torch.zeros(2, 3, 64, 64), "is_init": torch.ones(2, 1, dtype=torch.bool)},
        ...                 batch_size=[2])
        >>> net.value(td)["state_value"].shape, net.heatmap(td)["heatmap"].shape
        (torch.Size([2, 1]), torch.Size([2, 1, 64, 64]))
        >>> OccNet(OccNetConfig(heatmap=False)).heatmap is None
        True
    """

    def __init__(self, config: OccNetConfig) -> None:
        super().__init__()
        self.config = config
        encoder = ConvEncoder(3, config.conv_channels, config.image_size, config.batch_norm)
        self.encoder = TensorDictModule(encoder, in_keys=["pixels"], out_keys=["embed"])
        self.lstm = LSTMModule(input_size=encoder.out_features, hidden_size=config.lstm_hidden, in_key="embed", out_key="belief")
        self.trunk = TensorDictSequential(self.encoder, self.lstm)
        head_module = PolicyHead(config.lstm_hidden, config.policy_hidden, config.action_dim)
        distribution: dict = {"in_keys": list(POLICY_OUTPUTS), "distribution_class": IndependentNormal}
        head = TensorDictModule(head_module, in_keys=["belief"], out_keys=list(POLICY_OUTPUTS))
        self.actor = ProbabilisticActor(head, out_keys=["action"], return_log_prob=True, log_prob_key="action_log_prob", **distribution)
        self.critic = ValueOperator(ValueHead(config.lstm_hidden, config.value_hidden), in_keys=["belief"])
        if config.heatmap:
            self.heatmap_head = TensorDictSequential(
                TensorDictModule(
                    HeatmapHead(config.lstm_hidden, config.heatmap_channels, config.image_size),
                    in_keys=["belief"],
                    out_keys=["heatmap_logits"],
                ),
                TensorDictModule(torch.sigmoid, in_keys=["heatmap_logits"], out_keys=["heatmap"]),
            )
        else:
            self.heatmap_head = None
        self.policy = ProbabilisticActor(
            TensorDictSequential(self.trunk, head),
            out_keys=["action"],
            return_log_prob=True,
            log_prob_key="action_log_prob",
            **distribution,
        )
        self.value = TensorDictSequential(self.trunk, self.critic)
        self.heatmap = TensorDictSequential(self.trunk, self.heatmap_head) if self.heatmap_head is not None else None

    def make_primer(self) -> TensorDictPrimer:
        """The env transform that adds the LSTM's recurrent state entries (zeros at reset)."""
        return self.lstm.make_tensordict_primer()

    def num_parameters(self) -> int:
        return sum(p.numel() for p in self.parameters())


def with_remembered_detections(net: OccNet) -> OccNet:
    """A copy of ``net`` (the same weights) that reads images with remembered detections drawn in
    (``config.remembered_detections``; the ``"remembered"`` preset from a paper network). Only the
    env that feeds it changes: the weights are the trained network's, as a start for training.

    Examples:
        >>> import torch
        >>> from occrl.modules import make_occnet, with_remembered_detections
        >>> net = make_occnet("paper")
        >>> copy = with_remembered_detections(net)
        >>> copy.config.remembered_detections, all(torch.equal(a, b) for a, b in zip(net.state_dict().values(), copy.state_dict().values()))
        (True, True)
    """
    out = OccNet(replace(net.config, remembered_detections=True))
    out.load_state_dict(net.state_dict())
    return out.eval()


def make_occnet(preset: str | OccNetConfig = "paper", heatmap: bool = True, **overrides) -> OccNet:
    """Build the network of a named preset (``"paper"``) or a given config.

    ``heatmap=False`` builds the net without the heat-map head (greedy/stochastic baselines).
    The net is returned in eval mode: batch norm uses running statistics everywhere (collection,
    planning and the loss), and the trainer refreshes them explicitly (docs/design/training.md).

    Examples:
        >>> import torch
        >>> from occrl.envs import make_env
        >>> from occrl.modules import make_occnet
        >>> net = make_occnet("paper")
        >>> env = make_env(batch_size=2, seed=0).append_transform(net.make_primer())
        >>> td = net.policy(env.reset())
        >>> td["action"].shape, td["belief"].shape
        (torch.Size([2, 4]), torch.Size([2, 128]))
    """
    if isinstance(preset, OccNetConfig):
        config = preset
    elif preset in PRESETS:
        config = PRESETS[preset]
    else:
        raise ValueError(f"unknown preset {preset!r}; available: {sorted(PRESETS)}")
    fields = {**config.to_dict(), "heatmap": heatmap, **overrides}
    fields = {k: tuple(v) if isinstance(v, list) else v for k, v in fields.items()}
    return OccNet(OccNetConfig(**fields)).eval()
