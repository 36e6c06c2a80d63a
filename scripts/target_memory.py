"""Does the network remember where the target is once it is out of sight? Its heat-map, read
against the true target, by how long ago the camera last reported the target.

    python scripts/target_memory.py --weights occnet-takeover --stage 2 --tasks 96

A diagnosis that reads the true state (analysis only). The network's own sampled policy acts on
the held-out tasks (``occrl eval --method stochastic-gen``'s episodes); at every step with the
target inside the robot-centric window, the heat-map head's output (computed from the same
recurrent state the policy acted from) is compared with the true target footprint in the window
(the heat-map loss's label): the share of the map's mass on the footprint's pixels and its lift
(mean on the footprint over mean on the window). Steps are grouped by whether the camera reports
the target now ("visible"), reported it 1, 2-3, 4-7 or 8+ actions ago ("remembered"), or never
has in the episode ("never seen"). A network that remembers keeps its mass on the target after
it leaves view.
"""

from __future__ import annotations

import argparse
from collections import defaultdict

import numpy as np
import torch

from occrl.baselines import NetPolicy
from occrl.envs.episodes import episode_end, task_scenes
from occrl.eval.methods import make_method
from occrl.eval.runner import EVAL_SEED_BASE
from occrl.pretrained import network_name, weights_file

GROUPS = ("visible", "remembered 1", "remembered 2-3", "remembered 4-7", "remembered 8+", "never seen")


class WithHeatmap(torch.nn.Module):
    """The sampled policy, also writing the heat-map head's ``"predicted_heatmap"`` from the
    same step's ``"belief"``."""

    def __init__(self, policy: NetPolicy) -> None:
        super().__init__()
        self.policy = policy

    def reseed_worlds(self, seeds) -> None:
        self.policy.reseed_worlds(seeds)

    def forward(self, tensordict):
        tensordict = self.policy(tensordict)
        heat = self.policy.net.heatmap_head(tensordict.select("belief").clone())["heatmap"]
        return tensordict.set("predicted_heatmap", heat)


def group(visible: bool, seen_before: bool, since: int) -> str:
    if visible:
        return "visible"
    if not seen_before:
        return "never seen"
    return "remembered 1" if since == 1 else "remembered 2-3" if since <= 3 else "remembered 4-7" if since <= 7 else "remembered 8+"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--weights", default=None, help="weights file or shipped network name (default: occnet)")
    parser.add_argument("--stage", type=int, default=2, choices=(1, 2, 3))
    parser.add_argument("--tasks", type=int, default=96)
    args = parser.parse_args()
    if args.tasks < 1:
        raise SystemExit(f"--tasks must be >= 1, got {args.tasks}")
    method = make_method("stochastic-gen", weights_file(args.weights))
    if method.policy.net.heatmap_head is None:
        raise SystemExit("the network has no heat-map head (a greedy/stochastic baseline network); give one with a heat-map")
    seeds = [EVAL_SEED_BASE + i for i in range(args.tasks)]
    scenes = task_scenes(args.stage, seeds)
    policy = WithHeatmap(NetPolicy(method.policy.net, stochastic=True))
    rows = defaultdict(list)  # group -> (mass share, footprint area share, lift)

    def tally(td) -> None:  # one batch's trajectory (worlds, time): its steps grouped, in rows
        done = td["next", "done"].squeeze(-1).numpy()
        slot = td["privileged", "target_slot"][..., 0]
        # the camera's report, not the image: with remembered detections a slot can be drawn unseen
        reported = td["objects", "detected"] & ~td["objects"].get("remembered", torch.zeros_like(td["objects", "detected"]))
        visible = reported.gather(-1, slot[..., None])[..., 0].numpy()
        predicted = td["predicted_heatmap"][:, :, 0].numpy()
        footprint = td["privileged", "heatmap_target"].numpy().reshape(predicted.shape) > 0.5
        for b in range(done.shape[0]):
            seen_before, last = False, -1
            for t in range(episode_end(done[b]) + 1):
                if footprint[b, t].any():
                    p, m = predicted[b, t], footprint[b, t]
                    rows[group(bool(visible[b, t]), seen_before, t - last)].append(
                        (p[m].sum() / max(p.sum(), 1e-9), m.mean(), p[m].mean() / max(p.mean(), 1e-9))
                    )
                if visible[b, t]:
                    seen_before, last = True, t

    method.run_episodes(scenes, seeds, policy=policy, heatmap_target=True, on_rollout=tally)
    print(f"network {network_name(args.weights or 'occnet')}, stage {args.stage}, {args.tasks} held-out tasks, own sampled policy acting")
    print("| target | steps | heat-map mass on the target | footprint's share of the window | lift |")
    print("| --- | --- | --- | --- | --- |")
    for g in GROUPS:
        if rows[g]:
            mass, area, lift = np.mean(rows[g], axis=0)
            print(f"| {g} | {len(rows[g])} | {mass:.3f} | {area:.4f} | {lift:.1f}x |")


if __name__ == "__main__":
    main()
