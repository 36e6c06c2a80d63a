"""Training settings occrl no longer has, and how a stored config (a checkpoint's) that names one
is read: as if it did not where it was "off", refused with the commit that still has it otherwise."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["RemovedSetting", "REMOVED_SETTINGS", "drop_removed_settings"]


@dataclass(frozen=True)
class RemovedSetting:
    """A training setting occrl no longer has: the value that meant "off" (None: inert without the
    others, any value accepted) and the commit of the last version that had it."""

    off: object
    commit: str
    why: str


_EXPERIMENT = "an experiment that made no shipped network (the lab log, docs/lab/)"
# Settings removed from the library: a stored config (a checkpoint's) that names one at its "off"
# value reads as if it did not; any other value is refused, naming the commit that still has it.
REMOVED_SETTINGS: dict[str, RemovedSetting] = {
    **{
        name: RemovedSetting(off, "eed1cea", "it only served experiments shown to hurt (the lab log, docs/lab/)")
        for name, off in (("ppo_bc_coeff", 0.0), ("ppo_bc_min_scale", None), ("freeze_policy_scale", False))
    },
    **{
        name: RemovedSetting(off, "53b1240", _EXPERIMENT)
        for name, off in (
            ("detail_lr", 0.0),
            ("teacher_roots", "own"),
            ("teacher_to_the_end", False),
            ("start_scenes", ""),
            ("start_scenes_share", None),
            ("task_copies", 1),
            ("critic_to_trunk", True),
            ("success_weighting", "episode"),
            ("retrieval_labels", "planner"),
            ("takeover_retriever", "scripted"),
            ("takeover_at", "first-sight"),
            ("teacher_label_kinds", "all"),
            ("teacher_replan_inside", False),
            ("teacher_roll_in", 0),
        )
    },
}


def drop_removed_settings(stored: dict) -> dict:
    """``stored`` without the settings of :data:`REMOVED_SETTINGS`; ``ValueError`` where one is
    not at its "off" value, naming the commit whose occrl still has it.

    Examples:
        >>> from occrl.training.config import drop_removed_settings
        >>> drop_removed_settings({"lr": 1e-3, "task_copies": 1})
        {'lr': 0.001}
        >>> drop_removed_settings({"task_copies": 4})
        Traceback (most recent call last):
            ...
        ValueError: training setting task_copies=4 was removed from occrl (an experiment that made no shipped network (the lab log, docs/lab/)); to run or resume with it, use the version that has it: git checkout 53b1240
    """
    kept = dict(stored)
    for name, removed in REMOVED_SETTINGS.items():
        if name in kept:
            value = kept.pop(name)
            if removed.off is not None and value != removed.off:
                raise ValueError(
                    f"training setting {name}={value!r} was removed from occrl ({removed.why}); "
                    f"to run or resume with it, use the version that has it: git checkout {removed.commit}"
                )
    return kept
