"""Why did a method fail? Replays the failed tasks of an `occrl eval --out` file and sorts them.

    python scripts/failure_categories.py results/heldout/hybrid-4x4_s2.json --limit 40
    python scripts/failure_categories.py F.json --weights W.pt   # the run was made with --weights

Each failed task is run again (same method, task seed and noise, so the same episode) and put in
one category, read from the env's privileged ground truth (analysis only; no method reads it):

- dropped: an object fell off the front edge;
- never detected: the target was never reported by perception;
  (and whether its centre was ever inside the camera's field of view: a target that never was is
  one the search never turned to, such as one in a front corner beside the gripper's start);
- detected, never held: seen at some step, never between the fingers; split by how close the
  gripper came: it closed its fingers at least once and held nothing ("closed, missed"), it
  brought the target's centre within 8 cm of the point between its fingertips' middle and never
  closed ("approached, never closed"), or never that close ("never approached"); of the
  "closed, missed" it counts those that did come that close at some step;
- held, not out: grasped at some step but not pulled out within 50 actions.

It also prints the share of the episode's steps with the gripper outside the shelf (y < 0): a
failure with the target seen and the gripper outside all along is a search that never went in.
"""

from __future__ import annotations

import argparse
import json
from collections import Counter
from pathlib import Path

import numpy as np

from occrl.envs import world_constants as C
from occrl.envs.visibility import in_field_of_view
from occrl.eval.methods import make_method
from occrl.eval.runner import rollout_tasks
from occrl.pretrained import weights_file


# "approached": the target's centre came this close to the point midway along the open fingers
APPROACHED = 0.08  # m


def categorise(td) -> dict:
    """Category and facts of one replayed episode (a [1, T] rollout)."""
    slot = td["privileged", "target_slot"][0, :, 0]
    detected = td["objects", "detected"][0].gather(1, slot[:, None])[:, 0].numpy()
    held = td["next", "privileged", "target_held"][0, :, 0].numpy()
    dropped = td["next", "dropped"][0, :, 0].numpy()
    outside = (td["gripper_pose"][0, :, 1] < 0).numpy()
    # the target's centre within the camera's field of view (the camera at the gripper, looking
    # along its +y axis), occluded or not
    gripper = td["gripper_pose"][0].numpy().astype(float)
    target = td["privileged", "target_pose"][0].numpy().astype(float)
    in_view = in_field_of_view(target[:, :2], gripper)
    # the target's centre in the gripper frame, against the point midway along the fingers
    dx, dy = target[:, 0] - gripper[:, 0], target[:, 1] - gripper[:, 1]
    c, s = np.cos(gripper[:, 2]), np.sin(gripper[:, 2])
    to_grasp_point = np.hypot(c * dx + s * dy, -s * dx + c * dy - C.FINGER_LENGTH / 2)
    action = td["action"][0].numpy()
    closes = int(((action[:, 3] > 0) & ~td["gripper_closed"][0, :, 0].numpy()).sum())
    if dropped.any():
        category = "dropped"
    elif not detected.any():
        category = "never detected"
    elif not held.any():
        if closes:
            approach = "closed, missed"
        elif to_grasp_point.min() <= APPROACHED:
            approach = "approached, never closed"
        else:
            approach = "never approached"
        category = f"detected, never held ({approach})"
    else:
        category = "held, not out"
    return {
        "category": category,
        "first_detected": int(np.argmax(detected)) if detected.any() else None,
        "detected_share": float(detected.mean()),
        "outside_share": float(outside.mean()),
        "target_depth_m": float(td["privileged", "target_pose"][0, 0, 1]),
        "ever_in_view": bool(in_view.any()),
        "closes": closes,
        "nearest_to_grasp_point_m": float(to_grasp_point.min()),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("result", type=Path, help="an `occrl eval --out` JSON file (2D world)")
    parser.add_argument(
        "--weights", default=None, help="the --weights the evaluation used: a file or a shipped network's name (default: occnet)"
    )
    parser.add_argument("--limit", type=int, default=None, help="replay only the first N failures")
    args = parser.parse_args()

    d = json.loads(args.result.read_text())
    if d.get("world", "pymunk") != "pymunk" or d.get("objects"):
        raise SystemExit("only evaluations of the 2D world with the stage's own object counts can be replayed here")
    failed = [e["seed"] for e in d["episodes"] if not e["success"]][: args.limit]
    method = make_method(d["method"], weights_file(args.weights))
    counts: Counter = Counter()
    outside = []
    never_in_view = 0
    missed_nearest: list[float] = []
    for seed in failed:
        facts = categorise(rollout_tasks(method, d["stage"], [seed], d["noise"], replicate=d.get("replicate", 0)))
        counts[facts["category"]] += 1
        if facts["category"] == "detected, never held (closed, missed)":
            missed_nearest.append(facts["nearest_to_grasp_point_m"])
        outside.append(facts["outside_share"])
        never_in_view += facts["category"] == "never detected" and not facts["ever_in_view"]
        print(
            f"seed {seed}: {facts['category']:50s} first seen at step {facts['first_detected']}, seen on "
            f"{facts['detected_share']:.0%} of steps, gripper outside on {facts['outside_share']:.0%}, target depth {facts['target_depth_m']:.2f} m, "
            f"nearest to the grasp point {facts['nearest_to_grasp_point_m']:.2f} m"
            + ("" if facts["ever_in_view"] else ", never in the field of view"),
            flush=True,
        )
    print(f"{d['method']} stage {d['stage']}: {len(failed)} failures replayed: " + ", ".join(f"{k} {v}" for k, v in counts.most_common()))
    never_held = sum(v for k, v in counts.items() if k.startswith("detected, never held"))
    print(f"detected, never held: {never_held} (closed, missed; approached, never closed; never approached: split above)")
    missed = np.array(missed_nearest)
    print(
        f"closed, missed: {(missed <= APPROACHED).sum()} of {len(missed)} with the target's centre within "
        f"{APPROACHED * 100:.0f} cm of the grasp point at some step (the others never came that close)"
    )
    outside = np.array(outside)
    print(f"gripper outside the shelf on >= 90 % of the steps in {(outside >= 0.9).sum()} of {len(failed)} failures")
    print(f"never detected and never in the camera's field of view: {never_in_view} of {counts['never detected']}")


if __name__ == "__main__":
    main()
