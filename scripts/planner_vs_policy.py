"""The hybrid 4x4 planner against its network's own sampled policy, over every network measured
on the same 200 held-out stage-2 tasks: does a better policy make a better planner?

    python scripts/planner_vs_policy.py                              # the table, from the committed results
    python scripts/planner_vs_policy.py --plot results/diagnosis/planner_vs_policy_s2.png

Each row pairs two `occrl eval --out` files of one network, as NETWORKS below lists them (the
pairing rests on that list: a file's "network" names the weights file it loaded, and the two
evaluations of one network were sometimes run from two copies of it under different paths): its
own policy (`occrl eval --method stochastic-gen --stage 2 --tasks 200 --workers 1 --weights W`)
and the paper's planner on it (`--method hybrid-4x4`). The summary fits a least-squares line of
the planner's success on the policy's and gives the planner's mean margin over its policy; the
plot draws each network with its 95 % intervals, the hierarchical OMPL planner's success on the
same tasks and the goals the study set (planner >= 85 %, own policy >= 75 %).

The evaluations that no page of the docs cites by name are kept together in ``EVALS_ARCHIVE``
(a gzipped JSON object: path -> the evaluation file as it was committed there; each one is
also ``git show 53b1240:PATH``); the others are read from the tree.
"""

from __future__ import annotations

import argparse
import functools
import gzip
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
HIERARCHICAL = "results/heldout-physics2/hierarchical_s2.json"
EVALS_ARCHIVE = "results/diagnosis/planner_vs_policy_s2_evals.json.gz"
GOAL_PLANNER, GOAL_POLICY = 0.85, 0.75


@dataclass(frozen=True)
class Network:
    """One network: what it is, and the two evaluations of it on the held-out stage-2 tasks."""

    label: str
    """The run and iteration (docs/lab/stage2.md names each run's command)."""
    own: str
    """`occrl eval --method stochastic-gen` on it: its own sampled policy."""
    planner: str
    """`occrl eval --method hybrid-4x4` on it."""


