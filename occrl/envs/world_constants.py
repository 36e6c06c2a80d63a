"""World constants (DESIGN section 3). SI units, shelf frame.

The shelf interior is x in [-SHELF_HALF_WIDTH, SHELF_HALF_WIDTH], y in [0, SHELF_DEPTH]. The back wall
is at y = SHELF_DEPTH, the side walls at x = +-SHELF_HALF_WIDTH and the front edge y = 0 is open.
The gripper frame has its origin at the palm's front centre (where the camera sits) and its +y axis
along the approach direction; at theta = 0 it looks into the shelf (+y).
"""

from __future__ import annotations

import math

# --- shelf -------------------------------------------------------------------------------------
SHELF_HALF_WIDTH = 0.25
SHELF_DEPTH = 0.35
WALL_THICKNESS = 0.02
# An object whose centroid crosses this line has been pushed (or pulled) off the front edge.
FRONT_EDGE_Y = 0.0
# The target counts as retrieved once it is held and its centroid is past this line.
RETRIEVED_Y = -0.05

# --- objects -----------------------------------------------------------------------------------
MIN_VERTICES = 3
MAX_VERTICES = 8
MIN_OBJECT_RADIUS = 0.015  # circumradius: objects are about 3-9 cm across
MAX_OBJECT_RADIUS = 0.045
MIN_OBJECT_AREA = 2.0e-4  # m^2, rejects slivers
MAX_OBJECTS = 10  # observation slots
NOMINAL_DENSITY = 1.0  # kg / m^2 (paper)
NOMINAL_FRICTION = 0.3  # contact and floor friction coefficient (paper)
GRAVITY = 9.81  # only enters the floor friction force mu * m * g

# --- gripper (top-down Robotiq 2F-85 on a UR5 wrist) ------------------------------------------
GRIPPER_STROKE = 0.085  # max opening between the fingers
PALM_WIDTH = 0.09
PALM_DEPTH = 0.05
FINGER_WIDTH = 0.012
FINGER_LENGTH = 0.045
FOREARM_WIDTH = 0.07
FOREARM_LENGTH = 0.25
# force limits of the MuJoCo hand's servos; the pymunk gripper's mass and drive are integration
# settings (occrl.envs.pymunk2d.physics_settings)
GRIPPER_MAX_FORCE = 20.0  # N
GRIPPER_MAX_TORQUE = 2.0  # N m

# Reachable gripper poses (the arm's workspace in front of and inside the shelf).
GRIPPER_X_LIMITS = (-0.40, 0.40)
GRIPPER_Y_LIMITS = (-0.30, SHELF_DEPTH)
GRIPPER_THETA_LIMITS = (-math.pi / 2, math.pi / 2)

# --- camera ------------------------------------------------------------------------------------
CAMERA_FOV = math.radians(70.0)
DETECTION_THRESHOLD = 0.5  # detected when strictly more than this fraction is visible

# --- actions -----------------------------------------------------------------------------------
ACTION_DIM = 4  # forward, lateral, rotation (gripper frame), gripper (> 0 close, <= 0 open)
MAX_FORWARD = 0.05
MAX_LATERAL = 0.05
MAX_ROTATION = math.radians(15.0)
ACTION_DURATION = 0.5  # s of simulated time per action (steps: occrl.envs.pymunk2d.physics_settings)

# --- task --------------------------------------------------------------------------------------
STEP_REWARD = -1.0
DROP_PENALTY = -50.0
MAX_EPISODE_STEPS = 50
GAMMA = 0.995
