"""Is it the planner's model of the world or its network that holds the hybrid planner back?

    python scripts/oracle_roots.py --stage 2 --tasks 200 --roots state|target|own [--to-the-end] [--weights W] [--baseline F.json] [--out F.json]

The hybrid 4x4 planner (paper Alg. 1-2, the network's policy and value unchanged) plans from
roots that it could not know, on the README's held-out tasks (the planner reseeded per task as
`occrl eval` does):

- ``--roots state``: one root, the true state: every object on the shelf at its true pose and
  shape, hidden ones included, and the target where it is. At noise 0 the roll-outs then
  simulate the real future exactly (up to the policy's sampling); what fails is the policy the
  roll-outs follow and the value that scores them.
- ``--roots target``: the recreated state (detected objects only) with the target at its true
  pose while it is not detected, one root: a perfect heat-map; the objects the camera has not
  seen stay missing from the roll-outs, as in the planner.
- ``--roots own``: the planner's own roots (its heat-map's peaks, nothing privileged read); with
  ``--to-the-end`` the plain planner with its value replaced by roll-outs to the end.

``--to-the-end``: each roll-out runs to the episode's 50-action limit and its return is the
sum of the rewards (no value at a horizon): the policy's own outcome from each root, a Monte-Carlo
stand-in for a perfect value of this policy (slow: ~10 s per task).

Against the planner's own episodes on the same tasks (``--baseline``, an `occrl eval --out`
file) it prints the success of both, the tasks only one solved and the exact McNemar p-value.
A diagnosis for issue 16 (docs/decisions.md); it reads ``"privileged"`` (the true state), so
it is analysis, never a method.
"""

from __future__ import annotations

import argparse
import json
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np
import torch
from tensordict import TensorDictBase
from tqdm import tqdm

from occrl.envs import SceneObject
from occrl.envs.episodes import task_scenes
from occrl.eval.methods import make_method
from occrl.eval.runner import EVAL_SEED_BASE, paired_with, summarize
from occrl.envs import world_constants as C
from occrl.planners import HybridPlanner, RecreatedState, Root, recreate, with_target
from occrl.planners.rhp import NetworkStepper
from occrl.pretrained import network_name, weights_file


def true_state(obs: TensorDictBase) -> RecreatedState:
    """The true state of one observation (it reads ``"privileged"``): every object on the shelf at
    its true pose and shape, hidden ones included, the target where it is; the gripper as recreated.
    A held object is between the fingers at its true pose, so the imagined world grasps it."""
    state = recreate(obs)
    priv = obs.get("privileged")
    slot = int(priv.get("target_slot").reshape(-1)[0])
    poses = priv.get("object_pose").cpu().numpy().astype(float)
    present = priv.get("object_present").cpu().numpy().astype(bool)
    vertices = priv.get("object_vertices").cpu().numpy().astype(float)
    counts = priv.get("object_num_vertices").cpu().numpy()
    # rendering tells only the target from the rest: any other type id will do for clutter
    clutter_type = state.target_type + 1
    objects = tuple(
        SceneObject(state.target_type if k == slot else clutter_type, vertices[k, : counts[k]], tuple(poses[k]), k == slot)
        for k in np.flatnonzero(present)
    )
    return RecreatedState(objects, state.gripper_pose, state.opening, state.closed, state.target_type, state.target_vertices)


ROOTS = ("state", "target", "own")


class ZeroValueStepper(NetworkStepper):
    """The roll-outs' network calls with a value of 0 at the horizon."""

    def value(self, out: dict[str, torch.Tensor]) -> torch.Tensor:
        return torch.zeros(out["loc"].shape[0])


