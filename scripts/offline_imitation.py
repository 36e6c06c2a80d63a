"""Imitation at scale, offline: many gradient steps on one large labelled data set.

The DAgger runs of issue 16 took 16 gradient steps per iteration on a sliding aggregate of the
last 16 iterations: about 1,200 steps in a 75-iteration run, each on a window of ~130 sequences.
When the teacher acts every labelled step (``--imitation-beta-min 1``), the labels do not depend on
the learner, so the data can be collected once and trained on for as long as the CPU allows:

    # 1. the data set: a DAgger run that keeps every iteration and does not learn (learning rate 0)
    occrl train --preset cpu-curriculum --imitation-teacher clearing-observed --imitation-beta-min 1 \\
        --label-episodes success --critic-coeff 0 --heatmap-coeff 0 --collector single \\
        --replay-stage-workers 0 --num-envs 16 --init-weights occnet-takeover --start-stage 2 \\
        --promotion-eval-every 1000 --imitation-updates 1 --imitation-buffer-iters 1000 --lr 0 \\
        --iterations 150 --seed 7 --run-dir DATA
    # 2. the gradient steps (resumes from OUT/checkpoint.pt when stopped; the same weights either way)
    python scripts/offline_imitation.py --data DATA --init-weights occnet-takeover --steps 12000 \\
        --save-every 2000 --out OUT
    # 3. each saved network on the held-out tasks (named so that the plot finds them)
    occrl eval --method stochastic-gen --stage 2 --tasks 200 --workers 1 --weights OUT/weights_step6000.pt \
        --out OUT/stochastic-gen_s2_step6000.json
    # the data run's size and its teacher's success
    python scripts/offline_imitation.py --data DATA --summary
    # how the teacher's demonstrations begin, by the learner's steps before it
    python scripts/offline_imitation.py --data DATA --takeover
    # several data runs of the same settings (e.g. collected side by side with other --seed), fitted as one
    python scripts/offline_imitation.py --data DATA DATA_SEED8 --init-weights occnet-takeover --out OUT2
    # only the first 100 iterations of a longer data run (to compare with a run of 100 on the same seed)
    python scripts/offline_imitation.py --data DATA --first-iterations 100 --init-weights occnet-takeover --out OUT3
    # how far each network's mean action is from the teacher's, on a data run none was fitted on
    # (step 1 with another --seed and fewer --iterations)
    python scripts/offline_imitation.py --data DATA2 --assess occnet-takeover OUT/weights_step6000.pt
    # 4. training loss, validation NLL and held-out success against steps, for one or more fits
    python scripts/offline_imitation.py --plot curves.png OUT [OUT2 ...]
    # the average of several saved networks' weights (stochastic weight averaging), to evaluate as one
    python scripts/offline_imitation.py --average AVERAGE.pt OUT/weights_step6000.pt OUT/weights_step7000.pt ...

The loss is the trainer's (:meth:`occrl.training.learner.Learner.imitation_terms`, the data run's
settings: the teacher's negative log-likelihood on labelled frames, the critic and heat-map terms
at the data run's coefficients), with the data run's optimizer and learning rate unless
``--lr`` is given. Only sequences with at least one labelled frame are kept; a tenth of them
(``--validation-fraction``) is held out, and its mean negative log-likelihood per labelled frame is
logged every ``--log-every`` steps to ``OUT/metrics.jsonl`` (with the training loss), so
over-fitting shows. Batch-norm statistics stay those of the starting network (frozen, as in
``cpu-finetune``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import time
from dataclasses import dataclass
from pathlib import Path

import torch
from tensordict import TensorDictBase
from torchrl.modules import set_recurrent_mode
from tqdm import tqdm

from occrl.envs import world_constants as C
from occrl.modules.weights import load_weights, save_weights
from occrl.objectives import imitation_nll
from occrl.pretrained import network_name, weights_file
from occrl.training import load_checkpoint, save_checkpoint
from occrl.training.config import TrainConfig, dataclass_field_docs
from occrl.training.cpu_time import tree_cpu_seconds
from occrl.training.dagger_buffer import DaggerBuffer, as_float
from occrl.training.learner import Learner, recurrent_layers_training
from occrl.training.run_folder import CHECKPOINT

CHECKPOINT_MINUTES = 10.0  # a resume checkpoint at least this often
# options a resumed fit may change (how long, how often it reports, where the folders lie: the data
# set is recognised by its size) or that fit nothing
NOT_SETTINGS = ("steps", "save_every", "log_every", "summary", "assess", "data", "out")
# training settings that do not change what a data run's labels are: runs that differ only in these
# (and in their seeds and lengths, which are not training settings) are fitted together
NOT_LABELS = (
    "num_envs",
    "workers",
    "device",
    "teacher_inference",
    "promotion_eval_every",
    "promotion_eval_tasks",
    "imitation_buffer_iters",
    # how the teacher's motion was disturbed (DART noise): the labels are the same teacher's
    # undisturbed decisions
    "teacher_action_noise",
)


@dataclass
class Args:
    data: list[str]
    """Run folder(s) of the data run(s): each checkpoint names its settings and its DAgger data set.
    Several runs (of the same settings but for their seeds and lengths) are fitted as one data set."""
    first_iterations: int = 0
    """Read only the first N iterations of each data run (0: all it collected): e.g. a longer run cut
    to the length of another, so that two fits compare on the same episodes."""
    out: str = ""
    """Run folder of this fit: metrics.jsonl, weights_step<N>.pt, weights.pt, checkpoint.pt
    (needed unless --assess or --summary)."""
    init_weights: str = "occnet"
    """Network to start from: a pretrained name or a weights file."""
    steps: int = 12000
    """Gradient steps in all (a resumed fit continues up to this count)."""
    minibatch: int = 0
    """Sequences per gradient step (0: the data run's minibatch_envs)."""
    lr: float = 0.0
    """Learning rate (0: the data run's, unless that was 0, then 3e-4)."""
    heatmap_coeff: float = -1.0
    """Weight of the heat-map loss (the BCE against the privileged target map the data run
    stored); -1: the data run's (0 in the data runs above, which ran with --heatmap-coeff 0). Only
    a network with a heat-map head has the term."""
    save_every: int = 2000
    """Write weights_step<N>.pt every this many steps."""
    log_every: int = 200
    """Log the training loss and the validation NLL every this many steps."""
    validation_fraction: float = 0.1
    """Share of the labelled sequences held out of the fit, for the validation NLL."""
    seed: int = 0
    """Seeds the validation split and the minibatch draws."""
    summary: bool = False
    """Fit nothing: print the data run's size and its episodes' success (the teacher's, where it
    acted in every episode) and stop."""
    assess: list[str] = dataclasses.field(default_factory=list)
    """Fit nothing: print, for each of these networks, how far its mean action lies from the
    teacher's on every labelled frame of --data (a data run that none of them was fitted on)."""
    takeover: bool = False
    """Fit nothing: print, by how many steps the learner acted before the teacher took over
    (data runs of a teacher that takes over from the learner), how often the teacher's first three commands back the
    gripper out (forward below -0.3) and their mean forward command."""


def parse_args(argv: list[str] | None = None) -> Args:
    """An option per :class:`Args` field; its help the field's docstring."""
    docs = dataclass_field_docs(Args)
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    for f in dataclasses.fields(Args):
        required = f.default is dataclasses.MISSING
        if f.name in ("summary", "takeover"):
            parser.add_argument(f"--{f.name}", action="store_true", help=docs[f.name])
            continue
        if f.name == "assess":
            parser.add_argument("--assess", nargs="+", default=[], metavar="WEIGHTS", help=docs[f.name])
            continue
        if f.name == "data":
            parser.add_argument("--data", nargs="+", required=True, metavar="DATA_RUN", help=docs[f.name])
            continue
        kind = {"int": int, "float": float}.get(f.type, str)
        parser.add_argument(
            "--" + f.name.replace("_", "-"), type=kind, required=required, default=None if required else f.default, help=docs[f.name]
        )
    args = Args(**vars(parser.parse_args(argv)))
    if args.steps < 1 or args.save_every < 1 or args.log_every < 1 or args.minibatch < 0 or args.lr < 0 or args.first_iterations < 0:
        parser.error(f"--steps, --save-every and --log-every must be >= 1, --minibatch, --lr and --first-iterations >= 0; got {args}")
    if args.heatmap_coeff < 0 and args.heatmap_coeff != -1.0:
        parser.error(f"--heatmap-coeff must be >= 0, or -1 for the data run's setting; got {args.heatmap_coeff}")
    if not args.out and not args.assess and not args.summary and not args.takeover:
        parser.error("--out is needed (the fit's run folder) unless --assess, --summary or --takeover is given")
    if not 0.0 < args.validation_fraction < 1.0:
        parser.error(f"--validation-fraction must lie in (0, 1), got {args.validation_fraction}")
    return args


def labelled_sequences_of_runs(data_runs: list[Path], first_iterations: int = 0) -> tuple[TrainConfig, TensorDictBase, list[int]]:
    """:func:`labelled_sequences` of several data runs (each cut to its first ``first_iterations``
    when > 0), concatenated in the order given, and each run's count of sequences; their settings
    must agree except in :data:`NOT_LABELS` (the first run's are returned)."""
    config, data = labelled_sequences(data_runs[0], first_iterations)
    parts = [data]
    first = config.flat_settings()
    for run in data_runs[1:]:
        other, more = labelled_sequences(run, first_iterations)
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


def labelled_sequences(data_run: Path, first_iterations: int = 0) -> tuple[TrainConfig, TensorDictBase]:
    """The data run's settings and its aggregate's sequences with at least one labelled frame, [N, T]
    (of its first ``first_iterations`` iterations when > 0)."""
    obj = load_checkpoint(data_run / CHECKPOINT)
    config = TrainConfig.from_dict(obj["train_config"])
    name = obj["state"].get("dagger_data")
    if not name:
        raise ValueError(
            f"{data_run / CHECKPOINT} names no DAgger data set (was it written during the imitation phase, with --imitation-updates > 0?)"
        )
    buffer = DaggerBuffer(capacity=1)
    buffer.load(data_run / name)
    if len(buffer.batches) < obj["state"]["iteration"]:
        raise ValueError(
            f"{data_run / name} holds {len(buffer.batches)} of the run's {obj['state']['iteration']} iterations: "
            "collect with --imitation-buffer-iters at least --iterations so the data set keeps them all"
        )
    if first_iterations:
        if first_iterations > obj["state"]["iteration"]:
            raise ValueError(f"--first-iterations {first_iterations}: {data_run} has collected only {obj['state']['iteration']} iterations")
        del buffer.batches[first_iterations:]
    kept = []
    while buffer.batches:  # batch by batch, so that the data set is in memory about once
        batch = buffer.batches.pop(0)
        if "expert_weight" not in batch.keys():  # a teacher that labels every frame
            batch.set("expert_weight", torch.ones(batch.shape))
        kept.append(batch[batch.get("expert_weight").flatten(1).sum(1) > 0])
    return config, torch.cat(kept)


TAKEOVER_BANDS = ((0, 0), (1, 5), (6, 10), (11, 20), (21, C.MAX_EPISODE_STEPS))


def takeover_table(data: TensorDictBase, first: int = 3, backward: float = -0.3) -> str:
    """Markdown: the demonstrations (labelled episodes that start inside a sequence) by the step of
    the teacher's first labelled frame, i.e. how long the learner acted first, with the share of
    the teacher's first ``first`` forward commands below ``backward`` and their mean."""
    starts, weights, forward = (
        data.get("is_init").reshape(data.shape),
        data.get("expert_weight").reshape(data.shape),
        data.get("expert_action")[..., 0],
    )
    by_band = {band: [] for band in TAKEOVER_BANDS}
    skipped = 0
    for n in range(data.shape[0]):
        bounds = torch.nonzero(starts[n]).flatten().tolist()
        skipped += int(bool((weights[n, : bounds[0] if bounds else data.shape[1]] > 0).any()))  # began before the window
        for begin, end in zip(bounds, bounds[1:] + [data.shape[1]]):
            labelled = torch.nonzero(weights[n, begin:end] > 0).flatten()
            if len(labelled) == 0:
                continue
            t = int(labelled[0])
            band = next(b for b in TAKEOVER_BANDS if b[0] <= t <= b[1])
            by_band[band].append(forward[n, begin + t : min(begin + t + first, end)])
    lines = [
        f"| learner's steps before the teacher | demonstrations | teacher's first {first} forward commands below {backward} | their mean |",
        "| --- | --- | --- | --- |",
    ]
    for (low, high), commands in by_band.items():
        if commands:
            x = torch.cat(commands)
            label = f"{low}" if low == high else f"{low}-{high}"
            lines.append(f"| {label} | {len(commands)} | {100 * float((x < backward).float().mean()):.1f} % | {float(x.mean()):+.2f} |")
    lines.append(f"({skipped} labelled episodes began before their sequence's window and are not counted)")
    return "\n".join(lines)


def data_summary(data_run: Path, data: TensorDictBase, first_iterations: int = 0) -> str:
    """One line: the data run's iterations (its first ``first_iterations`` when > 0), its episodes
    (the first of each world in each iteration, as the trainer counts them) and their success with
    a 95 % interval, and what the fit reads of it."""
    iterations = load_checkpoint(data_run / CHECKPOINT)["state"]["iteration"]
    if first_iterations:
        iterations = min(iterations, first_iterations)
    rows = [json.loads(line) for line in (data_run / "metrics.jsonl").read_text().splitlines() if line.strip()]
    rows = [r for r in rows if r["iteration"] <= iterations]
    episodes = sum(r["episodes"] for r in rows)
    success = "no episode finished"
    if episodes > 0:
        rate = sum(r["success_rate"] * r["episodes"] for r in rows) / episodes
        half = 1.96 * math.sqrt(rate * (1 - rate) / episodes)
        success = f"success {100 * rate:.1f} % ({100 * (rate - half):.1f}-{100 * (rate + half):.1f})"
    labelled = int((data.get("expert_weight") > 0).sum())
    return (
        f"{data_run}: {iterations} iterations, {episodes} episodes, {success}; "
        f"{data.shape[0]} labelled sequences, {labelled} labelled frames"
    )


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


def plot(path: str, runs: list[str]) -> None:
    """Training loss, validation NLL and the held-out success of the evaluated saves
    (``stochastic-gen_s2_step<N>.json`` in each fit folder) against gradient steps."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for run in map(Path, runs):
        rows = [json.loads(line) for line in (run / "metrics.jsonl").read_text().splitlines()]
        line = axes[0].plot([r["step"] for r in rows], [r["validation_nll"] for r in rows], label=f"{run.name}: validation")[0]
        fit = [r for r in rows if "loss" in r]
        axes[0].plot([r["step"] for r in fit], [r["loss"] for r in fit], ls=":", color=line.get_color(), label=f"{run.name}: training")
        evals = sorted((int(f.stem.rsplit("step", 1)[1]), json.loads(f.read_text())) for f in run.glob("stochastic-gen_s2_step*.json"))
        if evals:
            x = [n for n, _ in evals]
            rate = [100 * e["success_rate"] for _, e in evals]
            half = [196 * (r / 100 * (1 - r / 100) / e["tasks"]) ** 0.5 for r, (_, e) in zip(rate, evals)]
            axes[1].errorbar(x, rate, yerr=half, marker="o", capsize=3, color=line.get_color(), label=run.name)
    axes[0].set(xlabel="gradient step", ylabel="NLL per labelled frame", title="imitation loss")
    axes[1].set(xlabel="gradient step", ylabel="success %", title="own policy, 200 held-out stage-2 tasks (95 % CI)")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


def average_weights(path: str, files: list[str]) -> None:
    """Write a weights file whose floating-point tensors are the mean of ``files``' (networks of the
    same configuration); the others (batch-norm counters) and the configuration are the first's."""
    nets = [load_weights(f) for f in files]
    configs = {json.dumps(n.config.to_dict(), sort_keys=True) for n in nets}
    if len(configs) > 1:
        raise SystemExit(f"--average needs networks of one configuration; {files} hold {len(configs)}")
    states = [n.state_dict() for n in nets]
    averaged = {k: torch.stack([s[k] for s in states]).mean(0) if v.is_floating_point() else v for k, v in states[0].items()}
    nets[0].load_state_dict(averaged)
    save_weights(path, nets[0], {"note": "scripts/offline_imitation.py --average of " + ", ".join(files)})
    print(f"wrote {path} (the average of {len(files)} networks)")


