"""Curriculum PPO (+ heat-map loss) training of OccNet with TorchRL collectors.

One iteration, top to bottom:

1. collect ``num_envs x steps_per_env`` frames with the current stochastic policy (every episode
   starts afresh; the seed of iteration ``i`` is ``seed + i``, so a resumed run is exact);
2. compute values and GAE advantages;
3. optimise for ``epochs`` passes over minibatches of whole sequences: PPO + c3 x heat-map BCE, or,
   during the warm start, the expert's negative log-likelihood + value + heat-map losses;
4. refresh batch-norm statistics on the batch (after the update, so that the update sees the
   function that collected the batch: PPO's probability ratio starts at exactly 1);
5. log, feed the curriculum with the finished episodes, checkpoint every few minutes.

The collector lives in :mod:`occrl.training.collection`, the update of each phase in
:mod:`occrl.training.learner`, the imitation teachers in :mod:`occrl.training.teachers`;
:meth:`Trainer.train` is the loop.
"""

from __future__ import annotations

import json
import logging
import math
import time
from pathlib import Path
from typing import Callable

import numpy as np
import torch
from tensordict import TensorDictBase
from torchrl.record.loggers import CSVLogger
from tqdm import tqdm

from occrl.distributed import WorkerDiedError, is_worker_death
from occrl.envs.episodes import run_episodes, task_scenes
from occrl.modules import make_occnet
from occrl.objectives import compute_advantages
from occrl.modules.weights import load_weights, save_weights
from occrl.planners import HybridPlanner
from occrl.training.checkpoint import load_checkpoint, save_checkpoint
from occrl.training.collection import TrainingCollector
from occrl.training.config import TrainConfig, same_run_settings, training_device
from occrl.training.cpu_time import tree_cpu_seconds
from occrl.training.curriculum import Curriculum
from occrl.training.dagger import ExpertMixPolicy
from occrl.training.learner import Learner
from occrl.training.plots import plot_learning_curves
from occrl.training.run_folder import (
    CHECKPOINT,
    DAGGER_DATA,
    METRICS,
    WARM_START_WEIGHTS,
    WEIGHTS,
    file_sha256,
    truncate_metrics,
)
from occrl.training.stats import episode_stats

__all__ = ["Trainer", "hybrid_validation_success", "VALIDATION_SEED_BASE"]

logger = logging.getLogger(__name__)

VALIDATION_SEED_BASE = 20_000_000  # hybrid-promotion tasks (held-out evaluation starts at 10_000_000)


def hybrid_validation_success(net, stage: int, tasks: int, noise: float = 0.0) -> float:
    """The paper's promotion statistic: hybrid 4x4 success of ``net`` on ``tasks`` fixed validation
    tasks of ``stage`` (task seeds from :data:`VALIDATION_SEED_BASE`, apart from training and
    held-out seeds). The trainer's default ``promotion_check``."""
    seeds = list(range(VALIDATION_SEED_BASE, VALIDATION_SEED_BASE + tasks))
    planner = HybridPlanner(net, m=4, h=4, seed=0)
    results = run_episodes(
        planner,
        task_scenes(stage, seeds),
        seeds,
        noise,
        batch_size=1,
        primers=[net.make_primer()],
        size=net.config.image_size,
        remembered_detections=net.config.remembered_detections,
    )
    return float(np.mean([r.success for r in results]))


