"""Is the close decision what the network's own policy loses? Its gripper command replaced by an oracle.

    python scripts/oracle_close.py --weights occnet-takeover --stage 2 --tasks 200 --modes policy,veto,oracle

A diagnosis that reads the true state (analysis only). ``stochastic-gen`` on the held-out tasks,
the motion always the policy's, the gripper command (the action's last entry) per mode:

- ``policy``: the policy's own (``occrl eval --method stochastic-gen`` exactly);
- ``veto``: the policy's, except that a close is turned into "stay open" unless closing now
  would hold the target (the world's grasp rule, :func:`~occrl.envs.pymunk2d.fingers.grasp_candidate`,
  on the true shapes) or the fingers already hold something;
- ``oracle``: closed exactly when closing now would hold the target, or the target is held.

At noise 0 the grasp rule on the true state is what the world does, so ``oracle`` is the policy
with a perfect close decision: what a better close could buy. Prints success per mode against
the first, with exclusive tasks and the exact McNemar p-value, and how many commands each mode
changed.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import torch

from occrl.baselines import NetPolicy
from occrl.envs.episodes import task_scenes
from occrl.envs.pymunk2d.fingers import grasp_candidate
from occrl.eval.methods import make_method
from occrl.eval.runner import EVAL_SEED_BASE, mcnemar_p, wilson_interval
from occrl.pretrained import network_name, weights_file

MODES = ("policy", "veto", "oracle")


class OracleClose(torch.nn.Module):
    """A policy whose gripper command is overridden per ``mode`` from the worlds' true state
    (``worlds``: the env's ``base_env.worlds``, set per batch by ``run_episodes``'s ``on_env``)."""

    def __init__(self, policy: NetPolicy, mode: str) -> None:
        super().__init__()
        if mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
        self.policy, self.mode, self.worlds, self.changed = policy, mode, [], 0

    def reseed_worlds(self, seeds) -> None:
        self.policy.reseed_worlds(seeds)

    def forward(self, tensordict):
        tensordict = self.policy(tensordict)
        if self.mode == "policy":
            return tensordict
        action = tensordict.get("action").clone()
        for b, world in enumerate(self.worlds):
            holds_target = world.held is not None and world.held == world.target_index
            graspable = (
                not world.closed
                and grasp_candidate(world.gripper_pose(), world.opening, world.object_world_polygons())[0] == world.target_index
            )
            wants = bool(action[b, 3] > 0)
            close = (holds_target or graspable) if self.mode == "oracle" else wants and (graspable or world.held is not None)
            self.changed += close != wants
            action[b, 3] = 1.0 if close else -1.0
        tensordict.set("action", action)
        return tensordict


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--weights", default=None, help="weights file or shipped network name (default: occnet)")
    parser.add_argument("--stage", type=int, default=2, choices=(1, 2, 3))
    parser.add_argument("--tasks", type=int, default=200)
    parser.add_argument("--modes", default="policy,veto,oracle", help=f"comma-separated, from {MODES}; the first is the reference")
    parser.add_argument("--out", default=None, help="write which tasks each mode solved to this JSON file")
    args = parser.parse_args()
    modes = args.modes.split(",")
    if any(m not in MODES for m in modes):
        raise SystemExit(f"--modes must be from {MODES}, got {args.modes!r}")
    if args.tasks < 1:
        raise SystemExit(f"--tasks must be >= 1, got {args.tasks}")
    method = make_method("stochastic-gen", weights_file(args.weights))
    seeds = [EVAL_SEED_BASE + i for i in range(args.tasks)]
    scenes = task_scenes(args.stage, seeds)
    solved: dict[str, list[bool]] = {}
    print(
        f"network {network_name(args.weights or 'occnet')}, stage {args.stage}, {args.tasks} held-out tasks: own sampled policy, gripper command per mode"
    )
    print(f"| mode | success | 95 % interval | only this / only {modes[0]} | McNemar p | commands changed |")
    print("| --- | --- | --- | --- | --- | --- |")
    for mode in modes:
        policy = OracleClose(NetPolicy(method.policy.net, stochastic=True), mode)
        results = method.run_episodes(scenes, seeds, policy=policy, on_env=lambda env: setattr(policy, "worlds", env.base_env.worlds))
        ok = [r.success for r in results]
        solved[mode] = ok
        n = sum(ok)
        lo, hi = wilson_interval(n, args.tasks)
        mine = sum(a and not b for a, b in zip(ok, solved[modes[0]]))
        theirs = sum(b and not a for a, b in zip(ok, solved[modes[0]]))
        versus = "- | -" if mode == modes[0] else f"{mine} / {theirs} | {mcnemar_p(mine, theirs):.3f}"
        print(f"| {mode} | {100 * n / args.tasks:.1f} % | {100 * lo:.1f}-{100 * hi:.1f} | {versus} | {policy.changed} |", flush=True)
    if args.out:
        Path(args.out).write_text(json.dumps({"weights": args.weights, "stage": args.stage, "solved": solved}))


if __name__ == "__main__":
    main()
