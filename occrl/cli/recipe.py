"""``occrl demos``, ``occrl fit`` and ``occrl recipe``: the default networks' recipe, step by step.

``occrl demos`` collects a teacher's demonstrations (:func:`occrl.training.demonstrations.collect_demonstrations`),
``occrl fit`` fits a network to them offline (:func:`occrl.training.offline_fit.fit_offline`), and
``occrl recipe NETWORK`` runs a shipped network's whole recipe (:mod:`occrl.cli.recipe_steps`) in
one run folder, a step per subfolder, and exports the network with its model card. Building these
parsers imports no torch.
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
from pathlib import Path

from occrl.atomic_files import write_text_atomic
from occrl.cli.options import COUNT, NON_NEGATIVE_NUMBER, SEED, HelpFormatter, bounded
from occrl.cli.recipe_steps import RECIPE_SIZES, RecipeStep, recipe_steps

__all__ = ["add_recipe_parsers", "run_demos", "run_fit", "run_recipe", "resolved_argv", "STEP_RECORD"]

STEP_RECORD = "recipe_step.json"  # written into a step's folder when it has finished: what, command, frames, cpu_hours
OPEN_FRACTION = bounded(float, 0.0, 1.0, low_open=True, what="a number in (0, 1)")

DEMOS_EPILOG = """\
examples:
  occrl demos --iterations 150 --seed 9 --out runs/demos-seed9      the recipe's demonstrations (120,000 frames)
  occrl demos --iterations 2 --num-envs 2 --out /tmp/demos           a smoke run (seconds)
  occrl demos --teacher clearing-observed --teacher-search learner --iterations 40 --out runs/d
                                             the teacher acts from the target's first sight only

The run folder is a training run's (checkpoint, metrics.jsonl): the same command again resumes it,
and occrl fit --data reads it."""

FIT_EPILOG = """\
examples:
  occrl fit --data runs/demos-seed9 runs/demos-seed10 --out runs/fit      the recipe's fit (3,000 steps)
  occrl fit --data /tmp/demos --init-weights /tmp/demos/weights.pt --steps 4 --out /tmp/fit
                                                  a smoke fit (seconds)

Writes FIT/weights.pt (for --init-weights of occrl train), weights_step<N>.pt and metrics.jsonl
(training loss, validation NLL, CPU and wall hours). The same command again resumes the fit."""

RECIPE_EPILOG = """\
examples:
  occrl recipe occnet --size smoke --run-dir /tmp/recipe     every step at a tiny size (minutes)
  occrl recipe occnet --run-dir runs/recipe                  the shipped network's recipe (CPU-hours: see its model card)
  occrl recipe occnet-noheatmap --run-dir runs/recipe        the same folder: the steps both share are done once
  occrl recipe occnet --list                                 print each step's command (to run one alone)

