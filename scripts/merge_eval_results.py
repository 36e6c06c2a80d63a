"""One `occrl eval --out` JSON from several runs of the same method and settings on disjoint seeds
(e.g. a long evaluation run as chunks of `--seed S --tasks N`): the episodes together, ordered by
seed, and the summary recomputed from them. Tasks are seeded by their own seeds, so the result is
the one a single run over all the seeds gives (per-task times aside).

    python scripts/merge_eval_results.py merged.json run_a.json run_b.json ...
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from occrl.envs.episodes import EpisodeResult
from occrl.eval.runner import summarize

# what each run must share; the summary's own fields and the first seed are recomputed
SETTINGS = ("method", "network", "stage", "objects", "noise", "world", "perception", "rollout_min_scale", "inference", "replicate", "batch")


def merge(results: list[dict]) -> dict:
    first = results[0]
    for r in results[1:]:
        differ = [k for k in SETTINGS if r.get(k) != first.get(k)]
        if differ:
            raise ValueError(f"the runs differ in {differ}; merge only runs of one method and settings")
    episodes = sorted((e for r in results for e in r["episodes"]), key=lambda e: e["seed"])
    seeds = [e["seed"] for e in episodes]
    if len(set(seeds)) != len(seeds):
        raise ValueError("the runs share task seeds; merge runs on disjoint seeds")
    summary = summarize([EpisodeResult(**e) for e in episodes])
    merged = {k: first[k] for k in first if k not in ("episodes", *summary)}
    merged["first_seed"] = seeds[0]
    return {**merged, **summary, "episodes": episodes}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", help="the merged JSON to write")
    parser.add_argument("files", nargs="+", help="occrl eval --out JSON files")
    args = parser.parse_args()
    merged = merge([json.loads(Path(f).read_text()) for f in args.files])
    Path(args.out).write_text(json.dumps(merged, indent=2))
    lo, hi = merged["success_ci95"]
    print(
        f"{merged['tasks']} tasks: success {merged['success_rate']:.1%} ({lo:.1%}-{hi:.1%}), dropped {merged['dropped']}; wrote {args.out}"
    )


if __name__ == "__main__":
    main()
