"""Command line: ``occrl demo | train | eval | export | bench``.

``occrl demo`` runs the hybrid planner with the shipped network on a few random shelves and writes
a summary and a GIF (the privileged scripted retriever when no network is shipped).
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import os
import re
import sys
import time
from pathlib import Path

from occrl import __version__
from occrl.atomic_files import write_text_atomic

__all__ = ["main"]


def _gl_available() -> bool:
    """MuJoCo camera images need an OpenGL backend (EGL headless); without one the demo still runs."""
    from occrl.envs.mujoco3d.camera import gl_available

    ok, why = gl_available()
    if not ok:
        print(f"no OpenGL backend for MuJoCo ({why}): the GIF shows no gripper-camera images (detection uses rays)")
    return ok


def _weights_file(value: str | None) -> str | None:
    from occrl.pretrained import weights_file

    return weights_file(value)


def _demo(args: argparse.Namespace) -> int:
    import numpy as np

    from occrl.envs import Scene, make_env
    from occrl.eval import episode_frames, save_film_strip, save_gif
    from occrl.pretrained import available, model_card

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    method = args.method
    if method != "scripted" and not args.weights and "occnet" not in available():
        print("no shipped network in this installation: showing the privileged scripted retriever instead")
        method = "scripted"
    primers = []
    if method == "scripted":
        from occrl.baselines import ScriptedRetriever

        policy, label = ScriptedRetriever(), "privileged scripted retriever (reads the true target pose)"
    else:
        from occrl.planners import HybridPlanner
        from occrl.modules.weights import load_weights
        from occrl.pretrained import load_pretrained

        net = load_weights(_weights_file(args.weights)) if args.weights else load_pretrained("occnet")
        m, h = (int(v) for v in method.split("-")[-1].split("x"))
        policy = HybridPlanner(net, m=m, h=h, seed=args.seed)
        primers = [net.make_primer()]
        card = model_card(args.weights or "occnet") or {"file": args.weights}
        label = f"hybrid planner {m}x{h} with network {card.get('summary', card)}"
    rows, frames_all = [], []
    print(f"occrl demo: {label}\n{args.tasks} random stage-{args.stage} shelves (task seeds {args.seed}..{args.seed + args.tasks - 1})")
    print(f"{'task':>4} {'objects':>7} {'result':>10} {'actions':>7} {'seconds':>7}")
    for k in range(args.tasks):
        scene = Scene.sample(args.stage, seed=args.seed + k)
        extra = {"world": "mujoco", "record_camera": _gl_available()} if args.world == "mujoco" else {}
        env = make_env(batch_size=1, scenes=[scene], heatmap_target=False, **extra)
        for p in primers:
            env.append_transform(p.clone())
        if hasattr(policy, "reseed"):
            policy.reseed(args.seed + k)
            policy.decisions.clear()
        t = time.time()
        td = env.rollout(50, policy=policy)[0]
        dt = time.time() - t
        nxt = td.get("next")
        result = "success" if bool(nxt["success"].any()) else ("dropped" if bool(nxt["dropped"].any()) else "failed")
        rows.append(
            {"task": k, "seed": args.seed + k, "objects": len(scene), "result": result, "actions": td.shape[0], "seconds": round(dt, 3)}
        )
        print(f"{k:>4} {len(scene):>7} {result:>10} {td.shape[0]:>7} {dt:>7.2f}")
        frames_all.extend(episode_frames(td, decisions=getattr(policy, "decisions", None)))
    success = float(np.mean([r["result"] == "success" for r in rows]))
    summary = {"method": method, "description": label, "stage": args.stage, "world": args.world, "tasks": rows, "success_rate": success}
    write_text_atomic(out / "demo_summary.json", json.dumps(summary, indent=2))
    gif = save_gif(frames_all, out / "demo.gif", fps=args.fps)
    strip = save_film_strip(frames_all[: max(1, len(frames_all) // args.tasks + 1)], out / "demo_strip.png")
    print(f"success {success:.0%}; wrote {out / 'demo_summary.json'}, {gif}, {strip}")
    return 0


def _stop_on_signals() -> None:
    """SIGTERM (cluster schedulers, ``kill``) and SIGINT stop training through the trainer's
    ``finally``, which writes the checkpoint. Needed explicitly: a background job started by a
    non-interactive shell ignores SIGINT, and Python's default SIGTERM skips ``finally``."""
    import signal

    def stop(signum, frame):
        raise KeyboardInterrupt(signal.Signals(signum).name)

    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGINT, stop)


