"""Check the papers' simulation claims against a sweep's results (docs/lab/study.md, the papers' simulation study).

Usage:
    python scripts/sweep_claims.py results/sweep/results.json            # the claims
    python scripts/sweep_claims.py results/sweep/results.json --tables   # plus success per method and point

Reads the rows written by ``occrl eval --sweep`` (``summarize_sweep``) and prints, per claim of
the papers (Sec. VI-C), the figures that test it, whether this sweep agrees, and whether the
difference the verdict rests on is beyond the spread. "Clearly" means the 95 % intervals do not
overlap; points are compared only where both methods were run. Where the sweep's episodes lie
beside ``results.json`` (``points.json.gz`` or ``points/``), two methods are compared on the same tasks by the exact
McNemar test (tasks only one of them solved; "beyond the spread": p < 0.05), else by whether
their intervals separate. Slopes over an axis get a 95 % interval from a parametric bootstrap
(each point's successes redrawn from its rate, 2,000 draws, fixed seed).
"""

from __future__ import annotations

import argparse
import json
from collections import defaultdict
from pathlib import Path

import numpy as np

from occrl.eval.runner import mcnemar_p, wilson_interval
from occrl.eval.sweep_store import point_episodes, sweep_points

BASELINES = ["greedy", "stochastic", "stochastic-gen", "hierarchical"]


def load(path: str) -> dict:
    rows = json.loads(open(path).read())
    table: dict = defaultdict(dict)
    for r in rows:
        table[(r["sweep"], r["method"])][r["value"]] = r
    return table


def load_episodes(path: str) -> dict:
    """{(sweep, method, value): {seed: success}} from the points beside ``results.json`` (empty if none)."""
    return {
        (p["sweep"], p["method"], float(p["value"])): {seed: e.success for seed, e in point_episodes(p).items()}
        for p in sweep_points(Path(path).parent)
    }


def paired(table, episodes, a: str, b: str, points) -> str:
    """How method ``a`` and ``b`` differ over ``points`` [(sweep, value)], and whether beyond the spread."""
    pairs = [(episodes.get((sw, a, v)), episodes.get((sw, b, v))) for sw, v in points]
    if pairs and all(x is not None and y is not None for x, y in pairs):
        only_a = sum(x[s] and not y[s] for x, y in pairs for s in x.keys() & y.keys())
        only_b = sum(y[s] and not x[s] for x, y in pairs for s in x.keys() & y.keys())
        p = mcnemar_p(only_a, only_b)
        return f"{'beyond' if p < 0.05 else 'within'} the spread ({a} / {b} alone solved {only_a} / {only_b} tasks, McNemar p = {p:.2g})"
    ra = [table[(sw, a)][v] for sw, v in points]
    rb = [table[(sw, b)][v] for sw, v in points]
    la, ha = wilson_interval(sum(r["successes"] for r in ra), sum(r["tasks"] for r in ra))
    lb, hb = wilson_interval(sum(r["successes"] for r in rb), sum(r["tasks"] for r in rb))
    separate = ha < lb or hb < la
    return f"{'beyond' if separate else 'within'} the spread (pooled 95 % intervals {pct(la)}-{pct(ha)} and {pct(lb)}-{pct(hb)})"


def slope_interval(table, sweep, method, draws: int = 2000) -> tuple[float, float]:
    """95 % interval of :func:`slope` by redrawing each point's successes from its rate."""
    pts = table[(sweep, method)]
    x = np.array(sorted(pts))
    xs = (x - x.min()) / (x.max() - x.min())
    rng = np.random.default_rng(0)
    n = np.array([pts[v]["tasks"] for v in x])
    rates = rng.binomial(n, [pts[v]["success_rate"] for v in x], size=(draws, len(x))) / n
    fits = np.polyfit(xs, rates.T, 1)[0]
    return float(np.percentile(fits, 2.5)), float(np.percentile(fits, 97.5))


def pct(x: float) -> str:
    return f"{100 * x:.1f} %"


def common_means(table, methods, episodes=None) -> dict | None:
    """Mean success of each method over the (sweep, value) points all of them were run on; where
    ``episodes`` holds every method's episodes of a point, over the tasks they all ran there
    (points extended to different task counts compare on the same tasks)."""
    common = None
    for m in methods:
        pts = {(sweep, v) for sweep in ("clutter", "noise") for v in table.get((sweep, m), {})}
        common = pts if common is None else common & pts
    if not common:
        return None
    episodes = episodes or {}

    def rate(sweep, v, m):
        runs = [episodes.get((sweep, k, v)) for k in methods]
        if all(r is not None for r in runs):
            seeds = set.intersection(*(set(r) for r in runs))
            return float(np.mean([episodes[(sweep, m, v)][s] for s in seeds]))
        return table[(sweep, m)][v]["success_rate"]

    return {m: float(np.mean([rate(sweep, v, m) for sweep, v in common])) for m in methods}


def common_points(table, methods) -> list[tuple[str, float]]:
    """The (sweep, value) points every one of ``methods`` was run on."""
    sets = [{(sw, v) for sw in ("clutter", "noise") for v in table.get((sw, m), {})} for m in methods]
    return sorted(set.intersection(*sets))


def slope(table, sweep, method) -> float | None:
    pts = table.get((sweep, method), {})
    if len(pts) < 2:
        return None
    x = np.array(sorted(pts))
    y = np.array([pts[v]["success_rate"] for v in x])
    span = x.max() - x.min()
    return float(np.polyfit((x - x.min()) / span, y, 1)[0])  # change in success over the whole axis


