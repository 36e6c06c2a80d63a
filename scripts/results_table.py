"""Markdown tables of `occrl eval --out` JSON files.

    python scripts/results_table.py results/heldout/*.json          # one row per file
    python scripts/results_table.py --grid results/heldout/*.json   # methods x (stage, noise), as in docs/lab/study.md
    python scripts/results_table.py --compare A.json B.json         # the same episodes; exclusive wins, McNemar p

``--compare`` matches two runs' tasks by seed: how many episodes are the same (outcome, drop,
length), the tasks only one of them solved and the exact McNemar p-value of the difference.
The row table gives success with its 95 % interval, drops, actions and time per task; the grid
gives success (95 % interval, drops) per method and stage at noise 0 and 0.15, for the 2D world
with each stage's own object counts.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from occrl.eval.runner import exclusive_wins, mcnemar_p

GRID_METHODS = ["hybrid-4x4", "hybrid-2x2", "hybrid-6x6", "hybrid-lim-4x4", "stochastic-gen", "stochastic", "greedy", "scripted"]
GRID_COLUMNS = [(1, 0.0), (2, 0.0), (3, 0.0), (1, 0.15), (2, 0.15), (3, 0.15)]


def row(d: dict) -> str:
    lo, hi = d["success_ci95"]
    seen = ", ".join(str(d[k]) for k in ("perception", "tag_layout") if d.get(k))
    where = f"{d.get('world', 'pymunk')}" + (f" ({seen})" if seen else "")
    where += f", shelf {d['shelf_height']} m" if d.get("shelf_height") else ""
    where += f", stage {d['stage']}" + (f", objects {d['objects']}" if d.get("objects") else "")
    return (
        f"| {d['method']} | {Path(str(d['network'])).name if d['network'] else '-'} | {where} | noise {d['noise']} | {d['tasks']} | "
        f"{d['success_rate']:.1%} ({lo:.1%}-{hi:.1%}) | {d['dropped']} | {d['mean_actions']:.1f} | {d['mean_seconds']:.2f} s |"
    )


def rows_table(results: list[dict]) -> str:
    lines = [
        "| method | network | tasks from | noise | tasks | success (95 % CI) | dropped | actions | time per task |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    return "\n".join(lines + [row(d) for d in results]) + "\n"


def grid_table(results: list[dict]) -> str:
    """Methods x (stage, noise) on the shipped networks (a method run with --weights is left out)."""
    cells: dict[str, dict] = {}
    for d in results:
        if d.get("world", "pymunk") != "pymunk" or d.get("objects") or str(d["network"]).endswith(".pt"):
            continue
        cells.setdefault(d["method"], {})[(d["stage"], d["noise"])] = d
    lines = [
        "| method | " + " | ".join(f"stage {s}, noise {n:g}" for s, n in GRID_COLUMNS) + " |",
        "| --- |" + " --- |" * len(GRID_COLUMNS),
    ]
    for m in GRID_METHODS:
        out = []
        for c in GRID_COLUMNS:
            d = cells.get(m, {}).get(c)
            if d is None:
                out.append("not run")
                continue
            lo, hi = d["success_ci95"]
            out.append(
                f"{d['success_rate'] * 100:.1f} % ({lo * 100:.1f}-{hi * 100:.1f})" + (f", {d['dropped']} dropped" if d["dropped"] else "")
            )
        lines.append(f"| {m} | " + " | ".join(out) + " |")
    return "\n".join(lines) + "\n"


def same_episodes(a: dict, b: dict) -> int:
    """Tasks (matched by seed) whose episodes have the same success, drop and number of actions."""
    other = {e["seed"]: e for e in b["episodes"]}
    keys = ("success", "dropped", "actions")
    return sum(all(e[k] == other[e["seed"]][k] for k in keys) for e in a["episodes"] if e["seed"] in other)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grid", action="store_true", help="methods x (stage, noise) instead of one row per file")
    parser.add_argument("--compare", action="store_true", help="two files: the same episodes, exclusive wins, McNemar p")
    parser.add_argument("files", nargs="+")
    args = parser.parse_args()
    results = [json.loads(Path(f).read_text()) for f in args.files]
    if args.compare:
        if len(results) != 2:
            parser.error("--compare takes exactly two files")
        a, b = results
        print(f"{same_episodes(a, b)} of {len(a['episodes'])} episodes the same")
        tasks, only_a, only_b = exclusive_wins(a["episodes"], b["episodes"])
        common = {e["seed"] for e in a["episodes"]} & {e["seed"] for e in b["episodes"]}
        solved = [sum(e["success"] for e in d["episodes"] if e["seed"] in common) for d in (a, b)]
        print(
            f"{tasks} tasks in both: solved {solved[0]} / {solved[1]}; only by the first {only_a}, only by the second {only_b}; "
            f"exact McNemar p = {mcnemar_p(only_a, only_b):.3f}"
        )
        return
    print(grid_table(results) if args.grid else rows_table(results), end="")


if __name__ == "__main__":
    main()
