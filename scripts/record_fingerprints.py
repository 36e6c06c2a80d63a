"""Record the behaviour fingerprints (seeded episodes, presets) into tests/data/fingerprints.json.

Usage:
    python scripts/record_fingerprints.py [--out tests/data/fingerprints.json]
    python scripts/record_fingerprints.py --alternate

Only after a change that alters behaviour on purpose (see occrl/fingerprints.py); that record drops
the alternates, which were of the old behaviour. ``--alternate``: keep the record as it is and add,
for every episode this machine plays otherwise, this machine's episode as an alternate (another
CPU's float rounding turned a near-tie of the planner; occrl.fingerprints explains). Run it on the
code the record was made with, never to make a behaviour change pass.
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

from occrl.fingerprints import all_fingerprints, machine_description, recorded_difference


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(Path(__file__).resolve().parent.parent / "tests" / "data" / "fingerprints.json"))
    parser.add_argument("--alternate", action="store_true", help="add this machine's differing episodes as alternates; keep the record")
    args = parser.parse_args()
    fps = all_fingerprints()
    if args.alternate:
        record = json.loads(Path(args.out).read_text())
        if fps["presets"] != record["presets"] or fps["max_episode_steps"] != record["max_episode_steps"]:
            raise SystemExit("the presets or the episode limit differ from the record: a behaviour change, not another CPU")
        alternates = record.setdefault("alternates", {})
        machine = machine_description()
        for name, fp in fps["episodes"].items():
            difference = recorded_difference(fp, record["episodes"][name], alternates.get(name, []))
            if difference is not None:
                alternates.setdefault(name, []).append({**fp, "machine": machine})
                print(f"{name:36s} differs here ({difference}): added as an alternate recorded on {machine}")
        Path(args.out).write_text(json.dumps(record, indent=2, sort_keys=True) + "\n")
        return
    Path(args.out).write_text(json.dumps(fps, indent=2, sort_keys=True) + "\n")
    for name, fp in fps["episodes"].items():
        print(f"{name:36s} {fp['steps']:3d} actions, success {fp['success']}, dropped {fp['dropped']}")
    print(f"{len(fps['presets'])} presets; written to {args.out}")


if __name__ == "__main__":
    main()
