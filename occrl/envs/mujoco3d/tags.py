"""Fiducial tags on the MuJoCo objects: where each tag sits and its texture in the model.

Each object carries one AprilTag (36h11 family, :mod:`occrl.perception`'s default dictionary) on every side
face wide enough for one, centred on the face at the wrist camera's height (or two side by side,
one centred on each half of the face, where the :class:`TagLayout` asks for pairs): the faces the gripper
camera sees (it sits below every object's top, so top faces are never in view). A tag's black
square is as wide as the face holds, within the :class:`TagLayout`'s sizes (by default 8 mm to
:data:`MAX_TAG_SIZE`), and is printed with a white border of one cell (an eighth of the square) on
a 0.2 mm card set into the face, its print 0.05 mm out of it (the catalogue puts the tag on the
face: a 0.05 mm offset, far below what the camera resolves). A face narrower than the smallest tag
with its border and the layout's clearance either side carries none. :data:`TAG_LAYOUTS` names
the layouts ``make_env(world="mujoco", perception="tags", tag_layout=...)`` and ``occrl eval
--tag-layout`` take; :data:`DEFAULT_TAG_LAYOUT` is theirs by default.

Tag ids follow the object's type: tag ``(type_id - 1) * 8 + face``, where face ``k`` runs from
vertex ``k`` to vertex ``k + 1`` of the type's counter-clockwise polygon, so a type always wears
the same tags (type ids 1 to :data:`MAX_TAGGED_TYPE`). The second tag of a pair, on the face's
half towards vertex ``k + 1``, is tag :data:`SECOND_TAG_BASE` ``+ (type_id - 1) * 8 + face``, so
layouts with pairs tag type ids 1 to :data:`MAX_PAIRED_TYPE` (the first tag of a pair keeps the
single tag's id).

The tag cards are visual only: geom group 3 (hidden from the visibility render and rays), no
contacts and no mass (the compiler's ``inertiagrouprange`` leaves group 3 out), so the physics and
the geometric visibility are those of the model without tags, bit for bit.

Tag frame (as OpenCV's ArUco pose estimation reports it): origin at the centre of the black
square, x to the right and y up as seen from the front, z out of the face towards the viewer.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from occrl.envs import world_constants as C
from occrl.envs.scene import Scene
from occrl.perception.opencv import require_opencv
from occrl.perception.synthetic import tag_texture

__all__ = [
    "MIN_TAG_SIZE",
    "MAX_TAG_SIZE",
    "FACE_CLEARANCE",
    "TAG_CENTRE_Z",
    "TAG_GROUP",
    "MAX_TAGGED_TYPE",
    "SECOND_TAG_BASE",
    "MAX_PAIRED_TYPE",
    "TagLayout",
    "TAG_LAYOUTS",
    "DEFAULT_TAG_LAYOUT",
    "as_tag_layout",
    "TagPlacement",
    "tag_id",
    "tag_placements",
    "add_tags",
]

MIN_TAG_SIZE = 0.008  # m, side of the black square (1 mm cells: still sharp from a 300 dpi print)
MAX_TAG_SIZE = 0.060  # m: larger faces still carry a 6 cm tag (its card fits the shortest object, 10 cm)
BORDER_CELLS = 1  # white border around the black square, in cells (the square is 8 cells wide)
FACE_CLEARANCE = 0.0005  # m kept free between the border and each vertical edge of the face
TAG_CENTRE_Z = 0.07  # m above the shelf floor: the wrist camera's height
CARD_THICKNESS = 0.0002
CARD_STANDOFF = 0.00005  # the print stands this far out of the face (no depth fighting with it)
TAG_GROUP = 3  # geom group of the tag cards: drawn in the RGB image only
MAX_TAGGED_TYPE = 587 // C.MAX_VERTICES  # 73: the ids of every face of types 1..73 are in the family
SECOND_TAG_BASE = 587 // 2  # 293: ids of the second tags of pairs start here
MAX_PAIRED_TYPE = SECOND_TAG_BASE // C.MAX_VERTICES  # 36: the first and second ids of types 1..36 never meet
CELL_PIXELS = 12  # texture pixels per cell


@dataclass(frozen=True)
class TagLayout:
    """How large the objects' tags are: each face carries the largest tag it holds with its
    border and ``clearance`` either side, at most ``max_size``; a face that cannot hold a
    ``min_size`` tag carries none. With ``pair_size``, a face whose halves each hold a tag of at
    least ``pair_size`` carries two, the largest each half holds (at most ``max_size``): one of
    them stays whole when an object in front hides half the face. Sizes are the black square's
    side in metres.

    Examples:
        >>> from occrl.envs.mujoco3d.tags import TAG_LAYOUTS, TagLayout
        >>> TAG_LAYOUTS["fitted"] == TagLayout(), TAG_LAYOUTS["at-most-3cm"].max_size
        (True, 0.03)
        >>> TagLayout(min_size=0.05, max_size=0.03)
        Traceback (most recent call last):
            ...
        ValueError: a TagLayout needs 0.004 <= min_size <= max_size <= 0.1 m, got min_size=0.05, max_size=0.03
        >>> layout = TagLayout(pair_size=0.02)
        >>> layout.tags_on_face(0.04), layout.tags_on_face(0.06)  # (along, size): one tag, then a pair
        ([(0.0, 0.0312)], [(-0.015, 0.0232), (0.015, 0.0232)])
    """

    min_size: float = MIN_TAG_SIZE
    max_size: float = MAX_TAG_SIZE
    clearance: float = FACE_CLEARANCE
    pair_size: float | None = None

    def __post_init__(self) -> None:
        for name in ("min_size", "max_size", "clearance") + (("pair_size",) if self.pair_size is not None else ()):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ValueError(f"TagLayout.{name} must be a finite number of metres, got {value!r}")
        if not 0.004 <= self.min_size <= self.max_size <= 0.1:
            raise ValueError(
                f"a TagLayout needs 0.004 <= min_size <= max_size <= 0.1 m, got min_size={self.min_size}, max_size={self.max_size}"
            )
        if not 0.0 <= self.clearance <= 0.01:
            raise ValueError(f"TagLayout.clearance must be in [0, 0.01] m, got {self.clearance}")
        if self.pair_size is not None and not self.min_size <= self.pair_size <= self.max_size:
            raise ValueError(
                f"TagLayout.pair_size must be None or in [min_size, max_size] = [{self.min_size}, {self.max_size}] m, got {self.pair_size}"
            )

    def tag_size(self, face_length: float) -> float | None:
        """The side of the tag a face of this length carries (None: too narrow for any)."""
        size = (face_length - 2.0 * self.clearance) / (1.0 + 2.0 * BORDER_CELLS / 8.0)
        if size < self.min_size:
            return None
        return min(size, self.max_size)

    def tags_on_face(self, face_length: float) -> list[tuple[float, float]]:
        """The tags a face of this length carries: ``(along, size)`` each, ``along`` the tag
        centre's distance from the face's midpoint towards its second vertex (m); an empty list
        when none fits."""
        if self.pair_size is not None:
            half = self.tag_size(face_length / 2)
            if half is not None and half >= self.pair_size:
                return [(-face_length / 4, half), (face_length / 4, half)]
        size = self.tag_size(face_length)
        return [] if size is None else [(0.0, size)]


TAG_LAYOUTS = {
    "fitted": TagLayout(),  # each tag as wide as its face allows, 8 mm to 6 cm
    "at-most-3cm": TagLayout(min_size=0.010, max_size=0.030, clearance=0.002),  # one common printed size, no small ones
    "pairs": TagLayout(pair_size=0.015),  # two tags on faces whose halves hold 1.5 cm ones (faces of 3.95 cm and more)
}
DEFAULT_TAG_LAYOUT = "pairs"  # make_env's and occrl eval's: the highest recall of the three


def as_tag_layout(layout: str | TagLayout) -> TagLayout:
    """A :class:`TagLayout`, or the one of :data:`TAG_LAYOUTS` named ``layout``."""
    if isinstance(layout, TagLayout):
        return layout
    if isinstance(layout, str) and layout in TAG_LAYOUTS:
        return TAG_LAYOUTS[layout]
    raise ValueError(f"tag_layout must be a TagLayout or one of {sorted(TAG_LAYOUTS)}, got {layout!r}")


@dataclass(frozen=True)
class TagPlacement:
    """One tag on one object: its id, the object (scene index and type), the face it is on, the
    side of its black square (m), its centre's distance from the face's midpoint towards the
    face's second vertex (m, 0 for a single tag), its centre's height above the object's base (m)
    and its pose in the object body's frame (centroid frame, z up from the object's mid-height),
    ``tag_to_object`` (4 x 4; the tag frame of the module docstring, the print's surface)."""

    tag_id: int
    object_index: int
    type_id: int
    face: int
    size: float
    along: float
    up: float
    tag_to_object: np.ndarray

    @property
    def card_width(self) -> float:
        """Side of the printed card: the black square and its white border."""
        return self.size * (1.0 + 2.0 * BORDER_CELLS / 8.0)


def tag_id(type_id: int, face: int, second: bool = False) -> int:
    """The tag id of face ``face`` of type ``type_id`` (``second``: the second tag of a pair).

    Examples:
        >>> from occrl.envs.mujoco3d.tags import tag_id
        >>> tag_id(1, 0), tag_id(3, 2), tag_id(3, 2, second=True)
        (0, 18, 311)
    """
    last = MAX_PAIRED_TYPE if second else MAX_TAGGED_TYPE
    if isinstance(type_id, bool) or not isinstance(type_id, (int, np.integer)) or not 1 <= type_id <= last:
        per_type = "16 per type with pairs" if second else "8 per type"
        raise ValueError(f"tagged objects need a type id in [1, {last}] (the 36h11 family has 587 tags, {per_type}), got {type_id!r}")
    if not 0 <= face < C.MAX_VERTICES:
        raise ValueError(f"face must be in [0, {C.MAX_VERTICES}), got {face!r}")
    return (SECOND_TAG_BASE if second else 0) + (int(type_id) - 1) * C.MAX_VERTICES + int(face)


def tag_placements(scene: Scene, heights: np.ndarray, layout: TagLayout = TagLayout()) -> list[TagPlacement]:
    """Every tag of a scene's objects (``heights``: each object's height in m), placed by ``layout``
    (here one tag per face unless given; the envs' default is :data:`DEFAULT_TAG_LAYOUT`).

    Examples:
        >>> import numpy as np
        >>> from occrl.envs import Scene
        >>> from occrl.envs.mujoco3d.tags import tag_placements
        >>> box = [[-0.03, -0.02], [0.03, -0.02], [0.03, 0.02], [-0.03, 0.02]]
        >>> scene = Scene.from_objects([{"vertices": box, "pose": (0.0, 0.2, 0.0), "is_target": True, "type_id": 2}])
        >>> tags = tag_placements(scene, np.array([0.12]))
        >>> [(t.tag_id, t.face, round(t.size, 4)) for t in tags]  # as wide as each face allows
        [(8, 0, 0.0472), (9, 1, 0.0312), (10, 2, 0.0472), (11, 3, 0.0312)]
        >>> tags[0].up, tags[0].tag_to_object[:3, 3].round(5).tolist()  # 7 cm up: 1 cm above mid-height, on the front face
        (0.07, [0.0, -0.02005, 0.01])
        >>> [round(t.size, 4) for t in tag_placements(scene, np.array([0.12]), TAG_LAYOUTS["at-most-3cm"])]  # 1 to 3 cm
        [0.03, 0.0288, 0.03, 0.0288]
        >>> [(t.tag_id, t.face, round(t.along, 4)) for t in tag_placements(scene, np.array([0.12]), TagLayout(pair_size=0.02))]
        [(8, 0, -0.015), (301, 0, 0.015), (9, 1, 0.0), (10, 2, -0.015), (303, 2, 0.015), (11, 3, 0.0)]
    """
    heights = np.asarray(heights, dtype=float).reshape(-1)
    if len(heights) != len(scene.objects):
        raise ValueError(f"heights must hold one height per object ({len(scene.objects)}), got {len(heights)}")
    if layout.pair_size is not None:
        too_high = sorted({o.type_id for o in scene.objects if o.type_id > MAX_PAIRED_TYPE})
        if too_high:
            raise ValueError(
                f"a TagLayout with pairs tags type ids 1 to {MAX_PAIRED_TYPE} (16 tags per type), the scene has type ids {too_high}; "
                "one tag per face (tag_layout='fitted') tags type ids up to 73"
            )
    out = []
    for i, (o, h) in enumerate(zip(scene.objects, heights)):
        v = np.asarray(o.vertices, dtype=float)
        for k in range(len(v)):
            a, b = v[k], v[(k + 1) % len(v)]
            length = float(np.hypot(*(b - a)))
            e = (b - a) / length
            n = np.array([e[1], -e[0]])  # outward normal of a counter-clockwise polygon
            for slot, (along, size) in enumerate(layout.tags_on_face(length)):
                card = size * (1.0 + 2.0 * BORDER_CELLS / 8.0)
                # centre height: the camera's, kept on the face (objects are at least 10 cm tall)
                up = min(max(TAG_CENTRE_Z, card / 2), h - card / 2)
                centre = (a + b) / 2 + e * along + n * CARD_STANDOFF
                pose = np.eye(4)
                pose[:3, 0] = (e[0], e[1], 0.0)  # right, seen from the front
                pose[:3, 1] = (0.0, 0.0, 1.0)  # up
                pose[:3, 2] = (n[0], n[1], 0.0)  # out of the face
                pose[:3, 3] = (centre[0], centre[1], up - h / 2)
                out.append(TagPlacement(tag_id(o.type_id, k, second=slot == 1), i, int(o.type_id), k, size, along, up, pose))
    return out


def add_tags(root, placements: list[TagPlacement]) -> None:
    """Add the tag cards to a dm_control ``mjcf`` model whose object bodies are named ``obj{i}``
    (:func:`~occrl.envs.mujoco3d.model.build_mjcf`): a textured box per tag in geom group
    :data:`TAG_GROUP`, without contacts or mass."""
    from occrl.envs.mujoco3d.camera import require_mujoco

    _, mjcf = require_mujoco()
    cv2 = require_opencv()
    root.compiler.inertiagrouprange = (0, TAG_GROUP - 1)  # the cards add no mass or inertia
    for p in placements:
        name = f"tag{p.tag_id}"
        if root.find("texture", name) is None:
            image = tag_texture(p.tag_id, CELL_PIXELS, margin_cells=BORDER_CELLS)
            ok, png = cv2.imencode(".png", np.repeat(image[..., None], 3, axis=-1))
            if not ok:  # pragma: no cover - OpenCV failing to encode a small image
                raise RuntimeError(f"OpenCV could not encode the texture of tag {p.tag_id}")
            texture = root.asset.add("texture", name=name, type="2d", file=mjcf.Asset(png.tobytes(), ".png"))
            root.asset.add("material", name=name, texture=texture, specular=0.0, shininess=0.0, reflectance=0.0)
        body = root.find("body", f"obj{p.object_index}")
        half = p.card_width / 2
        # the card's -y face is the printed one: local x right, -y out of the face, z up
        centre = p.tag_to_object[:3, 3] - p.tag_to_object[:3, 2] * (CARD_THICKNESS / 2)
        yaw = math.atan2(p.tag_to_object[1, 0], p.tag_to_object[0, 0])
        body.add(
            "geom",
            name=f"{name}_obj{p.object_index}",
            type="box",
            size=(half, CARD_THICKNESS / 2, half),
            pos=centre,
            euler=(0.0, 0.0, yaw),
            material=name,
            rgba=(1.0, 1.0, 1.0, 1.0),
            group=TAG_GROUP,
            contype=0,
            conaffinity=0,
            mass=0.0,
        )
