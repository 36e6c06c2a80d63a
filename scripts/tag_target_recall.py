"""How often the tag detector saw the target when it was in plain view, in the tasks a run through
the tags lost and another run won.

Replays (same seeds, so the same episodes) the tasks that ``REFERENCE`` solved and ``TAGS`` did not,
through the tags, and counts per observation whether the target was more than half visible (the
geometric rule) and whether the detector decoded it, and the same over all objects:

    MUJOCO_GL=egl python scripts/tag_target_recall.py results/mujoco-tags/hybrid-4x4_tags_200tasks.json \\
        results/mujoco-selfimit/hybrid-4x4_200tasks.json

``TAGS`` must be an ``occrl eval --perception tags`` result of a MuJoCo world (its method, network,
stage, objects, shelf and tag layout are replayed).
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from occrl.cli.options import parse_objects
from occrl.envs.episodes import task_scenes
from occrl.eval.methods import make_method
from occrl.pretrained import weights_file


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("tags", help="an occrl eval --perception tags result (JSON)")
    parser.add_argument("reference", help="a result on the same tasks (JSON): the tasks it solved and the tags run lost are replayed")
    args = parser.parse_args()
    run = json.load(open(args.tags))
    if run.get("perception") != "tags" or run.get("world") != "mujoco":
        raise SystemExit(f"{args.tags} is not a MuJoCo run through the tags (perception {run.get('perception')!r})")
    reference = {e["seed"]: e for e in json.load(open(args.reference))["episodes"]}
    seeds = [e["seed"] for e in run["episodes"] if not e["success"] and reference.get(e["seed"], {}).get("success")]
    method = make_method(run["method"], weights_file(run["network"]) if run["network"] else None)
    options = {k: run[k] for k in ("shelf_height", "tag_layout") if run.get(k) is not None}
    options.setdefault("tag_layout", "fitted")  # a result that does not name its tags predates the pairs default
    print(f"{len(seeds)} tasks only {args.reference} solved; per task: target in view / decoded then, all objects in view / decoded then")
    totals = np.zeros(4, dtype=np.int64)
    for seed in seeds:
        captured = {}
        (result,) = method.run_episodes(
            task_scenes(run["stage"], [seed], parse_objects(run.get("objects"))),  # as occrl eval read --objects
            [seed],
            batch_size=1,
            world="mujoco",
            perception="tags",
            on_env=lambda env: captured.__setitem__("env", env),
            on_rollout=lambda td: captured.__setitem__("td", td),
            **options,
        )
        td, world = captured["td"], captured["env"].base_env.worlds[0]
        steps = result.actions
        detected = td.get(("objects", "detected"))[0, :steps].numpy()
        type_ids = td.get(("objects", "type_id"))[0, :steps].numpy()
        in_view = td.get(("privileged", "visible_fraction"))[0, :steps, : world.num_objects].numpy() > 0.5
        decoded = np.array([[int(t) in set(type_ids[s][detected[s]].tolist()) for t in world.type_ids] for s in range(steps)])
        target = world.target_index
        counts = np.array(
            [in_view[:, target].sum(), (in_view[:, target] & decoded[:, target]).sum(), in_view.sum(), (in_view & decoded).sum()]
        )
        totals += counts
        end = "dropped" if result.dropped else f"{steps} actions"
        print(f"{seed} ({end}): target {counts[0]} / {counts[1]}, all objects {counts[2]} / {counts[3]}", flush=True)
    if totals[0] and totals[2]:
        print(
            f"target in view in {totals[0]} observations, decoded in {totals[1]} ({totals[1] / totals[0]:.0%}); "
            f"all objects {totals[2]}, decoded {totals[3]} ({totals[3] / totals[2]:.0%})"
        )


if __name__ == "__main__":
    main()