def _train(args: argparse.Namespace) -> int:
    from occrl.training import TrainConfig, Trainer, get_train_config

    # the options generated from TrainConfig (_add_train_settings); --preset picks the preset itself
    settable = [name for name in TrainConfig.field_docs() if name != "preset"]
    overrides = {name: getattr(args, name) for name in settable if getattr(args, name, None) is not None}
    if "device" in overrides:
        from occrl.training.trainer import training_device

        try:
            training_device(overrides["device"])
        except ValueError as err:
            print(f"--device: {err}", file=sys.stderr)
            return 2
    config = get_train_config(args.preset, **overrides)
    init_weights = args.init_weights
    if init_weights is not None and not Path(init_weights).exists():
        from occrl.pretrained import pretrained_path

        init_weights = pretrained_path(init_weights)  # ValueError naming the shipped networks otherwise
    trainer = Trainer(
        config,
        args.run_dir,
        seed=args.seed,
        progress=not args.no_progress,
        checkpoint_every_s=args.checkpoint_every,
        ray_address=args.ray_address,
        init_weights=init_weights,
    )
    _stop_on_signals()
    try:
        trainer.train(iterations=args.iterations, max_seconds=args.max_hours * 3600 if args.max_hours else None)
    except KeyboardInterrupt as stop:
        print(_train_summary(args), file=sys.stderr)
        print(
            f"stopped ({stop or 'interrupted'}); checkpoint saved at iteration {trainer.iteration}: run the same command again to resume",
            file=sys.stderr,
        )
        return 130
    finally:
        trainer.close()
    print(_train_summary(args))
    return 0


def _train_summary(args: argparse.Namespace) -> str:
    from occrl.training.plots import read_metrics
    from occrl.training.summary import training_summary

    metrics = Path(args.run_dir) / "metrics.jsonl"
    rows = read_metrics(metrics) if metrics.exists() else []
    return training_summary(rows, args.run_dir, preset=args.preset, seed=args.seed)


def _stop_ray_if_used(args: argparse.Namespace) -> None:
    if args.backend == "ray":
        from occrl.distributed import stop_ray

        stop_ray()


def _eval(args: argparse.Namespace) -> int:
    from occrl.eval.methods import METHODS, PLANNERS
    from occrl.eval.runner import run_tasks, summarize

    if args.rollout_min_scale:
        if args.sweep or not (args.method or "").startswith("hybrid"):
            print(
                "--rollout-min-scale applies to a single hybrid method (--method hybrid-...), not to "
                f"{'a sweep' if args.sweep else repr(args.method)}",
                file=sys.stderr,
            )
            return 2
        if not 0.0 <= args.rollout_min_scale <= 1.0:  # also catches NaN
            print(
                f"--rollout-min-scale must be in [0, 1] (a standard deviation in action units), got {args.rollout_min_scale}",
                file=sys.stderr,
            )
            return 2
    if args.sweep:
        from occrl.eval.sweep import run_sweep

        methods = args.methods.split(",") if args.methods else METHODS[:-1]
        unknown = [m for m in methods if m not in METHODS]
        if unknown:
            print(f"unknown method(s) {unknown}; available: {METHODS}", file=sys.stderr)
            return 2
        try:
            out = run_sweep(
                methods,
                args.out or "occrl-sweep",
                args.tasks,
                args.seed,
                batch=args.batch,
                workers=args.workers,
                weights=_weights_file(args.weights),
                progress=not args.no_progress,
                backend=args.backend,
                ray_address=args.ray_address,
                chunk=args.chunk,
                films=True,
            )
        finally:
            _stop_ray_if_used(args)
        from occrl.eval.sweep import sweep_tables

        print(sweep_tables(json.loads((out / "results.json").read_text())))  # the rows run_sweep just wrote
        print(f"wrote {out / 'results.csv'}, {out / 'results.json'}, {out / 'sweep.png'}, {out / 'films'}")
        return 0
    if not args.method:
        print("give --method (or --sweep)", file=sys.stderr)
        return 2

    if args.method not in METHODS:
        print(f"unknown method {args.method!r}; available: {METHODS}", file=sys.stderr)
        return 2
    seeds = list(range(args.seed, args.seed + args.tasks))
    objects = _parse_objects(args.objects)
    batch = 1 if args.method in PLANNERS else args.batch  # planners: one world per task, exact per-task time
    if args.world == "mujoco":
        batch = 1  # one MuJoCo world per task: per-task time is exact and memory stays small
    try:
        results = run_tasks(
            args.method,
            args.stage,
            seeds,
            args.noise,
            objects,
            batch,
            args.workers,
            _weights_file(args.weights),
            not args.no_progress,
            backend=args.backend,
            ray_address=args.ray_address,
            world=args.world,
            rollout_min_scale=args.rollout_min_scale,
        )
    finally:
        _stop_ray_if_used(args)
    summary = {
        "method": args.method,
        "network": args.weights or network_of(args.method),
        "stage": args.stage,
        "objects": args.objects,
        "noise": args.noise,
        "world": args.world,
        "first_seed": args.seed,
        **({"rollout_min_scale": args.rollout_min_scale} if args.rollout_min_scale else {}),
        **summarize(results),
        "episodes": [r.to_dict() for r in results],
    }
    lo, hi = summary["success_ci95"]
    if args.format == "text":
        print(
            f"{args.method}: {args.world} world, stage {args.stage}, objects {args.objects or 'of the stage'}, noise {args.noise}, {summary['tasks']} tasks: success {summary['success_rate']:.1%} "
            f"(95% CI {lo:.1%}-{hi:.1%}), dropped {summary['dropped']}, mean actions {summary['mean_actions']:.1f}, "
            f"mean time {summary['mean_seconds']:.2f} s"
        )
    else:
        print(_summary_table(summary, args.format))
    if args.out:
        write_text_atomic(args.out, json.dumps(summary, indent=2))  # never a half-written result
        print(f"wrote {args.out}")
    return 0