def claims(table, episodes=None) -> list[tuple[str, str, str, str]]:
    """(claim, figures, verdict, spread) per claim of the papers."""
    episodes = episodes or {}
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
    spread = "; ".join(
        f"vs {base}: " + paired(table, episodes, "hybrid-4x4", base, common)
        for base in BASELINES
        if (common := [(sw, v) for sw in ("clutter", "noise") for v in table.get((sw, base), {}) if v in table.get((sw, "hybrid-4x4"), {})])
    )
    out.append(
        (
            "hybrid (4x4) beats every baseline",
            f"{wins} of {total} (point, baseline) pairs higher, {ties} equal, {losses} lower; {clear} clearly higher",
            verdict if total else "not run",
            spread or "not run",
        )
    )
    # 2. larger m x h helps
    means = common_means(table, ("hybrid-2x2", "hybrid-4x4", "hybrid-6x6"), episodes)
    if means:
        order = means["hybrid-2x2"] <= means["hybrid-4x4"] <= means["hybrid-6x6"]
        points = common_points(table, ("hybrid-2x2", "hybrid-4x4", "hybrid-6x6"))
        out.append(
            (
                "larger m x h helps",
                ", ".join(f"{m} {pct(v)}" for m, v in means.items()) + " (mean over the points and tasks all three ran)",
                "agrees" if order else ("partly" if means["hybrid-2x2"] <= max(means["hybrid-4x4"], means["hybrid-6x6"]) else "disagrees"),
                "4x4 against 2x2: "
                + paired(table, episodes, "hybrid-4x4", "hybrid-2x2", points)
                + "; 6x6 against 4x4: "
                + paired(table, episodes, "hybrid-6x6", "hybrid-4x4", points),
            )
        )
    # 3. hybrid-lim slightly below hybrid
    pair = common_means(table, ("hybrid-lim-4x4", "hybrid-4x4"), episodes)
    if pair:
        lim, full = pair["hybrid-lim-4x4"], pair["hybrid-4x4"]
        d = full - lim
        out.append(
            (
                "hybrid-lim is slightly below hybrid",
                f"hybrid-4x4 {pct(full)} vs hybrid-lim-4x4 {pct(lim)} (difference {100 * d:+.1f} points)",
                "agrees" if 0 < d <= 0.1 else ("disagrees" if d <= 0 else "below by more than slightly"),
                paired(table, episodes, "hybrid-4x4", "hybrid-lim-4x4", common_points(table, ("hybrid-lim-4x4", "hybrid-4x4"))),
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
                f"at noise {low:g}: "
                + paired(table, episodes, "stochastic", "greedy", [("noise", low)])
                + f"; at noise {high:g}: "
                + paired(table, episodes, "stochastic", "greedy", [("noise", high)]),
            )
        )
    # 5. hierarchical drops sharpest
    for sweep in ("clutter", "noise"):
        slopes = {m: slope(table, sweep, m) for m in sorted({m for (sw, m) in table if sw == sweep})}
        slopes = {m: v for m, v in slopes.items() if v is not None}
        if "hierarchical" in slopes and len(slopes) > 1:
            steepest = min(slopes, key=slopes.get)
            ci = {m: slope_interval(table, sweep, m) for m in slopes}
            others = [m for m in slopes if m != "hierarchical"]
            h_lo, h_hi = ci["hierarchical"]
            if steepest == "hierarchical":
                apart = [m for m in others if h_hi < ci[m][0]]
                spread = f"hierarchical's interval below {len(apart)} of {len(others)} others'"
            else:
                apart = [m for m in others if ci[m][1] < h_lo]
                spread = f"{len(apart)} of {len(others)} others' intervals below hierarchical's" + (
                    f" ({', '.join(sorted(apart))})" if apart else ""
                )
            out.append(
                (
                    f"hierarchical drops sharpest ({sweep})",
                    "fitted change of success over the axis (95 % interval): "
                    + ", ".join(
                        f"{m} {100 * v:+.0f} ({100 * ci[m][0]:+.0f} to {100 * ci[m][1]:+.0f})"
                        for m, v in sorted(slopes.items(), key=lambda kv: (kv[1], kv[0]))  # ties by name: a stable order
                    ),
                    "agrees" if steepest == "hierarchical" else f"disagrees (steepest: {steepest})",
                    spread,
                )
            )
    # 6. success falls with clutter and noise
    for sweep in ("clutter", "noise"):
        falls = []
        for (sw, m), pts in sorted(table.items()):
            if sw == sweep and len(pts) >= 2:
                lo, hi = min(pts), max(pts)
                apart = pts[hi]["ci95_high"] < pts[lo]["ci95_low"] or pts[lo]["ci95_high"] < pts[hi]["ci95_low"]
                falls.append((m, pts[lo]["success_rate"], pts[hi]["success_rate"], apart))
        if falls:
            n_fall = sum(b < a for _, a, b, _ in falls)
            clearly = [m for m, _, _, apart in falls if apart]
            out.append(
                (
                    f"success falls with {sweep}",
                    "; ".join(f"{m} {pct(a)} -> {pct(b)}" for m, a, b, _ in falls),
                    "agrees" if n_fall == len(falls) else f"{n_fall} of {len(falls)} methods fall",
                    f"first and last point's intervals separate for {len(clearly)} of {len(falls)} methods",
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
    episodes = load_episodes(args.results)
    print("| claim (papers) | this sweep | verdict | beyond the spread? |")
    print("| --- | --- | --- | --- |")
    for claim, figures, verdict, spread in claims(table, episodes):
        print(f"| {claim} | {figures} | {verdict} | {spread} |")
    if args.tables:
        success_tables(table)


if __name__ == "__main__":
    main()
