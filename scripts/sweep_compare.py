"""Two sweep folders compared point by point on the same tasks: what changed between them for a method.

Usage:
    python scripts/sweep_compare.py SWEEP_NOISE0 SWEEP_NOISE015 --method hybrid-4x4
    python scripts/sweep_compare.py A B --method hierarchical --sweep clutter --groups 1-5,6-10

For every point (sweep, value) both folders hold for ``--method``, the tasks only A solved, only
B solved, and the exact McNemar p-value; then the same pooled over each group of values
(``--groups``, e.g. the clutter sweep's 1-5 and 6-10 objects). A point's tasks are matched by seed.
Typical use: the clutter sweep at noise 0 (A) against the same sweep at noise 0.15 (B), to see
what a model gap costs a method at each clutter level.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from occrl.eval.runner import mcnemar_p
from occrl.eval.sweep_store import point_episodes, sweep_points


def method_points(folder: Path, method: str, sweep: str) -> dict[float, dict[int, bool]]:
    """{value: {seed: success}} of ``method``'s points on ``sweep`` in a sweep folder."""
    return {float(p["value"]): {seed: e.success for seed, e in point_episodes(p).items()} for p in sweep_points(folder, method, sweep)}


def parse_groups(text: str) -> list[tuple[float, float]]:
    groups = []
    for part in filter(None, (p.strip() for p in text.split(","))):
        low, _, high = part.partition("-")
        try:
            groups.append((float(low), float(high or low)))
        except ValueError:
            raise SystemExit(f"--groups takes ranges such as 1-5,6-10; got {part!r}") from None
    return groups


def compare(a: dict[float, dict[int, bool]], b: dict[float, dict[int, bool]], groups: list[tuple[float, float]]) -> str:
    values = sorted(a.keys() & b.keys())
    if not values:
        raise SystemExit("the two folders hold no common point for this method and sweep")
    counts = {}
    lines = ["| point | tasks | solved A / B | only A / only B | McNemar p |", "| --- | --- | --- | --- | --- |"]
    for v in values:
        seeds = a[v].keys() & b[v].keys()
        only_a = sum(a[v][s] and not b[v][s] for s in seeds)
        only_b = sum(b[v][s] and not a[v][s] for s in seeds)
        solved = (sum(a[v][s] for s in seeds), sum(b[v][s] for s in seeds))
        counts[v] = (len(seeds), solved, only_a, only_b)
        lines.append(f"| {v:g} | {len(seeds)} | {solved[0]} / {solved[1]} | {only_a} / {only_b} | {mcnemar_p(only_a, only_b):.2g} |")
    for low, high in groups:
        inside = [counts[v] for v in values if low <= v <= high]
        if not inside:
            continue
        n = sum(c[0] for c in inside)
        sa, sb = sum(c[1][0] for c in inside), sum(c[1][1] for c in inside)
        oa, ob = sum(c[2] for c in inside), sum(c[3] for c in inside)
        lines.append(f"| {low:g}-{high:g} | {n} | {sa} / {sb} | {oa} / {ob} | {mcnemar_p(oa, ob):.2g} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("a", type=Path, help="sweep folder A (as occrl eval --sweep --out wrote it)")
    parser.add_argument("b", type=Path, help="sweep folder B")
    parser.add_argument("--method", required=True, help="method name, as in the points' file names")
    parser.add_argument("--sweep", default="clutter", choices=["clutter", "noise"])
    parser.add_argument("--groups", default="1-5,6-10", help="value ranges to pool, e.g. 1-5,6-10 ('' for none)")
    args = parser.parse_args()
    for folder in (args.a, args.b):
        if not sweep_points(folder):
            parser.error(
                f"{folder} holds no sweep points (points.json.gz or points/): give the folder a sweep wrote (occrl eval --sweep --out)"
            )
    print(f"{args.method}, {args.sweep} sweep: A = {args.a}, B = {args.b}\n")
    print(
        compare(method_points(args.a, args.method, args.sweep), method_points(args.b, args.method, args.sweep), parse_groups(args.groups))
    )


if __name__ == "__main__":
    main()
