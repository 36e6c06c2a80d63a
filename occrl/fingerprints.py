"""Fingerprints of seeded episodes and of the training presets: what a behaviour-preserving change
(a refactoring) must leave identical.

A fingerprint of a method on a task is its actions (stored to 1e-6) with the episode's length and
outcome; of a preset, its settings. ``python scripts/record_fingerprints.py`` writes
``tests/data/fingerprints.json``; ``tests/test_fingerprints.py`` recomputes them and compares
(:func:`same_episode`): the length and outcome exactly, the actions within
:data:`ACTION_TOLERANCE`. Another CPU rounds a network's float32 arithmetic differently in the last
bits: torch's scalar kernels (``ATEN_CPU_CAPABILITY=default``) against its vectorised ones moved
hybrid 4x4's actions by at most 1.3e-6 over a 50-action episode, which a digest of the actions
rounded to 1e-5 (the format until 2026-12-06) did not survive. Record them anew only with a
change that alters behaviour on purpose (physics, networks), and say so in the commit.

Such last-bit differences can also turn a near-tie of the hybrid planner's roll-out returns many
steps into an episode, after which it is another episode: on an AMD EPYC (torch's AVX512 kernels)
hybrid 4x4's stage-2 episode moves by 1e-6 from its third action and chooses another roll-out at
its 35th. Such an episode is recorded once more on that machine as an *alternate*
(``python scripts/record_fingerprints.py --alternate``, which leaves the main record as it is);
an episode passes when it equals the recorded one or one of its alternates
(:func:`recorded_difference`). A behaviour change would have to reproduce another CPU's episode
to pass.
"""

from __future__ import annotations

import inspect
import platform

import numpy as np
import torch

from occrl.baselines.hierarchical import HierarchicalPlanner
from occrl.envs import world_constants as C
from occrl.envs.episodes import episode_end
from occrl.eval.methods import Method, make_method
from occrl.eval.runner import rollout_tasks
from occrl.training.presets import TRAIN_PRESETS

__all__ = [
    "EPISODES",
    "HIERARCHICAL_TIMER_STRETCH",
    "hierarchical_for_fingerprints",
    "ACTION_TOLERANCE",
    "episode_fingerprint",
    "episode_difference",
    "same_episode",
    "recorded_difference",
    "machine_description",
    "preset_fingerprints",
    "all_fingerprints",
]

# (method, stage, task seed): the scripted retriever, hybrid 4x4 on the shipped occnet and the
# hierarchical planner on a few held-out stage-1 and stage-2 tasks. OMPL stops on timers (a
# query's restarts, its shortcutting, the episode's limit), so a hierarchical episode depends on
# the machine's speed wherever a timer ends a step that would have gone on; the planner runs here
# with every timer HIERARCHICAL_TIMER_STRETCH times its default (see hierarchical_for_fingerprints).
EPISODES = [
    ("scripted", 1, 10_000_000),
    ("scripted", 1, 10_000_001),
    ("scripted", 2, 10_000_000),
    ("scripted", 2, 10_000_002),
    ("hybrid-4x4", 1, 10_000_000),
    ("hybrid-4x4", 2, 10_000_003),
    ("hierarchical", 1, 10_000_000),
    ("hierarchical", 2, 10_000_001),
]


# On this machine (quiet) the two episodes' shortcutting took up to 0.41 s of its 0.75 s default
# deadline and a restarted query's second tree found its plan in 0.2 s of the 0.75 s restart
# period: under a 1.6x slower, loaded VM the stage-1 episode came out different. Four times the
# timers leave a 7x margin; the recorded actions are those of the default timers on a quiet machine
# (the first tree of the restarted query finds nothing in 7.5 s either).
HIERARCHICAL_TIMER_STRETCH = 4.0

# How far a recomputed action may lie from the recorded one: a hundred times another CPU's float
# rounding (about 1e-6, see the module docstring), 1/20,000 of an action's range [-1, 1]; a change
# that moves none of the recorded episodes' actions by more than this is below what they guard.
ACTION_TOLERANCE = 1e-4


def hierarchical_for_fingerprints(seed: int = 0):
    """The hierarchical planner with its defaults except every timer stretched by
    :data:`HIERARCHICAL_TIMER_STRETCH`: its seeded episodes then do not depend on the machine's speed."""
    defaults = inspect.signature(HierarchicalPlanner).parameters
    timers = {name: defaults[name].default * HIERARCHICAL_TIMER_STRETCH for name in ("plan_seconds", "restart_seconds", "time_limit")}
    return HierarchicalPlanner(seed=seed, **timers)