Each step writes into its own folder of --run-dir and is skipped once finished; the same command
again resumes after a stop. The network and its model card end up in RUN_DIR/export."""


def add_recipe_parsers(sub: argparse._SubParsersAction) -> None:
    """Add ``demos``, ``fit`` and ``recipe`` to the ``occrl`` subparsers ``sub``."""
    d = sub.add_parser(
        "demos",
        help="collect a teacher's demonstrations (its successful episodes as labels) for occrl fit",
        description="Collect demonstrations: a teacher acts in every step of every episode, its successful episodes are kept as "
        "labelled sequences, and the network does not learn.",
        epilog=DEMOS_EPILOG,
        formatter_class=HelpFormatter,
    )
    d.add_argument("--out", metavar="DIR", required=True, help="the run folder of the demonstrations (occrl fit --data DIR)")
    d.add_argument("--iterations", type=COUNT, required=True, help="iterations to collect, each --num-envs x 50 frames")
    d.add_argument("--seed", type=SEED, default=0, help="the run's seed (it fixes the tasks and the teacher's noise)")
    d.add_argument("--teacher", default="clearing-observed", help="the imitation teacher that acts (occrl.training.TEACHERS)")
    d.add_argument(
        "--teacher-search",
        default=None,
        help="clearing-observed teacher: hierarchical (the OMPL planner searches until the target is seen) or learner "
        "(default: hierarchical for the clearing-observed teacher, none for the others)",
    )
    d.add_argument("--action-noise", type=NON_NEGATIVE_NUMBER, default=0.05, help="the teacher's action noise (disturbed demonstrations)")
    d.add_argument("--label-episodes", choices=["success", "all"], default="success", help="which of the teacher's episodes are labels")
    d.add_argument("--num-envs", type=COUNT, default=16, help="worlds collected in parallel")
    d.add_argument("--stage", type=int, choices=[1, 2, 3], default=2, help="the curriculum stage of the tasks")
    d.add_argument(
        "--init-weights",
        metavar="FILE_OR_NAME",
        default="occnet-takeover",
        help="the network the run holds (it does not act: the teacher does): a weights file or a shipped network's name",
    )
    d.add_argument("--no-progress", action="store_true", help="no progress bar")
    d.set_defaults(func=run_demos)

    f = sub.add_parser(
        "fit",
        help="fit a network offline to collected demonstrations (occrl demos); writes weights for --init-weights",
        description="Fit a network to the labelled sequences of one or more demonstration runs by many gradient steps "
        "(the trainer's imitation loss); a tenth is held out for a validation NLL.",
        epilog=FIT_EPILOG,
        formatter_class=HelpFormatter,
    )
    f.add_argument("--data", metavar="DIR", nargs="+", required=True, help="demonstration run folders (occrl demos --out), fitted as one")
    f.add_argument("--out", metavar="DIR", required=True, help="the fit's folder: weights.pt, weights_step<N>.pt, metrics.jsonl")
    f.add_argument(
        "--init-weights",
        metavar="FILE_OR_NAME",
        default="occnet-takeover",
        help="the network to start from: a weights file or a shipped name",
    )
    f.add_argument("--steps", type=COUNT, default=3000, help="gradient steps in all (a resumed fit continues up to this count)")
    f.add_argument("--lr", type=NON_NEGATIVE_NUMBER, default=1e-4, help="learning rate (0: the data run's, or 3e-4 where that was 0)")
    f.add_argument("--save-every", type=COUNT, default=1000, help="write weights_step<N>.pt every this many steps")
    f.add_argument("--log-every", type=COUNT, default=200, help="log the training loss and the validation NLL every this many steps")
    f.add_argument("--validation-fraction", type=OPEN_FRACTION, default=0.1, help="share of the labelled sequences held out of the fit")
    f.add_argument("--seed", type=SEED, default=0, help="seeds the validation split and the minibatch draws")
    f.add_argument("--no-progress", action="store_true", help="no progress bar")
    f.set_defaults(func=run_fit)

    r = sub.add_parser(
        "recipe",
        help="reproduce a shipped network from scratch: every training step in order, then its export",
        description="Run a default network's whole recipe (warm start, takeover, demonstrations, offline fit, self-imitation) in "
        "one run folder and export the network with its model card.",
        epilog=RECIPE_EPILOG,
        formatter_class=HelpFormatter,
    )
    r.add_argument("network", help="occnet or occnet-noheatmap (or their own names, occnet-selfimit and occnet-noheatmap-selfimit)")
    r.add_argument("--run-dir", metavar="DIR", default=None, help="the recipe's folder, a subfolder per step (required unless --list)")
    r.add_argument(
        "--size",
        choices=RECIPE_SIZES,
        default="full",
        help="full: the shipped network's settings (CPU-hours: its model card); smoke: every step at a tiny size (minutes)",
    )
    r.add_argument("--list", action="store_true", help="print each step's command and run nothing")
    r.set_defaults(func=run_recipe)


def run_demos(args: argparse.Namespace) -> int:
    from occrl.training.demonstrations import collect_demonstrations

    settings = dict(
        teacher=args.teacher, teacher_search=args.teacher_search, action_noise=args.action_noise, label_episodes=args.label_episodes
    )
    last = collect_demonstrations(
        args.out,
        args.iterations,
        seed=args.seed,
        init_weights=args.init_weights,
        progress=not args.no_progress,
        num_envs=args.num_envs,
        stage=args.stage,
        **settings,
    )
    print(
        f"demonstrations {args.out}: {last['iteration']} iterations, {last['frames']:,} frames, "
        f"{last.get('cpu_hours', float('nan')):.3f} CPU hours; occrl fit --data {args.out} reads them"
    )
    return 0


def run_fit(args: argparse.Namespace) -> int:
    from occrl.training.offline_fit import FitConfig, fit_offline

    config = FitConfig(
        data=tuple(args.data),
        out=args.out,
        init_weights=args.init_weights,
        steps=args.steps,
        lr=args.lr,
        save_every=args.save_every,
        log_every=args.log_every,
        validation_fraction=args.validation_fraction,
        seed=args.seed,
    )
    summary = fit_offline(config, progress=not args.no_progress)
    print(
        f"fit {args.out}: {summary['step']} steps on {summary['sequences']} labelled sequences, validation NLL "
        f"{summary['validation_nll']:.3f}, {summary['cpu_hours']:.3f} CPU hours; wrote {summary['weights']}"
    )
    return 0


def resolved_argv(step: RecipeStep, run_dir: Path) -> list[str]:
    """The step's ``occrl`` arguments with earlier steps' outputs and its own folder filled in."""
    from occrl.cli.recipe_steps import RECIPES

    weights = {s.name: s.weights for steps in RECIPES.values() for s in steps}
    argv = []
    for word in step.argv:
        if word.startswith("{") and word.endswith("}"):
            name, _, part = word[1:-1].partition(":")
            word = str(run_dir / name) if part == "dir" else str(run_dir / name / weights[name])
        argv.append(word)
    return [*argv, "--run-dir" if step.command == "train" else "--out", str(run_dir / step.name)]


def step_cost(step: RecipeStep, folder: Path) -> tuple[int | None, float | None]:
    """Environment frames and CPU hours of a finished step (frames None for the offline fit)."""
    if step.command == "fit":
        import torch

        meta = torch.load(folder / "weights.pt", map_location="cpu", weights_only=True)["meta"]
        return None, round(meta["cpu_hours"], 4)
    from occrl.training.plots import read_metrics

    last = read_metrics(folder / "metrics.jsonl")[-1]
    return int(last["frames"]), round(last["cpu_hours"], 4) if "cpu_hours" in last else None


def run_recipe(args: argparse.Namespace) -> int:
    from occrl.cli import make_parser
    from occrl.pretrained import network_name

    network = network_name(args.network)
    steps = recipe_steps(network, args.size)
    run_dir = Path(args.run_dir if args.run_dir is not None else "RUN_DIR")
    commands = [resolved_argv(s, run_dir) for s in steps]
    if args.list:
        for i, (s, argv) in enumerate(zip(steps, commands), 1):
            print(f"{i}. {s.name}: {s.what}\n   occrl {shlex.join(argv)}")
        return 0
    if args.run_dir is None:
        print("occrl recipe: error: give --run-dir (the recipe's folder), or --list", file=sys.stderr)
        return 2
    parser = make_parser()
    done = []
    for i, (s, argv) in enumerate(zip(steps, commands), 1):
        command = "occrl " + shlex.join(argv)
        record = run_dir / s.name / STEP_RECORD
        if record.exists():
            saved = json.loads(record.read_text())
            if saved["command"] != command:
                raise ValueError(f"{run_dir / s.name} was made by another command ({saved['command']}); use another --run-dir")
            print(f"[{i}/{len(steps)}] {s.name}: finished before, skipped", flush=True)
            done.append(saved)
            continue
        print(f"[{i}/{len(steps)}] {s.name}: {s.what}\n  {command}", flush=True)
        parsed = parser.parse_args(argv)
        code = parsed.func(parsed)
        if code != 0:
            print(f"occrl recipe: step {s.name} stopped (exit status {code}); run the same command again to resume", file=sys.stderr)
            return code
        frames, cpu_hours = step_cost(s, run_dir / s.name)
        entry = {"what": s.what, "command": command, "frames": frames, "cpu_hours": cpu_hours}
        write_text_atomic(record, json.dumps(entry, indent=1))  # a step is finished once its record is whole
        done.append(entry)
        print(f"[{i}/{len(steps)}] {s.name}: done ({cpu_hours} CPU hours)", flush=True)
    before = run_dir / "recipe_before.json"
    write_text_atomic(before, json.dumps(done[:-1], indent=1))
    export = ["export", "--run-dir", str(run_dir / steps[-1].name), "--name", network, "--preset", "cpu-curriculum"]
    export += ["--dest", str(run_dir / "export"), "--recipe-before", str(before)]
    print(f"[export] occrl {shlex.join(export)}", flush=True)
    parsed = parser.parse_args(export)
    code = parsed.func(parsed)
    if code == 0:
        total = json.loads((run_dir / "export" / "model_cards.json").read_text())[network]["recipe_cpu_hours"]
        print(f"{network}: {run_dir / 'export'} ({total} CPU hours in all)")
    return code
