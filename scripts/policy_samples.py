"""Does the hybrid planner solve the tasks its network's own policy never solves?

    python scripts/policy_samples.py --policy P0.json P1.json ... --planner H0.json [H1.json ...] \\
        [--other stochastic=S0.json,S1.json ...] [--out F.json]

The paper's planner (Alg. 1-2) chooses among roll-outs of its network's sampled policy, so what it
can add over the policy depends on how the policy's outcomes vary with its own randomness. Each
P is one replicate of the policy on the same tasks (`occrl eval --method stochastic-gen --stage S
--tasks N --workers 1 --replicate R --out P_R.json`: the same shelves and execution noise, the
policy's draws from another seed); each H an evaluation of the planner on those tasks (`occrl eval
--method hybrid-4x4 ...`, replicates allowed); each ``--other`` a labelled list of more such files
(another policy's replicates, the hierarchical planner).

It prints, with the tasks grouped by how many of the K policy replicates solved them (0 of K ...
K of K), the tasks in each group and every method's success on them (the mean over its
replicates); and the share of tasks that at least one of k policy replicates solves (k = 1..K,
the exact mean over all k-subsets: a task solved by c of K counts 1 - C(K-c, k) / C(K, k)) beside
the planner's success: how many whole episodes of its policy, an oracle picking the right one per
task, the planner's choices are worth. A diagnosis for issues 16 and 21 (docs/experiments.md,
*Why the planner no longer leads the policies*); it reads result files only.
"""

from __future__ import annotations

import argparse
import json
from math import comb
from pathlib import Path

KEYS = ("stage", "noise", "objects", "world", "first_seed")


def load(path: str) -> tuple[dict, dict[int, bool]]:
    """A result file's settings (:data:`KEYS`) and its outcome per task seed."""
    d = json.loads(Path(path).read_text())
    settings = {key: d.get(key, "pymunk" if key == "world" else None) for key in KEYS}
    return settings, {int(e["seed"]): bool(e["success"]) for e in d["episodes"]}


def load_group(paths: list[str], settings: dict | None = None) -> tuple[dict, list[dict[int, bool]]]:
    """The outcomes of several result files of the same tasks; ``ValueError`` if their settings
    (stage, noise, objects, world, first seed) or their task seeds differ."""
    runs = []
    for path in paths:
        s, outcomes = load(path)
        if settings is None:
            settings = s
        elif s != settings:
            raise ValueError(f"{path}: its settings {s} differ from the first file's {settings}: compare runs of the same tasks")
        if runs and set(outcomes) != set(runs[0]):
            raise ValueError(f"{path}: its task seeds differ from the first file's: compare runs of the same tasks")
        runs.append(outcomes)
    return settings, runs


def union_curve(counts: list[int], replicates: int) -> list[float]:
    """Share of tasks solved by at least one of k replicates, k = 1..K, the exact mean over all
    k-subsets of the K replicates; ``counts``: how many of the K solved each task.

    Examples:
        >>> union_curve([0, 1, 2], 2)  # solved by none, one and both of two replicates
        [0.5, 0.6666666666666666]
    """
    return [sum(1 - comb(replicates - c, k) / comb(replicates, k) for c in counts) / len(counts) for k in range(1, replicates + 1)]


def samples_worth(curve: list[float], success: float) -> float | None:
    """The k (interpolated on the union curve; 1 for success at or below one replicate's) at which
    the curve reaches ``success``; None where the planner is above even K replicates together."""
    if success <= curve[0]:
        return 1.0
    for k in range(1, len(curve)):
        if curve[k] >= success:
            return k + (success - curve[k - 1]) / (curve[k] - curve[k - 1]) if curve[k] > curve[k - 1] else float(k + 1)
    return None


def analyse(policy: list[dict[int, bool]], methods: dict[str, list[dict[int, bool]]]) -> dict:
    """Per group of tasks (how many policy replicates solved them): tasks and each method's mean
    success; the union curve; the planner-like methods' worth in policy samples."""
    seeds = sorted(policy[0])
    K = len(policy)
    counts = {s: sum(run[s] for run in policy) for s in seeds}
    groups = []
    for c in range(K + 1):
        members = [s for s in seeds if counts[s] == c]
        row = {"solved_by": c, "tasks": len(members)}
        for name, runs in methods.items():
            row[name] = sum(run[s] for run in runs for s in members) / (len(runs) * len(members)) if members else None
        groups.append(row)
    curve = union_curve(list(counts.values()), K)
    success = {name: sum(sum(run.values()) for run in runs) / (len(runs) * len(seeds)) for name, runs in methods.items()}
    return {
        "replicates": K,
        "tasks": len(seeds),
        "policy_success": sum(counts.values()) / (K * len(seeds)),
        "groups": groups,
        "union_curve": curve,
        "success": success,
        "worth_in_samples": {name: samples_worth(curve, rate) for name, rate in success.items()},
    }


def report(result: dict, names: list[str]) -> str:
    K, n = result["replicates"], result["tasks"]
    lines = [
        f"{n} tasks, {K} replicates of the policy (mean success {100 * result['policy_success']:.1f} %)",
        "",
        "| policy replicates that solved the task | tasks | " + " | ".join(names) + " |",
        "| --- | --- | " + " | ".join("---" for _ in names) + " |",
    ]
    for row in result["groups"]:
        cells = ["-" if row[name] is None else f"{100 * row[name]:.1f} %" for name in names]
        lines.append(f"| {row['solved_by']} of {K} | {row['tasks']} | " + " | ".join(cells) + " |")
    lines += ["", "| k policy replicates, any solved | " + " | ".join(str(k) for k in range(1, K + 1)) + " |"]
    lines += ["| --- | " + " | ".join("---" for _ in range(K)) + " |"]
    lines += ["| tasks solved | " + " | ".join(f"{100 * u:.1f} %" for u in result["union_curve"]) + " |", ""]
    for name in names:
        worth = result["worth_in_samples"][name]
        said = (
            f"above all {K} together"
            if worth is None
            else f"as many tasks as {worth:.1f} of the policy's episodes, the right one picked per task"
        )
        lines.append(f"{name}: {100 * result['success'][name]:.1f} % of the tasks; {said}")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--policy", nargs="+", required=True, help="replicates of the network's sampled policy on the same tasks")
    parser.add_argument("--planner", nargs="+", required=True, help="the hybrid planner on the same tasks (one file per replicate)")
    parser.add_argument("--other", nargs="*", default=[], help="LABEL=F0.json,F1.json,...: more methods on the same tasks")
    parser.add_argument("--out", default=None, help="write the numbers as JSON")
    args = parser.parse_args()
    try:
        settings, policy = load_group(args.policy)
        methods = {"planner": load_group(args.planner, settings)[1]}
        for item in args.other:
            label, sep, files = item.partition("=")
            if not sep or not label or not files:
                parser.error(f"--other takes LABEL=F0.json,F1.json,..., got {item!r}")
            methods[label] = load_group(files.split(","), settings)[1]
        for name, runs in methods.items():
            if set(runs[0]) != set(policy[0]):
                raise ValueError(f"{name}: its task seeds differ from the policy's: compare runs of the same tasks")
    except ValueError as error:
        parser.error(str(error))
    methods = {"policy": policy, **methods}
    result = analyse(policy, methods)
    print(f"stage {settings['stage']}, noise {settings['noise']}")
    print(report(result, list(methods)))
    if args.out:
        Path(args.out).write_text(json.dumps({"settings": settings, **result}, indent=1))


if __name__ == "__main__":
    main()
