"""The 3D MuJoCo (dm_control) shelf the planners' decisions are executed in (paper Sec. VII).

Needs the optional extra: ``pip install -e ".[mujoco]"``. Nothing here is imported by
``import occrl``; ``occrl.envs.MujocoShelfEnv`` and ``make_env(world="mujoco")`` load it on use.

* :mod:`~occrl.envs.mujoco3d.env`: ``MujocoShelfEnv``, ``ShelfEnv``'s observation and task over
  MuJoCo worlds.
* :mod:`~occrl.envs.mujoco3d.world`: ``MujocoWorld``, the scene extruded into a dm_control model,
  stepped with the same action interface as the 2D world.
* :mod:`~occrl.envs.mujoco3d.model`: the MJCF model of shelf, objects and gripper.
* :mod:`~occrl.envs.mujoco3d.camera`: the gripper camera's visibility (pixels or rays).
* :mod:`~occrl.envs.mujoco3d.tags`: the fiducial tags on the objects (``perception="tags"``).
* :mod:`~occrl.envs.mujoco3d.wrist_camera`: the wrist camera's RGB frames, lighting and noise.
* :mod:`~occrl.envs.mujoco3d.tag_perception`: the scene's tag catalogue, the camera's calibration
  and the detector reading the frames.
"""