SUMMARY_COLUMNS = (
    "method",
    "network",
    "world",
    "stage",
    "objects",
    "noise",
    "tasks",
    "success_rate",
    "ci95_low",
    "ci95_high",
    "dropped",
    "physically_invalid",
    "mean_actions",
    "mean_seconds",
)


def _summary_table(summary: dict, fmt: str) -> str:
    """One evaluation's summary as a Markdown table or CSV (header and one row)."""
    row = {**summary, "ci95_low": summary["success_ci95"][0], "ci95_high": summary["success_ci95"][1]}
    cells = []
    for key in SUMMARY_COLUMNS:
        value = row.get(key)
        cells.append(f"{value:.4g}" if isinstance(value, float) else ("" if value is None else str(value)))
    if fmt == "csv":
        return ",".join(SUMMARY_COLUMNS) + "\n" + ",".join(cells)
    return "| " + " | ".join(SUMMARY_COLUMNS) + " |\n|" + " --- |" * len(SUMMARY_COLUMNS) + "\n| " + " | ".join(cells) + " |"


def _parse_objects(text: str | None) -> int | tuple[int, int] | None:
    """``--objects``: a count ("7") or a range ("1-10", each task draws its count from its seed)."""
    if text is None:
        return None
    try:
        if "-" in text:
            low, high = (int(v) for v in text.split("-", 1))
            if not 1 <= low <= high:
                raise ValueError
            return (low, high)
        count = int(text)
        if count < 1:
            raise ValueError
        return count
    except ValueError:
        raise ValueError(f"--objects must be a count >= 1 or a range LOW-HIGH with 1 <= LOW <= HIGH, got {text!r}") from None


def network_of(method: str) -> str | None:
    """The shipped network a method uses."""
    if method == "scripted":
        return None
    return "occnet-noheatmap" if method in ("greedy", "stochastic") else "occnet"


