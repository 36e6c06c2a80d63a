"""Where does the hybrid planner lose stage-2 tasks: in the search, or in the retrieval?

    python scripts/handover.py --stage 2 --tasks 200 [--weights W.pt] [--to scripted|clearing|clearing-observed|hierarchical] [--out F.json]
    python scripts/handover.py --from stochastic-gen --to scripted ...   # the network's own policy searches
    python scripts/handover.py --from hierarchical --to hybrid-4x4|stochastic-gen|clearing-observed [--weights W.pt] ...
    python scripts/handover.py --from hierarchical --to clearing-observed --teacher --action-noise 0.1 ...   # a DART teacher

The hybrid 4x4 planner acts from the start of each held-out task (the README's task seeds; the
planner reseeded per task as `occrl eval` does, so up to the hand-over the episodes are those of
the evaluation); from the first step at which perception reports the target, a retriever acts
instead until the episode ends (``occrl.baselines.handover.SearchThenRetrieve``): the privileged scripted retriever (``--to scripted``: it knows where the target is,
so it measures how often the retrieval from the planner's hand-over states can be done at all by
a direct reach, grasp and pull), the privileged clearing retriever (``--to clearing``: it first
carries the objects in the target's corridor aside), the same from the observations alone (``--to
clearing-observed``: the detected objects and the target's last detected outline) or the hierarchical planner (``--to hierarchical``: observations
only, its OMPL reach / rearrange / extract, as `occrl eval` runs it). The retriever's episode
starts at the hand-over (its first observation is flagged ``is_init``). The planner
keeps deciding underneath so that its LSTM state follows the real history (its actions are
discarded after the hand-over). Prints success of the combination against the hybrid planner's
own on the same tasks (from ``--baseline F.json`` of `occrl eval`, if given), and how many tasks
were handed over at all. ``--from stochastic-gen``: the network's own sampled policy searches
instead of the planner (its episodes up to the hand-over those of `occrl eval --method
stochastic-gen`). ``--from hierarchical --to hybrid-4x4`` (or ``stochastic-gen``, ``clearing-observed``) turns it
round: the hierarchical planner's Search (sweeps from the nearer end, stopping at the first
detection; a rearrangement where a sweep finds nothing) until the target is first reported, the
network's planner (or own policy, or the observed clearing retriever) from then on; it decides at every step from the start
(``SearchThenRetrieve(retriever_follows=True)``), so its memory holds the whole search,
and its decisions count from the hand-over. A diagnosis for issue 16 (docs/decisions.md); analysis only: the
retriever reads what its kind reads (the scripted one privileged state).
"""

from __future__ import annotations

import argparse
import json
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase
from tqdm import tqdm

from occrl.eval.methods import make_method
from occrl.baselines.handover import SearchThenRetrieve
from occrl.baselines.hierarchical import HierarchicalPlanner
from occrl.baselines.observed_clearing import ObservedClearingRetriever
from occrl.envs.episodes import task_scenes
from occrl.eval.runner import EVAL_SEED_BASE, paired_with, summarize
from occrl.pretrained import network_name, weights_file
from occrl.training.teachers import HIERARCHICAL_TEACHER

#: the network's decision makers that can take over from the hierarchical planner's search
NETWORK_RETRIEVERS = ("hybrid-4x4", "stochastic-gen")
#: what can take over from the hierarchical planner's search, following the episode from its start
FOLLOWING_RETRIEVERS = (*NETWORK_RETRIEVERS, "clearing-observed")


