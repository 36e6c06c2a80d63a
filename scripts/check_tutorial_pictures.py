"""Check a built docs site: every tutorial page exists and shows at least one picture.

    python -m sphinx -W --keep-going -b html docs HTML && python scripts/check_tutorial_pictures.py HTML

The tutorials are the notebooks of ``examples/notebooks/``, executed by the docs build
(docs/conf.py); a page without an ``<img>`` means a notebook drew nothing (or was not executed).
Exits 1 naming each page at fault, 0 printing each page's picture count.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = ROOT / "examples" / "notebooks"
IMAGE = re.compile(r"<img\s", re.IGNORECASE)


def tutorial_problems(html_dir: Path, notebooks: Path = NOTEBOOKS) -> tuple[dict[str, int], list[str]]:
    """Pictures per tutorial page, and one message per page that is missing or has none."""
    counts: dict[str, int] = {}
    problems: list[str] = []
    stems = sorted(p.stem for p in notebooks.glob("*.ipynb"))
    if not stems:
        problems.append(f"no notebooks in {notebooks}")
    for stem in stems:
        page = html_dir / "tutorials" / f"{stem}.html"
        if not page.is_file():
            problems.append(f"{page}: missing (is the notebook in the docs' toctree?)")
            continue
        counts[stem] = len(IMAGE.findall(page.read_text(encoding="utf-8")))
        if counts[stem] == 0:
            problems.append(f"{page}: no picture (<img>): did the notebook run and draw?")
    return counts, problems


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("html_dir", type=Path, help="the built site (sphinx -b html's output folder)")
    args = parser.parse_args(argv)
    if not args.html_dir.is_dir():
        parser.error(f"{args.html_dir} is not a folder (build the site first)")
    counts, problems = tutorial_problems(args.html_dir)
    for message in problems:
        print(message, file=sys.stderr)
    if not problems:
        print("tutorial pictures: " + ", ".join(f"{stem} {n}" for stem, n in counts.items()))
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
