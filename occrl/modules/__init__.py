"""Networks: encoder, heads and the OccNet builder (TorchRL modules)."""

from occrl.modules.encoder import ConvEncoder
from occrl.modules.heads import HeatmapHead, PolicyHead, ValueHead
from occrl.modules.occnet import PRESETS, OccNet, OccNetConfig, make_occnet, with_remembered_detections

__all__ = [
    "ConvEncoder",
    "PolicyHead",
    "ValueHead",
    "HeatmapHead",
    "OccNet",
    "OccNetConfig",
    "make_occnet",
    "PRESETS",
    "with_remembered_detections",
]
