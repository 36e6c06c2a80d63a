"""Command line: ``occrl demo | train | eval | export | bench``.

``occrl demo`` runs the hybrid planner with the shipped network on a few random shelves and writes
a summary and a GIF (the privileged scripted retriever when no network is shipped). The parser is
here; what each command does is in :mod:`occrl.cli.commands` (``export``: :mod:`occrl.cli.export`), the option types in
:mod:`occrl.cli.options`.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys

from occrl import __version__
from occrl.cli.commands import run_bench, run_demo, run_eval, run_train
from occrl.cli.export import run_export
from occrl.cli.options import COUNT, FINITE, NOISE, NON_NEGATIVE, POSITIVE, SCALE, SEED, add_train_settings

__all__ = ["main", "make_parser"]


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
    d.add_argument("--method", default="hybrid-4x4", choices=["hybrid-2x2", "hybrid-4x4", "hybrid-6x6", "scripted", "clearing"])
    d.add_argument("--weights", default=None, help="network weights file or a shipped network's name instead of occnet")
    d.add_argument(
        "--world",
        choices=["pymunk", "mujoco"],
        default="pymunk",
        help="execute in the 2D pymunk world or the 3D MuJoCo shelf (frames add the gripper-camera image)",
    )
    d.set_defaults(func=run_demo)

    t = sub.add_parser("train", help="train OccNet (curriculum PPO + heat-map loss); resumes from RUN_DIR")
    t.add_argument(
        "--preset", default="paper", help="training preset (occrl/training/presets.py): paper, cpu, cpu-finetune, cpu-curriculum, tiny"
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
    add_train_settings(t)
    t.add_argument(
        "--init-weights",
        default=None,
        help="start a new run from these weights: a weights file (e.g. a run's weights_warmstart.pt) "
        "or a shipped name (occnet, occnet-noheatmap); used by the cpu-finetune preset",
    )
    t.add_argument("--checkpoint-every", type=POSITIVE, default=300.0, help="seconds between checkpoints")
    t.add_argument("--no-progress", action="store_true")
    t.set_defaults(func=run_train)

    e = sub.add_parser("eval", help="run a method on fixed task seeds and report success, actions, time")
    e.add_argument(
        "--method",
        help="hybrid-2x2, hybrid-4x4, hybrid-6x6, hybrid-lim-4x4 (the papers'; any hybrid-MxH, hybrid-lim-MxH or hybrid-ompl-MxH runs), "
        "greedy, stochastic, stochastic-gen, hierarchical, or the privileged scripted and clearing",
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
        "interrupted sweep leaves a complete figure; cached points are extended, never recomputed",
    )
    e.add_argument("--stage", type=int, default=None, choices=[1, 2, 3], help="the tasks' curriculum stage (default 1)")
    e.add_argument(
        "--objects", default=None, help="object count per task: a number, or a range like 1-10 (each task draws its count from its seed)"
    )
    e.add_argument(
        "--world",
        choices=["pymunk", "mujoco"],
        default="pymunk",
        help="execution env: the 2D pymunk world or the 3D MuJoCo shelf (planners still plan in pymunk)",
    )
    e.add_argument(
        "--noise",
        type=NOISE,
        default=0.0,
        help="physics noise of the tasks; with --sweep: the clutter sweep alone, at this noise (use its own --out folder)",
    )
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
        "--weights",
        default=None,
        help="network weights file, or a shipped network's name (occnet-warmstart, occnet-ei, ...), instead of the method's default (occnet / occnet-noheatmap)",
    )
    e.add_argument(
        "--rollout-min-scale",
        type=SCALE,
        default=0.0,
        help="hybrid planners: floor on the roll-out policy's standard deviation (default 0: the policy's own, as in the paper)",
    )
    e.add_argument(
        "--proposal-bonus",
        type=FINITE,
        default=0.0,
        help="hybrid-ompl-MxH: added to the OMPL plan's roll-out return before it is compared with the policy's roll-outs, "
        "a prior for the plan in return units (default 0: scored as they are; a large value lets the plan decide alone)",
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
        "(policy samples, planner roll-outs) drawn anew (default 0: what every recorded result ran); repeat with N = 1, 2, ... "
        "to see how much a result varies with that randomness alone (greedy and scripted have none: the same result)",
    )
    e.add_argument("--out", default=None, help="write the results as JSON")
    e.add_argument(
        "--format",
        choices=["text", "markdown", "csv"],
        default="text",
        help="how to print the summary: a sentence, a Markdown table or CSV",
    )
    e.add_argument("--no-progress", action="store_true")
    e.set_defaults(func=run_eval)

    x = sub.add_parser("export", help="ship a training run's weights in the package (occrl.load_pretrained)")
    x.add_argument("--run-dir", required=True)
    x.add_argument(
        "--name",
        required=True,
        help="the shipped network's own name (occrl.pretrained.PRETRAINED_FILES, e.g. occnet-takeover); the default names occnet and occnet-noheatmap stand for one of them (DEFAULT_NETWORKS)",
    )
    x.add_argument("--preset", required=True, help="the training preset the run used")
    x.add_argument("--seed", type=SEED, default=0)
    x.add_argument(
        "--weights", default=None, help="weights file in the run folder (default weights.pt, the latest; e.g. weights_warmstart.pt)"
    )
    x.add_argument("--dest", default=None, help="write into this folder instead of the package's pretrained/ (for trying it out)")
    x.add_argument(
        "--recipe-before",
        default=None,
        help="JSON file listing the training steps that made the run's starting network (each: what, command, frames, cpu_hours); "
        "recorded in the card as recipe_before, with recipe_frames / recipe_cpu_hours totalled over them and the run",
    )
    x.set_defaults(func=run_export)

    b = sub.add_parser("bench", help="run a speed benchmark from benchmarks/")
    b.add_argument("name", help="e.g. env_throughput")
    b.add_argument("rest", nargs=argparse.REMAINDER)
    b.set_defaults(func=run_bench)

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
