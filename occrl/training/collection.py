"""The training run's TorchRL collector: one process, ``MultiSyncCollector`` or ``RayCollector``,
built for the current curriculum stage (rebuilt when it changes) and seeded per iteration.

Every iteration starts all episodes afresh (``reset_at_each_iter``) and is seeded by the
iteration, so a resumed run collects what an uninterrupted one would have; worker ``k`` of the
multi-process and the Ray collector steps envs seeded from ``seed + k`` the same way, so the two
collect identical batches (tested) and a run may resume under either.
"""

from __future__ import annotations

import logging
from functools import partial
from typing import Callable

import numpy as np
import torch
from tensordict import TensorDictBase
from torchrl.collectors import Collector, MultiSyncCollector
from torchrl.envs import TransformedEnv
from torchrl.envs.utils import ExplorationType

from occrl.envs import make_env
from occrl.modules import OccNet
from occrl.training.config import TrainConfig

__all__ = ["TrainingCollector", "SeededCollector", "training_env", "RAY_WORKER_MEMORY"]

logger = logging.getLogger(__name__)

RAY_WORKER_MEMORY = 2 * 1024**3  # bytes reserved per Ray collector worker


class SeededCollector(Collector):
    """A ``Collector`` whose ``set_seed`` does what ``MultiSyncCollector.set_seed`` does in each
    worker: seed the envs, the process's torch and numpy generators, then reset the envs. Ray
    workers run this class, so a "ray" run collects the same batches as a "multi" run (tested)."""

    def set_seed(self, seed: int, static_seed: bool = False) -> int:
        out = super().set_seed(seed, static_seed=static_seed)
        torch.manual_seed(seed)
        np.random.seed(seed)
        self.reset()
        return out


def training_env(
    stage: int,
    noise: float,
    num_envs: int,
    seed: int,
    primer_net: OccNet,
) -> TransformedEnv:
    """The env a collector worker steps: ``num_envs`` worlds of ``stage`` with the network's
    LSTM-state primer and image size."""
    env = make_env(
        batch_size=num_envs,
        stage=stage,
        noise=noise,
        seed=seed,
        size=primer_net.config.image_size,
        remembered_detections=primer_net.config.remembered_detections,
    )
    return env.append_transform(primer_net.make_primer())


class TrainingCollector:
    """The collector of a run (``config.collector``) for the current stage.

    Args:
        config: the run's settings (collector, workers, envs, steps, noise, replay workers).
        seed: the run's seed (worker ``k`` seeds its envs from ``seed + k``).
        acting_net: the network whose primer the envs get (the policy's network, on the CPU).
        threads: torch threads left to the main process by ``MultiSyncCollector``.
        ray_address: the Ray cluster of the "ray" collector (None: a local runtime).
    """

    def __init__(self, config: TrainConfig, seed: int, acting_net, threads: int, ray_address: str | None = None) -> None:
        config.validate()  # the settings' checks live there (worlds per worker among them)
        self.config = config
        self.seed = int(seed)
        self.acting_net = acting_net
        self.threads = threads
        self.ray_address = ray_address
        self.collector = None  # the TorchRL collector, or None before the first batch / after close
        self.stage: int | None = None
        self.policy = None
        self._iterator = None

    def worker_stages(self, stage: int) -> list[int]:
        """Curriculum stage of each collector worker: the last ``replay_stage_workers`` workers
        stay one stage back after a promotion (see :class:`TrainConfig`)."""
        c = self.config
        replay = c.replay_stage_workers if stage > 1 else 0
        return [stage] * (c.workers - replay) + [stage - 1] * replay

    def ensure(self, stage: int, make_policy: Callable[[], object]):
        """The collector for ``stage``, built (with the policy ``make_policy()`` returns) unless the
        current one already collects it."""
        if self.collector is not None and self.stage == stage:
            return self.collector
        self.close()
        c = self.config
        policy = make_policy()
        self.policy = policy
        if c.collector == "single":
            self.collector = Collector(
                partial(training_env, stage, c.noise, c.num_envs, self.seed, self.acting_net),
                policy,
                frames_per_batch=c.frames_per_batch,
                total_frames=-1,
                reset_at_each_iter=True,
                exploration_type=ExplorationType.RANDOM,
            )
        elif c.collector in ("multi", "ray"):
            per = c.num_envs // c.workers  # a whole number: TrainConfig.validate checks it
            # worker k steps envs seeded from seed + k in both: the same batches either way (tested)
            stages = self.worker_stages(stage)
            factories = [partial(training_env, stages[k], c.noise, per, self.seed + k, self.acting_net) for k in range(c.workers)]
            if c.collector == "multi":
                self.collector = MultiSyncCollector(
                    factories,
                    policy,
                    num_threads=self.threads,
                    frames_per_batch=c.frames_per_batch,
                    total_frames=-1,
                    reset_at_each_iter=True,
                    exploration_type=ExplorationType.RANDOM,
                )
            else:
                from torchrl.collectors.distributed import RayCollector

                from occrl.distributed import start_ray

                start_ray(self.ray_address, num_cpus=c.workers)
                self.collector = RayCollector(
                    factories,
                    policy,
                    collector_class=SeededCollector,
                    num_collectors=c.workers,
                    sync=True,
                    frames_per_batch=c.frames_per_batch,
                    total_frames=2**62,  # RayCollector stops at once on -1 ("endless" elsewhere)
                    reset_at_each_iter=True,
                    exploration_type=ExplorationType.RANDOM,
                    remote_configs={"num_cpus": 1, "memory": RAY_WORKER_MEMORY},
                )
        else:
            raise ValueError(f"collector must be 'single', 'multi' or 'ray', got {c.collector!r}")
        self.stage = stage
        self._iterator = iter(self.collector)
        return self.collector

    def next_batch(self, iteration_seed: int) -> TensorDictBase:
        """Seed the collector, send it the policy's weights and collect one batch, [envs, steps]."""
        self.collector.set_seed(iteration_seed)
        self.collector.update_policy_weights_()
        data = next(self._iterator)
        if data.batch_dims == 3:  # MultiSyncCollector: [workers, envs, time]
            data = data.reshape(-1, data.shape[-1])
        return data

    def discard(self) -> None:
        """Drop a collector whose Ray worker died (its surviving actors are stopped)."""
        broken, self.collector, self.stage = self.collector, None, None
        try:
            broken.shutdown()
        except Exception:  # noqa: BLE001 - the dead actor makes shutdown fail; nothing to keep
            pass

    def per_stage_success(self, data: TensorDictBase, episode_stats: Callable[[TensorDictBase], dict]) -> dict:
        """``success_rate_stageS`` per stage when the workers collect different stages (the rows
        of a batch are the workers' env batches in order)."""
        stages = self.worker_stages(self.stage) if self.config.collector != "single" else [self.stage]
        if len(set(stages)) < 2:
            return {}
        per = data.shape[0] // len(stages)
        out = {}
        for st in sorted(set(stages)):
            rows = torch.cat([torch.arange(k * per, (k + 1) * per) for k, s in enumerate(stages) if s == st])
            succ = episode_stats(data[rows])["success"]
            if succ:
                out[f"success_rate_stage{st}"] = float(np.mean(succ))
        return out

    def close(self) -> None:
        if self.collector is not None:
            try:
                self.collector.shutdown()
            finally:
                self.collector = None
        if self.config.collector == "ray":
            from occrl.distributed import stop_ray

            stop_ray()