class MotionNoise(TensorDictModuleBase):
    """``policy`` with Gaussian noise of standard deviation ``sigma`` on its executed motion
    (forward, lateral, rotation; clipped to [-1, 1]; the gripper command as decided), drawn from
    a generator reseeded with each task's seed: a DART data run's disturbed teacher."""

    def __init__(self, policy: TensorDictModuleBase, sigma: float) -> None:
        super().__init__()
        self.policy, self.sigma = policy, sigma
        self.in_keys, self.out_keys = policy.in_keys, policy.out_keys
        self.generator = torch.Generator().manual_seed(0)

    def reseed(self, seed: int) -> None:
        self.policy.reseed(seed)
        self.generator.manual_seed(seed)

    def reset(self) -> None:
        self.policy.reset()

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        tensordict = self.policy(tensordict)
        action = tensordict.get("action").clone()
        noise = torch.randn(action[..., :3].shape, generator=self.generator) * self.sigma
        action[..., :3] = (action[..., :3] + noise).clamp(-1.0, 1.0)
        tensordict.set("action", action)
        return tensordict


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stage", type=int, default=2)
    parser.add_argument("--tasks", type=int, default=200)
    parser.add_argument("--weights", default=None, help="the planner's network: a weights file or a shipped name (default: occnet)")
    parser.add_argument(
        "--from", dest="searcher", default="hybrid-4x4", choices=("hybrid-4x4", "stochastic-gen", "hierarchical"), help="who searches"
    )
    parser.add_argument(
        "--to", default="scripted", choices=("scripted", "clearing", "clearing-observed", "hierarchical", *NETWORK_RETRIEVERS)
    )
    parser.add_argument("--baseline", default=None, help="an `occrl eval --out` file of the searcher alone on the same tasks")
    parser.add_argument(
        "--teacher",
        action="store_true",
        help="--from hierarchical: the searcher with the training teacher's settings (occrl.training.teachers.HIERARCHICAL_TEACHER: "
        "1 s per OMPL query, re-planning when the world leaves its plan), as `occrl train --teacher-search hierarchical` runs it",
    )
    parser.add_argument(
        "--action-noise",
        type=float,
        default=0.0,
        help="Gaussian noise of this standard deviation added to every executed motion (forward, lateral, rotation; clipped to [-1, 1]), "
        "seeded by the task: the combination as a DART data run (--teacher-action-noise) executes it",
    )
    parser.add_argument("--out", default=None)
    args = parser.parse_args()
    if not 0.0 <= args.action_noise <= 1.0:
        parser.error(f"--action-noise must be in [0, 1] (a standard deviation in action units), got {args.action_noise}")
    if args.teacher and args.searcher != "hierarchical":
        parser.error("--teacher applies to --from hierarchical")
    torch.set_num_threads(1)
    if args.searcher == "hierarchical" and args.to not in FOLLOWING_RETRIEVERS:
        parser.error(f"--from hierarchical hands over to one of {list(FOLLOWING_RETRIEVERS)}; got --to {args.to}")
    if args.to in NETWORK_RETRIEVERS and args.searcher != "hierarchical":
        parser.error(f"--to {args.to} takes over from --from hierarchical only")
    label = "hybrid 4x4" if args.searcher == "hybrid-4x4" else args.searcher
    if args.searcher == "hierarchical":  # the retriever decides from the start (its memory of the search kept), counts after
        settings = HIERARCHICAL_TEACHER if args.teacher else dict(sweep_from="nearest", stop_when_located=True)
        searcher = HierarchicalPlanner(**settings)
        planner = make_method(args.to if args.to in NETWORK_RETRIEVERS else "hierarchical", weights_file(args.weights))  # primers
        retriever = ObservedClearingRetriever() if args.to == "clearing-observed" else planner.policy
        policy = SearchThenRetrieve(searcher, retriever, retriever_follows=True)
    else:
        planner = make_method(args.searcher, weights_file(args.weights))
        retriever = ObservedClearingRetriever() if args.to == "clearing-observed" else make_method(args.to).policy
        policy = SearchThenRetrieve(planner.policy, retriever)
    acting = MotionNoise(policy, args.action_noise) if args.action_noise > 0 else policy
    seeds = list(range(EVAL_SEED_BASE, EVAL_SEED_BASE + args.tasks))
    t0 = time.time()
    results, handed = [], []
    for seed in tqdm(seeds, desc=f"{label} -> {args.to}", unit="task"):  # one world per task, as `occrl eval` runs the planners
        before = policy.handovers
        policy.reset()  # a new task (run_episodes reseeds both parts with the task seed)
        policy.handovers = before
        handed.append(None)
        results += planner.run_episodes(task_scenes(args.stage, [seed]), [seed], batch_size=1, policy=acting)
        handed[-1] = policy.handovers > before
    summary = summarize(results)
    lo, hi = summary["success_ci95"]
    print(
        f"{label} -> {args.to} at the first detection, stage {args.stage}: {100 * summary['success_rate']:.1f} % "
        f"({100 * lo:.1f}-{100 * hi:.1f}) of {len(results)} tasks; handed over in {policy.handovers}; {time.time() - t0:.0f} s"
    )
    report = {
        "stage": args.stage,
        "from": args.searcher,
        "to": args.to,
        "teacher_settings": args.teacher,
        "action_noise": args.action_noise,
        # the network that decides (none where the hierarchical planner hands over to the clearing retriever)
        "weights": None
        if args.searcher == "hierarchical" and args.to not in NETWORK_RETRIEVERS
        else network_name(args.weights or "occnet"),
        "handovers": policy.handovers,
        **summary,
    }
    report["episodes"] = [{**r.to_dict(), "handed_over": h} for r, h in zip(results, handed)]
    if args.baseline:
        episodes = json.loads(open(args.baseline).read())["episodes"]
        base = {e["seed"]: e["success"] for e in episodes}
        # without a hand-over an episode is the planner's own: the same outcome and length
        length = {e["seed"]: e["actions"] for e in episodes}
        same = [length[r.seed] == r.actions and base[r.seed] == r.success for r, h in zip(results, handed) if not h and r.seed in base]
        print(f"tasks never handed over: {len(same)}, of them equal to the planner's own episode: {sum(same)}")
        pair = paired_with(report["episodes"], episodes)
        print(
            f"the planner alone on the same {pair['tasks']} tasks: {100 * pair['baseline_success_rate']:.1f} %; the hand-over wins "
            f"{pair['only_run']}, loses {pair['only_baseline']} (McNemar p = {pair['p']:.3f})"
        )
        report["baseline"] = {"file": args.baseline, **pair}
    if args.out:
        with open(args.out, "w") as f:
            json.dump(report, f, indent=1)


if __name__ == "__main__":
    main()
