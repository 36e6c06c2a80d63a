"""Command line: ``occrl demo | train | eval | export | bench | tags | calibrate | demos | fit | recipe``.

``occrl demo`` runs the hybrid planner with the shipped network on a few cluttered shelves whose
target starts hidden and writes a summary and a GIF. The parser is here; what each command does is
in :mod:`occrl.cli.commands` (``demo``: :mod:`occrl.cli.demo`, ``export``: :mod:`occrl.cli.export`, ``demos``, ``fit``
and ``recipe``: :mod:`occrl.cli.recipe`), the option types and the
training options in :mod:`occrl.cli.options`. Nothing heavy is imported to build the parser: the
training options (which import torch) are added only when ``occrl train`` is parsed or its help
is printed.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys

from occrl import __version__
from occrl.cli.commands import run_bench, run_eval, run_train
from occrl.cli.demo import DEMO_FIRST_SEED, DEMO_STAGE, run_demo
from occrl.cli.export import run_export
from occrl.cli.recipe import add_recipe_parsers
from occrl.cli.options import (
    COUNT,
    NOISE,
    NON_NEGATIVE,
    POSITIVE,
    SEED,
    CommandParser,
    HelpFormatter,
    add_train_options,
)
from occrl.cli.calibrate import add_calibrate_parser
from occrl.cli.tags import add_tags_parser

__all__ = ["main", "make_parser"]

DESCRIPTION = """\
occrl: occlusion-aware search for object retrieval in clutter. A robot gripper looks for a target
object hidden among others on a shelf and pulls it out; occrl's networks and planners decide how."""

EPILOG = """\
examples:
  occrl demo                                   watch the planner on 3 cluttered shelves (writes a GIF)
  occrl eval --method hybrid-4x4 --stage 2 --tasks 50
                                               success rate, actions and time of a method
  occrl train --preset tiny --run-dir /tmp/tiny --iterations 2
                                               a seconds-long training run
  occrl recipe occnet --size smoke --run-dir /tmp/recipe
                                               the shipped network's recipe at a tiny size (minutes)
  occrl COMMAND --help                         a command's options and examples"""

DEMO_EPILOG = f"""\
Without --seed the demo plays the first stage-{DEMO_STAGE} shelves from task seed {DEMO_FIRST_SEED} on whose target
the first observation does not show (5 to 10 objects each): the planner has to search for it.

examples:
  occrl demo                              3 shelves with the hybrid planner 4x4 and the shipped network
  occrl demo --tasks 1 --method hybrid-2x2
                                          one shelf, a faster planner
  occrl demo --world mujoco               the 3D MuJoCo shelf; frames add the gripper-camera image
  occrl demo --tasks 1 --seed 8           the shelf of task seed 8
  occrl demo --method scripted            the privileged scripted retriever (it reads the true target pose)

Written to --out: demo.gif (one frame per action; panels: true scene | network input with the
heat-map and the planner's candidate target poses), demo_strip.png (a grid of frames of the first
shelf) and demo_summary.json."""

TRAIN_EPILOG = """\
examples:
  occrl train --preset tiny --run-dir /tmp/tiny --iterations 2     a smoke run (seconds)
  occrl train --preset cpu --run-dir runs/cpu --max-hours 8        what trains on a CPU machine
  occrl train --preset paper --device cuda --run-dir runs/paper    the paper's settings on a GPU
  occrl train --preset cpu --lr 1e-4 --show-config                 print the settings a run would use
  occrl train --preset cpu --help                                  this help with preset cpu's values

Run the same command again to resume a stopped run from RUN_DIR's checkpoint."""

