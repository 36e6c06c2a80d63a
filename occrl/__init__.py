"""occrl: occlusion-aware search for object retrieval in clutter, as TorchRL components."""

__version__ = "0.3.0"


def load_pretrained(name: str = "occnet"):
    """Load a network shipped with the package (see :mod:`occrl.pretrained`)."""
    from occrl.pretrained import load_pretrained as _load

    return _load(name)


def _register_gymnasium_env() -> None:
    """``gymnasium.make("occrl/ShelfRetrieval-v0")`` after ``import occrl`` (gymnasium optional:
    ``pip install -e ".[gym]"``); the env module itself is imported only when an env is made."""
    try:
        import gymnasium
    except ImportError:
        return
    if "occrl/ShelfRetrieval-v0" not in gymnasium.envs.registry:
        gymnasium.register(
            id="occrl/ShelfRetrieval-v0",
            entry_point="occrl.envs.gym_env:ShelfRetrievalEnv",
            vector_entry_point="occrl.envs.gym_env:ShelfRetrievalVectorEnv",
        )


_register_gymnasium_env()

__all__ = ["load_pretrained", "__version__"]
