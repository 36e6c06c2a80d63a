"""Record the behaviour fingerprints (seeded episodes, presets) into tests/data/fingerprints.json.

Usage:
    python scripts/record_fingerprints.py [--out tests/data/fingerprints.json]

Only after a change that alters behaviour on purpose (see occrl/fingerprints.py).
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

from occrl.fingerprints import all_fingerprints


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(Path(__file__).resolve().parent.parent / "tests" / "data" / "fingerprints.json"))
    args = parser.parse_args()
    fps = all_fingerprints()
    Path(args.out).write_text(json.dumps(fps, indent=2, sort_keys=True) + "\n")
    for name, fp in fps["episodes"].items():
        print(f"{name:36s} {fp['steps']:3d} actions, success {fp['success']}, dropped {fp['dropped']}")
    print(f"{len(fps['presets'])} presets; written to {args.out}")


if __name__ == "__main__":
    main()
