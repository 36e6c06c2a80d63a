"""Print a markdown table of `occrl eval --out` JSON files (success with 95 % interval, drops,
actions, time per task), one row per file.

    python scripts/results_table.py ~/occrl-evals/*.json
"""

from __future__ import annotations

import json
import sys
from pathlib import Path


def row(path: Path) -> str:
    d = json.loads(path.read_text())
    lo, hi = d["success_ci95"]
    where = f"{d.get('world', 'pymunk')}, stage {d['stage']}" + (f", objects {d['objects']}" if d.get("objects") else "")
    return (f"| {d['method']} | {Path(str(d['network'])).name if d['network'] else '-'} | {where} | noise {d['noise']} | {d['tasks']} | "
            f"{d['success_rate']:.1%} ({lo:.1%}-{hi:.1%}) | {d['dropped']} | {d['mean_actions']:.1f} | {d['mean_seconds']:.2f} s |")


def main(paths: list[str]) -> None:
    print("| method | network | tasks from | noise | tasks | success (95 % CI) | dropped | actions | time per task |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for p in paths:
        print(row(Path(p)))


if __name__ == "__main__":
    main(sys.argv[1:])