NETWORKS = [
    Network(
        "occnet-warmstart (DAgger warm start)",
        "results/retrieval-takeover/stochastic-gen_s2_occnet_reference.json",
        "results/heldout-physics2/hybrid-4x4_s2.json",
    ),
    Network(
        "occnet-takeover (takeover 75)",
        "results/retrieval-takeover/stochastic-gen_s2_iteration75.json",
        "results/retrieval-takeover/hybrid-4x4_s2_iteration75.json",
    ),
    Network(
        "takeover 123",
        "results/retrieval-takeover/stochastic-gen_s2_iteration123.json",
        "results/retrieval-takeover/hybrid-4x4_s2_iteration123.json",
    ),
    Network(
        "takeover, reused labels 50",
        "results/retrieval-takeover/reuse/stochastic-gen_s2_iteration50.json",
        "results/retrieval-takeover/reuse/hybrid-4x4_s2_iteration50.json",
    ),
    Network(
        "expert iteration 25",
        "results/curriculum/expert-iteration/it25_stochastic-gen_s2.json",
        "results/curriculum/expert-iteration/it25_hybrid-4x4_s2.json",
    ),
    Network(
        "expert iteration 98",
        "results/curriculum/expert-iteration/it98_stochastic-gen_s2.json",
        "results/curriculum/expert-iteration/it98_hybrid-4x4_s2.json",
    ),
    Network(
        "expert iteration 140",
        "results/curriculum/expert-iteration/it140_stochastic-gen_s2.json",
        "results/curriculum/expert-iteration/it140_hybrid-4x4_s2.json",
    ),
    Network(
        "PPO from expert iteration 250", "results/ppo-from-ei/w250_stochastic-gen_s2.json", "results/ppo-from-ei/w250_hybrid-4x4_s2.json"
    ),
    Network(
        "PPO from expert iteration 615", "results/ppo-from-ei/w615_stochastic-gen_s2.json", "results/ppo-from-ei/w615_hybrid-4x4_s2.json"
    ),
    Network(
        "clearing-observed teacher 50",
        "results/clearing-observed/teacher-frames/stochastic-gen_s2_iteration50.json",
        "results/clearing-observed/teacher-frames/hybrid-4x4_s2_iteration50.json",
    ),
    Network(
        "fine (128 px) 316",
        "results/fine/detail-lr3e-4/stochastic-gen_s2_iteration316.json",
        "results/fine/detail-lr3e-4/hybrid-4x4_s2_iteration316.json",
    ),
    Network(
        "PPO, 4x batch 54",
        "results/ppo-from-takeover/bigbatch/stochastic-gen_s2_iteration54.json",
        "results/ppo-from-takeover/bigbatch/hybrid-4x4_s2_iteration54.json",
    ),
    Network(
        "PPO, value off the trunk 75",
        "results/ppo-from-takeover/detached-critic/stochastic-gen_s2_iteration75.json",
        "results/ppo-from-takeover/detached-critic/hybrid-4x4_s2_iteration75.json",
    ),
    Network(
        "PPO, value off the trunk 175",
        "results/ppo-from-takeover/detached-critic/stochastic-gen_s2_iteration175.json",
        "results/ppo-from-takeover/detached-critic/hybrid-4x4_s2_iteration175.json",
    ),
    Network(
        "PPO, value off the trunk 225",
        "results/ppo-from-takeover/detached-critic/stochastic-gen_s2_iteration225.json",
        "results/ppo-from-takeover/detached-critic/hybrid-4x4_s2_iteration225.json",
    ),
    Network(
        "self-imitation, imitation only 60",
        "results/success-labels/self-imitation-bc-only/stochastic-gen_s2_iteration60.json",
        "results/success-labels/self-imitation-bc-only/hybrid-4x4_s2_iteration60.json",
    ),
    Network(
        "self-imitation, value off the trunk 40",
        "results/success-labels/self-imitation-detached-critic/stochastic-gen_s2_iteration40.json",
        "results/success-labels/self-imitation-detached-critic/hybrid-4x4_s2_iteration40.json",
    ),
    Network(
        "takeover, successes only 50",
        "results/success-labels/takeover/stochastic-gen_s2_iteration50.json",
        "results/success-labels/takeover/hybrid-4x4_s2_iteration50.json",
    ),
    Network(
        "mixture of 4, converted from occnet-takeover",
        "results/mixture-hier-inside/stochastic-gen_s2_200tasks_start.json",
        "results/mixture-hier-inside/hybrid-4x4_s2_start.json",
    ),
    Network(
        "wide (4x the parameters), self-imitation 100",
        "results/wide/self-imitation-bc-only/stochastic-gen_s2_iteration100.json",
        "results/wide/self-imitation-bc-only/hybrid-4x4_s2_iteration100.json",
    ),
    Network(
        "clearing-observed successes, imitation loss alone, beta 1, 75",
        "results/clearing-observed/imitation-only/successes-beta1/stochastic-gen_s2_iteration75.json",
        "results/clearing-observed/imitation-only/successes-beta1/hybrid-4x4_s2_iteration75.json",
    ),
    Network(
        "offline imitation of clearing-observed, 4,000 steps",
        "results/offline-imitation/fit-lr1e-4/stochastic-gen_s2_step4000.json",
        "results/offline-imitation/fit-lr1e-4/hybrid-4x4_s2_step4000.json",
    ),
    Network(
        "offline imitation, disturbed demonstrations (DART 0.1), 4,000 steps",
        "results/offline-imitation/fit-dart010-lr1e-4/stochastic-gen_s2_step4000.json",
        "results/offline-imitation/fit-dart010-lr1e-4/hybrid-4x4_s2_step4000.json",
    ),
    Network(
        "offline imitation, disturbed demonstrations (DART 0.1), 8,000 steps",
        "results/offline-imitation/fit-dart010-lr1e-4/stochastic-gen_s2_step8000.json",
        "results/offline-imitation/fit-dart010-lr1e-4/hybrid-4x4_s2_step8000.json",
    ),
    Network(
        "offline imitation, hierarchical search + DART 0.05, 2,606 demonstrations, 3,000 steps",
        "results/offline-imitation/fit-dart005-more/stochastic-gen_s2_step3000.json",
        "results/offline-imitation/fit-dart005-more/hybrid-4x4_s2_step3000.json",
    ),
    Network(
        "that network + self-imitation of its successes, 80",
        "results/offline-imitation/selfimit-from-fit3k/stochastic-gen_s2_iteration80.json",
        "results/offline-imitation/selfimit-from-fit3k/hybrid-4x4_s2_iteration80.json",
    ),
]