class Trainer:
    """Train an OccNet. ``Trainer(config, run_dir, seed).train(iterations)``; resumes from
    ``run_dir/checkpoint.pt`` when it exists.

    ``promotion_check(net, stage, tasks, noise) -> success rate`` is the statistic of the "hybrid"
    promotion rule (default :func:`hybrid_validation_success`, the paper's); pass another to
    promote on something else (e.g. a different validation set).

    Examples:
        >>> import tempfile
        >>> from occrl.training import Trainer, get_train_config
        >>> trainer = Trainer(get_train_config("tiny"), tempfile.mkdtemp(), seed=0, progress=False)
        >>> trainer.train(iterations=1)["iteration"]
        1
    """

    def __init__(
        self,
        config: TrainConfig,
        run_dir: str | Path,
        seed: int = 0,
        progress: bool = True,
        checkpoint_every_s: float = 300.0,
        tensorboard: bool = True,
        ray_address: str | None = None,
        max_worker_restarts: int = 2,
        init_weights: str | Path | None = None,
        promotion_check: Callable[..., float] = hybrid_validation_success,
    ) -> None:
        config.validate()
        # the teacher of the imitation phase (None without one); a network it plans with is loaded
        # (and checked) whenever the settings name one
        self.teacher = config.imitation.teacher if config.imitation_iterations > 0 else None
        fixed_net = config.imitation.teacher.fixed_network() if config.imitation is not None else None
        self.config = config
        self.promotion_check = promotion_check
        self.ray_address = ray_address  # where the "ray" collector runs (None: a local Ray runtime)
        self.max_worker_restarts = max_worker_restarts
        # threads for the update; collector workers are idle meanwhile (sync collection), so the
        # main process may use every core (MultiSyncCollector would otherwise leave it one thread)
        self.update_threads = torch.get_num_threads()
        self.run_dir = Path(run_dir)
        self.run_dir.mkdir(parents=True, exist_ok=True)
        self.seed = int(seed)
        self.progress = progress
        self.checkpoint_every_s = checkpoint_every_s
        torch.manual_seed(self.seed)
        self.device = training_device(config.device)
        self.net = make_occnet(config.net_preset, heatmap=config.heatmap).eval()
        # collection, planner teachers and promotion checks act on the CPU: on self.acting_net,
        # the learner itself on a CPU run, else a CPU copy synchronised after every update
        self.acting_net = self.net
        if self.device.type != "cpu":
            self.acting_net = make_occnet(config.net_preset, heatmap=config.heatmap).eval()
            self.net.to(self.device)
        self.learner = Learner(self.net, config, self.device)
        self.loss, self.optimizer, self.dagger = self.learner.loss, self.learner.optimizer, self.learner.dagger
        self.curriculum = Curriculum(config.start_stage, config.promotion.threshold, config.promotion.window)
        self.iteration = 0
        self.saved_iteration: int | None = None  # the iteration of the checkpoint on disk (None: none yet)
        self.frames = 0
        self.train_seconds = 0.0
        self.cpu_seconds: float | None = 0.0  # CPU of the run's process tree (tree_cpu_seconds); None: not measured from the start
        self.expert = self.teacher.make_expert(self.acting_net, self.seed, fixed_net) if self.teacher is not None else None
        for leftover in self.run_dir.glob("*.tmp"):  # a write a crash interrupted; its target is intact
            leftover.unlink()
        ckpt = self.run_dir / CHECKPOINT
        if ckpt.exists():
            obj = load_checkpoint(ckpt, self.net, self.optimizer)
            if not same_run_settings(obj["train_config"], config.to_dict()):
                raise ValueError(f"{ckpt} was written with other training settings; use another run folder")
            st = obj["state"]
            if st["seed"] != self.seed:
                raise ValueError(f"{ckpt} was written with seed {st['seed']}, not {self.seed}")
            self.iteration, self.frames, self.train_seconds = st["iteration"], st["frames"], st["train_seconds"]
            self.cpu_seconds = st.get("cpu_seconds")  # checkpoints before it was measured: unknown
            self.saved_iteration = self.iteration
            self.curriculum.load_state_dict(st["curriculum"])
            if self.iteration < config.imitation_iterations and config.imitation.updates > 0:
                dagger_file = self.run_dir / (st.get("dagger_data") or DAGGER_DATA)  # checkpoints before 0.2: one fixed name
                if dagger_file.exists():
                    self.dagger.load(dagger_file)
                else:
                    logger.warning("no %s next to the checkpoint: the DAgger data set restarts empty (resume not exact)", dagger_file.name)
            logger.info("resumed %s at iteration %d (stage %d, %d frames)", ckpt, self.iteration, self.curriculum.stage, self.frames)
            self._truncate_metrics()
            self.init_weights = st.get("init_weights")
            if init_weights is not None and (self.init_weights or {}).get("sha256") != file_sha256(init_weights):
                # the checkpoint holds the weights; the starting point only matters for the record
                logger.warning(
                    "resuming %s, which started from %s, not from the given %s (the latter is ignored)",
                    ckpt,
                    (self.init_weights or {}).get("path", "scratch"),
                    init_weights,
                )
        else:
            self.init_weights = None
            self._truncate_metrics()  # rows of a run killed before its first checkpoint are redone
            if init_weights is not None:
                load_weights(init_weights, self.net)  # CheckpointError for another architecture or a bad file
                self.net.eval()
                self.init_weights = {"path": str(init_weights), "sha256": file_sha256(init_weights)}
                logger.info("new run from the weights in %s", init_weights)
        self._sync_acting_net()
        self.collection = TrainingCollector(config, self.seed, self.acting_net, self.update_threads, ray_address)
        self._loggers = self._make_loggers(tensorboard)

    # ------------------------------------------------------------------ plumbing
    def _sync_acting_net(self) -> None:
        """Copy the learner's weights and batch-norm statistics into the CPU copy that acts."""
        if self.acting_net is not self.net:
            self.acting_net.load_state_dict(self.net.state_dict())
            self.acting_net.eval()

    def _make_loggers(self, tensorboard: bool) -> list:
        loggers = [CSVLogger(exp_name="logs", log_dir=str(self.run_dir))]
        if tensorboard:
            try:
                from torchrl.record.loggers import TensorboardLogger

                loggers.append(TensorboardLogger(exp_name="tensorboard", log_dir=str(self.run_dir)))
            except ImportError:  # pragma: no cover - tensorboard is a dependency
                logger.warning("tensorboard is not installed; logging to CSV only")
        return loggers

    def _beta(self) -> float:
        """The share the teacher acts in (its :meth:`~occrl.training.teachers.Teacher.beta`) during
        the imitation phase, 0 afterwards (PPO)."""
        if self.teacher is None or self.iteration >= self.config.imitation_iterations:
            return 0.0
        return self.teacher.beta(self.iteration, self.config.imitation)

    def _collection_policy(self):
        """What the collector runs: the learner's policy, mixed with or labelled by the teacher."""
        if self.teacher is None:
            return self.acting_net.policy
        return self.teacher.collection_policy(self.acting_net.policy, self.expert)

    def _phase(self) -> str:
        c = self.config
        if self.iteration < c.imitation_iterations:
            return "imitation"
        if self.iteration < c.imitation_iterations + c.critic_warmup_iters:
            return "critic_warmup"
        return "ppo"

    def close(self) -> None:
        """Stop the collector (its worker processes or Ray actors)."""
        self.collection.close()

    # ------------------------------------------------------------------ one iteration
    def _collect(self) -> TensorDictBase:
        """One batch; when a Ray worker dies the collector is rebuilt and the iteration repeated
        (every iteration is seeded afresh, so the repeat gives the batch the lost one would have)."""
        for attempt in range(self.max_worker_restarts + 1):
            try:
                return self._collect_once()
            except Exception as err:
                if self.config.collector != "ray" or not is_worker_death(err):
                    raise
                self.collection.discard()  # stops the surviving actors of the broken collector
                if attempt == self.max_worker_restarts:
                    raise WorkerDiedError(
                        f"a Ray collector worker died at iteration {self.iteration} and {self.max_worker_restarts} "
                        f"replacements died too ({type(err).__name__}: {err})"
                    ) from err
                logger.error(
                    "a Ray collector worker died at iteration %d (%s); starting new workers and repeating the iteration (%d/%d)",
                    self.iteration,
                    type(err).__name__,
                    attempt + 1,
                    self.max_worker_restarts,
                )

    def _collect_once(self) -> TensorDictBase:
        self.collection.ensure(self.curriculum.stage, self._collection_policy)
        it_seed = self.seed * 1_000_003 + self.iteration
        torch.manual_seed(it_seed)
        beta = self._beta()
        if isinstance(self.collection.policy, ExpertMixPolicy):
            self.collection.policy.beta = beta
        if hasattr(self.expert, "reseed"):  # the planners
            self.expert.reseed(it_seed)
        if hasattr(self.expert, "sync_weights"):  # the planner teachers plan on the weights of this iteration
            self.expert.sync_weights()
        if hasattr(self.expert, "reset"):  # teachers with an episode memory
            self.expert.reset()
        return self.collection.next_batch(it_seed)

    def _hybrid_success(self) -> float:
        """The promotion statistic of the current network and stage (``promotion_check``)."""
        c = self.config
        rate = float(self.promotion_check(self.acting_net, self.curriculum.stage, c.promotion.eval_tasks, c.noise))
        self.acting_net.eval()
        logger.info("hybrid 4x4 validation success at iteration %d (stage %d): %.2f", self.iteration, self.curriculum.stage, rate)
        return rate

    def _progress_fields(self, summary: dict, phase: str, start_wall: float, max_seconds: float | None) -> dict:
        """The progress bar's fields: stage, phase, success, frames/s, and the time left when the
        run is bounded by time (tqdm's own ETA covers a bound in iterations) and the iterations
        to the next promotion check."""
        c = self.config
        fields = {"stage": summary["stage"], "phase": phase, "success": f"{summary['success_rate']:.2f}", "fps": f"{summary['fps']:.0f}"}
        if max_seconds is not None:
            left = max(0.0, max_seconds - (time.time() - start_wall))
            fields["left"] = f"{int(left // 3600)}:{int(left % 3600 // 60):02d}h"
        if c.promotion.rule == "hybrid" and phase in ("imitation", "ppo"):
            fields["check_in"] = f"{c.promotion.eval_every - self.iteration % c.promotion.eval_every}it"
        return fields

    def train(self, iterations: int | None = None, max_seconds: float | None = None) -> dict:
        """Run until ``iterations`` iterations in total (counting resumed ones) or ``max_seconds``."""
        c = self.config
        torch.set_num_threads(self.update_threads)
        target = iterations if iterations is not None else math.inf
        start_wall = time.time()
        last_ckpt = time.time()
        bar = None
        if self.progress:
            bar = tqdm(total=None if target == math.inf else target, initial=self.iteration, unit="it", desc="training")
        summary: dict = {}
        # whether the state is that of a finished iteration; from the update to the metrics row
        # (promotion check included) it is not, and an interruption there (SIGTERM, Ctrl-C, an
        # error) keeps the last checkpoint rather than write a half-done iteration
        consistent = True
        try:
            while self.iteration < target and (max_seconds is None or time.time() - start_wall < max_seconds):
                t0, cpu0 = time.time(), tree_cpu_seconds()
                phase = self._phase()
                beta = self._beta()
                data = self._collect()
                t_collect = time.time() - t0
                if phase == "imitation":  # the teacher's labels
                    self.teacher.label(data, self.expert, self.acting_net, seed=self.seed * 1_000_003 + self.iteration)
                consistent, unfinished = False, self.iteration + 1
                batch = self.learner.on_device(data)  # the collected batch (CPU) where the learner is
                compute_advantages(self.net, batch, c.gamma, c.gae_lambda)
                losses = self.learner.update(batch, phase)
                # after the update, for the next collection: refreshed between collection and update,
                # the statistics changed the policy under PPO's ratio (|log-prob change| 0.13 on average)
                self.learner.refresh_batch_norm(batch)
                self._sync_acting_net()
                stats = episode_stats(data)
                promoted = False
                if beta == 0.0:
                    promoted = self.curriculum.record(stats["success"], promote=c.promotion.rule == "learner")
                self.iteration += 1
                self.frames += data.numel()
                dt = time.time() - t0
                hybrid_rate = None
                if c.promotion.rule == "hybrid" and phase in ("imitation", "ppo") and self.iteration % c.promotion.eval_every == 0:
                    hybrid_rate = self._hybrid_success()
                    if hybrid_rate > c.promotion.threshold:
                        promoted = self.curriculum.promote()
                self.train_seconds += time.time() - t0
                if self.cpu_seconds is not None:
                    self.cpu_seconds += tree_cpu_seconds() - cpu0
                if phase == "imitation" and self.iteration == c.imitation_iterations:
                    save_weights(self.run_dir / WARM_START_WEIGHTS, self.net, {"train_preset": c.preset, **self.state()})
                summary = {
                    "iteration": self.iteration,
                    "frames": self.frames,
                    "stage": self.curriculum.stage,
                    "phase": phase,
                    "beta": beta,
                    "episodes": len(stats["success"]),
                    "success_rate": float(np.mean(stats["success"])) if stats["success"] else float("nan"),
                    "window_success_rate": self.curriculum.success_rate,
                    "episode_return": float(np.mean(stats["returns"])) if stats["returns"] else float("nan"),
                    "episode_length": float(np.mean(stats["lengths"])) if stats["lengths"] else float("nan"),
                    "fps": data.numel() / dt,
                    "collect_fps": data.numel() / max(t_collect, 1e-9),
                    "train_hours": self.train_seconds / 3600,
                    **losses,
                }
                if self.cpu_seconds is not None:
                    summary["cpu_hours"] = self.cpu_seconds / 3600
                if hybrid_rate is not None:
                    summary["hybrid_success_rate"] = hybrid_rate
                if self.teacher is not None:
                    summary.update(self.teacher.summary(self.expert))
                summary.update(self.collection.per_stage_success(data, episode_stats))
                self._log(summary)
                consistent = True
                if promoted:
                    logger.info("promoted to stage %d at iteration %d", self.curriculum.stage, self.iteration)
                if bar is not None:
                    bar.update(1)
                    bar.set_postfix(**self._progress_fields(summary, phase, start_wall, max_seconds))
                if time.time() - last_ckpt >= self.checkpoint_every_s:
                    self.save()
                    last_ckpt = time.time()
        finally:
            if bar is not None:
                bar.close()
            if consistent:
                self.save()
            else:
                logger.warning(
                    "stopped inside iteration %d's update or promotion check: kept the checkpoint of iteration %s",
                    unfinished,
                    self.saved_iteration,
                )
        return summary

    def _truncate_metrics(self) -> None:
        """Drop metric rows written after the checkpoint we resumed from (they will be redone)."""
        truncate_metrics(self.run_dir / METRICS, self.iteration)

    def _log(self, summary: dict) -> None:
        with open(self.run_dir / METRICS, "a") as f:
            f.write(json.dumps(summary) + "\n")
        for lg in self._loggers:
            for k, v in summary.items():
                if isinstance(v, (int, float)) and not (isinstance(v, float) and math.isnan(v)):
                    lg.log_scalar(k, float(v), step=self.frames)

    def state(self) -> dict:
        return {
            "iteration": self.iteration,
            "frames": self.frames,
            "train_seconds": self.train_seconds,
            "cpu_seconds": self.cpu_seconds,
            "seed": self.seed,
            "curriculum": self.curriculum.state_dict(),
            "init_weights": self.init_weights,
        }

    def save(self) -> None:
        """Write the resumable checkpoint, the weights file and the learning-curve plot.

        Crash-safe: every file is written to a temporary name and renamed into place, and the
        checkpoint is the commit point. The DAgger data set goes first, under a name that carries
        the iteration, which the checkpoint then records; only after the checkpoint is in place
        are older data sets deleted. A run killed at any moment resumes from the last complete
        checkpoint with the data set that belongs to it (tests/training/test_kill_resume.py)."""
        dagger_name = None
        if self.iteration < self.config.imitation_iterations and self.config.imitation.updates > 0:
            dagger_name = f"dagger_buffer-{self.iteration:07d}.pt"
            self.dagger.save(self.run_dir / dagger_name)
        save_checkpoint(
            self.run_dir / CHECKPOINT, self.net, self.optimizer, self.config.to_dict(), {**self.state(), "dagger_data": dagger_name}
        )
        self.saved_iteration = self.iteration
        for old in self.run_dir.glob("dagger_buffer*.pt"):
            if old.name != dagger_name:
                old.unlink()  # not named by the checkpoint any more (or the warm start is over)
        save_weights(self.run_dir / WEIGHTS, self.net, {"train_preset": self.config.preset, **self.state()})
        if not (self.run_dir / METRICS).exists():  # no iteration yet
            return
        try:
            plot_learning_curves(self.run_dir / METRICS, self.run_dir / "learning_curves.png")
        except Exception as err:  # a plot must never stop training
            logger.warning("could not plot learning curves: %s", err)