EVAL_EPILOG = """\
examples:
  occrl eval --method hybrid-4x4 --stage 2 --tasks 50
  occrl eval --method stochastic-gen --objects 1-10 --noise 0.1 --workers 2
  occrl eval --method greedy --format markdown --out greedy.json
  occrl eval --method hybrid-2x2 --world mujoco --tasks 20        execute in the 3D MuJoCo shelf
  occrl eval --sweep --tasks 300 --out occrl-sweep --workers 8    the papers' clutter and noise sweeps (hours)

Methods: hybrid-MxH (the hybrid planner, m roll-outs of depth h per root state; the papers' are
2x2, 4x4 and 6x6), hybrid-lim-MxH (the most likely root only), greedy and stochastic (the network
without heat-map: mean or sampled action), stochastic-gen (the full network, sampled),
hierarchical (OMPL search), hybrid-ompl-MxH, and the privileged scripted and clearing (they read
the true state)."""

EXPORT_EPILOG = """\
examples:
  occrl export --run-dir runs/cpu --name occnet-takeover --preset cpu-curriculum
  occrl export --run-dir runs/cpu --name occnet-takeover --preset cpu-curriculum --dest /tmp/try
                                 write into /tmp/try instead of the package (to try it out)"""

BENCH_EPILOG = """\
examples:
  occrl bench env_throughput
  occrl bench planner_speedup --batch 1
  occrl bench env_throughput --help          a benchmark's own options

The benchmarks are the scripts in benchmarks/ of a source checkout."""


def make_parser() -> argparse.ArgumentParser:
    """The ``occrl`` command line: demo, train, eval, export, bench, tags, calibrate, demos, fit,
    recipe.

    The ``train`` parser gets its training options (one per :class:`~occrl.training.TrainConfig`
    setting) when it parses or prints its help, so that building this parser imports no torch.
    """
    parser = argparse.ArgumentParser(prog="occrl", description=DESCRIPTION, epilog=EPILOG, formatter_class=HelpFormatter)
    parser.add_argument("-v", "--verbose", action="store_true", help="log progress (INFO) and show tracebacks of errors")
    parser.add_argument("--version", action="version", version=f"occrl {__version__}", help="print the version and exit")
    sub = parser.add_subparsers(title="commands", dest="command", required=True, metavar="COMMAND", parser_class=CommandParser)
    add_demo(sub)
    train = sub.add_parser(
        "train",
        help="train the network (curriculum PPO with the heat-map loss, or imitation); resumes from --run-dir",
        usage="occrl train [-h] [--preset NAME] (--run-dir DIR | --show-config) [OPTION ...]",
        description="Train OccNet by a preset's recipe; any training setting can be overridden by its option.",
        epilog=TRAIN_EPILOG,
        formatter_class=HelpFormatter,
        add_help=False,
        options=add_train_options,
    )
    train.set_defaults(func=run_train)
    add_eval(sub)
    add_export(sub)
    b = sub.add_parser(
        "bench",
        help="run a speed benchmark from benchmarks/",
        description="Run a speed benchmark script from benchmarks/ with its own options.",
        epilog=BENCH_EPILOG,
        formatter_class=HelpFormatter,
    )
    b.add_argument("name", metavar="NAME", help="the benchmark's name: a script in benchmarks/ without .py, e.g. env_throughput")
    b.add_argument("rest", metavar="OPTION", nargs=argparse.REMAINDER, help="the benchmark's own options")
    b.set_defaults(func=run_bench)
    add_tags_parser(sub)
    add_calibrate_parser(sub)
    add_recipe_parsers(sub)
    return parser