# One network evaluated again with its own randomness drawn anew (`occrl eval ... --replicate N`):
# the spread of a result that no change of network can be told from.
REPLICATES = {
    "occnet-takeover": (
        [
            "results/retrieval-takeover/stochastic-gen_s2_iteration75.json",
            "results/diagnosis/replicates/stochastic-gen_s2_takeover_replicate1.json",
            "results/diagnosis/replicates/stochastic-gen_s2_takeover_replicate2.json",
        ],
        [
            "results/retrieval-takeover/hybrid-4x4_s2_iteration75.json",
            "results/diagnosis/replicates/hybrid-4x4_s2_takeover_replicate1.json",
            "results/diagnosis/replicates/hybrid-4x4_s2_takeover_replicate2.json",
        ],
    ),
    "self-imitation from the offline fit, 80": (
        [
            "results/offline-imitation/selfimit-from-fit3k/stochastic-gen_s2_iteration80.json",
            "results/offline-imitation/selfimit-from-fit3k/stochastic-gen_s2_iteration80_replicate1.json",
        ],
        [
            "results/offline-imitation/selfimit-from-fit3k/hybrid-4x4_s2_iteration80.json",
            "results/offline-imitation/selfimit-from-fit3k/hybrid-4x4_s2_iteration80_replicate1.json",
            "results/offline-imitation/selfimit-from-fit3k/hybrid-4x4_s2_iteration80_replicate2.json",
        ],
    ),
    "PPO, value off the trunk 225": (
        [
            "results/ppo-from-takeover/detached-critic/stochastic-gen_s2_iteration225.json",
            "results/diagnosis/replicates/stochastic-gen_s2_ppo-detached225_replicate1.json",
        ],
        [
            "results/ppo-from-takeover/detached-critic/hybrid-4x4_s2_iteration225.json",
            "results/diagnosis/replicates/hybrid-4x4_s2_ppo-detached225_replicate1.json",
        ],
    ),
}


def solved(d: dict) -> np.ndarray:
    """The tasks' outcomes in seed order."""
    return np.array([bool(e["success"]) for e in sorted(d["episodes"], key=lambda e: e["seed"])])


def agreement(runs: list[dict]) -> float:
    """The mean share of tasks on which two of the runs had the same outcome, over every pair."""
    outcomes = [solved(d) for d in runs]
    same = [(a == b).mean() for i, a in enumerate(outcomes) for b in outcomes[i + 1 :]]
    return float(np.mean(same))


def replicates(label: str) -> tuple[list[dict], list[dict]]:
    """The own policy's and the planner's evaluations of one network's replicates."""
    own, planner = REPLICATES[label]
    return [load(f, "stochastic-gen", i) for i, f in enumerate(own)], [load(f, "hybrid-4x4", i) for i, f in enumerate(planner)]


def load(path: str | Path, method: str, replicate: int = 0) -> dict:
    """An evaluation file, checked to be ``method`` as the paper runs it (no roll-out spread floor,
    torch inference) on the 200 held-out stage-2 tasks at noise 0, in replicate ``replicate``."""
    d = json.loads((REPO / path).read_text()) if (REPO / path).exists() else archived_evaluations()[str(path)]
    where = (
        d["method"],
        d["stage"],
        d.get("objects"),
        d["noise"],
        d["tasks"],
        d["first_seed"],
        d.get("world", "pymunk"),
        d.get("rollout_min_scale", 0.0),
        d.get("inference", "torch"),
        d.get("replicate", 0),
    )
    if where != (method, 2, None, 0.0, 200, 10_000_000, "pymunk", 0.0, "torch", replicate):
        raise ValueError(
            f"{path}: expected {method} on the 200 held-out stage-2 tasks (objects of the stage, noise 0, pymunk, "
            f"no roll-out spread floor, torch inference, replicate {replicate}), got {where}"
        )
    return d


@functools.cache
def archived_evaluations() -> dict[str, dict]:
    """The evaluation files kept in ``EVALS_ARCHIVE``, by the path they were committed at."""
    return json.loads(gzip.decompress((REPO / EVALS_ARCHIVE).read_bytes()))


def pairs(networks: list[Network] = NETWORKS) -> list[tuple[Network, dict, dict]]:
    """Each network with its own policy's and its planner's evaluation."""
    return [(n, load(n.own, "stochastic-gen"), load(n.planner, "hybrid-4x4")) for n in networks]


def summary(rows: list[tuple[Network, dict, dict]]) -> dict:
    """Least-squares line planner = slope * policy + intercept, correlation, margins, ranges."""
    x = np.array([own["success_rate"] for _, own, _ in rows])
    y = np.array([planner["success_rate"] for _, _, planner in rows])
    slope, intercept = np.polyfit(x, y, 1)
    margin = y - x
    return {
        "networks": len(rows),
        "policy_range": (float(x.min()), float(x.max())),
        "planner_range": (float(y.min()), float(y.max())),
        "slope": float(slope),
        "intercept": float(intercept),
        "correlation": float(np.corrcoef(x, y)[0, 1]),
        "mean_margin": float(margin.mean()),
        "margin_range": (float(margin.min()), float(margin.max())),
        # the policy the fitted line would need for the planner goal (None: the line does not rise)
        "policy_for_planner_goal": float((GOAL_PLANNER - intercept) / slope) if slope > 0 else None,
    }


