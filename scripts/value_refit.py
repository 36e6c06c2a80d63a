"""Is the value head what holds the hybrid planner back on stage 2? Refit it and see.

    python scripts/value_refit.py --out ~/diag/occnet_vfit.pt                      # the shipped occnet
    python scripts/value_refit.py --weights checkpoints/expert-iteration-seed0/weights.pt --out W.pt
    occrl eval --method hybrid-4x4 --stage 2 --tasks 60 --seed 20000000 --weights W.pt   # then compare
    python scripts/value_refit.py --acting proposer --stages 2 --episodes-per-stage 256 --out W.pt
        # the value of what hybrid-ompl's hierarchical planner achieves (docs/decisions.md)

The planner scores each roll-out by its rewards plus gamma^h V at the horizon, V being the value
of the stochastic policy it rolls out. This script collects that policy's own episodes (or those
of another decision maker, ``--acting``: then the head learns what that one achieves) on
stages 1-3 (task seeds from 40,000,000, apart from the held-out and validation ranges), computes
the LSTM beliefs once with the trunk frozen, and fits a copy of the value head to the discounted
returns (truncated episodes bootstrapped with the head's value of their last state, so the fit is
repeated for ``--rounds`` rounds). It prints the correlation and explained variance of the
original and the refitted head on a tenth of the episodes kept out of the fit, per stage, and
writes the network with the refitted head.
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import time

import numpy as np
import torch
from tensordict import TensorDict
from torchrl.modules import set_recurrent_mode

from occrl.envs import world_constants as C
from occrl.eval.methods import Method, is_method, make_method
from occrl.eval.runner import rollout_tasks
from occrl.pretrained import load_pretrained, network_name, weights_file
from occrl.training import load_weights, save_weights

FIT_SEED_BASE = 40_000_000


def acting_method(acting: str, weights: str | None, image_size: int, remembered_detections: bool = False) -> Method:
    """The decision maker whose episodes the head is fitted on: ``stochastic-gen`` (the network's
    own sampled policy, what the paper's planner rolls out), any ``occrl eval`` method, or
    ``proposer`` (the hierarchical planner as ``hybrid-ompl-MxH`` runs it, acting itself)."""
    if acting == "proposer":
        from occrl.baselines.hybrid_ompl import make_proposer

        # the images the fitted network reads
        return Method("proposer", make_proposer(), image_size=image_size, remembered_detections=remembered_detections)
    method = make_method(acting, weights)
    # a method without a network ignores the image; the fitted network reads images of its own size
    if method.network is not None:
        return method
    return dataclasses.replace(method, image_size=image_size, remembered_detections=remembered_detections)


def collect(net, weights: str | None, per_stage: int, batch: int = 64, acting: str = "stochastic-gen", stages=(1, 2, 3)) -> list[dict]:
    """Episodes of the acting decision maker, with ``net``'s beliefs along them (its trunk run over
    the episode's images; ``net`` is the network of ``weights`` whose head is fitted): beliefs,
    rewards, and whether each ended by termination."""
    method = acting_method(acting, weights, net.config.image_size, net.config.remembered_detections)
    episodes = []
    start_time = time.time()
    for stage in stages:
        for start in range(0, per_stage, batch):
            first = FIT_SEED_BASE + stage * 100_000 + start
            seeds = list(range(first, first + min(batch, per_stage - start)))
            td = rollout_tasks(method, stage, seeds)
            with torch.no_grad(), set_recurrent_mode(True):
                belief = net.trunk(td.select("pixels", "is_init").copy()).get("belief")
            reward = td["next", "reward"][..., 0]
            done = td["next", "done"][..., 0]
            terminated = td["next", "terminated"][..., 0]
            for b in range(len(seeds)):
                end = int(torch.nonzero(done[b])[0]) if done[b].any() else reward.shape[1] - 1
                episodes.append(
                    {
                        "stage": stage,
                        "belief": belief[b, : end + 1].clone(),
                        "reward": reward[b, : end + 1].clone(),
                        "terminated": bool(terminated[b, end]),
                    }
                )
            print(f"stage {stage}: {start + len(seeds)} episodes collected ({time.time() - start_time:.0f} s)", flush=True)
    return episodes


def value_of(head, belief: torch.Tensor) -> torch.Tensor:
    return head(TensorDict({"belief": belief}, batch_size=[belief.shape[0]])).get("state_value")[:, 0]


@torch.no_grad()
def targets(head, episodes: list[dict]) -> list[torch.Tensor]:
    """Discounted returns; a truncated episode is bootstrapped with ``head``'s value of its last state."""
    out = []
    for ep in episodes:
        g = 0.0 if ep["terminated"] else float(value_of(head, ep["belief"][-1:])[0])
        y = torch.zeros(len(ep["reward"]))
        for t in range(len(y) - 1, -1, -1):
            g = float(ep["reward"][t]) + C.GAMMA * g
            y[t] = g
        out.append(y)
    return out


@torch.no_grad()
def report(head, episodes: list[dict], ys: list[torch.Tensor], label: str) -> None:
    for stage in sorted({ep["stage"] for ep in episodes}):
        idx = [i for i, ep in enumerate(episodes) if ep["stage"] == stage]
        v = torch.cat([value_of(head, episodes[i]["belief"]) for i in idx]).numpy()
        y = torch.cat([ys[i] for i in idx]).numpy()
        print(
            f"{label:16s} stage {stage}: correlation {np.corrcoef(v, y)[0, 1]:.2f}, explained variance "
            f"{1 - np.var(y - v) / np.var(y):.2f} (mean value {v.mean():.1f}, mean return {y.mean():.1f})",
            flush=True,
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--weights", default=None, help="weights file or shipped network name to start from (default: occnet)")
    parser.add_argument("--episodes-per-stage", type=int, default=512)
    parser.add_argument(
        "--acting",
        default="stochastic-gen",
        help="whose episodes: stochastic-gen (the network's own policy), an occrl eval method, or proposer (hybrid-ompl's hierarchical planner)",
    )
    parser.add_argument("--stages", default="1,2,3", help="comma-separated curriculum stages to collect on")
    parser.add_argument("--rounds", type=int, default=4)
    parser.add_argument("--epochs", type=int, default=15, help="passes over the data per round")
    parser.add_argument("--out", required=True, help="weights file of the network with the refitted value head")
    args = parser.parse_args()

    args.weights = weights_file(args.weights)
    torch.manual_seed(0)
    try:
        stages = tuple(int(s) for s in args.stages.split(","))
    except ValueError:
        stages = ()
    if not stages or any(s not in (1, 2, 3) for s in stages) or len(set(stages)) != len(stages):
        parser.error(f"--stages must name distinct stages among 1, 2, 3, comma-separated, got {args.stages!r}")
    if args.acting != "proposer" and not is_method(args.acting):
        parser.error(f"--acting must be proposer or an occrl eval method, got {args.acting!r}")
    net = load_weights(args.weights) if args.weights else load_pretrained("occnet")
    net.eval()
    episodes = collect(net, args.weights, args.episodes_per_stage, acting=args.acting, stages=stages)
    order = np.random.default_rng(0).permutation(len(episodes))
    test = [episodes[i] for i in order[: len(episodes) // 10]]
    train = [episodes[i] for i in order[len(episodes) // 10 :]]

    report(net.critic, test, targets(net.critic, test), "original head")
    head = copy.deepcopy(net.critic)
    optimizer = torch.optim.Adam(head.parameters(), lr=1e-3)
    beliefs = torch.cat([ep["belief"] for ep in train])
    ys = targets(net.critic, train)
    for r in range(args.rounds):
        if r:
            ys = targets(head, train)
        y = torch.cat(ys)
        for _ in range(args.epochs):
            perm = torch.randperm(len(y))
            for s in range(0, len(y), 512):
                j = perm[s : s + 512]
                loss = torch.nn.functional.mse_loss(value_of(head, beliefs[j]), y[j])
                optimizer.zero_grad()
                loss.backward()
                optimizer.step()
        report(head, test, targets(head, test), f"refit, round {r + 1}")
    net.critic.load_state_dict(head.state_dict())
    save_weights(
        args.out,
        net,
        meta={
            "note": f"value head refitted by scripts/value_refit.py from {network_name(args.weights or 'occnet')} "
            f"on {args.acting} episodes, stages {args.stages}"
        },
    )
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
