"""When the hybrid planner closes its fingers, did its imagination say the grasp would hold?

    python scripts/close_outcomes.py --stage 2 --tasks 100 --weights occnet-takeover
    python scripts/close_outcomes.py --stage 2 --seeds 10000057,10000081 --verbose

Replays held-out tasks with a hybrid planner and looks at every executed action that closes the
open gripper. For each such close it steps the chosen root's recreated world (the planner's own
model: detected objects, the target seen or hypothesised at a heat-map peak) by the executed
action and compares what that model predicted with what the real world did:

- imagined grasp of the target / none, against the real grasp of the target / none;
- the same action stepped in the true state (every object, hidden ones included, at its true
  pose: ``scripts/oracle_roots.py``): a grasp the recreated world makes and the true one does not
  is lost to what the camera has not seen;
  (for those objects: whether their centre is in the camera's field of view, and whether the
  camera detected them at an earlier step, which a memory of detections would have kept);
- whether the target was detected at that moment (a hypothesised target grasped in imagination
  but absent in reality is a search guess, not a model error);
- how many of the chosen root's m roll-outs closed on their first action (a close chosen from
  one roll-out out of m is the roll-outs' noise deciding, not the policy's mean).

A diagnosis (issue 16: "closed on nothing" is the planner's commonest stage-2 failure); it reads
the env's privileged ground truth only to score, never to decide.
"""

from __future__ import annotations

import argparse
import json
from collections import Counter
from pathlib import Path

import numpy as np

from occrl.envs.pymunk2d.fingers import grasp_candidate
from occrl.envs.visibility import in_field_of_view
from occrl.eval.methods import make_method
from occrl.eval.runner import EVAL_SEED_BASE, rollout_tasks
from occrl.planners import make_world, recreate
from occrl.pretrained import weights_file
from occrl.baselines.oracle_planner import true_state


def blocking_objects(td, t: int, truth) -> list[dict]:
    """The objects other than the target that reach between the open fingers at step ``t`` in the
    true state (``truth``, a world of :func:`true_state`, before the action), with what the camera
    knew of each: its centre in the field of view, its visible share now, detected before ``t``."""
    obs = td[0, t]
    slots = np.flatnonzero(obs["privileged", "object_present"].numpy().astype(bool))  # world index -> slot
    _, touching = grasp_candidate(truth.gripper_pose(), truth.opening, truth.object_world_polygons())
    gripper = truth.gripper_pose()
    out = []
    for i in sorted(touching):
        if i == truth.target_index:
            continue
        slot = int(slots[i])
        out.append(
            {
                "in_view": bool(in_field_of_view(truth.object_poses()[i, :2], gripper)),
                "visible_fraction": float(obs["privileged", "visible_fraction"][slot]),
                "detected_before": bool(td["objects", "detected"][0, : t + 1, slot].any()),
            }
        )
    return out


