"""From a wrist-camera image to occrl's detections: decode the tags, estimate their poses, and
turn each object's tags into its planar pose in the shelf frame.

:meth:`TagDetector.detect` returns exactly what ``occrl.envs.perception.observation_from_detections``
takes: one ``{"type_id": int, "pose": (x, y, theta), "vertices": [[x, y], ...]}`` per object seen,
the pose in the shelf frame and the vertices the catalogue's footprint about it.

How a pose is chosen (each tag's pose is ambiguous: a square seen small or face-on has two poses that
project almost alike, OpenCV's IPPE returns both):

1. each decoded tag of the catalogue gives one or two object poses: IPPE's best and, when it
   reprojects within :data:`AMBIGUITY_PX` pixels of the best, the other one;
2. an object seen through one tag takes, among the candidates whose up axis is within
   :data:`UPRIGHT_TOLERANCE_DEG` of the most upright one's (objects stand on the shelf floor), the
   one with the least reprojection error: a tag seen face-on has two upright candidates mirrored
   about the vertical, and the tilt alone cannot tell them apart;
3. an object seen through several tags takes one candidate per tag such that all agree pairwise
   within ``agreement`` (2 cm and 10 degrees by default); among the agreeing combinations whose
   total tilt is within :data:`UPRIGHT_TOLERANCE_DEG` of the least, the one with the least total
   reprojection error, and reports their mean pose;
4. with ``planar_fit`` (the default), the pose so chosen starts a fit of the object's planar pose
   (x, y, theta; upright on the shelf floor) to the corners of all its decoded tags
   (:func:`~occrl.perception.planar_fit.fit_planar_pose`); an object seen through one tag fits from
   each of its upright candidates and keeps the fit with the least reprojection error;
5. when no combination agrees: with ``planar_fit``, the object's planar pose is fitted to the
   corners of all its tags from each candidate of each tag, and the object is kept at the best fit
   when that reprojects within :data:`FIT_AGREEMENT_PX` (RMS pixels): the corners fit one upright
   object, only the tags' own poses (each with its tilt and yaw noise) disagreed. Otherwise (or
   without ``planar_fit``) the object is dropped for that frame (not reported), counted in
   :attr:`TagDetector.disagreement_count` and warned once per type: its tags do not fit one
   object, as when the catalogue misplaces one.

A decoded tag id that the catalogue does not list is skipped, counted in
:attr:`TagDetector.unknown_tag_count` and warned once per id. At most ``max_detections`` objects
(the observation's slots) are reported: the nearest to the camera.
"""

from __future__ import annotations

import itertools
import logging
import math
from typing import Any, NamedTuple

import numpy as np

from occrl.perception.camera import CameraModel
from occrl.perception.catalogue import TagCatalogue, TagEntry
from occrl.perception.edges import refine_tags_on_edges
from occrl.perception.checks import positive_number, rigid_transform, strict_int
from occrl.perception.frames import angle_difference, invert_transform, planar_pose, tilt_deg
from occrl.perception.opencv import DEFAULT_DICTIONARY, aruco_dictionary, as_grey_image, check_dictionary, require_opencv
from occrl.perception.planar_fit import fit_planar_pose

__all__ = [
    "TagDetector",
    "PoseCandidate",
    "REFINE_METHODS",
    "AMBIGUITY_PX",
    "UPRIGHT_TOLERANCE_DEG",
    "DEFAULT_AGREEMENT",
    "FIT_AGREEMENT_PX",
    "MAX_DETECTIONS",
    "MIN_MARKER_DISTANCE_RATE",
    "DUPLICATE_PX",
]

logger = logging.getLogger(__name__)

REFINE_METHODS = ("none", "subpix", "contour", "apriltag", "edges")
AMBIGUITY_PX = 1.0  # IPPE's second pose is kept when it reprojects within this of the best (RMS pixels)
# candidates (or combinations, by their total) this close to the least tilt count as upright alike:
# the reprojection error chooses among them
UPRIGHT_TOLERANCE_DEG = 5.0
DEFAULT_AGREEMENT = (0.02, 10.0)  # metres, degrees
# tags whose own poses disagree still make one object when one planar pose puts all their corners
# within this of the decoded ones (RMS pixels; corners are located to a few tenths of a pixel)
FIT_AGREEMENT_PX = 1.5
MAX_DETECTIONS = 10  # the observation's object slots (occrl.envs.world_constants.MAX_OBJECTS)
# OpenCV drops the smaller of two candidate squares closer than this (relative to the perimeter);
# its default, 0.125, dropped the tag for the outline of its white margin in 17 of 320 synthetic
# frames at 0.1-0.2 m (benchmarks/tag_detection.py); at 0.01 both outlines decode (one id twice)
MIN_MARKER_DISTANCE_RATE = 0.02
DUPLICATE_PX = 3.0  # the same id decoded twice with corners this close: one tag


