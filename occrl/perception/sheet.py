"""The tag sheet: a catalogue's tags at true size, laid out on pages to print.

Each tag is drawn with its white quiet zone (one cell around the black square) and labelled with
its id, its object type and where it goes; each page carries a 50 mm bar to check that the printer
kept the scale (print at 100 %, "actual size"). A PDF has one page per sheet; a PNG file is written
per page (``tags.png``, or ``tags-1.png``, ``tags-2.png``, ... when there are several), with its dpi
recorded.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from occrl.perception.catalogue import TagCatalogue, TagEntry
from occrl.perception.checks import strict_int
from occrl.perception.opencv import aruco_dictionary, check_dictionary, require_opencv

__all__ = ["PAGE_SIZES_MM", "tag_pixels", "sheet_pages", "write_tag_sheet", "SHEET_SUFFIXES"]

PAGE_SIZES_MM = {"a4": (210.0, 297.0), "letter": (215.9, 279.4)}
SHEET_SUFFIXES = (".pdf", ".png")
MARGIN_MM = 12.0
GAP_MM = 6.0
LABEL_MM = 3.0  # label text height
BAR_MM = 50.0
MM_PER_INCH = 25.4


def mm_to_px(mm: float, dpi: int) -> int:
    return int(round(mm * dpi / MM_PER_INCH))


def tag_pixels(entry: TagEntry, dpi: int) -> int:
    """The side of a tag's black square on the sheet, in pixels at ``dpi``."""
    return mm_to_px(entry.size * 1000, dpi)


def _font(px: int):
    try:
        return ImageFont.load_default(size=px)
    except TypeError:  # Pillow without FreeType sizes
        return ImageFont.load_default()


def _label(entry: TagEntry) -> list[str]:
    where = "top" if entry.face == "top" else f"face {entry.face}"
    return [f"tag {entry.tag_id}, type {entry.type_id}", f"{where}, {entry.size * 1000:g} mm"]


def sheet_pages(catalogue: TagCatalogue, dpi: int = 300, page: str = "a4", title: str = "") -> list[Image.Image]:
    """The sheet's pages (grey images, ``dpi`` pixels an inch), tags in id order."""
    dpi = strict_int("dpi", dpi, 50, 2401)
    if page not in PAGE_SIZES_MM:
        raise ValueError(f"page must be one of {sorted(PAGE_SIZES_MM)}, got {page!r}")
    cv2 = require_opencv()
    dictionary = aruco_dictionary(catalogue.dictionary)
    cells = check_dictionary(catalogue.dictionary).bits + 2
    width, height = (mm_to_px(v, dpi) for v in PAGE_SIZES_MM[page])
    margin, gap, label_px = mm_to_px(MARGIN_MM, dpi), mm_to_px(GAP_MM, dpi), mm_to_px(LABEL_MM, dpi)
    font = _font(label_px)
    header = 2 * label_px + gap

    def new_page() -> tuple[Image.Image, ImageDraw.ImageDraw]:
        image = Image.new("L", (width, height), 255)
        draw = ImageDraw.Draw(image)
        bar = mm_to_px(BAR_MM, dpi)
        draw.rectangle([margin, margin, margin + bar - 1, margin + label_px // 2], fill=0)
        text = f"{title + ': ' if title else ''}{catalogue.dictionary} tags; print at 100 % (actual size): this bar is {BAR_MM:g} mm"
        draw.text((margin, margin + label_px), text, fill=0, font=font)
        return image, draw

    pages = []
    image, draw = new_page()
    x, y, row = margin, margin + header, 0
    for entry in catalogue:
        side = tag_pixels(entry, dpi)
        quiet = int(np.ceil(side / cells))
        box = side + 2 * quiet
        lines = _label(entry)
        cell_w = max([box] + [int(draw.textlength(line, font=font)) + 1 for line in lines])
        cell_h = box + label_px * 3 * len(lines) // 2
        if cell_w > width - 2 * margin or cell_h > height - 2 * margin - header:
            raise ValueError(f"tag {entry.tag_id} ({entry.size * 1000:g} mm with its label) does not fit a {page} page")
        if x + cell_w > width - margin:  # next row
            x, y, row = margin, y + row + gap, 0
        if y + cell_h > height - margin:  # next page
            pages.append(image)
            image, draw = new_page()
            x, y, row = margin, margin + header, 0
        marker = cv2.aruco.generateImageMarker(dictionary, entry.tag_id, side, borderBits=1)
        image.paste(Image.fromarray(marker), (x + quiet, y + quiet))
        for k, line in enumerate(lines):
            draw.text((x, y + box + k * label_px * 3 // 2), line, fill=0, font=font)
        x += cell_w + gap
        row = max(row, cell_h)
    pages.append(image)
    return pages


def write_tag_sheet(catalogue: TagCatalogue, path: str | Path, dpi: int = 300, page: str = "a4", title: str = "") -> list[Path]:
    """Write the sheet as a PDF or PNG (by the suffix of ``path``); returns the files written."""
    path = Path(path)
    if path.suffix.lower() not in SHEET_SUFFIXES:
        raise ValueError(f"the sheet's file must end in .pdf or .png, got {path.name!r}")
    if not path.parent.is_dir():
        raise FileNotFoundError(f"the folder {path.parent} does not exist")
    pages = sheet_pages(catalogue, dpi, page, title)
    if path.suffix.lower() == ".pdf":
        pages[0].save(path, resolution=float(dpi), save_all=True, append_images=pages[1:])
        return [path]
    if len(pages) == 1:
        pages[0].save(path, dpi=(dpi, dpi))
        return [path]
    written = []
    for k, image in enumerate(pages, start=1):
        target = path.with_name(f"{path.stem}-{k}{path.suffix}")
        image.save(target, dpi=(dpi, dpi))
        written.append(target)
    return written