def episode_fingerprint(method_name: str, stage: int, seed: int) -> dict:
    """One seeded episode of a method: its actions (a list per step, rounded to 1e-6), length and
    outcome.

    Examples:
        >>> from occrl.fingerprints import episode_fingerprint
        >>> fp = episode_fingerprint("scripted", 1, 10_000_000)
        >>> sorted(fp), fp["success"], len(fp["actions"]) == fp["steps"]
        (['actions', 'dropped', 'steps', 'success'], True, True)
    """
    if method_name == "hierarchical":
        method = Method(method_name, hierarchical_for_fingerprints())
    else:
        method = make_method(method_name)
    td = rollout_tasks(method, stage, [seed])
    done = td.get(("next", "done"))[0, :, 0].numpy()
    end = episode_end(done)
    actions = td.get("action")[0, : end + 1].numpy().astype(np.float64)
    rounded = np.round(actions, 6) + 0.0  # + 0.0: -0.0 and 0.0 alike
    return {
        "actions": rounded.tolist(),
        "steps": int(end + 1),
        "success": bool(td.get(("next", "success"))[0, end, 0]),
        "dropped": bool(td.get(("next", "dropped"))[0, end, 0]),
    }


def episode_difference(fingerprint: dict, recorded: dict, atol: float = ACTION_TOLERANCE) -> str | None:
    """How an episode's fingerprint differs from a recorded one, or None when it equals it: the same
    length, success and drop, and every action within ``atol`` of the recorded one.

    Examples:
        >>> from occrl.fingerprints import episode_difference
        >>> recorded = {"actions": [[0.5, -1.0, 0.0, 1.0]], "steps": 1, "success": True, "dropped": False}
        >>> episode_difference({**recorded, "actions": [[0.5000013, -1.0, 0.0, 1.0]]}, recorded) is None
        True
        >>> episode_difference({**recorded, "actions": [[0.502, -1.0, 0.0, 1.0]]}, recorded)
        'action 0 off by 0.002 (tolerance 0.0001)'
    """
    outcome = {k: (fingerprint[k], recorded[k]) for k in ("steps", "success", "dropped") if fingerprint[k] != recorded[k]}
    if outcome:
        return f"(now, recorded): {outcome}"
    moved = np.abs(np.asarray(fingerprint["actions"], dtype=float) - np.asarray(recorded["actions"], dtype=float)).max(axis=-1)
    if (moved > atol).any():
        first = int(np.argmax(moved > atol))
        return f"action {first} off by {moved[first]:.3g} (tolerance {atol:g})"
    return None


def same_episode(fingerprint: dict, recorded: dict, atol: float = ACTION_TOLERANCE) -> bool:
    """Whether an episode's fingerprint equals a recorded one (:func:`episode_difference` finds nothing).

    Examples:
        >>> from occrl.fingerprints import same_episode
        >>> recorded = {"actions": [[0.5, -1.0, 0.0, 1.0]], "steps": 1, "success": True, "dropped": False}
        >>> same_episode({**recorded, "actions": [[0.5000013, -1.0, 0.0, 1.0]]}, recorded)
        True
        >>> same_episode({**recorded, "actions": [[0.502, -1.0, 0.0, 1.0]]}, recorded)
        False
    """
    return episode_difference(fingerprint, recorded, atol) is None


def recorded_difference(fingerprint: dict, recorded: dict, alternates: list[dict] = ()) -> str | None:
    """:func:`episode_difference` from the recorded fingerprint, or None when the episode equals it
    or one of its ``alternates`` (the same episode recorded on another CPU, each a fingerprint with
    a ``"machine"`` entry saying which).

    Examples:
        >>> from occrl.fingerprints import recorded_difference
        >>> recorded = {"actions": [[0.5, -1.0, 0.0, 1.0]], "steps": 1, "success": True, "dropped": False}
        >>> other = {**recorded, "actions": [[0.25, -1.0, 0.0, 1.0]], "machine": "another CPU"}
        >>> recorded_difference(other, recorded, [other]) is None, recorded_difference(other, recorded)
        (True, 'action 0 off by 0.25 (tolerance 0.0001)')
    """
    difference = episode_difference(fingerprint, recorded)
    if difference is None or any(same_episode(fingerprint, alternate) for alternate in alternates):
        return None
    if alternates:
        return f"{difference}; nor does it equal the {len(alternates)} alternate(s) recorded on {[a.get('machine') for a in alternates]}"
    return difference


def machine_description() -> str:
    """The CPU's model name (Linux's /proc/cpuinfo, else ``platform.processor()``) and the torch
    kernels it runs (``torch.backends.cpu.get_cpu_capability()``): what an alternate fingerprint
    records of the machine that made it."""
    model = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            model = next((line.split(":", 1)[1].strip() for line in f if line.startswith("model name")), model)
    except OSError:
        pass
    return f"{model}, torch CPU kernels {torch.backends.cpu.get_cpu_capability()}"


def preset_fingerprints() -> dict:
    """Every training preset's settings."""
    return {name: cfg.to_dict() for name, cfg in sorted(TRAIN_PRESETS.items())}


def all_fingerprints() -> dict:
    """The episodes of :data:`EPISODES` and the presets."""
    episodes = {f"{m}/stage{st}/seed{s}": episode_fingerprint(m, st, s) for m, st, s in EPISODES}
    return {"max_episode_steps": C.MAX_EPISODE_STEPS, "episodes": episodes, "presets": preset_fingerprints()}
