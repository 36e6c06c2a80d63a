"""The tag catalogue: where a tag sits on its object, the file format, and clear errors."""

import json

import numpy as np
import pytest

from occrl.perception import TagCatalogue, TagEntry

from tests.perception.scenes import box, catalogue


def test_side_tag_sits_on_its_face_facing_out():
    entry = TagEntry(0, 3, box(0.025), 0.12, 1, (0.005, 0.07), 0.03)  # face 1: the edge x = 0.025
    corners = entry.corners_in_object
    np.testing.assert_allclose(corners[:, 0], 0.025)
    np.testing.assert_allclose(entry.tag_in_object[:3, 2], [1, 0, 0], atol=1e-12)  # out of the face
    np.testing.assert_allclose(entry.tag_in_object[:3, 1], [0, 0, 1], atol=1e-12)  # reads upright
    # top-left, top-right, bottom-right, bottom-left seen from outside (looking along -x)
    np.testing.assert_allclose(corners[:, 1], [-0.01, 0.02, 0.02, -0.01], atol=1e-12)
    np.testing.assert_allclose(corners[:, 2], [0.085, 0.085, 0.055, 0.055], atol=1e-12)


def test_top_tag():
    entry = TagEntry(1, 3, box(0.025), 0.12, "top", (0.0, 0.005), 0.03)
    np.testing.assert_allclose(entry.corners_in_object[:, 2], 0.12)
    with pytest.raises(ValueError, match="does not fit on the top"):
        TagEntry(1, 3, box(0.025), 0.12, "top", (0.015, 0.0), 0.03)


def test_clockwise_footprint_is_turned():
    entry = TagEntry(0, 3, box(0.025)[::-1], 0.12, 0, (0.0, 0.07), 0.03)
    assert entry.footprint == tuple(tuple(v) for v in box(0.025))


def test_json_round_trip(tmp_path):
    cat = catalogue()
    cat.to_json(tmp_path / "tags.json")
    again = TagCatalogue.from_json(tmp_path / "tags.json")
    assert again.to_dict() == cat.to_dict()
    assert [e.tag_id for e in again] == [0, 1, 2, 3, 10]
    assert again.type_ids == [3, 5] and again[10].type_id == 5 and 4 not in again and again.get(4) is None
    with pytest.raises(KeyError, match=r"tag 4 is not in the catalogue \(ids: \[0, 1, 2, 3, 10\]\)"):
        again[4]


def tag(**change):
    return {"tag_id": 0, "face": 0, "offset": [0.0, 0.05], "size": 0.03, **change}


def obj(tags, **change):
    return {"type_id": 3, "height": 0.1, "footprint": box(0.025), "tags": tags, **change}


@pytest.mark.parametrize(
    "data, message",
    [
        ({"objects": [obj([tag(), tag()])]}, "tag 0 is listed twice"),
        ({"objects": [obj([tag(tag_id=587)])]}, r"tag 587 is not in apriltag_36h11, whose ids are 0-586"),
        ({"objects": [obj([tag()]), obj([tag(tag_id=1)], height=0.2)]}, "tags 0 and 1 of type 3 give it different footprints or heights"),
        ({"objects": [obj([tag(size=0.06)])]}, r"objects\[0\]: tag 0: a 0.06 m tag at along = 0 m does not fit face 0"),
        ({"objects": [obj([tag(offset=[0.0, 0.095])])]}, "centred 0.095 m up does not fit a face 0.1 m high"),
        ({"objects": [obj([tag(face=4)])]}, r"face must be 'top' or a side face 0-3"),
        ({"objects": [obj([tag(face="side")])]}, r"face must be 'top' or a side face 0-3 .*got 'side'"),
        ({"objects": [obj([tag()], type_id=0)]}, r"type_id must be in \[1, 1000000\), got 0"),
        ({"objects": [obj([tag()], footprint=[[0, 0], [1, 1]])]}, "a polygon needs 3 to 8 vertices, got 2"),
        ({"objects": [obj([tag()], footprint=[[0, 0], [0.1, 0], [0.05, 0.01], [0.1, 0.1], [0, 0.1]])]}, "not strictly convex"),
        ({"objects": [obj([tag(colour="red")])]}, r"tags\[0\] has unknown keys \['colour'\]"),
        ({"objects": [obj([{"tag_id": 0, "face": 0, "size": 0.03}])]}, r"tags\[0\] is missing \['offset'\]"),
        ({"objects": [obj([])]}, "'tags' must be a non-empty list"),
        ({"objects": [obj([tag()])], "dictionary": "qr"}, r"unknown tag dictionary 'qr'; allowed: \['apriltag_16h5'"),
        ({"tags": []}, "must hold {'dictionary': ..., 'objects': \\[...\\]}"),
    ],
)
def test_bad_catalogue_is_named(tmp_path, data, message):
    path = tmp_path / "tags.json"
    path.write_text(json.dumps(data))
    with pytest.raises((ValueError, TypeError), match=message):
        TagCatalogue.from_json(path)


def test_missing_file():
    with pytest.raises(FileNotFoundError, match="catalogue file nowhere.json does not exist"):
        TagCatalogue.from_json("nowhere.json")


def test_a_catalogue_value_of_the_wrong_type_is_a_value_error_the_cli_reports(tmp_path, capsys):
    from occrl.cli import main

    path = tmp_path / "tags.json"
    path.write_text(json.dumps({"objects": [obj([tag()], height="0.12")]}))
    with pytest.raises(ValueError, match=r"objects\[0\]"):
        TagCatalogue.from_json(path)
    assert main(["tags", str(path), "--out", str(tmp_path / "sheet.png")]) == 2
    assert "occrl tags: error:" in capsys.readouterr().err