def by_target_position(rows: list[tuple[Network, dict, dict]]) -> str:
    """Solve rates (averaged over the networks) by quartile of the target's depth and of its
    distance from the shelf's centre line, against the hierarchical planner's on the same tasks."""
    from occrl.envs.episodes import task_scenes

    seeds = [e["seed"] for e in sorted(rows[0][2]["episodes"], key=lambda e: e["seed"])]
    scenes = task_scenes(2, seeds)
    depth = np.array([s.target.pose[1] for s in scenes])
    side = np.abs([s.target.pose[0] for s in scenes])
    planner = np.array([solved(p) for _, _, p in rows]).mean(0)
    own = np.array([solved(o) for _, o, _ in rows]).mean(0)
    hierarchical = solved(load(HIERARCHICAL, "hierarchical"))
    lines = [
        "| target position (quartile of the 200 tasks) | tasks | hybrid 4x4 | own policy | hierarchical |",
        "| --- | --- | --- | --- | --- |",
    ]
    for name, value in (("depth y", depth), ("distance from the centre line, abs(x),", side)):
        quartile = np.digitize(value, np.quantile(value, [0.25, 0.5, 0.75]))
        for q in range(4):
            m = quartile == q
            lines.append(
                f"| {name} {value[m].min():.3f}-{value[m].max():.3f} m | {m.sum()} | {planner[m].mean():.0%} | {own[m].mean():.0%} | "
                f"{hierarchical[m].mean():.0%} |"
            )
    return "\n".join(lines) + "\n"


def table(rows: list[tuple[Network, dict, dict]]) -> str:
    lines = ["| network (run, iteration) | own policy (95 % CI) | hybrid 4x4 (95 % CI) | margin |", "| --- | --- | --- | --- |"]
    for n, own, planner in sorted(rows, key=lambda r: r[1]["success_rate"]):
        cells = [f"{d['success_rate']:.1%} ({d['success_ci95'][0]:.1%}-{d['success_ci95'][1]:.1%})" for d in (own, planner)]
        lines.append(f"| {n.label} | {cells[0]} | {cells[1]} | {100 * (planner['success_rate'] - own['success_rate']):+.1f} |")
    s = summary(rows)
    need = s["policy_for_planner_goal"]
    need = "more than 100 %" if need is None or need > 1 else f"{need:.0%}"
    lines += [
        "",
        f"{s['networks']} networks: own policy {s['policy_range'][0]:.1%}-{s['policy_range'][1]:.1%}, "
        f"planner {s['planner_range'][0]:.1%}-{s['planner_range'][1]:.1%}; least squares: planner = "
        f"{s['slope']:.2f} x policy + {s['intercept']:.1%} (correlation {s['correlation']:.2f}); the planner's margin "
        f"over its policy {100 * s['mean_margin']:+.1f} points on average ({100 * s['margin_range'][0]:+.1f} to "
        f"{100 * s['margin_range'][1]:+.1f}); on that line the planner goal ({GOAL_PLANNER:.0%}) needs an own policy of {need}.",
    ]
    t = task_structure(rows)
    lines += [
        "",
        f"Per task, over the {t['networks']} networks: the planner solved {t['planner_all']} tasks on every network, "
        f"{t['planner_none']} on none (of these the own policy solved {t['none_by_own']} on any network, the hierarchical "
        f"planner {t['none_by_hierarchical']}), the other {t['planner_some']} on {t['some_rate']:.0%} of the networks on "
        f"average; the own policy solved {t['own_all']} on every network and {t['own_none']} on none. Correlation of a "
        f"task's planner and own-policy solve rates over the networks: {t['task_correlation']:.2f}.",
        "",
        f"Two networks' planners agree on {t['planner_agreement']:.1%} of the tasks on average, their own policies on "
        f"{t['own_agreement']:.1%}.",
    ]
    for label in REPLICATES:
        own, planner = replicates(label)
        lines.append(
            f"{label} run {len(planner)} times with its randomness drawn anew (replicates 0-{len(planner) - 1}): planner "
            + " / ".join(f"{d['success_rate']:.1%}" for d in planner)
            + f", agreeing on {agreement(planner):.1%} of the tasks; own policy "
            + " / ".join(f"{d['success_rate']:.1%}" for d in own)
            + f", agreeing on {agreement(own):.1%}."
        )
    return "\n".join(lines) + "\n"


