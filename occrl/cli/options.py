"""The command line's option types (checked values with argparse's one-line errors), its help
formatter, and the training options generated from :class:`~occrl.training.TrainConfig` (added only
when ``occrl train`` is used: they import torch)."""

from __future__ import annotations

import argparse
import math
import re
import sys
from typing import TYPE_CHECKING, Callable, Sequence

if TYPE_CHECKING:
    from occrl.training.config import TrainConfig


__all__ = [
    "bounded",
    "HelpFormatter",
    "CommandParser",
    "plain_text",
    "given_preset",
    "add_train_options",
    "add_train_settings",
    "parse_objects",
    "checked_weights_file",
]


def bounded(kind, low=None, high=None, low_open=False, what=""):
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


COUNT = bounded(int, 1, what="an integer >= 1")
NON_NEGATIVE = bounded(int, 0, what="an integer >= 0")
SEED = bounded(int, 0, 2**63 - 1, what="an integer in [0, 2**63)")
POSITIVE = bounded(float, 0.0, low_open=True, what="a number > 0")
NOISE = bounded(float, 0.0, 1.0, what="a number in [0, 1] (the paper uses 0 to 0.25)")


FRACTION = bounded(float, 0.0, 1.0, what="a number in [0, 1]")
NON_NEGATIVE_NUMBER = bounded(float, 0.0, what="a number >= 0")
DISCOUNT = bounded(float, 0.0, 1.0, low_open=True, what="a number in (0, 1]")
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
    **{
        name: FRACTION
        for name in ("heatmap_fraction", "imitation_beta_min", "promote_threshold", "gae_lambda", "noise", "teacher_action_noise")
    },
    "gamma": DISCOUNT,
}


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Help that shows each option's default (unless its help already says it) and prints the
    description and the epilog's examples as written."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        if "(default" in text or not action.option_strings or action.required or action.default in (None, argparse.SUPPRESS):
            return text
        if action.default is False and action.nargs == 0:  # a flag
            return f"{text} (default: off)"
        return f"{text} (default: %(default)s)"


