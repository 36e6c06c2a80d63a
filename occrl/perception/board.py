"""The calibration board: a ChArUco board (a chessboard whose white squares hold ArUco markers),
its true-size print, and finding its corners in an image.

The board frame is OpenCV's: origin at the board's top-left outer corner as printed, x to the
right along the ``squares_x`` squares, y down along the ``squares_y`` squares, z into the board;
metres. Its inner corners (``(squares_x - 1) * (squares_y - 1)`` of them) are numbered row by row
from the top left, OpenCV's ChArUco corner ids. The default board fills an A4 page: 5 x 7 squares
of 35 mm with 26 mm markers of the ``aruco_5x5_100`` dictionary (not the AprilTag family on the
objects, so the board's markers are never taken for an object's tag).

A board page (PDF or PNG) carries the board at true size, a 50 mm bar to check the print's scale
and a line naming the board's settings. Print at 100 % ("actual size") and measure a square: if it
is not the ``square_length`` printed on the page, give the measured length to the calibration.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from occrl.perception.checks import positive_number, strict_int
from occrl.perception.opencv import DICTIONARIES, as_grey_image, require_opencv
from occrl.perception.sheet import BAR_MM, MARGIN_MM, PAGE_SIZES_MM, SHEET_SUFFIXES, mm_to_px

__all__ = [
    "CalibrationBoard",
    "BoardView",
    "find_board",
    "board_image",
    "draw_board",
    "board_page",
    "write_board",
    "BOARD_DICTIONARIES",
    "DEFAULT_BOARD_DICTIONARY",
    "MIN_BOARD_CORNERS",
]

# the dictionaries a board may use: OpenCV's ArUco families, and the AprilTag ones of the tags
BOARD_DICTIONARIES = {
    "aruco_4x4_50": "DICT_4X4_50",
    "aruco_5x5_100": "DICT_5X5_100",
    "aruco_6x6_250": "DICT_6X6_250",
    "aruco_7x7_250": "DICT_7X7_250",
    **{name: entry.opencv_name for name, entry in DICTIONARIES.items()},
}
DEFAULT_BOARD_DICTIONARY = "aruco_5x5_100"
MIN_BOARD_CORNERS = 6  # ChArUco corners, on at least 2 rows and 2 columns, for a view to count
MAX_SQUARES = 50
LABEL_MM = 3.5


def dictionary_size(name: str) -> int:
    """How many markers the board dictionary ``name`` holds."""
    if name not in BOARD_DICTIONARIES:
        raise ValueError(f"unknown board dictionary {name!r}; allowed: {sorted(BOARD_DICTIONARIES)}")
    if name in DICTIONARIES:
        return DICTIONARIES[name].size
    return int(BOARD_DICTIONARIES[name].rsplit("_", 1)[1])


@dataclass(frozen=True)
class CalibrationBoard:
    """A ChArUco board: ``squares_x`` x ``squares_y`` squares of ``square_length`` metres, the white
    ones holding markers of ``marker_length`` metres from ``dictionary`` (a key of
    :data:`BOARD_DICTIONARIES`). The defaults fill an A4 page.

    Examples:
        >>> from occrl.perception.board import CalibrationBoard
        >>> board = CalibrationBoard()
        >>> board.size, board.corner_count, board.marker_count
        ((0.175, 0.245), 24, 17)
        >>> CalibrationBoard(marker_length=0.04)
        Traceback (most recent call last):
        ...
        ValueError: marker_length (0.04 m) must be shorter than square_length (0.035 m): a marker sits inside a white square
    """

    squares_x: int = 5
    squares_y: int = 7
    square_length: float = 0.035
    marker_length: float = 0.026
    dictionary: str = DEFAULT_BOARD_DICTIONARY

    def __post_init__(self) -> None:
        for name in ("squares_x", "squares_y"):
            strict_int(name, getattr(self, name), 3, MAX_SQUARES + 1)
        square = positive_number("square_length", self.square_length, "metres")
        marker = positive_number("marker_length", self.marker_length, "metres")
        if square > 1.0:
            raise ValueError(f"square_length must be in metres (at most 1), got {square}: a 35 mm square is 0.035")
        if marker >= square:
            raise ValueError(
                f"marker_length ({marker:g} m) must be shorter than square_length ({square:g} m): a marker sits inside a white square"
            )
        if self.marker_count > dictionary_size(self.dictionary):
            raise ValueError(
                f"a {self.squares_x} x {self.squares_y} board needs {self.marker_count} markers; "
                f"{self.dictionary} has {dictionary_size(self.dictionary)}: choose a larger dictionary or fewer squares"
            )
        object.__setattr__(self, "square_length", square)
        object.__setattr__(self, "marker_length", marker)

    @property
    def size(self) -> tuple[float, float]:
        """The board's width and height (m)."""
        return round(self.squares_x * self.square_length, 9), round(self.squares_y * self.square_length, 9)

    @property
    def corner_count(self) -> int:
        """The number of inner (ChArUco) corners."""
        return (self.squares_x - 1) * (self.squares_y - 1)

    @property
    def marker_count(self) -> int:
        """The number of markers (one per white square)."""
        return self.squares_x * self.squares_y // 2

    def corner_points(self) -> np.ndarray:
        """The inner corners in the board frame, ``(corner_count, 3)`` metres, in id order."""
        cols, rows = np.meshgrid(np.arange(1, self.squares_x), np.arange(1, self.squares_y))
        return np.stack([cols.ravel(), rows.ravel(), np.zeros(cols.size)], axis=1) * self.square_length

    def opencv_board(self) -> Any:
        """OpenCV's ``cv2.aruco.CharucoBoard`` for this board."""
        cv2 = require_opencv()
        dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, BOARD_DICTIONARIES[self.dictionary]))
        return cv2.aruco.CharucoBoard((self.squares_x, self.squares_y), self.square_length, self.marker_length, dictionary)

    def describe(self) -> str:
        """One line naming the board's settings, as the calibration commands take them."""
        return (
            f"ChArUco board {self.squares_x} x {self.squares_y} squares of {self.square_length * 1000:g} mm, "
            f"markers {self.marker_length * 1000:g} mm, {self.dictionary}"
        )