def nearly_most_upright(scored: list[tuple[float, float, Any]]) -> list[tuple[float, float, Any]]:
    """The ``(tilt_deg, reprojection_px, item)`` triples whose tilt is within
    :data:`UPRIGHT_TOLERANCE_DEG` of the least, in the order given."""
    least = min(tilt for tilt, _, _ in scored)
    return [s for s in scored if s[0] <= least + UPRIGHT_TOLERANCE_DEG]


def most_upright_then_sharpest(scored: list[tuple[float, float, Any]]) -> Any:
    """Of ``(tilt_deg, reprojection_px, item)`` triples, the item with the least reprojection error
    among the :func:`nearly_most_upright` (the first such on a tie)."""
    return min(nearly_most_upright(scored), key=lambda s: s[1])[2]


class PoseCandidate(NamedTuple):
    """One pose a tag allows: the tag in the camera frame, the object in the shelf frame, and the
    RMS reprojection error (pixels) of the tag's corners."""

    camera_tag: np.ndarray
    shelf_object: np.ndarray
    reprojection_px: float


class TagDetector:
    """Decodes the catalogue's tags in a camera image and reports the objects they sit on.

    Args:
        camera: the calibrated wrist camera (its image size is the one :meth:`detect` accepts).
        catalogue: the tags and their objects; its dictionary must be ``dictionary``.
        dictionary: the tag family (:data:`occrl.perception.opencv.DICTIONARIES`).
        refine: the corner refinement: ``"edges"`` (default): OpenCV's ``"subpix"`` then lines
            fitted to the square's sides (:mod:`occrl.perception.edges`; no inward bias, so more
            accurate on small and far tags), or OpenCV's own ``"subpix"``, ``"contour"``,
            ``"apriltag"`` or ``"none"``.
        agreement: (metres, degrees) within which the poses of an object's tags agree (module
            docstring, steps 3 and 5).
        max_detections: at most this many objects are reported, the nearest to the camera.
        planar_fit: fit each object's planar pose to its tags' corners, and keep an object whose
            tags' own poses disagree when one such fit explains its corners (steps 4 and 5 of the
            module docstring); False reports the pose the tags' own poses give (steps 1-3) and
            drops an object whose tags disagree.

    Examples:
        >>> import numpy as np
        >>> from occrl.perception import CameraModel, TagCatalogue, TagDetector
        >>> camera = CameraModel.from_fov(640, 480, 70.0)
        >>> box = [[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]]
        >>> catalogue = TagCatalogue.from_dict({"objects": [{"type_id": 3, "height": 0.12, "footprint": box,
        ...     "tags": [{"tag_id": 0, "face": 0, "offset": [0.0, 0.06], "size": 0.03}]}]})
        >>> detector = TagDetector(camera, catalogue)
        >>> detector.detect(np.full((480, 640), 255, np.uint8), np.eye(4))  # nothing in view
        []
        >>> detector.detect(np.zeros((480, 640, 4), np.uint8), np.eye(4))
        Traceback (most recent call last):
        ...
        ValueError: image must be (480, 640, 3) RGB or (480, 640) grey, uint8 (the camera's 640 x 480), got shape (480, 640, 4) and dtype uint8
    """

    def __init__(
        self,
        camera: CameraModel,
        catalogue: TagCatalogue,
        dictionary: str = DEFAULT_DICTIONARY,
        refine: str = "edges",
        agreement: tuple[float, float] = DEFAULT_AGREEMENT,
        max_detections: int = MAX_DETECTIONS,
        planar_fit: bool = True,
    ) -> None:
        if not isinstance(camera, CameraModel):
            raise TypeError(f"camera must be a CameraModel (occrl.perception.load_camera reads one), got {type(camera).__name__}")
        if not isinstance(catalogue, TagCatalogue):
            raise TypeError(f"catalogue must be a TagCatalogue (TagCatalogue.from_json reads one), got {type(catalogue).__name__}")
        check_dictionary(dictionary)
        if catalogue.dictionary != dictionary:
            raise ValueError(f"the catalogue lists {catalogue.dictionary} tags but the detector decodes {dictionary}; use one dictionary")
        if refine not in REFINE_METHODS:
            raise ValueError(f"refine must be one of {list(REFINE_METHODS)}, got {refine!r}")
        if not isinstance(agreement, (tuple, list)) or len(agreement) != 2:
            raise ValueError(f"agreement must be (metres, degrees), got {agreement!r}")
        self.agreement = (
            positive_number("agreement distance", agreement[0], "m"),
            positive_number("agreement angle", agreement[1], "degrees"),
        )
        self.max_detections = strict_int("max_detections", max_detections, 1, 10_000)
        if not isinstance(planar_fit, bool):
            raise TypeError(f"planar_fit must be a bool, got {planar_fit!r}")
        self.planar_fit = planar_fit
        cv2 = require_opencv()
        self._cv2 = cv2
        self.camera = camera
        self.catalogue = catalogue
        self.dictionary = dictionary
        self.refine = refine
        params = cv2.aruco.DetectorParameters()
        params.cornerRefinementMethod = {
            "none": cv2.aruco.CORNER_REFINE_NONE,
            "subpix": cv2.aruco.CORNER_REFINE_SUBPIX,
            "contour": cv2.aruco.CORNER_REFINE_CONTOUR,
            "apriltag": cv2.aruco.CORNER_REFINE_APRILTAG,
            "edges": cv2.aruco.CORNER_REFINE_SUBPIX,
        }[refine]
        params.minMarkerDistanceRate = MIN_MARKER_DISTANCE_RATE
        self._cells = check_dictionary(dictionary).bits + 2
        self._aruco = cv2.aruco.ArucoDetector(aruco_dictionary(dictionary), params)
        self._camera_matrix = camera.intrinsic_matrix
        self._distortion = camera.distortion_array
        self.unknown_tag_count = 0
        self.disagreement_count = 0
        self.overflow_count = 0
        self._warned_unknown: set[int] = set()
        self._warned_disagreement: set[int] = set()

    # -- images ------------------------------------------------------------------------------

    def grey_image(self, image: Any) -> np.ndarray:
        """``image`` checked against the camera and turned grey: (H, W, 3) uint8 RGB or (H, W)
        uint8, H x W the camera's; ``ValueError`` (``TypeError`` for a non-array) otherwise."""
        if not isinstance(image, np.ndarray):
            raise TypeError(f"image must be a numpy array, (H, W, 3) uint8 RGB or (H, W) uint8, got {type(image).__name__}")
        h, w = self.camera.height, self.camera.width
        if image.dtype != np.uint8 or image.shape not in ((h, w, 3), (h, w)):
            raise ValueError(
                f"image must be ({h}, {w}, 3) RGB or ({h}, {w}) grey, uint8 (the camera's {w} x {h}), got shape {image.shape} and dtype {image.dtype}"
            )
        return as_grey_image("image", image)

    def detect_tags(self, image: np.ndarray) -> list[dict[str, Any]]:
        """The tags decoded in ``image`` (catalogued or not), for debugging: ``{"tag_id": int,
        "corners": (4, 2) float array}`` each, corners in pixels in OpenCV's order (top-left,
        top-right, bottom-right, bottom-left as the tag reads), sorted by tag id."""
        grey = self.grey_image(image)
        corners, ids, _ = self._aruco.detectMarkers(grey)
        if ids is None:
            return []
        tags = []
        for i, c in zip(ids.reshape(-1), corners):
            c = np.asarray(c, dtype=float).reshape(4, 2)
            if not any(t["tag_id"] == i and np.abs(t["corners"] - c).max() <= DUPLICATE_PX for t in tags):
                tags.append({"tag_id": int(i), "corners": c})
        if self.refine == "edges":
            for tag, corners in zip(tags, refine_tags_on_edges(grey, [t["corners"] for t in tags], self._cells)):
                tag["corners"] = corners
        return sorted(tags, key=lambda t: t["tag_id"])

    # -- poses -------------------------------------------------------------------------------

    def tag_pose_candidates(self, entry: TagEntry, corners: np.ndarray, shelf_camera: np.ndarray) -> list[PoseCandidate]:
        """The poses a tag's ``corners`` allow (best first): IPPE's best, and its other solution
        when that reprojects within :data:`AMBIGUITY_PX` of the best; a solution behind the camera
        or not finite (IPPE on a degenerate square) is left out. ``shelf_camera``: the camera's
        pose in the shelf frame."""
        cv2 = self._cv2
        found, rvecs, tvecs, errors = cv2.solvePnPGeneric(
            entry.corners_in_tag,
            np.asarray(corners, dtype=float).reshape(4, 1, 2),
            self._camera_matrix,
            self._distortion,
            flags=cv2.SOLVEPNP_IPPE_SQUARE,
        )
        if not found:
            return []
        errors = np.asarray(errors, dtype=float).reshape(-1)
        object_tag_inverse = invert_transform(entry.tag_in_object)
        out = []
        for rvec, tvec, err in zip(rvecs, tvecs, errors):
            if out and err > out[0].reprojection_px + AMBIGUITY_PX:
                continue
            camera_tag = np.eye(4)
            camera_tag[:3, :3] = cv2.Rodrigues(rvec)[0]
            camera_tag[:3, 3] = np.asarray(tvec, dtype=float).reshape(3)
            if not (np.isfinite(camera_tag).all() and math.isfinite(err)):  # a degenerate square: no pose
                continue
            if camera_tag[2, 3] <= 0:  # behind the camera
                continue
            out.append(PoseCandidate(camera_tag, shelf_camera @ camera_tag @ object_tag_inverse, float(err)))
        return out

    def _agree(self, a: np.ndarray, b: np.ndarray) -> bool:
        pa, pb = planar_pose(a), planar_pose(b)
        distance = math.hypot(pa[0] - pb[0], pa[1] - pb[1])
        return distance <= self.agreement[0] and abs(math.degrees(angle_difference(pa[2], pb[2]))) <= self.agreement[1]

    def object_pose(
        self,
        type_id: int,
        candidates: list[list[PoseCandidate]],
        tags: list[tuple[TagEntry, np.ndarray]] | None = None,
        shelf_camera: np.ndarray | None = None,
    ) -> tuple[float, float, float] | None:
        """One object's planar pose from its tags' candidates (one list per tag), by the rule of
        :mod:`occrl.perception.detector`; None when its tags disagree. ``tags`` (their catalogue
        entries and decoded corners) and ``shelf_camera`` let tags whose own poses disagree be
        fitted together (step 5, with ``planar_fit``)."""
        candidates = [c for c in candidates if c]
        if not candidates:
            return None
        if len(candidates) == 1:
            scored = [(tilt_deg(c.shelf_object), c.reprojection_px, c) for c in candidates[0]]
            return planar_pose(most_upright_then_sharpest(scored).shelf_object)
        # beyond 8 tags, the rest add their best candidate only (at most 2^8 combinations)
        options = candidates[:8] + [c[:1] for c in candidates[8:]]
        agreeing = []
        for combo in itertools.product(*options):
            if all(self._agree(a.shelf_object, b.shelf_object) for a, b in itertools.combinations(combo, 2)):
                agreeing.append((sum(tilt_deg(c.shelf_object) for c in combo), sum(c.reprojection_px for c in combo), combo))
        if not agreeing and self.planar_fit and tags is not None and shelf_camera is not None:
            starts = [planar_pose(c.shelf_object) for options in candidates for c in options]
            pose, rms = self._best_fit(tags, starts, shelf_camera)
            if rms <= FIT_AGREEMENT_PX:
                return pose
        if not agreeing:
            self.disagreement_count += 1
            if type_id not in self._warned_disagreement:
                self._warned_disagreement.add(type_id)
                logger.warning(
                    "the tags of type %d disagree by more than %.3g m / %.3g deg%s; the object is dropped for that frame "
                    "(counted in disagreement_count; check the catalogue's tag placement; warned once per type)",
                    type_id,
                    *self.agreement,
                    f" and no upright pose fits their corners within {FIT_AGREEMENT_PX:g} px" if self.planar_fit else "",
                )
            return None
        poses = np.array([planar_pose(c.shelf_object) for c in most_upright_then_sharpest(agreeing)])
        theta = math.atan2(np.sin(poses[:, 2]).mean(), np.cos(poses[:, 2]).mean())
        return float(poses[:, 0].mean()), float(poses[:, 1].mean()), theta

    def fitted_pose(
        self,
        pose: tuple[float, float, float],
        candidates: list[list[PoseCandidate]],
        tags: list[tuple[TagEntry, np.ndarray]],
        shelf_camera: np.ndarray,
    ) -> tuple[float, float, float]:
        """The planar pose fitted to the corners of ``tags`` (their catalogue entries and decoded
        corners) from ``pose``, the pose :meth:`object_pose` chose; an object seen through one tag
        also fits from that tag's other upright candidates and keeps the least reprojection error."""
        starts = [pose]
        if len(tags) == 1:  # each upright candidate (the chosen one among them)
            (options,) = [c for c in candidates if c]
            scored = [(tilt_deg(c.shelf_object), c.reprojection_px, c) for c in options]
            starts = [planar_pose(c.shelf_object) for _, _, c in nearly_most_upright(scored)]
        return self._best_fit(tags, starts, shelf_camera)[0]

    def _best_fit(
        self, tags: list[tuple[TagEntry, np.ndarray]], starts: list[tuple[float, float, float]], shelf_camera: np.ndarray
    ) -> tuple[tuple[float, float, float], float]:
        """The planar pose fitted to the corners of ``tags`` from each of ``starts`` with the least
        RMS reprojection error (pixels), and that error."""
        points = np.concatenate([entry.corners_in_object for entry, _ in tags])
        pixels = np.concatenate([np.asarray(corners, dtype=float).reshape(4, 2) for _, corners in tags])
        fits = [fit_planar_pose(points, pixels, start, shelf_camera, self._camera_matrix, self._distortion) for start in starts]
        return min(fits, key=lambda f: f[1])

    def detect(self, image: np.ndarray, gripper_pose: np.ndarray) -> list[dict[str, Any]]:
        """The objects whose tags are decoded in ``image``, as
        ``occrl.envs.perception.observation_from_detections`` takes them (sorted by type id).

        Args:
            image: (H, W, 3) uint8 RGB or (H, W) uint8 grey, the camera's size.
            gripper_pose: the gripper's 4x4 pose in the shelf frame (maps gripper-frame points to
                shelf-frame points; :func:`occrl.perception.frames.gripper_pose_matrix` makes it
                from a planar pose and a height).
        """
        grey = self.grey_image(image)
        shelf_gripper = rigid_transform("gripper_pose", gripper_pose)
        shelf_camera = shelf_gripper @ self.camera.hand_camera
        tags = self.detect_tags(grey)
        by_type: dict[int, list[list[PoseCandidate]]] = {}
        seen: dict[int, list[tuple[TagEntry, np.ndarray]]] = {}
        for tag in tags:
            entry = self.catalogue.get(tag["tag_id"])
            if entry is None:
                self._unknown(tag["tag_id"])
                continue
            by_type.setdefault(entry.type_id, []).append(self.tag_pose_candidates(entry, tag["corners"], shelf_camera))
            seen.setdefault(entry.type_id, []).append((entry, tag["corners"]))
        objects = []
        for type_id in sorted(by_type):
            pose = self.object_pose(type_id, by_type[type_id], seen[type_id], shelf_camera)
            if pose is not None and self.planar_fit:
                pose = self.fitted_pose(pose, by_type[type_id], seen[type_id], shelf_camera)
            if pose is not None:
                footprint = self.catalogue.tags_of(type_id)[0].footprint
                objects.append({"type_id": type_id, "pose": pose, "vertices": [list(v) for v in footprint]})
        if len(objects) > self.max_detections:
            self.overflow_count += len(objects) - self.max_detections
            cam = shelf_camera[:2, 3]
            nearest = sorted(objects, key=lambda o: math.hypot(o["pose"][0] - cam[0], o["pose"][1] - cam[1]))[: self.max_detections]
            objects = sorted(nearest, key=lambda o: o["type_id"])
        return objects

    def _unknown(self, tag_id: int) -> None:
        self.unknown_tag_count += 1
        if tag_id not in self._warned_unknown:
            self._warned_unknown.add(tag_id)
            logger.warning("tag %d is not in the catalogue: skipped (counted in unknown_tag_count; warned once per id)", tag_id)
