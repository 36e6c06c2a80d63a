"""occrl: occlusion-aware search for object retrieval in clutter, as TorchRL components."""

__version__ = "0.1.0"
