"""The recipe of the default networks, step by step, as ``occrl`` commands (``occrl recipe``).

Each step is one command (``occrl train``, ``occrl demos``, ``occrl fit``) writing into its own
folder of the recipe's run folder; ``{name}`` in a command stands for the weights file an earlier
step ``name`` wrote. ``full`` is the recipe of the shipped networks (their model cards record the
same settings); ``smoke`` the same commands at a tiny size (a few minutes on a CPU), which checks
the chain and nothing about the networks.
"""

from __future__ import annotations

import shlex
from dataclasses import dataclass

__all__ = ["RecipeStep", "RECIPES", "RECIPE_SIZES", "recipe_steps", "SMOKE_OPTIONS"]

RECIPE_SIZES = ("full", "smoke")


@dataclass(frozen=True)
class RecipeStep:
    """One step of a recipe: what it makes and the ``occrl`` command that makes it."""

    name: str
    """The step's folder in the recipe's run folder (and how later commands name its weights)."""
    what: str
    """What the step is, in a sentence (a model card's recipe_before)."""
    argv: tuple[str, ...]
    """The ``occrl`` command without its folder option (--run-dir / --out, added by the recipe)."""
    weights: str = "weights.pt"
    """The file in the step's folder that later steps start from."""

    @property
    def command(self) -> str:
        """The command's first word (train, demos, fit)."""
        return self.argv[0]


SELF_IMITATION = (
    "--preset cpu-curriculum --imitation-teacher self --label-episodes success --critic-coeff 0 --heatmap-coeff 0 "
    "--collector single --replay-stage-workers 0 --start-stage 2 --promotion-eval-every 1000 --seed 0 --iterations 80"
)
TAKEOVER = (
    "--preset cpu-curriculum --imitation-teacher hybrid-acting --teacher-inference onnxruntime --retrieval-takeover 0.5 "
    "--collector single --replay-stage-workers 0 --num-envs 8 --start-stage 2 --seed 0 --iterations 75"
)
DEMOS = "--teacher clearing-observed --teacher-search hierarchical --action-noise 0.05 --label-episodes success --num-envs 16 --stage 2"


def step(name: str, what: str, command: str, weights: str = "weights.pt") -> RecipeStep:
    return RecipeStep(name, what, tuple(shlex.split(command)), weights)


WARMSTART = step(
    "warmstart",
    "warm start: the cpu preset's DAgger on the privileged scripted retriever, stage 1, 400 iterations",
    "train --preset cpu --seed 0 --iterations 400",
    weights="weights_warmstart.pt",
)
TAKEOVER_STEP = step(
    "takeover",
    "takeover: 75 iterations on stage 2 learning from the hybrid planner acting, the scripted retriever taking over half of the retrievals",
    f"train {TAKEOVER} --promotion-eval-tasks 100 --init-weights {{warmstart}}",
)
DEMOS_SEED9 = step(
    "demos-seed9",
    "demonstrations: the clearing-observed teacher (hierarchical search, action noise 0.05) acts in every stage-2 "
    "episode, its successful episodes kept as labels",
    f"demos {DEMOS} --init-weights {{takeover}} --iterations 150 --seed 9",
)
DEMOS_SEED10 = step(
    "demos-seed10", "demonstrations: the same, a second seed", f"demos {DEMOS} --init-weights {{takeover}} --iterations 40 --seed 10"
)

RECIPES: dict[str, tuple[RecipeStep, ...]] = {  # the shipped network a recipe makes -> its steps, in order
    "occnet-selfimit": (
        WARMSTART,
        TAKEOVER_STEP,
        DEMOS_SEED9,
        DEMOS_SEED10,
        step(
            "fit",
            "offline fit to both demonstration runs' labelled sequences, 3,000 gradient steps",
            "fit --data {demos-seed9:dir} {demos-seed10:dir} --init-weights {takeover} --lr 1e-4 --steps 3000 --save-every 1000",
        ),
        step(
            "selfimit",
            "self-imitation: 80 iterations imitating its own successful stage-2 episodes",
            f"train {SELF_IMITATION} --init-weights {{fit}}",
        ),
    ),
    "occnet-noheatmap-selfimit": (
        WARMSTART,  # the full network's takeover plans for the takeover without heat-map and holds the demonstrations
        TAKEOVER_STEP,
        step(
            "noheatmap-warmstart",
            "warm start of the network without heat-map head: the cpu preset's DAgger on the scripted retriever, 400 iterations",
            "train --preset cpu --no-heatmap --seed 0 --iterations 400",
            weights="weights_warmstart.pt",
        ),
        step(
            "noheatmap-takeover",
            "takeover without heat-map head: the same, the acting planner on the fixed full takeover network",
            f"train {TAKEOVER} --no-heatmap --teacher-weights {{takeover}} --promotion learner --promote-threshold 1.0 "
            "--init-weights {noheatmap-warmstart}",
        ),
        DEMOS_SEED9,
        DEMOS_SEED10,
        step(
            "noheatmap-fit",
            "offline fit of the network without heat-map head to the same two demonstration runs, 3,000 gradient steps",
            "fit --data {demos-seed9:dir} {demos-seed10:dir} --init-weights {noheatmap-takeover} --lr 1e-4 --steps 3000 --save-every 1000",
        ),
        step(
            "noheatmap-selfimit",
            "self-imitation without heat-map head: 80 iterations imitating its own successful stage-2 episodes",
            f"train {SELF_IMITATION} --no-heatmap --promotion learner --init-weights {{noheatmap-fit}}",
        ),
    ),
}

# the smoke size: the options each command gets on top (later options win in argparse), per command
SMOKE_OPTIONS = {
    "train": "--iterations 1 --imitation-iters 1 --num-envs 2 --steps-per-env 8 --minibatch-envs 2 --collector single "
    "--promotion-eval-tasks 2 --no-progress",
    "demos": "--iterations 2 --num-envs 2 --no-progress",  # whole 50-step sequences: episodes that finish, some with success
    "fit": "--steps 4 --save-every 2 --log-every 2 --no-progress",
}


def recipe_steps(network: str, size: str) -> tuple[RecipeStep, ...]:
    """The steps of ``network``'s recipe (a shipped network's own name) at ``size`` (full or smoke)."""
    if network not in RECIPES:
        raise ValueError(f"no recipe for {network!r}; recipes: {sorted(RECIPES)}")
    if size not in RECIPE_SIZES:
        raise ValueError(f"size must be one of {RECIPE_SIZES}, got {size!r}")
    steps = RECIPES[network]
    if size == "full":
        return steps
    return tuple(RecipeStep(s.name, s.what, with_options(s.argv, shlex.split(SMOKE_OPTIONS[s.command])), s.weights) for s in steps)


def with_options(argv: tuple[str, ...], options: list[str]) -> tuple[str, ...]:
    """``argv`` (a command, then options each followed by its values) with ``options`` set: an
    option it has takes the new values in its place, the others are appended."""
    groups: list[list[str]] = []
    for word in [*argv, *options]:
        if word.startswith("--") or not groups:
            groups.append([word])
        else:
            groups[-1].append(word)
    merged: dict[str, list[str]] = {}
    for group in groups:
        merged[group[0]] = group  # a later option replaces an earlier one in its place
    return tuple(word for group in merged.values() for word in group)
