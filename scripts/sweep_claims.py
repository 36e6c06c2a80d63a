"""Check the papers' simulation claims against a sweep's results (docs/experiments.md, the papers' simulation study).

Usage:
    python scripts/sweep_claims.py results/sweep/results.json            # the claims
    python scripts/sweep_claims.py results/sweep/results.json --tables   # plus success per method and point

Reads the rows written by ``occrl eval --sweep`` (``summarize_sweep``) and prints, per claim of
the papers (Sec. VI-C), the figures that test it and whether this sweep agrees. "Clearly" means
the 95 % intervals do not overlap; points are compared only where both methods were run.
"""

from __future__ import annotations

import argparse
import json
from collections import defaultdict

import numpy as np

BASELINES = ["greedy", "stochastic", "stochastic-gen", "hierarchical"]


def load(path: str) -> dict:
    rows = json.loads(open(path).read())
    table: dict = defaultdict(dict)
    for r in rows:
        table[(r["sweep"], r["method"])][r["value"]] = r
    return table


def pct(x: float) -> str:
    return f"{100 * x:.1f} %"


def common_means(table, methods) -> dict | None:
    """Mean success of each method over the (sweep, value) points all of them were run on."""
    common = None
    for m in methods:
        pts = {(sweep, v) for sweep in ("clutter", "noise") for v in table.get((sweep, m), {})}
        common = pts if common is None else common & pts
    if not common:
        return None
    return {m: float(np.mean([table[(sweep, m)][v]["success_rate"] for sweep, v in common])) for m in methods}


def slope(table, sweep, method) -> float | None:
    pts = table.get((sweep, method), {})
    if len(pts) < 2:
        return None
    x = np.array(sorted(pts))
    y = np.array([pts[v]["success_rate"] for v in x])
    span = x.max() - x.min()
    return float(np.polyfit((x - x.min()) / span, y, 1)[0])  # change in success over the whole axis