def _export(args: argparse.Namespace) -> int:
    """Ship a run's weights inside the package as a named pretrained network."""
    import shutil

    import torch

    from occrl.pretrained import PRETRAINED_DIR, PRETRAINED_FILES
    from occrl.modules.weights import load_weights, save_weights
    from occrl.training.checkpoint import load_checkpoint
    from occrl.training.plots import read_metrics

    if args.name not in PRETRAINED_FILES:
        print(f"name must be one of {sorted(PRETRAINED_FILES)}", file=sys.stderr)
        return 2
    run = Path(args.run_dir)
    weights_path = run / (args.weights or "weights.pt")
    net = load_weights(weights_path)
    meta = torch.load(weights_path, map_location="cpu", weights_only=True).get("meta", {})
    rows = read_metrics(run / "metrics.jsonl")
    iteration = int(meta.get("iteration", rows[-1]["iteration"]))  # the file's own iteration, else the run's last
    upto = [r for r in rows if r["iteration"] <= iteration] or rows
    last = upto[-1]
    stage = max(r["stage"] for r in upto)
    card = {
        "train_preset": args.preset,
        "seed": args.seed,
        "weights_file": weights_path.name,
        "iterations": last["iteration"],
        "frames": last["frames"],
        "cpu_hours": round(last["train_hours"] * 2, 2),  # wall hours x 2 cores
        "wall_hours": round(last["train_hours"], 2),
        "stage_reached": stage,
        "phase": last["phase"],
        "summary": f"{args.name}: preset {args.preset}, iteration {last['iteration']}, {last['frames']:,} frames, stage {stage}, "
        f"{last['phase']} phase",
    }
    checkpoint = run / "checkpoint.pt"
    started_from = load_checkpoint(checkpoint)["state"].get("init_weights") if checkpoint.exists() else None
    if started_from:  # the run began from another network (--init-weights): its own training comes first
        card["init_weights"] = Path(started_from["path"]).name
        card["summary"] += f", started from {Path(started_from['path']).name}"
    dest = Path(args.dest) if args.dest else PRETRAINED_DIR
    dest.mkdir(parents=True, exist_ok=True)
    save_weights(dest / PRETRAINED_FILES[args.name], net, card)
    cards_path = dest / "model_cards.json"
    cards = json.loads(cards_path.read_text()) if cards_path.exists() else {}
    cards[args.name] = card
    cards_path.write_text(json.dumps(cards, indent=2))
    docs = Path(__file__).resolve().parent.parent / "docs"
    if not args.dest and docs.exists() and (run / "learning_curves.png").exists():
        shutil.copy(run / "learning_curves.png", docs / f"learning_curves_{args.name}.png")
    print(json.dumps(card, indent=2))
    return 0


def _bench(args: argparse.Namespace) -> int:
    import runpy

    root = Path(__file__).resolve().parent.parent / "benchmarks"
    script = root / f"{args.name}.py"
    if not script.exists():
        if not root.exists():
            print(
                "occrl bench: error: the benchmarks are scripts in benchmarks/ of a source checkout "
                "(git clone the repository, pip install -e ., then occrl bench NAME); this installation has none",
                file=sys.stderr,
            )
            return 2
        available = sorted(p.stem for p in root.glob("*.py"))
        print(f"occrl bench: error: no benchmark {args.name!r}; available: {available}", file=sys.stderr)
        return 2
    sys.argv = [str(script)] + args.rest
    runpy.run_path(str(script), run_name="__main__")
    return 0


def _bounded(kind, low=None, high=None, low_open=False, what=""):
    """An argparse type: a ``kind`` (int or float) within [low, high] (``low_open``: > low), finite;
    otherwise argparse's one-line error naming the option, the value and what is allowed."""

    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not {'an integer' if kind is int else 'a number'}") from None
        if kind is float and not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"{text} is not a finite number")
        too_low = low is not None and (value <= low if low_open else value < low)
        if too_low or (high is not None and value > high):
            raise argparse.ArgumentTypeError(f"{text} is out of range; allowed: {what}")
        return value

    return parse


COUNT = _bounded(int, 1, what="an integer >= 1")
NON_NEGATIVE = _bounded(int, 0, what="an integer >= 0")
SEED = _bounded(int, 0, 2**63 - 1, what="an integer in [0, 2**63)")
POSITIVE = _bounded(float, 0.0, low_open=True, what="a number > 0")
NOISE = _bounded(float, 0.0, 1.0, what="a number in [0, 1] (the paper uses 0 to 0.25)")
SCALE = _bounded(float, 0.0, 1.0, what="a number in [0, 1]")


FRACTION = _bounded(float, 0.0, 1.0, what="a number in [0, 1]")
NON_NEGATIVE_NUMBER = _bounded(float, 0.0, what="a number >= 0")
DISCOUNT = _bounded(float, 0.0, 1.0, low_open=True, what="a number in (0, 1]")
# argparse types of the training settings that are not plain non-negative integers or numbers
SETTING_TYPES = {
    **{
        name: COUNT
        for name in (
            "num_envs",
            "steps_per_env",
            "workers",
            "epochs",
            "minibatch_envs",
            "imitation_buffer_iters",
            "promote_window",
            "promotion_eval_every",
            "promotion_eval_tasks",
        )
    },
    **{name: FRACTION for name in ("heatmap_fraction", "imitation_beta_min", "promote_threshold", "gae_lambda", "noise")},
    "gamma": DISCOUNT,
}