class CommandParser(argparse.ArgumentParser):
    """A command's parser whose options may be added only when it is used: ``options(parser,
    argv)`` runs once, before the first parse or help, with the command's own arguments (so the
    help can show the values of a ``--preset`` given there)."""

    def __init__(self, *args, options: Callable[[argparse.ArgumentParser, Sequence[str]], None] | None = None, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.pending_options = options

    def add_pending_options(self, argv: Sequence[str] = ()) -> None:
        if self.pending_options is not None:
            options, self.pending_options = self.pending_options, None
            options(self, list(argv))

    def parse_known_args(self, args=None, namespace=None):
        self.add_pending_options(sys.argv[1:] if args is None else args)
        return super().parse_known_args(args, namespace)

    def format_help(self) -> str:
        self.add_pending_options()
        return super().format_help()

    def format_usage(self) -> str:
        self.add_pending_options()
        return super().format_usage()


def plain_text(doc: str) -> str:
    """A docstring's text for ``--help``: reST roles and literals as plain words, ``%`` escaped.

    Examples:
        >>> from occrl.cli.options import plain_text
        >>> plain_text('Learning rate of a ``"fine"`` network (:func:`occrl.modules.with_finer_input`); 10 %')
        'Learning rate of a "fine" network (occrl.modules.with_finer_input); 10 %%'
    """
    text = re.sub(r":\w+:`~?([^`]+)`", r"\1", doc).replace("``", "")
    return text.replace("%", "%%")


# the training settings a first run is most likely to change: shown with the common options
COMMON_SETTINGS = ("device", "num_envs", "collector", "workers", "lr")


def given_preset(argv: Sequence[str], default: str = "paper") -> str:
    """The ``--preset`` among a command's arguments (the last one given), else ``default``."""
    preset = default
    for k, arg in enumerate(argv):
        if arg == "--preset" and k + 1 < len(argv):
            preset = argv[k + 1]
        elif arg.startswith("--preset="):
            preset = arg.split("=", 1)[1]
    return preset


def add_train_options(parser: argparse.ArgumentParser, argv: Sequence[str] = ()) -> None:
    """``occrl train``'s options: the common ones first, then one per
    :class:`~occrl.training.TrainConfig` setting (``--num-envs`` for ``num_envs``,
    ``--heatmap/--no-heatmap`` for a flag) with its docstring as help and the value of the preset
    named in ``argv`` (``paper`` by default) as default; an option given overrides the preset's value."""
    from occrl.training.config import TrainConfig
    from occrl.training.presets import TRAIN_PRESETS

    preset = given_preset(argv)
    shown = preset if preset in TRAIN_PRESETS else "paper"
    common = parser.add_argument_group("common options")
    common.add_argument("-h", "--help", action="help", help="show this help and exit (with --preset P: P's values as defaults)")
    common.add_argument(
        "--preset",
        metavar="NAME",
        default="paper",
        help=f"training preset, the recipe the settings below start from: {', '.join(TRAIN_PRESETS)}",
    )
    common.add_argument(
        "--run-dir",
        metavar="DIR",
        default=None,
        help="run folder (checkpoint, logs, curves); keep it outside the source tree (required, except with --show-config)",
    )
    common.add_argument("--seed", type=SEED, default=0, help="training seed")
    common.add_argument("--iterations", type=COUNT, default=None, help="stop after this many iterations in total (default: no limit)")
    common.add_argument("--max-hours", type=POSITIVE, default=None, help="stop after this many hours of this session (default: no limit)")
    common.add_argument(
        "--show-config",
        action="store_true",
        help="print the settings this command would train with (the preset's, with the options given) and exit",
    )
    docs = TrainConfig.field_docs()  # read once: it parses the class's source
    add_train_settings(common, TRAIN_PRESETS[shown], names=COMMON_SETTINGS, docs=docs)
    common.add_argument("--no-progress", action="store_true", help="no progress bar")
    run = parser.add_argument_group("starting and saving")
    run.add_argument(
        "--init-weights",
        default=None,
        help="start a new run from these weights: a weights file (e.g. a run's weights_warmstart.pt) "
        "or a shipped name (occnet, occnet-noheatmap); used by the cpu-finetune preset (default: a new network)",
    )
    run.add_argument("--checkpoint-every", type=POSITIVE, default=300.0, help="seconds between checkpoints")
    run.add_argument(
        "--ray-address",
        default=None,
        help="with --collector ray: join this Ray cluster ('auto', 'host:6379', 'ray://host:10001') (default: start a local Ray runtime)",
    )
    settings = parser.add_argument_group(
        f"training settings of preset {shown}",
        f"Each defaults to the preset's value, shown here for preset {shown} (occrl train --preset NAME --help shows another's).",
    )
    add_train_settings(settings, TRAIN_PRESETS[shown], skip=("preset", *COMMON_SETTINGS), docs=docs)


def add_train_settings(
    group: argparse._ArgumentGroup,
    preset: TrainConfig,
    names: Sequence[str] | None = None,
    skip: Sequence[str] = (),
    docs: dict[str, str] | None = None,
) -> None:
    """One option per :class:`~occrl.training.TrainConfig` setting (those in ``names``, in that
    order, or all but ``skip``), its help the setting's docstring with ``preset``'s value as the
    default; the parsed value is None where the option is not given. ``docs``: the settings'
    docstrings when already read (:meth:`~occrl.training.TrainConfig.field_docs`)."""
    from occrl.modules import PRESETS
    from occrl.training.config import SETTING_CHOICES, TrainConfig

    docs = docs if docs is not None else TrainConfig.field_docs()
    kinds = TrainConfig.setting_types()  # the flat settings, one option each (TrainConfig.flat_settings)
    values = preset.flat_settings()
    for name in names if names is not None else [n for n in kinds if n not in skip]:
        kind, value = kinds[name], values[name]
        flag = "--" + name.replace("_", "-")
        shown = ("on" if value else "off") if isinstance(value, bool) else (repr(value) if value == "" else value)
        text = f"{plain_text(docs[name])} (default: {plain_text(str(shown))})"
        if kind == "bool":
            group.add_argument(flag, dest=name, action=argparse.BooleanOptionalAction, default=None, help=text)
        elif name == "start_stage":
            group.add_argument(flag, dest=name, type=int, choices=[1, 2, 3], default=None, help=text)
        elif kind == "int":
            group.add_argument(flag, dest=name, type=SETTING_TYPES.get(name, NON_NEGATIVE), default=None, help=text)
        elif kind == "float":
            group.add_argument(flag, dest=name, type=SETTING_TYPES.get(name, NON_NEGATIVE_NUMBER), default=None, help=text)
        else:
            choices = PRESETS if name == "net_preset" else SETTING_CHOICES.get(name)
            group.add_argument(flag, dest=name, choices=choices, default=None, help=text)


def parse_objects(text: str | None) -> int | tuple[int, int] | None:
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


def checked_weights_file(value: str | None) -> str | None:
    from occrl.pretrained import weights_file

    return weights_file(value)
