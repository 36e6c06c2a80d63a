"""Ray plumbing shared by training (``RayCollector``) and evaluation (``occrl eval --backend ray``).

Ray is an optional dependency (``pip install "occrl[ray]"``). Without an address a local Ray
runtime is started with as many CPUs as asked for; with ``address`` ("auto" or
"ray://host:10001" or "host:6379") an existing cluster is joined. Only the runtime this module
started is shut down by :func:`stop_ray`.

Examples:
    >>> from occrl.distributed import ray_available
    >>> isinstance(ray_available(), bool)
    True
"""

from __future__ import annotations

import importlib.util
import logging

__all__ = ["ray_available", "require_ray", "start_ray", "stop_ray", "is_worker_death", "WorkerDiedError"]

logger = logging.getLogger(__name__)

_STARTED_HERE = False


class WorkerDiedError(RuntimeError):
    """A Ray worker (collector or evaluation actor) died and could not be replaced.

    Examples:
        >>> from occrl.distributed import WorkerDiedError
        >>> try:
        ...     raise WorkerDiedError("collector 1 died twice")
        ... except RuntimeError as err:
        ...     print(type(err).__name__, err)
        WorkerDiedError collector 1 died twice
    """


def ray_available() -> bool:
    """True when the optional dependency ray is installed (without importing it).

    Examples:
        >>> from occrl.distributed import ray_available
        >>> ray_available()  # ray is installed here (pip install "occrl[ray]")
        True
    """
    return importlib.util.find_spec("ray") is not None


def require_ray(what: str = "the Ray backend"):
    """Import ray or fail with the install command.

    Examples:
        >>> from occrl.distributed import require_ray
        >>> require_ray("the Ray collector").__name__
        'ray'
    """
    if not ray_available():
        raise ImportError(
            f'{what} needs the optional dependency ray: pip install "occrl[ray]" '
            "(or choose the 'single' / 'multi' collector, the local eval backend)"
        )
    import ray

    return ray


def start_ray(address: str | None = None, num_cpus: int | None = None) -> None:
    """Join the cluster at ``address`` or start a local runtime (no dashboard, quiet workers).

    Examples:
        Starting a local runtime takes several seconds, hence skipped here:

        >>> import ray
        >>> from occrl.distributed import start_ray, stop_ray
        >>> start_ray(num_cpus=1)  # doctest: +SKIP
        >>> ray.is_initialized()  # doctest: +SKIP
        True
        >>> stop_ray()  # doctest: +SKIP
    """
    global _STARTED_HERE
    ray = require_ray()
    if ray.is_initialized():
        return
    if address:
        logger.info("joining the Ray cluster at %s", address)
        ray.init(address=address, log_to_driver=False)
    else:
        logger.info("starting a local Ray runtime with %s CPUs", num_cpus)
        ray.init(num_cpus=num_cpus, include_dashboard=False, log_to_driver=False, configure_logging=False)
    _STARTED_HERE = True


def stop_ray() -> None:
    """Shut down the Ray runtime if :func:`start_ray` started (or joined) it.

    Examples:
        >>> import ray
        >>> from occrl.distributed import stop_ray
        >>> stop_ray()  # nothing was started here: a no-op
        >>> ray.is_initialized()
        False
    """
    global _STARTED_HERE
    if _STARTED_HERE and ray_available():
        import ray

        if ray.is_initialized():
            ray.shutdown()
    _STARTED_HERE = False


def is_worker_death(err: BaseException) -> bool:
    """True for the errors Ray raises when an actor or its node dies.

    Examples:
        >>> from ray.exceptions import RayActorError
        >>> from occrl.distributed import is_worker_death
        >>> is_worker_death(RayActorError()), is_worker_death(RuntimeError("a bug in the worker"))
        (True, False)
    """
    if not ray_available():
        return False
    from ray import exceptions as rex

    kinds = tuple(
        k
        for k in (
            getattr(rex, n, None)
            for n in ("RayActorError", "ActorDiedError", "ActorUnavailableError", "WorkerCrashedError", "NodeDiedError")
        )
        if k is not None
    )
    return isinstance(err, kinds)