def action_errors(net, data: TensorDictBase, chunk: int) -> dict[str, float]:
    """On the labelled frames of ``data``: the mean absolute difference between the policy's mean
    action and the teacher's (forward and lateral in mm, rotation in degrees), and the share of
    frames where both agree on closing the gripper (command > 0) or not, overall and on the
    frames where the teacher closes."""
    sums = torch.zeros(3)
    agree = frames = closes = agree_on_close = 0.0
    scale = torch.tensor([1000 * C.MAX_FORWARD, 1000 * C.MAX_LATERAL, math.degrees(C.MAX_ROTATION)])
    with torch.no_grad(), set_recurrent_mode(True):
        for start in range(0, data.shape[0], chunk):
            td = as_float(data[start : start + chunk])
            head = net.actor.module[0](net.trunk(td).select("belief").copy())
            loc = head.get("loc")
            teacher, labelled = td.get("expert_action"), td.get("expert_weight").reshape(td.shape) > 0
            loc, teacher = loc[labelled], teacher[labelled]
            sums += ((loc[:, :3].clamp(-1, 1) - teacher[:, :3]).abs() * scale).sum(0)
            same = (loc[:, 3] > 0) == (teacher[:, 3] > 0)
            agree += float(same.sum())
            closes += float((teacher[:, 3] > 0).sum())
            agree_on_close += float(same[teacher[:, 3] > 0].sum())
            frames += loc.shape[0]
    forward, lateral, rotation = (sums / frames).tolist()
    return {
        "forward_mm": forward,
        "lateral_mm": lateral,
        "rotation_deg": rotation,
        "close_agreement": agree / frames,
        "close_agreement_where_teacher_closes": agree_on_close / max(closes, 1.0),
    }


