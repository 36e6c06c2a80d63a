"""occrl: occlusion-aware search for object retrieval in clutter, as TorchRL components."""

__version__ = "0.2.0"


def load_pretrained(name: str = "occnet"):
    """Load a network shipped with the package (see :mod:`occrl.pretrained`)."""
    from occrl.pretrained import load_pretrained as _load

    return _load(name)


__all__ = ["load_pretrained", "__version__"]