class OracleRootsPlanner(HybridPlanner):
    """The hybrid planner planning from privileged roots (``which``: ``"state"`` or ``"target"``)
    or its own (``"own"``, no privileged key read); ``to_the_end``: roll-outs to the episode's
    action limit, scored by their rewards alone."""

    def __init__(self, net, which: str, to_the_end: bool = False, **kwargs) -> None:
        super().__init__(net, **kwargs)
        if which not in ROOTS:
            raise ValueError(f"which must be one of {ROOTS}, got {which!r}")
        self.which = which
        self.to_the_end = to_the_end
        if to_the_end:
            self.stepper = ZeroValueStepper(net)
        self.in_keys = [*self.in_keys, *(["privileged"] if which != "own" else []), "step_count"]

    def decide(self, obs: TensorDictBase, heatmap: np.ndarray, hidden):
        if self.to_the_end:  # the roll-outs' depth: the actions left in the episode
            self.h = max(1, C.MAX_EPISODE_STEPS - int(obs.get("step_count").reshape(-1)[0]))
        return super().decide(obs, heatmap, hidden)

    def roots(self, obs: TensorDictBase, heatmap: np.ndarray) -> list[Root]:
        if self.which == "own":
            return super().roots(obs, heatmap)
        if self.which == "state":
            return [Root(true_state(obs), 1.0)]
        state = recreate(obs)
        if state.target_detected:
            return [Root(state, 1.0)]
        priv = obs.get("privileged")
        slot = int(priv.get("target_slot").reshape(-1)[0])
        return [Root(with_target(state, tuple(priv.get("object_pose")[slot].cpu().numpy().astype(float))), 1.0)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stage", type=int, default=2, choices=(1, 2, 3))
    parser.add_argument("--tasks", type=int, default=200)
    parser.add_argument("--roots", default="state", choices=ROOTS)
    parser.add_argument("--to-the-end", action="store_true", help="roll-outs to the action limit, no value at a horizon")
    parser.add_argument("--weights", default=None, help="the planner's network: a weights file or a shipped name (default: occnet)")
    parser.add_argument("--baseline", default=None, help="an `occrl eval --out` file of hybrid 4x4 on the same tasks")
    parser.add_argument("--out", default=None)
    args = parser.parse_args()
    torch.set_num_threads(1)
    method = make_method("hybrid-4x4", weights_file(args.weights))
    planner = OracleRootsPlanner(method.policy.net, args.roots, args.to_the_end, m=4, h=4)
    name = f"hybrid {'4 roll-outs to the end' if args.to_the_end else '4x4'} from " + (
        "its own roots" if args.roots == "own" else f"the true {args.roots}"
    )
    settings = {"stage": args.stage, "roots": args.roots, "to_the_end": args.to_the_end, "weights": network_name(args.weights or "occnet")}
    report_planner_run(method, planner, name, args.stage, args.tasks, settings, args.baseline, args.out)


def report_planner_run(method, planner, name: str, stage: int, tasks: int, settings: dict, baseline: str | None, out: str | None) -> dict:
    """Run ``planner`` (in ``method``'s env settings) on the first ``tasks`` held-out tasks of
    ``stage``, one world per task as `occrl eval` runs the planners, print its success (and, with
    ``baseline``, an `occrl eval --out` file, the tasks only one of them solved and the exact
    McNemar p), and write ``settings``, the summary and the episodes to ``out``."""
    seeds = list(range(EVAL_SEED_BASE, EVAL_SEED_BASE + tasks))
    t0 = time.time()
    results = []
    for seed in tqdm(seeds, desc=name, unit="task"):
        results += method.run_episodes(task_scenes(stage, [seed]), [seed], batch_size=1, policy=planner)
    summary = summarize(results)
    lo, hi = summary["success_ci95"]
    print(
        f"{name}, stage {stage}: {100 * summary['success_rate']:.1f} % "
        f"({100 * lo:.1f}-{100 * hi:.1f}) of {len(results)} tasks, {summary['dropped']} dropped; {time.time() - t0:.0f} s"
    )
    report = {**settings, **summary}
    report["episodes"] = [r.to_dict() for r in results]
    if baseline:
        pair = paired_with(report["episodes"], json.loads(open(baseline).read())["episodes"])
        print(
            f"the baseline ({baseline}) on the same {pair['tasks']} tasks: {100 * pair['baseline_success_rate']:.1f} %; solved only "
            f"by this planner: {pair['only_run']}, only by the baseline: {pair['only_baseline']} (McNemar p = {pair['p']:.3f})"
        )
        report["baseline"] = {"file": baseline, **pair}
    if out:
        with open(out, "w") as f:
            json.dump(report, f, indent=1)
    return report


if __name__ == "__main__":
    main()