def add_demo(sub: argparse._SubParsersAction) -> None:
    """``occrl demo``'s options."""
    d = sub.add_parser(
        "demo",
        help="watch the planner retrieve hidden targets from cluttered shelves; writes a GIF",
        description="Play a few shelves with a method and write a GIF of every action, a picture strip and a summary.",
        epilog=DEMO_EPILOG,
        formatter_class=HelpFormatter,
    )
    d.add_argument("--tasks", type=COUNT, default=3, help="shelves to play")
    d.add_argument(
        "--stage",
        type=int,
        default=DEMO_STAGE,
        choices=[1, 2, 3],
        help="curriculum stage: 1-4, 5-10 or 7-10 objects (3: target at the back)",
    )
    d.add_argument(
        "--seed",
        type=SEED,
        default=None,
        help=f"play the shelves of task seeds SEED, SEED+1, ... (default: the first shelves from seed {DEMO_FIRST_SEED} on "
        "whose target the first observation does not show)",
    )
    d.add_argument("--out", metavar="DIR", default="occrl-demo", help="folder for demo.gif, demo_strip.png and demo_summary.json")
    d.add_argument("--fps", type=POSITIVE, default=4.0, help="GIF frames per second")
    d.add_argument(
        "--method",
        default="hybrid-4x4",
        choices=["hybrid-2x2", "hybrid-4x4", "hybrid-6x6", "scripted", "clearing"],
        help="the hybrid planner MxH (m roll-outs of depth h per candidate target pose) with the network, or a privileged retriever",
    )
    d.add_argument(
        "--weights",
        metavar="FILE_OR_NAME",
        default=None,
        help="network weights file or a shipped network's name (default: the shipped occnet)",
    )
    d.add_argument(
        "--world",
        choices=["pymunk", "mujoco"],
        default="pymunk",
        help="execute in the 2D pymunk world or the 3D MuJoCo shelf (frames add the gripper-camera image)",
    )
    d.set_defaults(func=run_demo)


def add_eval(sub: argparse._SubParsersAction) -> None:
    """``occrl eval``'s options."""
    e = sub.add_parser(
        "eval",
        help="run a method on fixed task seeds and report success, actions, time",
        description="Evaluate a method on the tasks of fixed seeds (the same seeds give the same shelves and episodes).",
        epilog=EVAL_EPILOG,
        formatter_class=HelpFormatter,
    )
    e.add_argument(
        "--method",
        help="hybrid-2x2, hybrid-4x4, hybrid-6x6, hybrid-lim-4x4 (any hybrid-MxH, hybrid-lim-MxH or hybrid-ompl-MxH runs), "
        "greedy, stochastic, stochastic-gen, hierarchical, or the privileged scripted and clearing (default: none; give it or --sweep)",
    )
    e.add_argument("--sweep", action="store_true", help="the papers' clutter and noise sweeps (resumable; --out is a folder)")
    e.add_argument(
        "--methods", default=None, help="comma-separated methods for --sweep (default: all but the privileged scripted and clearing)"
    )
    e.add_argument(
        "--chunk",
        type=COUNT,
        default=None,
        help="with --sweep: rounds of this many tasks (every point gets them before any gets more), so an "
        "interrupted sweep leaves a complete figure; cached points are extended, never recomputed (default: all tasks at once)",
    )
    e.add_argument("--stage", type=int, default=None, choices=[1, 2, 3], help="the tasks' curriculum stage (default: 1)")
    e.add_argument(
        "--objects",
        default=None,
        help="object count per task: a number, or a range like 1-10 (each task draws its count from its seed) (default: the stage's)",
    )
    e.add_argument(
        "--world",
        choices=["pymunk", "mujoco"],
        default="pymunk",
        help="execution env: the 2D pymunk world or the 3D MuJoCo shelf (planners still plan in pymunk)",
    )
    e.add_argument(
        "--perception",
        choices=["geometric", "tags"],
        default="geometric",
        help="with --world mujoco: what the planner is told it sees: the objects more than 50 %% visible at their true poses "
        '(geometric) or what a tag detector decodes in the wrist camera\'s 640 x 480 image (tags; pip install -e ".[camera]")',
    )
    e.add_argument(
        "--shelf-height",
        type=float,
        default=None,
        help="with --world mujoco: the shelf's inside height in m, 0.2-1.0; the papers' real-robot protocol: 0.40 with "
        "--stage 2 --objects 1-8 (default: 0.30)",
    )
    e.add_argument(
        "--tag-layout",
        choices=["fitted", "at-most-3cm", "pairs"],
        default=None,
        help="with --perception tags: the objects' tags: one per face, as wide as the face allows, 8 mm to 6 cm (fitted); "
        "one per face, 1 to 3 cm (at-most-3cm); or as fitted but two side by side on faces of 3.95 cm and more (pairs) "
        "(default: pairs)",
    )
    e.add_argument(
        "--noise",
        type=NOISE,
        default=0.0,
        help="physics noise of the tasks; with --sweep: the clutter sweep alone, at this noise (use its own --out folder)",
    )
    e.add_argument("--tasks", type=COUNT, default=200, help="tasks per point (the paper uses 300 for sweeps)")
    e.add_argument("--seed", type=SEED, default=10_000_000, help="first task seed (default: %(default)s, the first of the held-out tasks)")
    e.add_argument("--batch", type=COUNT, default=16, help="worlds stepped together (policies; planners use 1)")
    e.add_argument("--workers", type=COUNT, default=1, help="processes (or Ray actors) to spread tasks over")
    e.add_argument(
        "--backend",
        choices=["local", "ray"],
        default="local",
        help="local processes or Ray actors (results are the same for the same seeds)",
    )
    e.add_argument("--ray-address", default=None, help="with --backend ray: join this Ray cluster (default: start a local Ray runtime)")
    e.add_argument(
        "--weights",
        default=None,
        help="network weights file, or a shipped network's name (occnet-warmstart, occnet-ei, ...) "
        "(default: the method's own, occnet or occnet-noheatmap)",
    )
    e.add_argument(
        "--inference",
        choices=["torch", "onnxruntime"],
        default="torch",
        help="hybrid planners: how the roll-outs call the network (onnxruntime: several times faster per call, equal to float "
        "rounding, so a few decisions may differ; pip install onnx onnxruntime)",
    )
    e.add_argument(
        "--replicate",
        type=NON_NEGATIVE,
        default=0,
        help="run replicate N of each task: the same shelves and execution noise, the decision maker's own randomness "
        "(policy samples, planner roll-outs) drawn anew (0: what every recorded result ran); repeat with N = 1, 2, ... "
        "to see how much a result varies with that randomness alone (greedy and scripted have none: the same result)",
    )
    e.add_argument("--out", metavar="FILE", default=None, help="write the results as JSON to this file (default: print only)")
    e.add_argument(
        "--format",
        choices=["text", "markdown", "csv"],
        default="text",
        help="how to print the summary: a sentence, a Markdown table or CSV",
    )
    e.add_argument("--no-progress", action="store_true", help="no progress bar")
    e.set_defaults(func=run_eval)


