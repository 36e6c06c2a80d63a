"""The tag catalogue: which tag sits where on which object.

Each object type carries one or more square tags. The object frame is the one its footprint is
given in (the planar pose's frame, as ``occrl.envs.perception.observation_from_detections`` takes
it), with its origin on the object's base and +z up; the object is a prism of ``height`` over its
``footprint``.

A tag sits on a side face or on the top:

* ``face = k`` (an int): the side face over the footprint edge from vertex k to vertex k + 1
  (counter-clockwise order); ``offset = (along, up)``: the tag centre's distance from the edge's
  midpoint towards vertex k + 1 and its height above the base (m). The tag reads upright seen from
  outside: its x axis runs along the edge, its y axis up, its z axis out of the face.
* ``face = "top"``: ``offset = (x, y)``, the tag centre in the object frame; its x and y axes are the
  object's.

``size`` is the side of the tag's black square (m), OpenCV's and AprilTag's tag size.

A catalogue file (JSON)::

    {"dictionary": "apriltag_36h11",
     "objects": [{"type_id": 3, "height": 0.12,
                  "footprint": [[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]],
                  "tags": [{"tag_id": 0, "face": 0, "offset": [0.0, 0.06], "size": 0.03}]}]}
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any, Iterator, Sequence

import numpy as np

from occrl.perception.checks import check_keys, convex_footprint, finite_array, positive_number, strict_int
from occrl.perception.opencv import DEFAULT_DICTIONARY, check_dictionary

__all__ = ["TagEntry", "TagCatalogue", "MAX_TYPE_ID", "TAG_KEYS", "OBJECT_KEYS"]

MAX_TYPE_ID = 1_000_000  # occrl's type ids lie in [1, MAX_TYPE_ID) (occrl.envs.observation)
TAG_KEYS = ("tag_id", "face", "offset", "size")
OBJECT_KEYS = ("type_id", "height", "footprint", "tags")
FIT_TOLERANCE = 1e-9


@dataclass(frozen=True)
class TagEntry:
    """One tag of the catalogue and the object it sits on (conventions in
    :mod:`occrl.perception.catalogue`); checked when made.

    Examples:
        >>> from occrl.perception import TagEntry
        >>> box = [[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]]
        >>> tag = TagEntry(tag_id=5, type_id=3, footprint=box, height=0.12, face=0, offset=(0.0, 0.06), size=0.03)
        >>> tag.tag_in_object[:3, 3].tolist()  # the centre of the face under the edge y = -0.02
        [0.0, -0.02, 0.06]
        >>> TagEntry(5, 3, box, 0.12, 0, (0.0, 0.06), 0.05)
        Traceback (most recent call last):
        ...
        ValueError: tag 5: a 0.05 m tag at along = 0 m does not fit face 0, an edge of 0.04 m
    """

    tag_id: int
    type_id: int
    footprint: tuple[tuple[float, float], ...]
    height: float
    face: int | str
    offset: tuple[float, float]
    size: float

    def __post_init__(self) -> None:
        tag_id = strict_int("tag_id", self.tag_id, 0, 2**31)
        name = f"tag {tag_id}"
        type_id = strict_int(f"{name}: type_id", self.type_id, 1, MAX_TYPE_ID)
        footprint = convex_footprint(f"{name}: footprint", self.footprint)
        height = positive_number(f"{name}: height", self.height, "m")
        size = positive_number(f"{name}: size", self.size, "m, the side of the tag's black square")
        offset = finite_array(f"{name}: offset", self.offset, (2,), "(along, up) for a side face or (x, y) for the top, in metres")
        face = self.face
        n = len(footprint)
        if face == "top":
            corners = offset + size / 2 * np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]])
            edges = np.roll(footprint, -1, axis=0) - footprint
            rel = corners[:, None, :] - footprint[None]
            inside = edges[None, :, 0] * rel[..., 1] - edges[None, :, 1] * rel[..., 0] >= -FIT_TOLERANCE
            if not inside.all():
                raise ValueError(
                    f"{name}: a {size} m tag centred at {offset.tolist()} does not fit on the top of footprint {footprint.tolist()}"
                )
        elif isinstance(face, (int, np.integer)) and not isinstance(face, (bool, np.bool_)):
            if not 0 <= face < n:
                raise ValueError(f"{name}: face must be 'top' or a side face 0-{n - 1} (the edge from vertex k to k + 1), got {face}")
            edge = float(np.linalg.norm(footprint[(face + 1) % n] - footprint[face]))
            along, up = offset
            if abs(along) + size / 2 > edge / 2 + FIT_TOLERANCE:
                raise ValueError(f"{name}: a {size:g} m tag at along = {along:g} m does not fit face {face}, an edge of {edge:.3g} m")
            if not size / 2 - FIT_TOLERANCE <= up <= height - size / 2 + FIT_TOLERANCE:
                raise ValueError(f"{name}: a {size:g} m tag centred {up:g} m up does not fit a face {height:g} m high")
            face = int(face)
        else:
            raise ValueError(f"{name}: face must be 'top' or a side face 0-{n - 1} (the edge from vertex k to k + 1), got {face!r}")
        object.__setattr__(self, "tag_id", tag_id)
        object.__setattr__(self, "type_id", type_id)
        object.__setattr__(self, "footprint", tuple((float(x), float(y)) for x, y in footprint))
        object.__setattr__(self, "height", height)
        object.__setattr__(self, "face", face)
        object.__setattr__(self, "offset", (float(offset[0]), float(offset[1])))
        object.__setattr__(self, "size", size)

    @cached_property
    def tag_in_object(self) -> np.ndarray:
        """The 4x4 pose of the tag frame (OpenCV's: centre, x right, y up, z out of the tag) in the
        object frame (read-only)."""
        t = np.eye(4)
        if self.face == "top":
            t[:3, 3] = [self.offset[0], self.offset[1], self.height]
            t.flags.writeable = False
            return t
        fp = np.array(self.footprint)
        a, b = fp[self.face], fp[(self.face + 1) % len(fp)]
        e = (b - a) / np.linalg.norm(b - a)
        x_axis = np.array([e[0], e[1], 0.0])
        z_axis = np.array([e[1], -e[0], 0.0])  # outward: right of a counter-clockwise edge
        t[:3, :3] = np.stack([x_axis, [0.0, 0.0, 1.0], z_axis], axis=1)
        mid = (a + b) / 2 + self.offset[0] * e
        t[:3, 3] = [mid[0], mid[1], self.offset[1]]
        t.flags.writeable = False
        return t

    @cached_property
    def corners_in_tag(self) -> np.ndarray:
        """(4, 3) the tag's corners in its own frame, in OpenCV's order: top-left, top-right,
        bottom-right, bottom-left as the tag reads (read-only)."""
        s = self.size / 2
        corners = np.array([[-s, s, 0.0], [s, s, 0.0], [s, -s, 0.0], [-s, -s, 0.0]])
        corners.flags.writeable = False
        return corners

    @cached_property
    def corners_in_object(self) -> np.ndarray:
        """(4, 3) the tag's corners in the object frame (order of :attr:`corners_in_tag`; read-only)."""
        t = self.tag_in_object
        corners = self.corners_in_tag @ t[:3, :3].T + t[:3, 3]
        corners.flags.writeable = False
        return corners


class TagCatalogue:
    """The tags of a set of objects, looked up by tag id (format in :mod:`occrl.perception.catalogue`).

    Tag ids are unique and lie in the dictionary; the tags of one type agree on its footprint and
    height.

    Examples:
        >>> from occrl.perception import TagCatalogue
        >>> box = [[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]]
        >>> catalogue = TagCatalogue.from_dict({"objects": [{"type_id": 3, "height": 0.12, "footprint": box,
        ...     "tags": [{"tag_id": 0, "face": 0, "offset": [0.0, 0.06], "size": 0.03},
        ...              {"tag_id": 1, "face": "top", "offset": [0.0, 0.0], "size": 0.03}]}]})
        >>> len(catalogue), catalogue[1].type_id, catalogue.get(7), [t.tag_id for t in catalogue.tags_of(3)]
        (2, 3, None, [0, 1])
    """

    def __init__(self, entries: Sequence[TagEntry], dictionary: str = DEFAULT_DICTIONARY) -> None:
        info = check_dictionary(dictionary)
        self.dictionary = dictionary
        self._entries: dict[int, TagEntry] = {}
        shapes: dict[int, TagEntry] = {}
        for entry in entries:
            if not isinstance(entry, TagEntry):
                raise TypeError(f"a catalogue holds TagEntry items, got {type(entry).__name__}")
            if entry.tag_id >= info.size:
                raise ValueError(f"tag {entry.tag_id} is not in {dictionary}, whose ids are 0-{info.size - 1}")
            if entry.tag_id in self._entries:
                raise ValueError(f"tag {entry.tag_id} is listed twice; a tag id names one tag")
            first = shapes.setdefault(entry.type_id, entry)
            if (first.footprint, first.height) != (entry.footprint, entry.height):
                raise ValueError(
                    f"tags {first.tag_id} and {entry.tag_id} of type {entry.type_id} give it different footprints or heights; one type has one shape"
                )
            self._entries[entry.tag_id] = entry

    def __len__(self) -> int:
        return len(self._entries)

    def __iter__(self) -> Iterator[TagEntry]:
        return iter(sorted(self._entries.values(), key=lambda e: e.tag_id))

    def __contains__(self, tag_id: object) -> bool:
        return tag_id in self._entries

    def __getitem__(self, tag_id: int) -> TagEntry:
        try:
            return self._entries[tag_id]
        except KeyError:
            raise KeyError(f"tag {tag_id} is not in the catalogue (ids: {sorted(self._entries)})") from None

    def get(self, tag_id: int) -> TagEntry | None:
        """The entry of ``tag_id``, or None when the catalogue has no such tag."""
        return self._entries.get(tag_id)

    @property
    def type_ids(self) -> list[int]:
        """The object types, sorted."""
        return sorted({e.type_id for e in self._entries.values()})

    def tags_of(self, type_id: int) -> list[TagEntry]:
        """The tags of one object type, by tag id."""
        return [e for e in self if e.type_id == type_id]

    def to_dict(self) -> dict[str, Any]:
        """The catalogue file's content (JSON-ready)."""
        objects = []
        for type_id in self.type_ids:
            tags = self.tags_of(type_id)
            objects.append(
                {
                    "type_id": type_id,
                    "height": tags[0].height,
                    "footprint": [list(v) for v in tags[0].footprint],
                    "tags": [{"tag_id": t.tag_id, "face": t.face, "offset": list(t.offset), "size": t.size} for t in tags],
                }
            )
        return {"dictionary": self.dictionary, "objects": objects}

    @classmethod
    def from_dict(cls, data: Any, source: str = "catalogue") -> "TagCatalogue":
        """The catalogue of a catalogue file's content; ``ValueError`` naming what is wrong where."""
        if not isinstance(data, dict) or not isinstance(data.get("objects"), list):
            raise ValueError(f"{source} must hold {{'dictionary': ..., 'objects': [...]}}, got {type(data).__name__}")
        check_keys(source, data, ("objects",), ("dictionary",))
        entries = []
        for i, obj in enumerate(data["objects"]):
            where = f"{source}: objects[{i}]"
            if not isinstance(obj, dict):
                raise ValueError(f"{where} must be a mapping with the keys {list(OBJECT_KEYS)}, got {obj!r}")
            check_keys(where, obj, OBJECT_KEYS)
            if not isinstance(obj["tags"], list) or not obj["tags"]:
                raise ValueError(f"{where}: 'tags' must be a non-empty list of tags, got {obj['tags']!r}")
            for j, tag in enumerate(obj["tags"]):
                if not isinstance(tag, dict):
                    raise ValueError(f"{where}: tags[{j}] must be a mapping with the keys {list(TAG_KEYS)}, got {tag!r}")
                check_keys(f"{where}: tags[{j}]", tag, TAG_KEYS)
                try:
                    entries.append(
                        TagEntry(tag["tag_id"], obj["type_id"], obj["footprint"], obj["height"], tag["face"], tag["offset"], tag["size"])
                    )
                except (TypeError, ValueError) as err:  # a file's bad value is bad input
                    raise ValueError(f"{where}: {err}") from None
        try:
            return cls(entries, data.get("dictionary", DEFAULT_DICTIONARY))
        except ValueError as err:
            raise ValueError(f"{source}: {err}") from None

    @classmethod
    def from_json(cls, path: str | Path) -> "TagCatalogue":
        """Read a catalogue file."""
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"catalogue file {path} does not exist")
        try:
            data = json.loads(path.read_text())
        except json.JSONDecodeError as err:
            raise ValueError(f"catalogue file {path} is not valid JSON: {err}") from None
        return cls.from_dict(data, source=f"catalogue file {path}")

    def to_json(self, path: str | Path) -> None:
        """Write the catalogue file."""
        Path(path).write_text(json.dumps(self.to_dict(), indent=2) + "\n")