def close_records(method, stage: int, seed: int, noise: float = 0.0) -> list[dict]:
    """One record per executed close of one task's episode (up to its first end)."""
    planner = method.policy
    planner.decisions.clear()
    td = rollout_tasks(method, stage, [seed], noise)
    decisions = list(planner.decisions)
    done = td["next", "done"][0, :, 0].numpy()
    end = int(np.argmax(done)) + 1 if done.any() else len(done)
    action = td["action"][0].numpy()
    closed_before = td["gripper_closed"][0, :, 0].numpy()
    real_held = td["next", "privileged", "target_held"][0, :, 0].numpy()
    success = bool(td["next", "success"][0, end - 1, 0]) if ("next", "success") in td.keys(True) else None
    records = []
    for t in range(min(end, len(decisions))):
        if not (action[t, 3] > 0 and not closed_before[t]):
            continue
        d = decisions[t]
        root = d.roots[d.chosen_root]
        world = make_world(root.state)
        world.step(d.action)
        truth = make_world(true_state(td[0, t]))
        blockers = blocking_objects(td, t, truth)
        truth.step(d.action)
        first = d.result.first_actions[d.chosen_root]  # (m, 4)
        records.append(
            {
                "seed": seed,
                "step": t,
                "target_detected": bool(recreate(td[0, t]).target_detected),  # a root's target may be a guess
                "roots": len(d.roots),
                "imagined_target_grasp": world.held is not None and world.held == world.target_index,
                "imagined_any_grasp": world.held is not None,
                "true_state_target_grasp": truth.held is not None and truth.held == truth.target_index,
                "real_target_grasp": bool(real_held[t]),
                "blockers": blockers,
                "rollouts_closing": int((first[:, 3] > 0).sum()),
                "m": int(first.shape[0]),
                "episode_success": success,
            }
        )
    return records


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--method", default="hybrid-4x4", help="a hybrid planner (hybrid-MxH)")
    parser.add_argument("--stage", type=int, default=2, choices=(1, 2, 3))
    parser.add_argument("--tasks", type=int, default=100, help="the first N held-out task seeds")
    parser.add_argument("--seeds", default=None, help="comma-separated task seeds instead of --tasks")
    parser.add_argument("--weights", default=None, help="a weights file or a shipped network's name (default: occnet)")
    parser.add_argument("--out", type=Path, default=None, help="write every close's record as JSON")
    parser.add_argument("--verbose", action="store_true", help="print every close")
    args = parser.parse_args()
    if not args.method.startswith("hybrid"):
        raise SystemExit(f"--method must be a hybrid planner (hybrid-2x2, hybrid-4x4, ...), got {args.method!r}")
    seeds = [int(s) for s in args.seeds.split(",")] if args.seeds else list(range(EVAL_SEED_BASE, EVAL_SEED_BASE + args.tasks))
    method = make_method(args.method, weights_file(args.weights))
    records = []
    for seed in seeds:
        recs = close_records(method, args.stage, seed)
        records += recs
        if args.verbose:
            for r in recs:
                print(r, flush=True)
    table: Counter = Counter()
    for r in records:
        seen = "target seen" if r["target_detected"] else "target hypothesised"
        imagined = "imagined grasp" if r["imagined_target_grasp"] else "imagined miss"
        truth = "true-state grasp" if r["true_state_target_grasp"] else "true-state miss"
        real = "real grasp" if r["real_target_grasp"] else "real miss"
        table[(seen, imagined, truth, real)] += 1
    print(f"{args.method} stage {args.stage}, {len(seeds)} tasks, weights {args.weights or 'occnet'}: {len(records)} closes")
    for key, n in sorted(table.items()):
        print(f"  {' / '.join(key):80s} {n}")
    futile = [r for r in records if not r["imagined_target_grasp"] and not r["real_target_grasp"]]
    if futile:
        spread = Counter(r["rollouts_closing"] for r in futile)
        print(
            "closes that missed in imagination and in reality, by roll-outs of the chosen root closing on their first action: "
            + ", ".join(f"{k} of {futile[0]['m']}: {v}" for k, v in sorted(spread.items()))
        )
        print(f"  of them with another object grasped in imagination: {sum(r['imagined_any_grasp'] for r in futile)}")
    unseen = [b for r in records if r["imagined_target_grasp"] and not r["true_state_target_grasp"] for b in r["blockers"]]
    if unseen:
        print(
            f"objects between the fingers that the recreated world lacked: {len(unseen)}; centre outside the camera's "
            f"field of view {sum(not b['in_view'] for b in unseen)}, in view but hidden {sum(b['in_view'] for b in unseen)}; "
            f"detected at an earlier step {sum(b['detected_before'] for b in unseen)}"
        )
    if args.out:
        args.out.write_text(json.dumps({"method": args.method, "stage": args.stage, "weights": args.weights, "closes": records}, indent=1))


if __name__ == "__main__":
    main()
