"""``occrl tags``: the sheet's tags at true size, decodable, labelled; bad input named."""

import re

import numpy as np
import pytest
from PIL import Image

from occrl.cli import main
from occrl.perception import CameraModel, TagDetector
from occrl.perception.sheet import sheet_pages, tag_pixels

from tests.perception.scenes import catalogue

pytest.importorskip("cv2")


def test_png_tags_measure_their_size_and_decode(tmp_path, capsys):
    cat = catalogue()
    cat.to_json(tmp_path / "tags.json")
    assert main(["tags", str(tmp_path / "tags.json"), "--out", str(tmp_path / "sheet.png"), "--dpi", "300"]) == 0
    assert "5 tags of 2 object types on 1 file(s)" in capsys.readouterr().out
    sheet = Image.open(tmp_path / "sheet.png")
    assert sheet.size == (2480, 3508)  # A4 at 300 dpi
    assert sheet.info["dpi"] == pytest.approx((300, 300), abs=0.01)
    image = np.asarray(sheet.convert("L"))[:1500]  # the top 12.7 cm: the two rows of tags
    detector = TagDetector(CameraModel.from_fov(image.shape[1], image.shape[0], 60.0), cat)
    tags = detector.detect_tags(image)
    assert [t["tag_id"] for t in tags] == [0, 1, 2, 3, 10]
    expected = 30 / 25.4 * 300  # 30 mm at 300 dpi: 354.3 pixels
    assert tag_pixels(cat[0], 300) == 354
    for tag in tags:
        sides = np.linalg.norm(np.roll(tag["corners"], -1, axis=0) - tag["corners"], axis=1)
        assert np.abs(sides - expected).max() <= 1.5, (tag["tag_id"], sides)


def test_pdf_page_is_a4_at_true_scale(tmp_path):
    cat = catalogue()
    cat.to_json(tmp_path / "tags.json")
    assert main(["tags", str(tmp_path / "tags.json"), "--out", str(tmp_path / "sheet.pdf")]) == 0
    data = (tmp_path / "sheet.pdf").read_bytes()
    assert data.startswith(b"%PDF")
    (box,) = re.findall(rb"/MediaBox \[ ?0 0 ([\d.]+) ([\d.]+) ?\]", data)
    assert [float(v) for v in box] == pytest.approx([595.3, 841.9], abs=0.2)  # A4 in points


def test_many_tags_fill_several_pages():
    objects = [
        {
            "type_id": t + 1,
            "height": 0.1,
            "footprint": [[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]],
            "tags": [{"tag_id": t, "face": 0, "offset": [0.0, 0.05], "size": 0.03}],
        }
        for t in range(30)
    ]
    cat = catalogue(objects)
    pages = sheet_pages(cat, dpi=100)
    assert len(pages) == 2
    detector = TagDetector(CameraModel.from_fov(pages[0].width, pages[0].height, 60.0), cat)
    found = [t["tag_id"] for page in pages for t in detector.detect_tags(np.asarray(page))]
    assert sorted(found) == list(range(30))


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--out", "{tmp}/sheet.jpg"], "the sheet's file must end in .pdf or .png, got 'sheet.jpg'"),
        (["--out", "{tmp}/no/sheet.png"], "does not exist"),
        (["--out", "{tmp}/sheet.png", "--dpi", "10"], "argument --dpi: 10 is out of range; allowed: an integer in [50, 2400]"),
    ],
)
def test_bad_input_is_named(tmp_path, capsys, argv, message):
    catalogue().to_json(tmp_path / "tags.json")
    code = main(["tags", str(tmp_path / "tags.json")] + [a.format(tmp=tmp_path) for a in argv])
    assert code == 2 and message in capsys.readouterr().err
    assert not list(tmp_path.glob("sheet*"))


def test_missing_catalogue_is_named(tmp_path, capsys):
    assert main(["tags", str(tmp_path / "none.json"), "--out", str(tmp_path / "s.png")]) == 2
    assert "occrl tags: error: catalogue file" in capsys.readouterr().err
