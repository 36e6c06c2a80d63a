"""How the pymunk shelf world integrates an action: step size, solver and finger model.

The world is in metres, so every pymunk tolerance is set for metres (pymunk's defaults assume
pixels: its ``collision_slop`` of 0.1 tolerates 10 cm of overlap here). :data:`DEFAULT_PHYSICS` is
what every env, planner and baseline uses; :data:`LEGACY_PHYSICS` reproduces the physics of
occrl 0.1.0 bit for bit, for benchmarks and for re-running figures made before the change.
``benchmarks/physics_validity.py`` measures penetration and cost of any settings side by side and
docs/lab/environment.md ("Physics validity") gives the measurements behind the defaults.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["PhysicsSettings", "DEFAULT_PHYSICS", "LEGACY_PHYSICS", "INVALID_PENETRATION"]

# pymunk's defaults (single-precision constants, kept exact so that LEGACY_PHYSICS is bit-exact)
PYMUNK_COLLISION_SLOP = 0.10000000149011612
PYMUNK_COLLISION_BIAS = 0.0017970074436457143

# A state with a deeper overlap between two bodies (or a body and a wall) is physically invalid.
INVALID_PENETRATION = 0.005  # m


@dataclass(frozen=True)
class PhysicsSettings:
    """Integration settings of :class:`~occrl.envs.ShelfWorld`.

    Examples:
        >>> from occrl.envs.pymunk2d.physics_settings import DEFAULT_PHYSICS, PhysicsSettings
        >>> DEFAULT_PHYSICS.collision_slop  # metres
        0.0005
        >>> PhysicsSettings(substeps=0)
        Traceback (most recent call last):
        ...
        ValueError: substeps must be an int >= 1, got 0
    """

    substeps: int = 40
    """Physics steps per action (the action lasts ``ACTION_DURATION`` = 0.5 s of simulated time)."""
    contact_substeps: int = 2
    """Each step is split into this many while the gripper touches anything (adaptive stepping:
    fine steps only while something is pushed). 1 = fixed steps."""
    iterations: int = 20
    """Chipmunk solver iterations per step."""
    collision_slop: float = 0.0005
    """Overlap (m) the solver tolerates without correcting it."""
    collision_bias: float = 1e-7
    """Fraction of an overlap left uncorrected after one second (pymunk's default, 0.0018,
    corrects 7.6 % of an overlap per 12.5 ms step; 1e-7 corrects 18 %)."""
    gripper_mass: float = 0.01
    """Mass (kg) of the gripper body. The objects weigh 0.2-6 g (1 kg/m^2, paper): a gripper
    hundreds of times heavier pressing one against a wall is a mass ratio that Chipmunk's
    iterative solver resolves too slowly, and the object is squeezed into the wall."""
    gripper_max_force: float = 0.4
    """Force (N) of the joint that drives the gripper towards its commanded pose: twice the floor
    friction of ten of the heaviest objects, so the gripper pushes any pile but stalls against
    a wall instead of crushing objects into it (a force-limited arm's protective stop)."""
    gripper_max_torque: float = 0.04
    """Torque (N m) of the joint that turns the gripper (the force over a 10 cm arm)."""
    gripper_max_speed: float = 0.5
    """Fastest correction (m/s) of the driving joint when the gripper lags its commanded pose
    (the commanded motion itself is at most 0.1 m/s); the turning joint's is 10x this in rad/s."""
    grasp_max_force: float = math.inf
    """Force (N) with which the grasp holds (and centres) the object; a held object slips when
    pulled harder."""
    finger_contact: bool = True
    """Fingers open only until they touch an object or a wall (as they close until contact), and a
    grasped object is drawn to the centre between the fingers by the grasp joint during the action.
    False: the fingers snap open to the full stroke and the grasp moves the object to the centre at
    once (occrl 0.1.0), both of which can place a body inside another."""

    measure_validity: bool = True
    """Measure penetration and wall crossings after every action (``ShelfWorld.penetration``);
    a planner's imagined worlds may skip it. Unmeasured, the penetration reads NaN."""

    def __post_init__(self) -> None:
        for name in ("substeps", "contact_substeps", "iterations"):
            v = getattr(self, name)
            if not isinstance(v, int) or isinstance(v, bool) or v < 1:
                raise ValueError(f"{name} must be an int >= 1, got {v!r}")
        if not 0.0 <= self.collision_slop <= 0.2:
            raise ValueError(f"collision_slop must be in [0, 0.2] m, got {self.collision_slop!r}")
        if not 0.0 < self.collision_bias < 1.0:
            raise ValueError(f"collision_bias must be in (0, 1), got {self.collision_bias!r}")
        for name in ("gripper_mass", "gripper_max_force", "gripper_max_torque", "gripper_max_speed", "grasp_max_force"):
            v = getattr(self, name)
            if not v > 0.0:
                raise ValueError(f"{name} must be > 0, got {v!r}")

    @property
    def cost(self) -> int:
        """Solver work per action in the worst case (steps x iterations), for comparisons."""
        return self.substeps * self.contact_substeps * self.iterations


DEFAULT_PHYSICS = PhysicsSettings()

# occrl 0.1.0: 10 steps of 50 ms, pymunk's pixel-unit tolerances, a 0.5 kg gripper driven with
# 20 N, snapping fingers, nothing measured.
LEGACY_PHYSICS = PhysicsSettings(
    substeps=10,
    contact_substeps=1,
    iterations=20,
    collision_slop=PYMUNK_COLLISION_SLOP,
    collision_bias=PYMUNK_COLLISION_BIAS,
    gripper_mass=0.5,
    gripper_max_force=20.0,
    gripper_max_torque=2.0,
    gripper_max_speed=0.5,
    finger_contact=False,
    measure_validity=False,
)
