"""The real-robot entry (`observation_from_detections`): valid random detections are accepted,
every malformed one is refused with a message naming the field (property-based, hypothesis)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from occrl.envs import observation_from_detections
from occrl.envs import world_constants as C
from occrl.envs.scene import random_convex_polygon
from occrl.planners import recreate

finite = st.floats(-1.0, 1.0, allow_nan=False, allow_infinity=False)


@st.composite
def valid_inputs(draw) -> dict:
    """A perception system's output as the docstring allows it."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    count = draw(st.integers(0, 10))
    type_ids = draw(st.lists(st.integers(1, 999_999), min_size=count, max_size=count, unique=True))
    detections = [
        {
            "type_id": t,
            "pose": (draw(finite) * 0.3, draw(finite) * 0.4, draw(finite) * math.pi),
            "vertices": random_convex_polygon(rng).tolist(),
        }
        for t in type_ids
    ]
    if draw(st.booleans()) and detections:  # clockwise order is accepted too
        detections[0]["vertices"] = detections[0]["vertices"][::-1]
    return {
        "gripper_pose": (draw(finite) * 0.4, draw(finite) * 0.3, draw(finite) * 1.5),
        "gripper_opening": draw(st.floats(0.0, C.GRIPPER_STROKE)),
        "detections": detections,
        "target_type": draw(st.integers(1, 999_999)),
        "target_vertices": random_convex_polygon(rng),
        "gripper_closed": draw(st.booleans()),
    }


@settings(max_examples=60, deadline=None)
@given(valid_inputs())
def test_valid_detections_are_accepted_and_planned_on(inputs):
    obs = observation_from_detections(**inputs)
    assert int(obs["objects", "detected"].sum()) == len(inputs["detections"])
    state = recreate(obs[0])  # the planner's entry reads it
    # closed fingers held apart with the target unseen: the planner places the target in hand
    assert len(state.objects) - len(inputs["detections"]) in (0, 1)


# (field, a bad value, words the message must contain)
CORRUPTIONS = [
    ("gripper_pose", (0.0, math.nan, 0.0), "gripper_pose"),
    ("gripper_pose", (0.0, 0.1), "gripper_pose"),
    ("gripper_pose", "front", "gripper_pose"),
    ("gripper_opening", -0.01, "gripper_opening"),
    ("gripper_opening", 0.2, "gripper_opening"),
    ("gripper_opening", math.inf, "gripper_opening"),
    ("gripper_opening", [0.01, 0.02], "gripper_opening"),
    ("gripper_closed", "yes", "gripper_closed"),
    ("target_type", 0, "target_type"),
    ("target_type", 2.5, "target_type"),
    ("target_type", True, "target_type"),
    ("target_type", 10**7, "target_type"),
    ("target_vertices", [[0.0, 0.0], [0.01, 0.0]], "target_vertices"),
    ("target_vertices", [[0.0, 0.0], [0.02, 0.0], [0.01, 0.005], [0.02, 0.02], [0.0, 0.02]], "target_vertices"),
    ("target_vertices", [[0.0, 0.0], [math.nan, 0.0], [0.0, 0.02]], "target_vertices"),
    ("detections", "box", "detections"),
    ("detections", [[1, (0.0, 0.1, 0.0)]], "detections[0]"),
    ("detections", [{"type_id": 3, "pose": (0.0, 0.1, 0.0)}], "vertices"),
    ("detections", [{"pose": (0.0, 0.1, 0.0), "vertices": [[0, 0], [0.02, 0], [0, 0.02]]}], "type_id"),
    ("detections", [{"type_id": -1, "pose": (0.0, 0.1, 0.0), "vertices": [[0, 0], [0.02, 0], [0, 0.02]]}], "type_id"),
    ("detections", [{"type_id": 3, "pose": (0.0, math.inf, 0.0), "vertices": [[0, 0], [0.02, 0], [0, 0.02]]}], "pose"),
    ("detections", [{"type_id": 3, "pose": (0.0, 0.1, 0.0), "vertices": [[0, 0]] * 9}], "vertices"),
    ("detections", [{"type_id": 3, "pose": (0.0, 0.1, 0.0), "vertices": [[0, 0], [0.02, 0], [0.04, 0]]}], "vertices"),
    ("detections", [{"type_id": 3, "pose": (0.0, 0.1, 0.0), "vertices": [[0, 0], [0.02, 0], [0, 0.02]]}] * 2, "type_id"),
    (
        "detections",
        [{"type_id": k + 1, "pose": (0.0, 0.1, 0.0), "vertices": [[0, 0], [0.02, 0], [0, 0.02]]} for k in range(11)],
        "detections",
    ),
]


@settings(max_examples=60, deadline=None)
@given(valid_inputs(), st.sampled_from(CORRUPTIONS))
def test_malformed_detections_are_refused_with_the_field_named(inputs, corruption):
    field, value, words = corruption
    inputs[field] = value
    with pytest.raises((ValueError, TypeError)) as info:
        observation_from_detections(**inputs)
    assert words in str(info.value)


def test_a_missing_key_is_named():
    with pytest.raises(ValueError, match=r"detections\[0\] is missing \['vertices'\]"):
        observation_from_detections(
            (0.0, -0.1, 0.0), 0.085, [{"type_id": 3, "pose": (0.1, 0.2, 0.0)}], 3, [[-0.02, -0.02], [0.02, -0.02], [0.0, 0.02]]
        )
