"""Hybrid-planner decision time of this checkout against a reference checkout, in one run.

Usage:
    git worktree add /tmp/occrl-ref <commit>        # the code to compare against
    python benchmarks/planner_speedup.py --reference /tmp/occrl-ref [--decisions 24] [--rounds 2] [--inference onnxruntime] [--weights occnet]
    python benchmarks/planner_speedup.py --reference /tmp/occrl-ref --episodes 8 [--rounds 2] [--method hybrid-2x2] [--batch 1] [--save runs.json]

Both sides take the same decisions (observations along scripted stage-2 episodes, one planner per
m x h that sees them in episode order, as in an episode) in child processes on one core each,
alternated side by side for ``--rounds`` rounds so that the machine's drift hits both alike. It
prints, per m x h, the p50 and p95 decision time of each side and their ratio (this / reference),
and whether both sides chose the same actions (they should, unless the reference predates a
behaviour change). ``--inference onnxruntime`` runs this side's roll-outs on ONNX Runtime (the
reference side always uses its default). ``--episodes N`` times whole held-out stage-2 episodes
instead (hybrid 4x4, or ``--method hybrid-2x2|hybrid-6x6``, as ``occrl eval`` runs it: one planner
for all tasks, so what it keeps between decisions counts), timing every decision of each world's
own episode (not those the planner makes for a batch's worlds after their episode ended), and
checks that both sides played the same episodes; it also prints how many roll-out worlds each
side's planner built and rebuilt in the first round (where the checkout counts them). The
pooled percentiles compare each side's own episodes, whose mix of cheap (one root) and dear
(three roots) decisions differs where the episodes differ (ONNX Runtime's rounding turns
near-ties); the line "the same work" compares only the decisions of the episodes both sides
played alike (the same actions at every step, to 1e-3), decision for decision: the like-for-like ratio; under it, the median of each such
decision's own ratio (this / reference), which does not depend on where the percentile of a mix
of cheap and dear decisions falls. ``--save`` writes every run's times for a closer look.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

SIZES = ((2, 2), (4, 4), (6, 6))

# what each child runs: only public API that both sides have
CHILD = r"""
import json, sys, time
import torch
torch.set_num_threads(1)
from occrl.baselines import ScriptedRetriever
from occrl.envs import Scene, make_env
from occrl.planners import HybridPlanner
from occrl.training import load_weights

decisions = int(sys.argv[1])
options = {"inference": sys.argv[3]} if sys.argv[3] != "torch" else {}
net = load_weights(sys.argv[4])
obs, seed = [], 0
while len(obs) < decisions:
    env = make_env(batch_size=1, scenes=[Scene.sample(2, seed=20_000 + seed)], heatmap_target=False).append_transform(net.make_primer())
    seed += 1
    td = env.rollout(12, ScriptedRetriever())
    obs += [td[:, t].exclude("privileged") for t in range(0, td.shape[1], 3)]
obs = obs[:decisions]
out = {}
for m, h in json.loads(sys.argv[2]):
    planner = HybridPlanner(net, m=m, h=h, seed=0, **options)
    times, actions = [], []
    for td in obs:
        t = time.perf_counter()
        actions.append(planner(td.clone())["action"].reshape(-1).tolist())
        times.append(time.perf_counter() - t)
    out[f"{m}x{h}"] = {"times": times, "actions": actions}
print(json.dumps(out))
"""


# --episodes: whole held-out stage-2 episodes of a hybrid planner as occrl eval runs them (one planner
# for all tasks, so its kept roll-out worlds carry over from decision to decision)
EPISODES_CHILD = r"""
import json, sys, time
import torch
torch.set_num_threads(1)
from occrl.envs.episodes import run_episodes, task_scenes
from occrl.eval.methods import make_method

tasks = int(sys.argv[1])
options = {"inference": sys.argv[2]} if sys.argv[2] != "torch" else {}
method = make_method(sys.argv[4], weights=sys.argv[3], **options)
batch = int(sys.argv[5])


# the planner keeps only its latest decisions (it deletes the oldest hundred past 200): time them all
class KeepAll(list):
    def __delitem__(self, key):
        pass
