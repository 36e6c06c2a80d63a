"""The aggregated DAgger data set: labelled sequences of the last few iterations, kept compact.

DAgger trains on everything the learner has visited so far, labelled by the expert; keeping the
last ``capacity`` iterations bounds memory. Images and heat-map labels are stored as uint8
(the palette colours and 0/1 labels round-trip exactly).
"""

from __future__ import annotations

from pathlib import Path

import torch
from tensordict import TensorDict, TensorDictBase

__all__ = ["DaggerBuffer", "as_float"]

_KEYS = [
    "pixels",
    "is_init",
    "recurrent_state_h",
    "recurrent_state_c",
    "expert_action",
    "expert_weight",
    "value_target",
    ("privileged", "heatmap_target"),
]


class DaggerBuffer:
    """Expert-labelled [B, T] batches of the last ``capacity`` iterations, sampled as whole sequences.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from occrl.training.dagger_buffer import DaggerBuffer
        >>> buffer = DaggerBuffer(capacity=2)
        >>> for _ in range(3):  # three iterations of 2 sequences x 5 steps; the oldest is dropped
        ...     buffer.add(TensorDict({"pixels": torch.ones(2, 5, 3, 64, 64), "expert_action": torch.zeros(2, 5, 4)},
        ...                           batch_size=[2, 5]))
        >>> len(buffer), buffer.batches[0]["pixels"].dtype  # sequences kept, stored compactly
        (4, torch.uint8)
        >>> batch = buffer.sample(3, generator=torch.Generator().manual_seed(0))
        >>> batch.shape, batch["pixels"].dtype, bool((batch["pixels"] == 1.0).all())
        (torch.Size([3, 5]), torch.float32, True)
    """

    def __init__(self, capacity: int) -> None:
        self.capacity = int(capacity)
        self.batches: list[TensorDictBase] = []

    def __len__(self) -> int:
        return sum(b.shape[0] for b in self.batches)

    def add(self, data: TensorDictBase) -> None:
        """Store the expert-labelled [B, T] batch (copies only what the imitation loss reads)."""
        keys = [k for k in _KEYS if k in data.keys(True)]
        slim = data.select(*keys).clone()
        slim.set("pixels", (slim.get("pixels") * 255).round().to(torch.uint8))
        if ("privileged", "heatmap_target") in slim.keys(True):
            slim.set(("privileged", "heatmap_target"), slim.get(("privileged", "heatmap_target")).to(torch.uint8))
        self.batches.append(slim)
        while len(self.batches) > self.capacity:
            self.batches.pop(0)

    def sample(self, num_sequences: int, generator: torch.Generator | None = None) -> TensorDictBase:
        """``num_sequences`` random whole sequences, as float tensors again: [num_sequences, T]."""
        sizes = torch.tensor([b.shape[0] for b in self.batches])
        flat_idx = torch.randint(int(sizes.sum()), (num_sequences,), generator=generator)
        bounds = torch.cumsum(sizes, 0)
        rows = []
        for i in flat_idx.tolist():
            k = int(torch.searchsorted(bounds, torch.tensor(i), right=True))
            start = 0 if k == 0 else int(bounds[k - 1])
            rows.append(self.batches[k][i - start])
        return as_float(torch.stack(rows))

    def save(self, path: str | Path) -> None:
        tmp = Path(str(path) + ".tmp")
        torch.save(
            {"capacity": self.capacity, "batches": [b.to_dict() for b in self.batches], "shapes": [list(b.shape) for b in self.batches]},
            tmp,
        )
        tmp.replace(path)

    def load(self, path: str | Path) -> None:
        obj = torch.load(path, map_location="cpu", weights_only=True)
        self.capacity = int(obj["capacity"])
        self.batches = [TensorDict(d, batch_size=s) for d, s in zip(obj["batches"], obj["shapes"])]


def as_float(stored: TensorDictBase) -> TensorDictBase:
    """Stored (compact) sequences as the losses read them: pixels in [0, 1] and heat-map labels as
    floats again, in a new tensordict (the other entries shared).

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from occrl.training.dagger_buffer import as_float
        >>> as_float(TensorDict({"pixels": torch.full((1, 2, 3, 4, 4), 255, dtype=torch.uint8)}, batch_size=[1, 2]))["pixels"].max()
        tensor(1.)
    """
    out = stored.copy()
    out.set("pixels", stored.get("pixels").float() / 255.0)
    if ("privileged", "heatmap_target") in stored.keys(True):
        out.set(("privileged", "heatmap_target"), stored.get(("privileged", "heatmap_target")).float())
    return out
