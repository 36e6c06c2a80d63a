"""``occrl tags``: a catalogue's tag sheet at true size, to print (:mod:`occrl.perception.sheet`)."""

from __future__ import annotations

import argparse

from occrl.cli.options import HelpFormatter, bounded

__all__ = ["add_tags_parser", "run_tags"]

DPI = bounded(int, 50, 2400, what="an integer in [50, 2400]")

EPILOG = """\
examples:
  occrl tags my_catalogue.json --out tags.pdf             every tag of the catalogue, A4 pages
  occrl tags my_catalogue.json --out tags.png --dpi 600   PNG at 600 dpi (tags-1.png, ... if several pages)

Print at 100 % scale and check the 50 mm bar on each page with a ruler before sticking the tags."""


def add_tags_parser(sub) -> None:
    """Add the ``tags`` command to the ``occrl`` subparsers ``sub``."""
    g = sub.add_parser(
        "tags",
        help="write a tag catalogue's tags at true size (PDF or PNG) to print and stick on the objects",
        description="Write the tags of a catalogue (JSON, see occrl.perception.catalogue) at true size, each labelled with "
        "its tag id, object type and face, with a 50 mm bar per page to check the print's scale. Needs OpenCV: "
        'pip install "occrl[camera]".',
        epilog=EPILOG,
        formatter_class=HelpFormatter,
    )
    g.add_argument("catalogue", help="the tag catalogue (JSON)")
    g.add_argument("--out", required=True, help="the sheet: a .pdf (one page per sheet) or a .png (one file per page)")
    g.add_argument("--dpi", type=DPI, default=300, help="pixels per inch of the sheet")
    g.add_argument("--page", choices=["a4", "letter"], default="a4", help="paper size")
    g.set_defaults(func=run_tags)


def run_tags(args: argparse.Namespace) -> int:
    from pathlib import Path

    from occrl.perception import TagCatalogue
    from occrl.perception.sheet import write_tag_sheet

    catalogue = TagCatalogue.from_json(args.catalogue)
    written = write_tag_sheet(catalogue, args.out, dpi=args.dpi, page=args.page, title=Path(args.catalogue).name)
    print(
        f"{len(catalogue)} tags of {len(catalogue.type_ids)} object types on {len(written)} file(s): " + ", ".join(str(p) for p in written)
    )
    print("print at 100 % (actual size) and check the 50 mm bar before cutting")
    return 0