def add_export(sub: argparse._SubParsersAction) -> None:
    """``occrl export``'s options."""
    x = sub.add_parser(
        "export",
        help="ship a training run's weights in the package (occrl.load_pretrained)",
        description="Copy a training run's weights into the package as a named shipped network, with its model card.",
        epilog=EXPORT_EPILOG,
        formatter_class=HelpFormatter,
    )
    x.add_argument("--run-dir", metavar="DIR", required=True, help="the training run's folder (occrl train --run-dir)")
    x.add_argument(
        "--name",
        required=True,
        help="the shipped network's own name (occrl.pretrained.PRETRAINED_FILES, e.g. occnet-takeover); "
        "the default names occnet and occnet-noheatmap stand for one of them (DEFAULT_NETWORKS)",
    )
    x.add_argument("--preset", required=True, help="the training preset the run used")
    x.add_argument("--seed", type=SEED, default=0, help="the training seed the run used")
    x.add_argument(
        "--weights", default=None, help="weights file in the run folder (default: weights.pt, the latest; e.g. weights_warmstart.pt)"
    )
    x.add_argument("--dest", default=None, help="write into this folder instead of the package's pretrained/ (default: the package)")
    x.add_argument(
        "--recipe-before",
        default=None,
        help="JSON file listing the training steps that made the run's starting network (each: what, command, frames, cpu_hours); "
        "recorded in the card as recipe_before, with recipe_frames / recipe_cpu_hours totalled over them and the run "
        "(default: none: the card lists no earlier steps)",
    )
    x.set_defaults(func=run_export)


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
