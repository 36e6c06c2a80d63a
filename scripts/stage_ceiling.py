"""How many held-out tasks of each stage has *any* evaluated method solved?

    python scripts/stage_ceiling.py results/heldout/*.json results/curriculum/*/*.json results/ppo-from-ei/*.json

Reads `occrl eval --out` JSON files of the 2D world at noise 0 that cover the same task seeds
(200 held-out seeds from 10,000,000 by default), and prints per stage: each run's success, the
share of tasks solved by at least one run (the union), and the seeds nobody solved. The ranking
says how far every method built here is from the paper's promotion rule (hybrid 4x4 > 80 % on a
stage); the union is what an oracle picking the right run per task would get, and it grows with
every stochastic run (each solves a few tasks by chance), so it is no bound on what is possible.
"""

from __future__ import annotations

import argparse
import json
from collections import defaultdict
from pathlib import Path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("files", nargs="+", type=Path)
    parser.add_argument("--first-seed", type=int, default=10_000_000)
    parser.add_argument("--tasks", type=int, default=200)
    args = parser.parse_args()

    runs: dict[int, list[tuple[str, set[int], float]]] = defaultdict(list)
    for path in args.files:
        d = json.loads(path.read_text())
        if (
            d.get("world", "pymunk") != "pymunk"
            or d.get("objects")
            or d.get("noise", 0.0) != 0.0
            or d.get("first_seed") != args.first_seed
            or d.get("tasks") != args.tasks
        ):
            continue
        solved = {e["seed"] for e in d["episodes"] if e["success"]}
        network = Path(str(d["network"])).name if d.get("network") else "-"
        label = f"{path.parent.name}/{path.stem}" if path.parent.name != "heldout" else path.stem
        runs[d["stage"]].append((f"{label} ({d['method']}, {network})", solved, d["success_rate"]))

    seeds = set(range(args.first_seed, args.first_seed + args.tasks))
    for stage in sorted(runs):
        print(f"stage {stage}: {len(runs[stage])} runs on the same {args.tasks} tasks")
        for label, _, rate in sorted(runs[stage], key=lambda r: -r[2]):
            print(f"  {rate:6.1%}  {label}")
        union = set().union(*(solved for _, solved, _ in runs[stage]))
        never = sorted(seeds - union)
        print(f"  solved by at least one run: {len(union & seeds) / len(seeds):.1%}; never solved: {len(never)} tasks")
        print(f"  never solved: {' '.join(map(str, never))}")


if __name__ == "__main__":
    main()