def claims(table) -> list[tuple[str, str, str]]:
    out = []
    # 1. hybrid beats every baseline
    wins = ties = losses = clear = clearly_lower = total = 0
    for sweep in ("clutter", "noise"):
        hyb = table.get((sweep, "hybrid-4x4"), {})
        for base in BASELINES:
            for value, b in table.get((sweep, base), {}).items():
                if value not in hyb:
                    continue
                h = hyb[value]
                total += 1
                wins += h["success_rate"] > b["success_rate"]
                ties += h["success_rate"] == b["success_rate"]
                losses += h["success_rate"] < b["success_rate"]
                clear += h["ci95_low"] > b["ci95_high"]
                clearly_lower += h["ci95_high"] < b["ci95_low"]
    if losses == 0:
        verdict = "agrees"
    elif clearly_lower == 0:
        verdict = "agrees within the intervals (no baseline clearly higher anywhere)"
    else:
        verdict = f"disagrees ({clearly_lower} pair{'s' if clearly_lower != 1 else ''} clearly lower)"
    out.append(
        (
            "hybrid (4x4) beats every baseline",
            f"{wins} of {total} (point, baseline) pairs higher, {ties} equal, {losses} lower; {clear} clearly higher",
            verdict if total else "not run",
        )
    )
    # 2. larger m x h helps
    means = common_means(table, ("hybrid-2x2", "hybrid-4x4", "hybrid-6x6"))
    if means:
        order = means["hybrid-2x2"] <= means["hybrid-4x4"] <= means["hybrid-6x6"]
        out.append(
            (
                "larger m x h helps",
                ", ".join(f"{m} {pct(v)}" for m, v in means.items()) + " (mean over the points all three ran)",
                "agrees" if order else ("partly" if means["hybrid-2x2"] <= max(means["hybrid-4x4"], means["hybrid-6x6"]) else "disagrees"),
            )
        )
    # 3. hybrid-lim slightly below hybrid
    pair = common_means(table, ("hybrid-lim-4x4", "hybrid-4x4"))
    if pair:
        lim, full = pair["hybrid-lim-4x4"], pair["hybrid-4x4"]
        d = full - lim
        out.append(
            (
                "hybrid-lim is slightly below hybrid",
                f"hybrid-4x4 {pct(full)} vs hybrid-lim-4x4 {pct(lim)} (difference {100 * d:+.1f} points)",
                "agrees" if 0 < d <= 0.1 else ("disagrees" if d <= 0 else "below by more than slightly"),
            )
        )
    # 4. stochastic beats greedy at low noise, they converge at high noise
    s, g = table.get(("noise", "stochastic"), {}), table.get(("noise", "greedy"), {})
    common = sorted(set(s) & set(g))
    if len(common) >= 2:
        low, high = common[0], common[-1]
        d_low = s[low]["success_rate"] - g[low]["success_rate"]
        d_high = s[high]["success_rate"] - g[high]["success_rate"]
        ok = d_low > 0 and abs(d_high) < abs(d_low)
        out.append(
            (
                "stochastic beats greedy at low noise; they converge at high noise",
                f"stochastic - greedy: {100 * d_low:+.1f} points at noise {low:g}, {100 * d_high:+.1f} at noise {high:g}",
                "agrees" if ok else "disagrees",
            )
        )
    # 5. hierarchical drops sharpest
    for sweep in ("clutter", "noise"):
        slopes = {m: slope(table, sweep, m) for m in {m for (sw, m) in table if sw == sweep}}
        slopes = {m: v for m, v in slopes.items() if v is not None}
        if "hierarchical" in slopes and len(slopes) > 1:
            steepest = min(slopes, key=slopes.get)
            out.append(
                (
                    f"hierarchical drops sharpest ({sweep})",
                    "fitted change of success over the axis: "
                    + ", ".join(f"{m} {100 * v:+.0f}" for m, v in sorted(slopes.items(), key=lambda kv: kv[1])),
                    "agrees" if steepest == "hierarchical" else f"disagrees (steepest: {steepest})",
                )
            )
    # 6. success falls with clutter and noise
    for sweep in ("clutter", "noise"):
        falls = []
        for (sw, m), pts in sorted(table.items()):
            if sw == sweep and len(pts) >= 2:
                lo, hi = min(pts), max(pts)
                falls.append((m, pts[lo]["success_rate"], pts[hi]["success_rate"]))
        if falls:
            n_fall = sum(b < a for _, a, b in falls)
            out.append(
                (
                    f"success falls with {sweep}",
                    "; ".join(f"{m} {pct(a)} -> {pct(b)}" for m, a, b in falls),
                    "agrees" if n_fall == len(falls) else f"{n_fall} of {len(falls)} methods fall",
                )
            )
    return out


METHOD_ORDER = ["hybrid-6x6", "hybrid-4x4", "hybrid-2x2", "hybrid-lim-4x4", "stochastic-gen", "stochastic", "greedy", "hierarchical"]


def success_tables(table) -> None:
    for sweep, label in (("clutter", "objects"), ("noise", "noise")):
        values = sorted({v for (sw, _), pts in table.items() if sw == sweep for v in pts})
        if not values:
            continue
        methods = [m for m in METHOD_ORDER if (sweep, m) in table] + sorted(m for (sw, m) in table if sw == sweep and m not in METHOD_ORDER)
        print(f"\nsuccess (%) against {label}:\n")
        print("| method | " + " | ".join(f"{v:g}" for v in values) + " |")
        print("| --- | " + " | ".join("---" for _ in values) + " |")
        for m in methods:
            pts = table[(sweep, m)]
            print(f"| {m} | " + " | ".join(f"{100 * pts[v]['success_rate']:.0f}" if v in pts else "" for v in values) + " |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results", help="results.json of a sweep folder")
    parser.add_argument("--tables", action="store_true", help="also print success per method and point")
    args = parser.parse_args()
    table = load(args.results)
    tasks = sorted({r["tasks"] for pts in table.values() for r in pts.values()})
    half = [(r["ci95_high"] - r["ci95_low"]) / 2 for pts in table.values() for r in pts.values()]
    print(
        f"tasks per point: {', '.join(map(str, tasks))}; 95 % interval half-width: median {100 * np.median(half):.1f} "
        f"points, largest {100 * max(half):.1f}\n"
    )
    print("| claim (papers) | this sweep | verdict |")
    print("| --- | --- | --- |")
    for claim, figures, verdict in claims(table):
        print(f"| {claim} | {figures} | {verdict} |")
    if args.tables:
        success_tables(table)


if __name__ == "__main__":
    main()
