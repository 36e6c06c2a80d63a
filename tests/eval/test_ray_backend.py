"""``occrl eval --backend ray``: tasks spread over Ray actors give the local backend's results."""

from pathlib import Path

import pytest

import occrl
from occrl.distributed import ray_available
from occrl.eval.runner import EVAL_SEED_BASE, run_tasks

pytestmark = pytest.mark.skipif(not ray_available(), reason="ray is not installed (pip install 'occrl[ray]')")

SHIPPED = Path(occrl.__file__).parent / "pretrained" / "occnet-takeover.pt"


def _outcomes(results):
    return [(r.seed, r.objects, r.success, r.dropped, r.actions) for r in results]  # wall time differs


@pytest.mark.integration
def test_ray_backend_matches_local_for_the_same_seeds():
    import ray

    from occrl.distributed import stop_ray

    seeds = list(range(EVAL_SEED_BASE, EVAL_SEED_BASE + 6))
    try:
        for method, weights in (("scripted", None), ("stochastic-gen", SHIPPED)):
            local = run_tasks(method, 1, seeds, noise=0.1, batch=2, workers=1, weights=weights, progress=False)
            remote = run_tasks(method, 1, seeds, noise=0.1, batch=2, workers=2, weights=weights, progress=False, backend="ray")
            assert _outcomes(remote) == _outcomes(local), method
            if method == "scripted":  # a real comparison: the episodes differ from each other
                assert len({r.actions for r in local}) > 1 and any(r.success for r in local)
    finally:
        stop_ray()
    assert not ray.is_initialized()


def test_unknown_backend_is_refused():
    with pytest.raises(ValueError, match="backend must be 'local' or 'ray'"):
        run_tasks("scripted", 1, [EVAL_SEED_BASE], backend="slurm", progress=False)
