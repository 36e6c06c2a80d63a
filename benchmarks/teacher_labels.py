"""The hierarchical teacher on one batch: labels per second, who succeeds, re-plans, where it ends.

Usage:
    python benchmarks/teacher_labels.py [--beta 1.0] [--worlds 8] [--stage 2] [--weights occnet]
                                        [--full-sweeps] [--label-kinds reach,extract]

Runs one batch of ``--worlds`` stage-``--stage`` tasks for 50 steps with
``occrl.training.dagger.OnlineTeacherPolicy``: the hierarchical planner with the trainer's teacher
settings (``HIERARCHICAL_TEACHER``; ``--full-sweeps``: the paper's left-to-right sweeps instead)
labels every step while the teacher (a share ``--beta`` of the episodes) or the network's sampled
policy acts. Prints labels per second (one core; the machine's speed varies, compare runs made
side by side), first-episode success of teacher and learner episodes, the teacher's re-plans
(plans the learner left), the stages its episodes ended in, and the share of labelled steps.
"""

from __future__ import annotations

import argparse
import logging
import time

import torch
from torchrl.envs.utils import ExplorationType, set_exploration_type

from occrl.baselines.hierarchical import HierarchicalPlanner
from occrl.envs import make_env
from occrl.modules.weights import load_weights
from occrl.pretrained import weights_file
from occrl.training.dagger import OnlineTeacherPolicy
from occrl.training.teachers import HIERARCHICAL_TEACHER


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--beta", type=float, default=1.0, help="share of episodes the teacher acts in")
    parser.add_argument("--worlds", type=int, default=8)
    parser.add_argument("--stage", type=int, default=2)
    parser.add_argument("--seed", type=int, default=123)
    parser.add_argument("--weights", default="occnet", help="the learner: a shipped name or a weights file")
    parser.add_argument("--full-sweeps", action="store_true", help="the paper's Search: full left-to-right sweeps")
    parser.add_argument("--label-kinds", default=None, help="label only these action kinds, e.g. reach,extract")
    args = parser.parse_args()
    logging.disable(logging.WARNING)  # failed OMPL queries are expected on the learner's states
    net = load_weights(weights_file(args.weights)).eval()
    settings = dict(HIERARCHICAL_TEACHER)
    if args.full_sweeps:
        settings.update(sweep_from="left", stop_when_located=False)
    teacher = HierarchicalPlanner(seed=0, **settings)
    kinds = tuple(args.label_kinds.split(",")) if args.label_kinds else None
    policy = OnlineTeacherPolicy(net.policy, teacher, args.beta, label_kinds=kinds)
    env = make_env(batch_size=args.worlds, stage=args.stage, seed=args.seed).append_transform(net.make_primer())
    torch.manual_seed(0)
    t0 = time.time()
    with set_exploration_type(ExplorationType.RANDOM), torch.no_grad():
        data = env.rollout(50, policy, break_when_any_done=False)
    seconds = time.time() - t0
    done, success = data["next", "done"].squeeze(-1), data["next", "success"].squeeze(-1)
    first = done.float().argmax(-1)
    solved = [bool(done[b].any() and success[b, first[b]]) for b in range(args.worlds)]
    acts = data["teacher_acts"][:, 0, 0].tolist()
    ends: dict[str, int] = {}
    for ep in teacher.episodes:
        ends[ep.stage] = ends.get(ep.stage, 0) + 1
    t_ok = sum(s for s, a in zip(solved, acts) if a)
    l_ok = sum(s for s, a in zip(solved, acts) if not a)
    print(f"teacher settings: {settings}, label kinds: {kinds or 'all'}, learner: {args.weights}")
    print(f"{data.numel()} labels in {seconds:.0f} s: {data.numel() / seconds:.1f} labels/s (one batch, this machine)")
    print(f"first-episode success: teacher {t_ok}/{sum(acts)}, learner {l_ok}/{len(acts) - sum(acts)}")
    print(f"re-plans: {sum(ep.replans for ep in teacher.episodes)}; teacher stages at the end: {ends}")
    if "expert_weight" in data.keys():
        print(f"labelled steps: {float(data['expert_weight'].mean()):.1%}")


if __name__ == "__main__":
    main()