class BoardView(NamedTuple):
    """The board's corners found in one image: their ids, pixel positions ``(n, 2)`` and positions
    in the board frame ``(n, 3)``."""

    ids: np.ndarray
    image_points: np.ndarray
    board_points: np.ndarray


def find_board(image: np.ndarray, board: CalibrationBoard, detector: Any = None) -> BoardView | None:
    """The board's corners in ``image`` (grey or RGB uint8), or ``None`` when fewer than
    :data:`MIN_BOARD_CORNERS` are found or they lie on one row or one column. ``detector`` is a
    ``cv2.aruco.CharucoDetector`` of the board to reuse (one is made otherwise)."""
    grey = as_grey_image("image", image)
    cv2 = require_opencv()
    if detector is None:
        detector = cv2.aruco.CharucoDetector(board.opencv_board())
    corners, ids, _, _ = detector.detectBoard(grey)
    if ids is None or len(ids) < MIN_BOARD_CORNERS:
        return None
    ids = ids.ravel().astype(int)
    rows, cols = np.divmod(ids, board.squares_x - 1)
    if len(set(rows.tolist())) < 2 or len(set(cols.tolist())) < 2:  # a line of corners fixes no plane
        return None
    return BoardView(ids, corners.reshape(-1, 2).astype(float), board.corner_points()[ids])