def _add_train_settings(parser: argparse.ArgumentParser) -> None:
    """One option per :class:`~occrl.training.TrainConfig` setting (``--num-envs`` for
    ``num_envs``; ``--heatmap/--no-heatmap`` for a flag), its help the setting's docstring; an
    option given overrides the preset's value."""
    from dataclasses import fields

    from occrl.modules import PRESETS
    from occrl.training.config import SETTING_CHOICES, TrainConfig

    docs = TrainConfig.field_docs()
    group = parser.add_argument_group("training settings (default: the preset's; TrainConfig)")
    for f in fields(TrainConfig):
        if f.name == "preset":
            continue
        flag = "--" + f.name.replace("_", "-")
        text = re.sub(r":\w+:`~?([^`]+)`", r"\1", docs[f.name]).replace("``", "").replace("%", "%%")  # no reST in --help
        if f.type in (bool, "bool"):
            group.add_argument(flag, dest=f.name, action=argparse.BooleanOptionalAction, default=None, help=text)
        elif f.name == "start_stage":
            group.add_argument(flag, dest=f.name, type=int, choices=[1, 2, 3], default=None, help=text)
        elif f.type in (int, "int"):
            group.add_argument(flag, dest=f.name, type=SETTING_TYPES.get(f.name, NON_NEGATIVE), default=None, help=text)
        elif f.type in (float, "float"):
            group.add_argument(flag, dest=f.name, type=SETTING_TYPES.get(f.name, NON_NEGATIVE_NUMBER), default=None, help=text)
        else:
            choices = PRESETS if f.name == "net_preset" else SETTING_CHOICES.get(f.name)
            group.add_argument(flag, dest=f.name, choices=choices, default=None, help=text)


