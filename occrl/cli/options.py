"""The command line's option types (checked values with argparse's one-line errors) and the
training options generated from :class:`~occrl.training.TrainConfig`."""

from __future__ import annotations

import argparse
import math
import re


__all__ = ["bounded", "add_train_settings", "parse_objects", "checked_weights_file"]


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
SCALE = bounded(float, 0.0, 1.0, what="a number in [0, 1]")
FINITE = bounded(float, what="a finite number")


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
            "task_copies",
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


def add_train_settings(parser: argparse.ArgumentParser) -> None:
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