method.policy.decisions = KeepAll()
seeds = [10_000_000 + i for i in range(tasks)]
wall, results, decisions, roots, owners, chosen = 0.0, [], [], [], [], []
# batches of `batch` worlds (16, as occrl eval runs them), one planner for all. The planner decides
# for every world of a batch at every step, world by world, also for worlds whose episode has ended
# (one checkout leaves them as they ended, another resets them): only the decisions of a world's
# own episode count, step t of world b being decision t * B + b of its batch.
for start in range(0, tasks, batch):
    chunk = seeds[start : start + batch]
    before = len(method.policy.decisions)
    t = time.perf_counter()
    out = run_episodes(method.policy, task_scenes(2, chunk), chunk, 0.0, batch, method.primers, method.exploration)
    wall += time.perf_counter() - t
    results += out
    made = method.policy.decisions[before:]
    actions = {r.seed: int(r.actions) for r in out}
    assert len(made) % len(chunk) == 0, (len(made), len(chunk))
    for k, d in enumerate(made):
        if k // len(chunk) < actions[chunk[k % len(chunk)]]:
            decisions.append(d.seconds)
            chosen.append([float(v) for v in d.action])
            roots.append(len(d.roots))
            owners.append([chunk[k % len(chunk)], k // len(chunk)])  # (episode seed, step)
# the roll-out worlds the planner built and rebuilt (a checkout whose planner keeps none, or does
# not count them: None)
pool = getattr(method.policy, "pool", None)
built, rebuilt = getattr(pool, "built", None), getattr(pool, "rebuilt", None)
print(json.dumps({"wall": wall, "decisions": decisions, "roots": roots, "owners": owners, "actions": chosen, "episodes": [[r.seed, bool(r.success), int(r.actions)] for r in results], "built": built, "rebuilt": rebuilt}))
"""


def round_ratios(runs: dict[str, list[dict]], q: float) -> list[float]:
    """Per round, this side's q-th percentile decision time over the reference's."""
    return [float(np.percentile(a["decisions"], q) / np.percentile(b["decisions"], q)) for a, b in zip(runs["this"], runs["reference"])]


def same_work(runs: dict[str, list[dict]], atol: float = 1e-3) -> tuple[int, dict[str, list[np.ndarray]]]:
    """The decisions of the episodes both sides played alike (seed, success and length the same,
    and every step's action within ``atol`` of the reference's first round, in every round of
    both sides), each side's times (ms) per round in one order, (seed, step) by (seed, step): the
    same decisions on the same observations, so their percentiles compare the same work, whatever
    the other episodes' mix of decisions. (Seed, success and length alone do not make an episode
    the same: a failed one runs to the step limit whatever it did.) Returns the number of such
    episodes and the times."""
    played = [{tuple(e) for e in run["episodes"]} for side in runs for run in runs[side]]
    alike = {e[0] for e in set.intersection(*played)}
    if all("actions" in run for side in runs for run in runs[side]):  # (a checkout that records them)
        first = runs["reference"][0]
        recorded = {tuple(o): a for o, a in zip(first["owners"], first["actions"])}
        for run in (run for side in runs for run in runs[side]):
            for o, a in zip(run["owners"], run["actions"]):
                if o[0] in alike and not (tuple(o) in recorded and np.allclose(a, recorded[tuple(o)], atol=atol)):
                    alike.discard(o[0])
    times: dict[str, list[np.ndarray]] = {}
    for side in runs:
        times[side] = []
        for run in runs[side]:
            keyed = {tuple(o): 1e3 * t for o, t in zip(run["owners"], run["decisions"]) if o[0] in alike}
            times[side].append(np.array([keyed[k] for k in sorted(keyed)]))
    return len(alike), times


def by_roots(t: dict[str, np.ndarray], k: dict[str, np.ndarray], rounds: int) -> str:
    """The decisions' p50 by their number of roots (the target unseen: up to three), each side:
    ``t`` the decision times (ms) and ``k`` their roots, each side's rounds together."""
    parts = []
    for n in np.unique(np.concatenate(list(k.values()))):
        ref, this = t["reference"][k["reference"] == n], t["this"][k["this"] == n]
        p_ref = f"{np.percentile(ref, 50):.1f}" if len(ref) else "-"
        p_this = f"{np.percentile(this, 50):.1f}" if len(this) else "-"
        ratio = f" ({np.percentile(this, 50) / np.percentile(ref, 50):.2f}x)" if len(ref) and len(this) else ""
        parts.append(
            f"{n} root{'s' if n > 1 else ''}: {len(ref) // rounds} / {len(this) // rounds} a round, p50 {p_ref} -> {p_this} ms{ratio}"
        )
    return "by the decisions' roots: " + "; ".join(parts)


def measure(
    root: Path, weights: str, decisions: int, inference: str = "torch", episodes: int = 0, method: str = "hybrid-4x4", batch: int = 16
) -> dict:
    env = dict(os.environ, PYTHONPATH=str(root), OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    args = (
        [EPISODES_CHILD, str(episodes), inference, weights, method, str(batch)]
        if episodes
        else [CHILD, str(decisions), json.dumps(SIZES), inference, weights]
    )
    proc = subprocess.run(
        [sys.executable, "-c", *args],
        cwd=root,
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    if proc.returncode != 0:
        raise SystemExit(f"the run in {root} failed:\n{proc.stderr[-3000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reference", required=True, help="a checkout of the code to compare against (e.g. a git worktree)")
    parser.add_argument("--decisions", type=int, default=24)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--inference", choices=["torch", "onnxruntime"], default="torch", help="this side's roll-out inference")
    parser.add_argument(
        "--episodes",
        type=int,
        default=0,
        help="instead: the wall time of this many held-out stage-2 episodes of --method (occrl eval's way) per side",
    )
    parser.add_argument(
        "--method",
        choices=[f"hybrid-{m}x{h}" for m, h in SIZES],
        default="hybrid-4x4",
        help="with --episodes: the planner whose episodes are timed (default hybrid-4x4)",
    )
    parser.add_argument(
        "--weights",
        default="occnet",
        help="the network both sides plan with: a weights file or a name shipped in this checkout (default occnet; "
        "occnet-warmstart for the figures measured before occrl 0.3.0, when it was the default)",
    )
    parser.add_argument(
        "--batch",
        type=int,
        default=16,
        help="with --episodes: worlds played together (16, as occrl eval); 1 plays each episode alone, so that "
        "the planner's noise for one world does not depend on how the other side treats another world's ended episode "
        "(a623dfe resets it, later checkouts leave it): the same episodes on both sides, for the same work",
    )
    parser.add_argument("--save", default=None, help="with --episodes: write every run's times, roots and episodes (JSON) here")
    args = parser.parse_args()
    if args.batch < 1:
        parser.error(f"--batch must be a number of worlds >= 1, got {args.batch}")
    if args.method != "hybrid-4x4" and not args.episodes:
        parser.error("--method applies with --episodes (the decision benchmark times 2x2, 4x4 and 6x6 together)")
    from occrl.pretrained import network_name, weights_file

    weights = str(Path(weights_file(args.weights)).resolve())
    if not Path(weights).is_file():
        raise SystemExit(f"--weights {args.weights!r} is neither a weights file nor a shipped network")
    print(f"network: {network_name(args.weights)} ({weights})", flush=True)
    here = Path(__file__).resolve().parent.parent
    ref = Path(args.reference).resolve()
    if not (ref / "occrl" / "__init__.py").is_file():
        raise SystemExit(f"--reference must be a checkout of occrl (no occrl/__init__.py under {ref})")
    runs: dict[str, list[dict]] = {"this": [], "reference": []}
    for r in range(args.rounds):
        for side, root in (("reference", ref), ("this", here)) if r % 2 == 0 else (("this", here), ("reference", ref)):
            runs[side].append(
                measure(
                    root, weights, args.decisions, args.inference if side == "this" else "torch", args.episodes, args.method, args.batch
                )
            )
            print(f"round {r + 1}/{args.rounds}: {side} done", flush=True)
    if args.episodes:
        wall = {side: np.array([run["wall"] for run in runs[side]]) for side in runs}
        same = sum(a == b for a, b in zip(runs["this"][0]["episodes"], runs["reference"][0]["episodes"]))
        t = {side: 1e3 * np.concatenate([run["decisions"] for run in runs[side]]) for side in runs}
        p = {side: (np.percentile(v, 50), np.percentile(v, 95)) for side, v in t.items()}
        print(
            f"\n{args.episodes} held-out stage-2 episodes of {args.method} in batches of {args.batch} x {args.rounds} rounds, one core per side; reference: {ref}; "
            f"this side's inference: {args.inference}\nwall per round: reference {', '.join(f'{w:.1f}' for w in wall['reference'])} s, "
            f"this {', '.join(f'{w:.1f}' for w in wall['this'])} s; ratio of the medians {np.median(wall['this']) / np.median(wall['reference']):.2f}x; "
            f"the same episodes (seed, success, actions) in {same}/{args.episodes}\n"
            f"their decisions (the planner's own time, as HybridPlanner.decisions records it; those of the episodes' own "
            f"steps, {len(t['reference']) // args.rounds} / {len(t['this']) // args.rounds} a round): p50 {p['reference'][0]:.1f} -> {p['this'][0]:.1f} ms "
            f"({p['this'][0] / p['reference'][0]:.2f}x), p95 {p['reference'][1]:.1f} -> {p['this'][1]:.1f} ms ({p['this'][1] / p['reference'][1]:.2f}x)\n"
            f"round by round: p50 {', '.join(f'{a:.2f}x' for a in round_ratios(runs, 50))}, p95 {', '.join(f'{a:.2f}x' for a in round_ratios(runs, 95))}"
        )
        print(by_roots(t, {side: np.concatenate([run["roots"] for run in runs[side]]) for side in runs}, args.rounds))
        alike, w = same_work(runs)
        if alike and all(len(r) for r in w["this"]):
            pooled = {side: np.concatenate(w[side]) for side in w}
            q = {side: (np.percentile(v, 50), np.percentile(v, 95)) for side, v in pooled.items()}
            rounds = [
                (np.percentile(a, 50) / np.percentile(b, 50), np.percentile(a, 95) / np.percentile(b, 95))
                for a, b in zip(w["this"], w["reference"])
            ]
            print(
                f"the same work (the {len(w['this'][0])} decisions a round of the {alike} episodes both sides played alike): "
                f"p50 {q['reference'][0]:.1f} -> {q['this'][0]:.1f} ms ({q['this'][0] / q['reference'][0]:.2f}x), "
                f"p95 {q['reference'][1]:.1f} -> {q['this'][1]:.1f} ms ({q['this'][1] / q['reference'][1]:.2f}x); "
                f"round by round: p50 {', '.join(f'{a:.2f}x' for a, _ in rounds)}, p95 {', '.join(f'{b:.2f}x' for _, b in rounds)}"
            )
            # each decision against itself (the percentiles of a mix of cheap one-root and dear
            # three-root decisions can fall between the two where each side's mix of ranks differs)
            each = np.concatenate([a / b for a, b in zip(w["this"], w["reference"])])
            lo, mid, hi = np.percentile(each, [5, 50, 95])
            print(
                f"  decision by decision (this / reference of each decision, every round): median {mid:.2f}x (5th-95th percentile {lo:.2f}-{hi:.2f}x)"
            )
        if args.save:
            Path(args.save).write_text(json.dumps(runs))
            print(f"every run's times written to {args.save}")
        first = {side: runs[side][0] for side in runs}
        counts = {side: f"{r['built']} / {r['rebuilt']}" if r.get("built") is not None else "not counted" for side, r in first.items()}
        print(f"roll-out worlds built / rebuilt (first round): reference {counts['reference']}, this {counts['this']}")
        return
    print(
        f"\n{args.decisions} decisions on stage-2 states x {args.rounds} rounds, one core per side; reference: {ref}; "
        f"this side's inference: {args.inference}"
    )
    print("| m x h | reference p50 / p95 (ms) | this p50 / p95 (ms) | ratio p50 | ratio p95 | same actions (to 1e-4) |")
    print("| --- | --- | --- | --- | --- | --- |")
    for m, h in SIZES:
        key = f"{m}x{h}"
        t = {side: 1e3 * np.concatenate([run[key]["times"] for run in runs[side]]) for side in runs}
        p = {side: (np.percentile(v, 50), np.percentile(v, 95)) for side, v in t.items()}
        same = sum(np.allclose(a, b, atol=1e-4) for a, b in zip(runs["this"][0][key]["actions"], runs["reference"][0][key]["actions"]))
        print(
            f"| {key} | {p['reference'][0]:.1f} / {p['reference'][1]:.1f} | {p['this'][0]:.1f} / {p['this'][1]:.1f} "
            f"| {p['this'][0] / p['reference'][0]:.2f}x | {p['this'][1] / p['reference'][1]:.2f}x | {same}/{args.decisions} |"
        )


if __name__ == "__main__":
    main()