def make_parser() -> argparse.ArgumentParser:
    """The ``occrl`` command line: demo, train, eval, export, bench."""
    parser = argparse.ArgumentParser(prog="occrl", description=__doc__.splitlines()[0])
    parser.add_argument("-v", "--verbose", action="store_true")
    parser.add_argument("--version", action="version", version=f"occrl {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    d = sub.add_parser("demo", help="retrieve targets from random shelves; writes a summary and a GIF")
    d.add_argument("--tasks", type=COUNT, default=3)
    d.add_argument("--stage", type=int, default=1, choices=[1, 2, 3])
    d.add_argument("--seed", type=SEED, default=2024)
    d.add_argument("--out", default="occrl-demo")
    d.add_argument("--fps", type=POSITIVE, default=4.0)
    d.add_argument("--method", default="hybrid-4x4", choices=["hybrid-2x2", "hybrid-4x4", "hybrid-6x6", "scripted"])
    d.add_argument("--weights", default=None, help="network weights file or a shipped network's name instead of occnet")
    d.add_argument(
        "--world",
        choices=["pymunk", "mujoco"],
        default="pymunk",
        help="execute in the 2D pymunk world or the 3D MuJoCo shelf (frames add the gripper-camera image)",
    )
    d.set_defaults(func=_demo)

    t = sub.add_parser("train", help="train OccNet (curriculum PPO + heat-map loss); resumes from RUN_DIR")
    t.add_argument(
        "--preset", default="paper", help="training preset (occrl/training/config.py): paper, cpu, cpu-finetune, cpu-curriculum, tiny"
    )
    t.add_argument("--run-dir", required=True, help="run folder (checkpoint, logs, curves); keep it outside the source tree")
    t.add_argument("--seed", type=SEED, default=0)
    t.add_argument("--iterations", type=COUNT, default=None, help="stop after this many iterations in total")
    t.add_argument("--max-hours", type=POSITIVE, default=None, help="stop after this many hours of this session")
    t.add_argument(
        "--ray-address",
        default=None,
        help="with --collector ray: join this Ray cluster ('auto', 'host:6379', 'ray://host:10001'); default: start a local Ray runtime",
    )
    _add_train_settings(t)
    t.add_argument(
        "--init-weights",
        default=None,
        help="start a new run from these weights: a weights file (e.g. a run's weights_warmstart.pt) "
        "or a shipped name (occnet, occnet-noheatmap); used by the cpu-finetune preset",
    )
    t.add_argument("--checkpoint-every", type=POSITIVE, default=300.0, help="seconds between checkpoints")
    t.add_argument("--no-progress", action="store_true")
    t.set_defaults(func=_train)

    e = sub.add_parser("eval", help="run a method on fixed task seeds and report success, actions, time")
    e.add_argument("--method", help="hybrid-2x2, hybrid-4x4, hybrid-6x6, hybrid-lim-4x4, greedy, stochastic, stochastic-gen, scripted")
    e.add_argument("--sweep", action="store_true", help="the papers' clutter and noise sweeps (resumable; --out is a folder)")
    e.add_argument("--methods", default=None, help="comma-separated methods for --sweep (default: all but scripted)")
    e.add_argument(
        "--chunk",
        type=COUNT,
        default=None,
        help="with --sweep: rounds of this many tasks (every point gets them before any gets more), so an "
        "interrupted sweep leaves a complete figure; cached points are extended, never recomputed",
    )
    e.add_argument("--stage", type=int, default=1, choices=[1, 2, 3])
    e.add_argument(
        "--objects", default=None, help="object count per task: a number, or a range like 1-10 (each task draws its count from its seed)"
    )
    e.add_argument(
        "--world",
        choices=["pymunk", "mujoco"],
        default="pymunk",
        help="execution env: the 2D pymunk world or the 3D MuJoCo shelf (planners still plan in pymunk)",
    )
    e.add_argument("--noise", type=NOISE, default=0.0)
    e.add_argument("--tasks", type=COUNT, default=200, help="tasks per point (the paper uses 300 for sweeps)")
    e.add_argument("--seed", type=SEED, default=10_000_000, help="first task seed (held-out range by default)")
    e.add_argument("--batch", type=COUNT, default=16, help="worlds stepped together (policies; planners use 1)")
    e.add_argument("--workers", type=COUNT, default=1, help="processes (or Ray actors) to spread tasks over")
    e.add_argument(
        "--backend",
        choices=["local", "ray"],
        default="local",
        help="local processes or Ray actors (results are the same for the same seeds)",
    )
    e.add_argument("--ray-address", default=None, help="with --backend ray: join this Ray cluster (default: a local runtime)")
    e.add_argument(
        "--weights", default=None, help="network weights file, or a shipped network's name (occnet-ei), instead of the method's default"
    )
    e.add_argument(
        "--rollout-min-scale",
        type=SCALE,
        default=0.0,
        help="hybrid planners: floor on the roll-out policy's standard deviation (default 0: the policy's own, as in the paper)",
    )
    e.add_argument("--out", default=None, help="write the results as JSON")
    e.add_argument(
        "--format",
        choices=["text", "markdown", "csv"],
        default="text",
        help="how to print the summary: a sentence, a Markdown table or CSV",
    )
    e.add_argument("--no-progress", action="store_true")
    e.set_defaults(func=_eval)

    x = sub.add_parser("export", help="ship a training run's weights in the package (occrl.load_pretrained)")
    x.add_argument("--run-dir", required=True)
    x.add_argument("--name", required=True, help="occnet, occnet-noheatmap or occnet-ei")
    x.add_argument("--preset", required=True, help="the training preset the run used")
    x.add_argument("--seed", type=SEED, default=0)
    x.add_argument(
        "--weights", default=None, help="weights file in the run folder (default weights.pt, the latest; e.g. weights_warmstart.pt)"
    )
    x.add_argument("--dest", default=None, help="write into this folder instead of the package's pretrained/ (for trying it out)")
    x.set_defaults(func=_export)

    b = sub.add_parser("bench", help="run a speed benchmark from benchmarks/")
    b.add_argument("name", help="e.g. env_throughput")
    b.add_argument("rest", nargs=argparse.REMAINDER)
    b.set_defaults(func=_bench)

    return parser


def main(argv: list[str] | None = None) -> int:
    parser = make_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exit_:  # argparse printed the usage and a one-line error (or the help)
        return int(exit_.code or 0)
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    os.environ.setdefault("MUJOCO_GL", "egl")
    try:
        return args.func(args)
    except (ValueError, FileNotFoundError, ImportError) as err:  # bad input: say what, not a traceback
        if args.verbose:
            raise
        print(f"occrl {args.command}: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