def task_structure(rows: list[tuple[Network, dict, dict]]) -> dict:
    """Which tasks the planner (and the own policy) solves on every network, on none, on some."""
    own = np.array([solved(o) for _, o, _ in rows]).mean(0)
    planner = np.array([solved(p) for _, _, p in rows]).mean(0)
    hierarchical = solved(load(HIERARCHICAL, "hierarchical"))
    none, some = planner == 0, (planner > 0) & (planner < 1)
    return {
        "networks": len(rows),
        "planner_all": int((planner == 1).sum()),
        "planner_none": int(none.sum()),
        "planner_some": int(some.sum()),
        "some_rate": float(planner[some].mean()),
        "none_by_own": int((own[none] > 0).sum()),
        "none_by_hierarchical": int(hierarchical[none].sum()),
        "own_all": int((own == 1).sum()),
        "own_none": int((own == 0).sum()),
        "task_correlation": float(np.corrcoef(planner, own)[0, 1]),
        "planner_agreement": agreement([p for _, _, p in rows]),
        "own_agreement": agreement([o for _, o, _ in rows]),
    }


def plot(rows: list[tuple[Network, dict, dict]], out: Path) -> None:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.4, 5.2))
    ax = fig.add_subplot()
    for _, own, planner in rows:
        x, y = 100 * own["success_rate"], 100 * planner["success_rate"]
        (xlo, xhi), (ylo, yhi) = (np.array(own["success_ci95"]) * 100), (np.array(planner["success_ci95"]) * 100)
        ax.errorbar(x, y, xerr=[[x - xlo], [xhi - x]], yerr=[[y - ylo], [yhi - y]], fmt="o", color="tab:blue", ms=4, lw=0.6, alpha=0.8)
    for label, colour in zip(REPLICATES, ["tab:orange", "tab:purple", "tab:brown", "tab:olive"]):
        own, planner = replicates(label)
        pairs = min(len(own), len(planner))  # replicate i of both (a network may have more of one)
        xs_, ys_ = [100 * d["success_rate"] for d in own[:pairs]], [100 * d["success_rate"] for d in planner[:pairs]]
        ax.plot(
            xs_,
            ys_,
            "s",
            color=colour,
            ms=5,
            mfc="none",
            label=f"{label}, replicates 0-{pairs - 1} (own policy i with planner i)",
        )
    s = summary(rows)
    xs = np.linspace(30, 100, 2)
    ax.plot(xs, 100 * (s["slope"] * xs / 100 + s["intercept"]), color="tab:blue", lw=1, label=f"least squares, slope {s['slope']:.2f}")
    ax.plot(xs, xs, color="grey", lw=0.8, ls=":", label="planner = its policy")
    hierarchical = load(HIERARCHICAL, "hierarchical")
    ax.axhline(
        100 * hierarchical["success_rate"], color="tab:red", lw=1, ls="--", label=f"hierarchical (OMPL) {hierarchical['success_rate']:.1%}"
    )
    ax.axhline(100 * GOAL_PLANNER, color="tab:green", lw=1, label=f"goal: planner >= {GOAL_PLANNER:.0%}")
    ax.axvline(100 * GOAL_POLICY, color="tab:green", lw=1, ls="-.", label=f"goal: own policy >= {GOAL_POLICY:.0%}")
    ax.set(
        xlim=(30, 100), ylim=(30, 100), xlabel="network's own sampled policy, stage 2 (%)", ylabel="hybrid 4x4 on that network, stage 2 (%)"
    )
    ax.set_title(f"{len(rows)} networks, 200 held-out stage-2 tasks each", fontsize=10)
    ax.legend(fontsize=8, loc="lower right")
    ax.grid(alpha=0.3)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110, bbox_inches="tight")


def main(argv: list[str] | None = None) -> str:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--plot", type=Path, help="also draw the networks, the fitted line and the goals to this PNG")
    args = parser.parse_args(argv)
    rows = pairs()
    text = table(rows) + "\nBy the target's position (hybrid 4x4 and own policy averaged over the networks):\n\n" + by_target_position(rows)
    print(text, end="")
    if args.plot:
        plot(rows, args.plot)
        print(f"plot: {args.plot}")
    return text


if __name__ == "__main__":
    main()