def draw_board(board: CalibrationBoard, width: int, height: int) -> np.ndarray:
    """The board drawn on ``width`` x ``height`` pixels (uint8 grey, no margin): each square's edges
    rounded to the nearest pixel from the board's own scale, so the whole keeps its size within a
    pixel at any resolution; each marker centred in its white square."""
    cv2 = require_opencv()
    opencv_board = board.opencv_board()
    image = np.zeros((height, width), dtype=np.uint8)
    xs = np.round(np.arange(board.squares_x + 1) * width / board.squares_x).astype(int)
    ys = np.round(np.arange(board.squares_y + 1) * height / board.squares_y).astype(int)
    for corners, marker_id in zip(opencv_board.getObjPoints(), opencv_board.getIds()):
        col, row = (np.asarray(corners)[:, :2].mean(axis=0) // board.square_length).astype(int)
        x0, x1, y0, y1 = xs[col], xs[col + 1], ys[row], ys[row + 1]
        image[y0:y1, x0:x1] = 255
        side = int(round(board.marker_length / board.square_length * min(x1 - x0, y1 - y0)))
        marker = cv2.aruco.generateImageMarker(opencv_board.getDictionary(), int(marker_id), side, borderBits=1)
        top, left = y0 + (y1 - y0 - side) // 2, x0 + (x1 - x0 - side) // 2
        image[top : top + side, left : left + side] = marker
    return image


def board_image(board: CalibrationBoard, pixels_per_square: int) -> np.ndarray:
    """The board alone, uint8 grey, ``pixels_per_square`` pixels a square, no margin.

    Examples:
        >>> from occrl.perception.board import CalibrationBoard, board_image
        >>> image = board_image(CalibrationBoard(), 40)
        >>> image.shape, int(image[20, 20]), int(image[1, 41])  # the top-left square is black
        ((280, 200), 0, 255)
    """
    ppsq = strict_int("pixels_per_square", pixels_per_square, 8, 10_000)
    return draw_board(board, board.squares_x * ppsq, board.squares_y * ppsq)


def _font(px: int) -> ImageFont.ImageFont:
    try:
        return ImageFont.load_default(size=px)
    except TypeError:  # Pillow without FreeType sizes
        return ImageFont.load_default()


def board_page(board: CalibrationBoard, dpi: int = 300, page: str = "a4") -> Image.Image:
    """A page (grey, ``dpi`` pixels an inch) with the board centred at true size under a 50 mm
    scale bar and a line naming the board."""
    dpi = strict_int("dpi", dpi, 50, 2401)
    if page not in PAGE_SIZES_MM:
        raise ValueError(f"page must be one of {sorted(PAGE_SIZES_MM)}, got {page!r}")
    page_w, page_h = PAGE_SIZES_MM[page]
    board_w, board_h = (v * 1000 for v in board.size)
    header = 2.5 * LABEL_MM
    if board_w > page_w - 2 * MARGIN_MM or board_h > page_h - 2 * MARGIN_MM - header:
        raise ValueError(
            f"the board ({board_w:g} x {board_h:g} mm) does not fit the {page} page ({page_w:g} x {page_h:g} mm with "
            f"{MARGIN_MM:g} mm margins and the scale bar): use fewer or smaller squares"
        )
    image = Image.new("L", (mm_to_px(page_w, dpi), mm_to_px(page_h, dpi)), 255)
    draw = ImageDraw.Draw(image)
    margin, label = mm_to_px(MARGIN_MM, dpi), mm_to_px(LABEL_MM, dpi)
    draw.rectangle([margin, margin, margin + mm_to_px(BAR_MM, dpi) - 1, margin + label // 2], fill=0)
    text = f"{board.describe()}; print at 100 % (actual size): this bar is {BAR_MM:g} mm"
    draw.text((margin, margin + label), text, fill=0, font=_font(label))
    # the board's outline in pixels: rounding each edge, not each square, keeps the scale within a pixel
    width, height = mm_to_px(board_w, dpi), mm_to_px(board_h, dpi)
    drawn = draw_board(board, width, height)
    top = margin + mm_to_px(header, dpi) + (mm_to_px(page_h, dpi) - 2 * margin - mm_to_px(header, dpi) - height) // 2
    image.paste(Image.fromarray(drawn), ((image.width - width) // 2, top))
    return image


def write_board(board: CalibrationBoard, path: str | Path, dpi: int = 300, page: str = "a4") -> Path:
    """Write the board's page as a PDF or PNG (by the suffix of ``path``); returns the path."""
    path = Path(path)
    if path.suffix.lower() not in SHEET_SUFFIXES:
        raise ValueError(f"the board's file must end in .pdf or .png, got {path.name!r}")
    if not path.parent.is_dir():
        raise FileNotFoundError(f"the folder {path.parent} does not exist")
    image = board_page(board, dpi, page)
    if path.suffix.lower() == ".pdf":
        image.save(path, resolution=float(dpi))
    else:
        image.save(path, dpi=(dpi, dpi))
    return path