def main(argv: list[str] | None = None) -> None:
    import sys

    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["--plot"]:
        if len(argv) < 3:
            raise SystemExit("usage: offline_imitation.py --plot FIGURE.png FIT_FOLDER [FIT_FOLDER ...]")
        plot(argv[1], argv[2:])
        return
    if argv[:1] == ["--average"]:
        if len(argv) < 4:
            raise SystemExit("usage: offline_imitation.py --average OUT.pt WEIGHTS WEIGHTS [WEIGHTS ...]")
        average_weights(argv[1], argv[2:])
        return
    args = parse_args(argv)
    runs = [Path(d) for d in args.data]
    config, data, counts = labelled_sequences_of_runs(runs, args.first_iterations)
    start = 0
    for run, count in zip(runs, counts):  # each run's line (its sequences come in the order of the runs)
        print(data_summary(run, data[start : start + count], args.first_iterations))
        start += count
    if len(runs) > 1:
        print(f"together: {data.shape[0]} labelled sequences, {int((data.get('expert_weight') > 0).sum())} labelled frames")
    if args.summary:
        return
    if args.takeover:
        print(takeover_table(data))
        return
    overrides = {"minibatch_envs": args.minibatch or config.minibatch_envs, "lr": args.lr or config.lr or 3e-4}
    if args.heatmap_coeff >= 0:
        overrides["heatmap_coeff"] = args.heatmap_coeff
    config = dataclasses.replace(config, **overrides)
    if args.assess:
        print("| network | forward (mm) | lateral (mm) | rotation (deg) | close agreement | where the teacher closes |")
        print("| --- | --- | --- | --- | --- | --- |")
        for name in args.assess:
            e = action_errors(load_weights(weights_file(name)), data, config.minibatch_envs)
            print(
                f"| {name} | {e['forward_mm']:.1f} | {e['lateral_mm']:.1f} | {e['rotation_deg']:.2f} | "
                f"{100 * e['close_agreement']:.1f} % | {100 * e['close_agreement_where_teacher_closes']:.1f} % |"
            )
        return
    split = torch.randperm(data.shape[0], generator=torch.Generator().manual_seed(args.seed))
    n_val = max(1, round(args.validation_fraction * data.shape[0]))
    validation, train = data[split[:n_val]], DaggerBuffer(capacity=1)
    train.batches = [data[split[n_val:]]]
    print(f"{len(train)} sequences to fit, {n_val} held out")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    net = load_weights(weights_file(args.init_weights))
    learner = Learner(net, config, torch.device("cpu"))
    generator = torch.Generator().manual_seed(args.seed + 1)
    losses: list[float] = []
    settings = {k: v for k, v in dataclasses.asdict(args).items() if k not in NOT_SETTINGS}
    settings["sequences"] = data.shape[0]  # the data run's folder may have collected on since
    step = 0
    spent = {"cpu_seconds": 0.0, "wall_seconds": 0.0}  # of the gradient steps and their logging, over every resume
    if (out / CHECKPOINT).exists():
        obj = load_checkpoint(out / CHECKPOINT, net, learner.optimizer)
        saved = {k: v for k, v in obj["state"]["settings"].items() if k not in NOT_SETTINGS}
        defaults = {f.name: f.default for f in dataclasses.fields(Args)}
        # a setting added since the checkpoint was written matches it while it keeps its default
        if saved != {k: v for k, v in settings.items() if k in saved or v != defaults.get(k)}:
            raise ValueError(f"{out / CHECKPOINT} was written with other settings ({obj['state']['settings']}); use another --out")
        step = obj["state"]["step"]
        generator.set_state(obj["state"]["generator"])
        losses[:] = obj["state"]["losses"]  # the training losses since the last log line
        # None: a fit checkpointed before its time was kept, so its totals are unknown
        spent = {k: obj["state"].get(k) for k in spent}
        print(f"resumed {out / CHECKPOINT} at step {step}")
    meta = {"note": f"scripts/offline_imitation.py from {network_name(args.init_weights)} on {', '.join(args.data)}", "settings": settings}

    cpu0, wall0 = tree_cpu_seconds(), time.monotonic()

    def time_spent() -> dict[str, float | None]:
        """CPU and wall seconds of the fit so far, this process's share added to the resumed totals."""
        now = {"cpu_seconds": tree_cpu_seconds() - cpu0, "wall_seconds": time.monotonic() - wall0}
        return {k: None if spent[k] is None else spent[k] + now[k] for k in spent}

    def hours_spent() -> dict[str, float]:
        """The fit's cost so far in hours (cpu_hours, wall_hours; absent when not known)."""
        return {k.replace("seconds", "hours"): v / 3600 for k, v in time_spent().items() if v is not None}

    def checkpoint() -> None:
        save_checkpoint(
            out / CHECKPOINT,
            net,
            learner.optimizer,
            config.to_dict(),
            {"step": step, "generator": generator.get_state(), "settings": settings, "losses": losses, **time_spent()},
        )

    metrics = out / "metrics.jsonl"
    if step == 0:
        metrics.write_text("")
        with metrics.open("a") as f:
            f.write(
                json.dumps(
                    {"step": 0, "validation_nll": validation_nll(net, validation, config.imitation.min_scale, config.minibatch_envs)}
                )
                + "\n"
            )
    else:  # drop lines past the checkpoint (written after it by a run that was then stopped)
        rows = [line for line in metrics.read_text().splitlines() if json.loads(line)["step"] <= step]
        metrics.write_text("".join(r + "\n" for r in rows))
    last_checkpoint = time.monotonic()
    bar = tqdm(total=args.steps, initial=step, desc="imitation", unit="step")
    while step < args.steps:
        with recurrent_layers_training(net):
            terms = learner.imitation_terms(learner.on_device(train.sample(config.minibatch_envs, generator)))
            learner.step(terms)
        losses.append(float(sum(v.detach() for v in terms.values())))
        step += 1
        bar.update()
        if step % args.log_every == 0:
            row = {
                "step": step,
                "loss": sum(losses) / len(losses),
                "validation_nll": validation_nll(net, validation, config.imitation.min_scale, config.minibatch_envs),
            }
            row.update(hours_spent())
            losses.clear()
            with metrics.open("a") as f:
                f.write(json.dumps(row) + "\n")
            bar.set_postfix(loss=f"{row['loss']:.3f}", val=f"{row['validation_nll']:.3f}")
        if step % args.save_every == 0 or step == args.steps:
            save_weights(out / f"weights_step{step}.pt", net, {**meta, "step": step, **hours_spent()})
            checkpoint()
            last_checkpoint = time.monotonic()
        elif time.monotonic() - last_checkpoint > 60 * CHECKPOINT_MINUTES:
            checkpoint()
            last_checkpoint = time.monotonic()
    bar.close()
    save_weights(out / "weights.pt", net, {**meta, "step": step, **hours_spent()})
    print(f"wrote {out / 'weights.pt'} (step {step})")


if __name__ == "__main__":
    main()
