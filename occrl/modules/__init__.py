"""Networks: encoder, heads and the OccNet builder (TorchRL modules)."""

from occrl.modules.encoder import ConvEncoder
from occrl.modules.heads import HeatmapHead, PolicyHead, ValueHead
from occrl.modules.occnet import PRESETS, OccNet, OccNetConfig, make_occnet, with_remembered_detections
from occrl.modules.finer_input import with_finer_input
from occrl.modules.mixture_policy import GaussianMixture, MixturePolicyHead, with_mixture_policy
from occrl.modules.wider import with_wider_network

__all__ = [
    "ConvEncoder",
    "PolicyHead",
    "ValueHead",
    "HeatmapHead",
    "OccNet",
    "OccNetConfig",
    "make_occnet",
    "PRESETS",
    "with_finer_input",
    "MixturePolicyHead",
    "GaussianMixture",
    "with_mixture_policy",
    "with_remembered_detections",
    "with_wider_network",
]
