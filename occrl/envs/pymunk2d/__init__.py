"""The 2D shelf world the planners imagine and the default env executes in (pymunk).

* :mod:`~occrl.envs.pymunk2d.world`: :class:`ShelfWorld`, a scene as rigid pymunk bodies with
  the gripper, one action at a time, exact snapshots.
* :mod:`~occrl.envs.pymunk2d.fingers`: the fingers' geometry (which object closing fingers grasp,
  where moving fingers stop); :mod:`~occrl.envs.pymunk2d.finger_actuation`: the gripper command's
  effect on the fingers and the grasp.
* :mod:`~occrl.envs.pymunk2d.joints`: the drive, floor-friction and grasp joints;
  :mod:`~occrl.envs.pymunk2d.body_properties`: masses, moments and cached shape layouts.
* :mod:`~occrl.envs.pymunk2d.physics_settings`: how it integrates (:class:`PhysicsSettings`).
* :mod:`~occrl.envs.pymunk2d.physics_validity`: the adversarial-pushing check that solids stay
  apart.
"""

from occrl.envs.pymunk2d.physics_settings import DEFAULT_PHYSICS, LEGACY_PHYSICS, PhysicsSettings
from occrl.envs.pymunk2d.world import ShelfWorld

__all__ = ["ShelfWorld", "PhysicsSettings", "DEFAULT_PHYSICS", "LEGACY_PHYSICS"]
