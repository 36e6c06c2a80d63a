"""The observation image's classes and colours (paper Sec. IV-A): the label of every pixel of a
label map (:mod:`occrl.envs.render`) and the palette that turns labels into the network's input.

Observable space grey, occluded space white (outside the field of view or in the shadow of a
detected object or a wall, cast from the camera), walls brown, the open front edge black, clutter
red, the target green, the gripper blue.
"""

from __future__ import annotations

import numpy as np
import torch

__all__ = ["LABELS", "PALETTE", "labels_to_pixels", "labels_to_rgb"]

LABELS = {"observable": 0, "occluded": 1, "wall": 2, "edge": 3, "clutter": 4, "target": 5, "gripper": 6}
PALETTE = np.array(
    [
        [128, 128, 128],  # observable: grey
        [255, 255, 255],  # occluded: white
        [150, 90, 40],  # wall: brown
        [0, 0, 0],  # front edge: black
        [220, 30, 30],  # clutter: red
        [30, 200, 30],  # target: green
        [40, 80, 230],  # gripper: blue
    ],
    dtype=np.uint8,
)

_PALETTE_CHANNELS = np.ascontiguousarray((PALETTE.astype(np.float32) / 255.0).T)  # (3, classes)
_PALETTE_END_TO_END = _PALETTE_CHANNELS.reshape(-1)  # channel c's colour of label k at c * classes + k
_CHANNEL_OFFSETS = (len(PALETTE) * np.arange(3)).astype(np.uint8)


def labels_to_pixels(labels: np.ndarray) -> torch.Tensor:
    """(B, S, S) labels -> (B, 3, S, S) float32 colours in [0, 1], the network input.
    (One ``np.take`` from the three channels' palettes laid end to end, each pixel's label offset
    to its channel's: faster than a take per channel into the channel-strided output, and than
    numpy's fancy indexing with a transpose, itself several times faster than torch's.)

    Raises:
        ValueError: if a label is not one of :data:`LABELS`' values.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.palette import LABELS, labels_to_pixels
        >>> px = labels_to_pixels(np.full((2, 64, 64), LABELS["occluded"], dtype=np.uint8))
        >>> px.shape, px.dtype, float(px.min())  # occluded space is white
        (torch.Size([2, 3, 64, 64]), torch.float32, 1.0)
    """
    labels = np.asarray(labels)
    if labels.size and ((labels.dtype.kind != "u" and labels.min() < 0) or labels.max() >= len(PALETTE)):
        raise ValueError(
            f"labels must be in [0, {len(PALETTE)}) (occrl.envs.palette.LABELS), got values in [{labels.min()}, {labels.max()}]"
        )
    out = np.empty((labels.shape[0], 3, *labels.shape[1:]), dtype=np.float32)
    offsets = _CHANNEL_OFFSETS.reshape(1, 3, *[1] * (labels.ndim - 1))
    np.take(_PALETTE_END_TO_END, labels[:, None] + offsets, out=out, mode="clip")  # (in range: checked above)
    return torch.from_numpy(out)


def labels_to_rgb(labels: np.ndarray) -> np.ndarray:
    """(..., H, W) labels -> (..., H, W, 3) uint8 colours.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.palette import LABELS, labels_to_rgb
        >>> rgb = labels_to_rgb(np.array([[LABELS["observable"], LABELS["target"]]], dtype=np.uint8))
        >>> rgb.shape, rgb[0, 1].tolist()
        ((1, 2, 3), [30, 200, 30])
    """
    return PALETTE[labels]
