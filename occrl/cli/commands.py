"""What the ``occrl`` commands train, eval and bench do (demo: :mod:`occrl.cli.demo`, export:
:mod:`occrl.cli.export`; the parser is in :mod:`occrl.cli`)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING, Sequence

from occrl.atomic_files import write_text_atomic

from occrl.cli.options import checked_weights_file, parse_objects

__all__ = ["run_train", "train_overrides", "config_listing", "run_eval", "run_bench", "network_of"]

if TYPE_CHECKING:
    from occrl.training import TrainConfig, Trainer


def _stop_on_signals() -> list[str]:
    """SIGTERM (cluster schedulers, ``kill``) and SIGINT stop training through the trainer's
    ``finally``, which writes the checkpoint. Needed explicitly: a background job started by a
    non-interactive shell ignores SIGINT, and Python's default SIGTERM skips ``finally``.
    Returns the names of the signals received, in order (empty until one arrives)."""
    import signal

    received: list[str] = []

    def stop(signum: int, frame: FrameType | None) -> None:
        received.append(signal.Signals(signum).name)
        raise KeyboardInterrupt(received[-1])

    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGINT, stop)
    return received


def train_overrides(args: argparse.Namespace) -> dict:
    """The training settings an ``occrl train`` command sets by its options (by their flat names;
    ``--preset`` picks the preset they override)."""
    from occrl.training import TrainConfig

    settable = [name for name in TrainConfig.field_docs() if name != "preset"]  # the options made by add_train_settings
    return {name: getattr(args, name) for name in settable if getattr(args, name, None) is not None}


def run_train(args: argparse.Namespace) -> int:
    if args.run_dir is None and not args.show_config:
        print("occrl train: error: give --run-dir (the run's folder: checkpoint, logs, curves), or --show-config", file=sys.stderr)
        return 2
    from occrl.training import Trainer, get_train_config

    overrides = train_overrides(args)
    if "device" in overrides:
        from occrl.training.config import training_device

        try:
            training_device(overrides["device"])
        except ValueError as err:
            print(f"--device: {err}", file=sys.stderr)
            return 2
    config = get_train_config(args.preset, **overrides)
    if args.show_config:
        config.validate()
        print(config_listing(config, sorted(overrides)))
        return 0
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
    received = _stop_on_signals()
    try:
        trainer.train(iterations=args.iterations, max_seconds=args.max_hours * 3600 if args.max_hours else None)
    except KeyboardInterrupt as stop:
        return _stopped(args, trainer, str(stop) or "interrupted")
    except Exception as err:
        if not received or isinstance(err, OSError) or not _raised_while_interrupted(err):
            raise  # a failure of its own (a checkpoint that could not be written is one)
        # The stop arrived inside a library call that turned the KeyboardInterrupt into another
        # error while handling it (TorchRL's MultiSyncCollector, when the signal lands while it
        # starts its worker processes, raises "Converting a tensordict to boolean value is not
        # permitted"): the trainer's finally kept the checkpoint, so this is the stop asked for.
        print(f"note: {type(err).__name__} from a library while stopping on {received[0]}: {err}", file=sys.stderr)
        return _stopped(args, trainer, received[0])
    finally:
        trainer.close()
    print(_train_summary(args))
    return 0


def config_listing(config: TrainConfig, given: Sequence[str] = ()) -> str:
    """The settings of a training run, one per line (``occrl train --show-config``); the names in
    ``given`` (set by options) are marked with the preset's own value.

    Examples:
        >>> from occrl.cli.commands import config_listing
        >>> from occrl.training import get_train_config
        >>> print(config_listing(get_train_config("tiny", lr=1e-3), ["lr"]).splitlines()[0])
        training settings of preset tiny with --lr 0.001 (32 frames per iteration):
    """
    from occrl.training.presets import TRAIN_PRESETS

    preset = TRAIN_PRESETS[config.preset].flat_settings()  # by the options' names
    settings = config.flat_settings()
    flags = []
    for name in [name for name in settings if name in given]:  # in the settings' order
        flag, value = "--" + name.replace("_", "-"), settings[name]
        flags.append((flag if value else f"--no-{flag[2:]}") if isinstance(value, bool) else f"{flag} {value}")
    options = f" with {' '.join(flags)}" if flags else ""
    lines = [f"training settings of preset {config.preset}{options} ({config.frames_per_batch} frames per iteration):"]
    for name, value in settings.items():
        mark = f"   (option; preset {config.preset}: {preset[name]!r})" if name in given else ""
        lines.append(f"  {name:<24} {value!r}{mark}")
    return "\n".join(lines)


def _raised_while_interrupted(err: BaseException) -> bool:
    """Whether ``err`` was raised while a KeyboardInterrupt (a stop signal) was being handled."""
    seen: set[int] = set()
    context = err.__context__
    while context is not None and id(context) not in seen:
        if isinstance(context, KeyboardInterrupt):
            return True
        seen.add(id(context))
        context = context.__context__
    return False


def _stopped(args: argparse.Namespace, trainer: Trainer, why: str) -> int:
    """A training run stopped by a signal: its summary, where it can resume, exit status 130."""
    print(_train_summary(args), file=sys.stderr)
    print(
        f"stopped ({why}); checkpoint of iteration {trainer.saved_iteration} on disk: run the same command again to resume",
        file=sys.stderr,
    )
    return 130


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


def run_eval(args: argparse.Namespace) -> int:
    from occrl.eval.methods import METHODS, PRIVILEGED, is_method, is_planner, method_network
    from occrl.envs.episodes import EPISODE_TIMING
    from occrl.eval.runner import run_tasks, summarize

    if args.inference != "torch" and (args.sweep or not (args.method or "").startswith("hybrid")):
        print(
            f"--inference applies to a single hybrid method (--method hybrid-...), not to {'a sweep' if args.sweep else repr(args.method)}",
            file=sys.stderr,
        )
        return 2
    if args.replicate and args.sweep:
        print(
            "--replicate applies to a single method (--method M), not to a sweep (its points extend by task, not by replicate)",
            file=sys.stderr,
        )
        return 2
    if args.sweep:
        from occrl.eval.sweep import run_sweep

        # the sweeps fix these themselves (stage-2 scenes, their object counts, the 2D world)
        ignored = [
            flag for flag, given in (("--method", args.method), ("--stage", args.stage), ("--objects", args.objects)) if given is not None
        ]
        ignored += ["--world mujoco"] if args.world != "pymunk" else []
        ignored += ["--perception tags"] if args.perception != "geometric" else []
        ignored += ["--shelf-height"] if args.shelf_height is not None else []
        ignored += ["--tag-layout"] if args.tag_layout is not None else []
        if ignored:
            print(
                f"--sweep runs the papers' sweeps in the 2D world on stage-2 scenes with their own object counts "
                f"(methods by --methods, clutter-sweep noise by --noise); drop {', '.join(ignored)}",
                file=sys.stderr,
            )
            return 2

        methods = args.methods.split(",") if args.methods else [m for m in METHODS if m not in PRIVILEGED]
        unknown = [m for m in methods if not is_method(m)]
        if unknown:
            print(
                f"unknown method(s) {unknown}; available: {METHODS} (or any hybrid-MxH / hybrid-lim-MxH / hybrid-ompl-MxH)", file=sys.stderr
            )
            return 2
        try:
            out = run_sweep(
                methods,
                args.out or "occrl-sweep",
                args.tasks,
                args.seed,
                batch=args.batch,
                workers=args.workers,
                weights=checked_weights_file(args.weights),
                progress=not args.no_progress,
                backend=args.backend,
                ray_address=args.ray_address,
                chunk=args.chunk,
                films=True,
                sweeps=("clutter",) if args.noise else ("clutter", "noise"),
                clutter_noise=args.noise,
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
    stage = 1 if args.stage is None else args.stage

    if not is_method(args.method):
        print(
            f"unknown method {args.method!r}; available: {METHODS} (or any hybrid-MxH / hybrid-lim-MxH / hybrid-ompl-MxH)", file=sys.stderr
        )
        return 2
    if args.perception != "geometric" and args.world != "mujoco":
        print(f"--perception {args.perception} needs --world mujoco (the 2D world has no camera image)", file=sys.stderr)
        return 2
    if args.shelf_height is not None:
        from occrl.envs.mujoco3d.model import check_shelf_height

        if args.world != "mujoco":
            print("--shelf-height needs --world mujoco (the 2D world has no height)", file=sys.stderr)
            return 2
        try:
            check_shelf_height(args.shelf_height)
        except ValueError as e:
            print(f"--shelf-height: {e}", file=sys.stderr)
            return 2
    if args.tag_layout is not None and args.perception != "tags":
        print("--tag-layout sizes the tags the detector reads: it needs --world mujoco --perception tags", file=sys.stderr)
        return 2
    seeds = list(range(args.seed, args.seed + args.tasks))
    objects = parse_objects(args.objects)
    batch = 1 if is_planner(args.method) else args.batch  # planners: one world per task, exact per-task time
    if args.world == "mujoco":
        batch = 1  # one MuJoCo world per task: per-task time is exact and memory stays small
    try:
        results = run_tasks(
            args.method,
            stage,
            seeds,
            args.noise,
            objects,
            batch,
            args.workers,
            checked_weights_file(args.weights),
            not args.no_progress,
            backend=args.backend,
            ray_address=args.ray_address,
            world=args.world,
            inference=args.inference,
            replicate=args.replicate,
            perception=args.perception,
            shelf_height=args.shelf_height,
            tag_layout=args.tag_layout,
        )
    finally:
        _stop_ray_if_used(args)
    from occrl.envs.mujoco3d.tags import DEFAULT_TAG_LAYOUT

    summary = {
        "method": args.method,
        "network": method_network(args.method, args.weights)[0],  # a default name resolved to the network it stands for
        "stage": stage,
        "objects": args.objects,
        "noise": args.noise,
        "world": args.world,
        **({"perception": args.perception} if args.perception != "geometric" else {}),
        **({"shelf_height": args.shelf_height} if args.shelf_height is not None else {}),
        **({"tag_layout": args.tag_layout or DEFAULT_TAG_LAYOUT} if args.perception == "tags" else {}),
        "first_seed": args.seed,
        **({"inference": args.inference} if args.inference != "torch" else {}),
        **({"replicate": args.replicate} if args.replicate else {}),
        # times per task: each task's own episode (occrl >= 0.3.0), with `batch` tasks run at a time
        "timing": EPISODE_TIMING,
        "batch": batch,
        **summarize(results),
        "episodes": [r.to_dict() for r in results],
    }
    lo, hi = summary["success_ci95"]
    if args.format == "text":
        print(
            f"{args.method}: {args.world} world{', tags' if args.perception == 'tags' else ''}, stage {stage}, objects {args.objects or 'of the stage'}, noise {args.noise}, {summary['tasks']} tasks: success {summary['success_rate']:.1%} "
            f"(95% CI {lo:.1%}-{hi:.1%}), dropped {summary['dropped']}, mean actions {summary['mean_actions']:.1f}, "
            f"mean time per task {summary['mean_seconds']:.2f} s"
            + (f" ({batch} tasks at a time)" if batch > 1 else "")
            + (f", replicate {args.replicate}" if args.replicate else "")
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


def network_of(method: str) -> str | None:
    """The shipped network a method uses (None: it uses none)."""
    from occrl.eval.methods import default_network

    return default_network(method)


def run_bench(args: argparse.Namespace) -> int:
    import runpy

    root = Path(__file__).resolve().parents[2] / "benchmarks"
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
