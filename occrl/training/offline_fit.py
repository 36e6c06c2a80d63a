"""The offline fit: many gradient steps on demonstrations collected once (``occrl fit``).

When the teacher acts in every labelled step (:func:`~occrl.training.demonstrations.collect_demonstrations`),
the labels do not depend on the learner, so the data can be collected once and fitted for as long
as the CPU allows. :func:`fit_offline` reads the labelled sequences of one or more data runs,
holds a share out for a validation negative log-likelihood, and takes gradient steps with the
trainer's imitation loss (:meth:`occrl.training.learner.Learner.imitation_terms`, at the data
run's coefficients, optimizer and learning rate unless :attr:`FitConfig.lr` is given).
Batch-norm statistics stay those of the starting network. The fit resumes from its checkpoint
and ends in the same weights either way; it logs its CPU and wall time.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import time
from dataclasses import dataclass
from pathlib import Path

import torch
from tensordict import TensorDictBase
from torchrl.modules import set_recurrent_mode

from occrl.modules.weights import load_weights, save_weights
from occrl.objectives import imitation_nll
from occrl.pretrained import network_name, weights_file
from occrl.training.checkpoint import load_checkpoint, save_checkpoint
from occrl.training.config import TrainConfig
from occrl.training.cpu_time import tree_cpu_seconds
from occrl.training.dagger_buffer import DaggerBuffer, as_float
from occrl.training.learner import Learner, recurrent_layers_training
from occrl.training.run_folder import CHECKPOINT, METRICS, WEIGHTS

__all__ = ["FitConfig", "fit_offline", "labelled_sequences", "labelled_sequences_of_runs", "NOT_LABELS"]

logger = logging.getLogger(__name__)

CHECKPOINT_MINUTES = 10.0  # a resume checkpoint at least this often
# training settings that do not change what a data run's labels are: data runs that differ only in
# these (and in their seeds and lengths, which are not training settings) are fitted together
NOT_LABELS = (
    "num_envs",
    "workers",
    "device",
    "teacher_inference",
    "promotion_eval_every",
    "promotion_eval_tasks",
    "imitation_buffer_iters",
    "teacher_action_noise",  # the labels are the same teacher's undisturbed decisions
)
# FitConfig fields a resumed fit may change (how long, how often it reports, where the folders lie)
NOT_FIT_SETTINGS = ("data", "out", "steps", "save_every", "log_every")


@dataclass(frozen=True)
class FitConfig:
    """Settings of an offline fit (``occrl fit``'s options)."""

    data: tuple[str, ...]
    """Run folders of the data runs (occrl demos --out): each checkpoint names its settings and its
    data set. Several runs of the same settings but for their seeds and lengths are fitted as one."""
    out: str
    """Folder of the fit: metrics.jsonl, weights_step<N>.pt, weights.pt, checkpoint.pt."""
    init_weights: str = "occnet-takeover"
    """Network to start from: a shipped network's name or a weights file."""
    steps: int = 3000
    """Gradient steps in all (a resumed fit continues up to this count)."""
    lr: float = 1e-4
    """Learning rate (0: the data run's, or 3e-4 where that was 0)."""
    save_every: int = 1000
    """Write weights_step<N>.pt every this many steps."""
    log_every: int = 200
    """Log the training loss and the validation NLL every this many steps."""
    validation_fraction: float = 0.1
    """Share of the labelled sequences held out of the fit, for the validation NLL."""
    seed: int = 0
    """Seeds the validation split and the minibatch draws."""

    def validate(self) -> None:
        """``ValueError`` naming the setting that is out of range."""
        if not self.data:
            raise ValueError("data: name at least one data run folder")
        if self.steps < 1 or self.save_every < 1 or self.log_every < 1:
            raise ValueError(f"steps, save_every and log_every must be >= 1, got {self.steps}, {self.save_every}, {self.log_every}")
        if self.lr < 0:
            raise ValueError(f"lr must be >= 0 (0: the data run's), got {self.lr}")
        if not 0.0 < self.validation_fraction < 1.0:
            raise ValueError(f"validation_fraction must lie in (0, 1), got {self.validation_fraction}")


def labelled_sequences(data_run: Path) -> tuple[TrainConfig, TensorDictBase]:
    """The data run's settings and its data set's sequences with at least one labelled frame, [N, T]."""
    obj = load_checkpoint(data_run / CHECKPOINT)
    config = TrainConfig.from_dict(obj["train_config"])
    name = obj["state"].get("dagger_data")
    if not name:
        raise ValueError(f"{data_run / CHECKPOINT} names no data set (is it a run folder of occrl demos?)")
    buffer = DaggerBuffer(capacity=1)
    buffer.load(data_run / name)
    if len(buffer.batches) < obj["state"]["iteration"]:
        raise ValueError(
            f"{data_run / name} holds {len(buffer.batches)} of the run's {obj['state']['iteration']} iterations: "
            "the data set must keep every iteration (imitation_buffer_iters at least the iterations)"
        )
    kept = []
    while buffer.batches:  # batch by batch, so that the data set is in memory about once
        batch = buffer.batches.pop(0)
        if "expert_weight" not in batch.keys():  # a teacher that labels every frame
            batch.set("expert_weight", torch.ones(batch.shape))
        kept.append(batch[batch.get("expert_weight").flatten(1).sum(1) > 0])
    return config, torch.cat(kept)


def labelled_sequences_of_runs(data_runs: list[Path]) -> tuple[TrainConfig, TensorDictBase, list[int]]:
    """:func:`labelled_sequences` of several data runs concatenated in the order given, and each
    run's count of sequences; their settings must agree except in :data:`NOT_LABELS` (the first
    run's settings are returned)."""
    config, data = labelled_sequences(data_runs[0])
    parts = [data]
    first = config.flat_settings()
    for run in data_runs[1:]:
        other, more = labelled_sequences(run)
        theirs = other.flat_settings()
        differ = sorted(k for k, v in theirs.items() if k not in NOT_LABELS and first.get(k) != v)
        if differ:
            settings = ", ".join(f"{k}: {theirs[k]!r} against {first.get(k)!r}" for k in differ)
            raise ValueError(
                f"{run} was collected with other settings than {data_runs[0]} ({settings}); "
                f"only {', '.join(NOT_LABELS)}, seeds and lengths may differ between data runs fitted together"
            )
        if more.shape[1:] != data.shape[1:]:
            raise ValueError(f"{run}'s sequences are {tuple(more.shape[1:])} long, {data_runs[0]}'s {tuple(data.shape[1:])}")
        parts.append(more)
    return config, parts[0] if len(parts) == 1 else torch.cat(parts), [p.shape[0] for p in parts]


def validation_nll(net, data: TensorDictBase, min_scale: float, chunk: int) -> float:
    """Mean negative log-likelihood of the teacher's actions per labelled frame of ``data``."""
    total, frames = 0.0, 0.0
    with torch.no_grad(), set_recurrent_mode(True):
        for start in range(0, data.shape[0], chunk):
            td = as_float(data[start : start + chunk])
            n = float(td.get("expert_weight").sum())
            total += float(imitation_nll(net, net.trunk(td), min_scale)) * n
            frames += n
    return total / frames


def fit_offline(config: FitConfig, progress: bool = True) -> dict:
    """Fit ``config.init_weights`` to the data runs' labelled sequences; returns the fit's summary
    (step, sequences, validation_nll, cpu_hours, wall_hours, weights: the path of ``out/weights.pt``).

    Examples:
        >>> from occrl.training.offline_fit import FitConfig
        >>> FitConfig(data=("DATA9", "DATA10"), out="FIT").steps
        3000
    """
    config.validate()
    runs = [Path(d) for d in config.data]
    train_config, data, counts = labelled_sequences_of_runs(runs)
    for run, count in zip(runs, counts):
        logger.info("%s: %d labelled sequences", run, count)
    train_config = dataclasses.replace(train_config, lr=config.lr or train_config.lr or 3e-4)
    split = torch.randperm(data.shape[0], generator=torch.Generator().manual_seed(config.seed))
    n_val = max(1, round(config.validation_fraction * data.shape[0]))
    validation, train = data[split[:n_val]], DaggerBuffer(capacity=1)
    train.batches = [data[split[n_val:]]]
    logger.info("%d sequences to fit, %d held out", len(train), n_val)
    out = Path(config.out)
    out.mkdir(parents=True, exist_ok=True)
    net = load_weights(weights_file(config.init_weights))
    learner = Learner(net, train_config, torch.device("cpu"))
    generator = torch.Generator().manual_seed(config.seed + 1)
    minibatch, min_scale = train_config.minibatch_envs, train_config.imitation.min_scale
    losses: list[float] = []
    settings = {k: v for k, v in dataclasses.asdict(config).items() if k not in NOT_FIT_SETTINGS}
    settings["sequences"] = data.shape[0]  # a data run's folder may have collected on since
    step = 0
    spent = {"cpu_seconds": 0.0, "wall_seconds": 0.0}  # of the gradient steps and their logging, over every resume
    if (out / CHECKPOINT).exists():
        obj = load_checkpoint(out / CHECKPOINT, net, learner.optimizer)
        if obj["state"]["settings"] != settings:
            raise ValueError(f"{out / CHECKPOINT} was written with other settings ({obj['state']['settings']}); use another out folder")
        step = obj["state"]["step"]
        generator.set_state(obj["state"]["generator"])
        losses[:] = obj["state"]["losses"]  # the training losses since the last log line
        spent = {k: obj["state"][k] for k in spent}
        logger.info("resumed %s at step %d", out / CHECKPOINT, step)
    meta = {"note": f"occrl fit from {network_name(config.init_weights)} on {', '.join(config.data)}", "settings": settings}
    cpu0, wall0 = tree_cpu_seconds(), time.monotonic()

    def hours_spent() -> dict[str, float]:
        """The fit's CPU and wall hours so far, this process's share added to the resumed totals."""
        now = {"cpu_seconds": tree_cpu_seconds() - cpu0, "wall_seconds": time.monotonic() - wall0}
        return {k.replace("seconds", "hours"): (spent[k] + now[k]) / 3600 for k in spent}

    def checkpoint() -> None:
        seconds = {k.replace("hours", "seconds"): 3600 * v for k, v in hours_spent().items()}
        state = {"step": step, "generator": generator.get_state(), "settings": settings, "losses": losses, **seconds}
        save_checkpoint(out / CHECKPOINT, net, learner.optimizer, train_config.to_dict(), state)

    metrics = out / METRICS
    if step == 0:
        metrics.write_text(json.dumps({"step": 0, "validation_nll": validation_nll(net, validation, min_scale, minibatch)}) + "\n")
    else:  # drop lines past the checkpoint (written after it by a fit that was then stopped)
        rows = [line for line in metrics.read_text().splitlines() if json.loads(line)["step"] <= step]
        metrics.write_text("".join(r + "\n" for r in rows))
    last_checkpoint = time.monotonic()
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=config.steps, initial=step, desc="offline fit", unit="step")
    row: dict = {}
    while step < config.steps:
        with recurrent_layers_training(net):
            terms = learner.imitation_terms(learner.on_device(train.sample(minibatch, generator)))
            learner.step(terms)
        losses.append(float(sum(v.detach() for v in terms.values())))
        step += 1
        if bar is not None:
            bar.update()
        if step % config.log_every == 0:
            row = {"step": step, "loss": sum(losses) / len(losses), "validation_nll": validation_nll(net, validation, min_scale, minibatch)}
            row.update(hours_spent())
            losses.clear()
            with metrics.open("a") as f:
                f.write(json.dumps(row) + "\n")
            if bar is not None:
                bar.set_postfix(loss=f"{row['loss']:.3f}", val=f"{row['validation_nll']:.3f}")
        if step % config.save_every == 0 or step == config.steps:
            save_weights(out / f"weights_step{step}.pt", net, {**meta, "step": step, **hours_spent()})
            checkpoint()
            last_checkpoint = time.monotonic()
        elif time.monotonic() - last_checkpoint > 60 * CHECKPOINT_MINUTES:
            checkpoint()
            last_checkpoint = time.monotonic()
    if bar is not None:
        bar.close()
    hours = hours_spent()
    save_weights(out / WEIGHTS, net, {**meta, "step": step, **hours})
    logger.info("wrote %s (step %d, %.3f CPU hours)", out / WEIGHTS, step, hours["cpu_hours"])
    last_nll = row.get("validation_nll", json.loads(metrics.read_text().splitlines()[-1])["validation_nll"])
    return {"step": step, "sequences": data.shape[0], "validation_nll": last_nll, **hours, "weights": str(out / WEIGHTS)}
