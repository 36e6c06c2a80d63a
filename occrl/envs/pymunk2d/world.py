"""The shelf world: pymunk physics of a top-down gripper pushing and grasping convex objects.

Physics queries live here, apart from task logic (:class:`~occrl.envs.ShelfEnv`) and perception
(:mod:`occrl.envs.visibility`, :mod:`occrl.envs.render`).

Model (DESIGN section 3):

* Objects are dynamic pymunk polygons. Friction against the shelf floor is a pivot joint and a
  gear joint to a static body whose forces are limited to mu * m * g (and the matching torque).
* The gripper is one dynamic body (palm, two fingers, forearm) driven towards a kinematic control
  body by force-limited joints, so walls stop it and it pushes objects with bounded force.
* An action is a pose increment in the gripper frame executed at constant velocity over
  ``ACTION_DURATION`` seconds of simulated time, then everything is brought to rest (quasi-static
  execution: the real robot pauses to perceive between actions).
* Grasping: closing the fingers on an object that straddles the gripper axis between the fingers
  centres it and holds it rigidly (a weld); other objects stop the fingers at contact. Opening
  releases. This replaces finger friction, which a 2D engine models poorly.
* Noise: before each action the density, friction and vertices of every object are perturbed
  about their nominal values (``noise`` level, DESIGN section 3).

Determinism: every action starts from a *cold* solver. Chipmunk keeps hidden state between steps
(cached contact impulses, joint impulses, shape hash ids, the bodies' position-correction
velocities), so resetting poses alone drifts. Before
each action the world removes its dynamic shapes and joints, resets the shape id counter and the
previous time step, and adds fresh ones in a fixed order. The state is therefore exactly the small
:meth:`ShelfWorld.snapshot`: poses, gripper opening, grasp and the noise generator.
"""

from __future__ import annotations

import copy
import logging
import math

import numpy as np
import pymunk
import pymunk.batch
from pymunk._chipmunk_cffi import lib as _cp

from occrl.envs import world_constants as C
from occrl.envs.geometry import convex_hull, polygon_area, polygon_centroid, transform_points, transform_polygons
from occrl.envs.task import StepOutcome, task_outcome
from occrl.envs.shelf_geometry import beyond_walls, gripper_polygons, wall_polygons
from occrl.envs.pymunk2d import contact_list, joint_reset
from occrl.envs.pymunk2d.body_properties import gripper_moment, mass_and_moment, padded_and_radii
from occrl.envs.pymunk2d.finger_actuation import FingerActuation
from occrl.envs.pymunk2d.joints import drive_and_floor_joints, grasp_joints
from occrl.envs.pymunk2d.physics_settings import DEFAULT_PHYSICS, INVALID_PENETRATION, PhysicsSettings
from occrl.envs.scene import Scene

# the shelf geometry (gripper_polygons, wall_polygons, inverse_pose, beyond_walls) lives in
# occrl.envs.shelf_geometry, the fingers' (grasp_candidate and where fingers stop) in
# occrl.envs.pymunk2d.fingers and their actuation in occrl.envs.pymunk2d.finger_actuation, the
# joints in occrl.envs.pymunk2d.joints, masses and cached layouts in occrl.envs.pymunk2d.body_properties
__all__ = ["ShelfWorld"]

logger = logging.getLogger(__name__)

_AT_REST = (0.0, 0.0)

_GRIPPER_GROUP = 1  # shapes in this group never collide with each other (gripper + held object)
_IN_GRIPPER_GROUP = pymunk.ShapeFilter(group=_GRIPPER_GROUP)
_NO_GROUP = pymunk.ShapeFilter()
_IDENTITY = pymunk.Transform.identity()
# contact depths of every touching pair after a step (arbiters no longer touching read 0)
_CONTACT_DEPTHS = pymunk.batch.ArbiterFields.DISTANCE_1 | pymunk.batch.ArbiterFields.DISTANCE_2


class ShelfWorld(FingerActuation):
    """A pymunk shelf world built from a :class:`~occrl.envs.Scene`.

    Args:
        scene: the objects and the gripper's start pose.
        noise: physics/shape noise level (DESIGN: 0 to 0.25) applied before each action.
        rng: generator for the noise, the only randomness in the world.
        physics: integration settings (step size, solver, finger model); the default holds
            penetration <= 2 mm under hard pushing (docs/lab/environment.md, "Physics validity").

    After each :meth:`step`, :attr:`penetration` is the deepest overlap (m) between any two
    bodies or a body and a wall, and :attr:`crossed_wall` says whether an object's centroid is
    beyond a wall; :meth:`physically_valid` combines both.

    Examples:
        >>> from occrl.envs import Scene, ShelfWorld
        >>> world = ShelfWorld(Scene.sample(stage=1, seed=0))
        >>> snap = world.snapshot()
        >>> out = world.step([1.0, 0.0, 0.0, -1.0])
        >>> pose_after = world.gripper_pose()
        >>> world.restore(snap); _ = world.step([1.0, 0.0, 0.0, -1.0])
        >>> bool((world.gripper_pose() == pose_after).all())
        True
    """

    def __init__(
        self, scene: Scene, noise: float = 0.0, rng: np.random.Generator | None = None, physics: PhysicsSettings = DEFAULT_PHYSICS
    ) -> None:
        if not 0.0 <= noise <= 1.0:
            raise ValueError(f"noise level must be in [0, 1], got {noise}")
        if not isinstance(physics, PhysicsSettings):
            raise TypeError(f"physics must be an occrl.envs.PhysicsSettings, got {type(physics).__name__}")
        self.physics = physics
        self.noise = float(noise)
        self.rng = rng if rng is not None else np.random.default_rng(0)
        self._take_scene(scene)
        self._contact_buffer = pymunk.batch.Buffer()
        self._build(scene)

    def rebuild(self, scene: Scene) -> None:
        """Become the world of another ``scene`` with as many objects, in this pymunk space: each
        object's shape, mass and friction set anew, every body placed at rest, the gripper open and
        empty. It then steps bit for bit as ``ShelfWorld(scene, physics=self.physics)`` would
        (tested), at a fraction of the cost of building one: for planners that keep their imagined
        worlds between decisions (:class:`occrl.planners.WorldPool`). Noise-free worlds only.

        Raises:
            ValueError: if the scene has another number of objects or the world has noise; the
                world is left unchanged.
        """
        if len(scene.objects) != self.num_objects:
            raise ValueError(f"rebuild needs a scene of {self.num_objects} objects (this world's), got {len(scene.objects)}")
        if self.noise > 0.0:
            raise ValueError(f"rebuild is for noise-free worlds (the planners' imagined ones); this one has noise {self.noise}")
        self._take_scene(scene)
        for i, vertices in enumerate(self.nominal_vertices):
            key = vertices.tobytes()
            if self._nominal_shapes[i] == key:  # this shape, mass and friction already: set as they are
                continue
            # the convex hull pymunk.Poly builds from the vertices (cpPolyShapeSetVerts), as a new shape has it
            self.shapes[i].unsafe_set_vertices(vertices.tolist(), transform=_IDENTITY)
            self._set_physics(i, vertices, C.NOMINAL_DENSITY, C.NOMINAL_FRICTION)
            self._nominal_shapes[i] = key
        self._set_opening(C.GRIPPER_STROKE)
        self._set_poses(np.asarray(scene.gripper_pose, float), np.array([o.pose for o in scene.objects], float).reshape(-1, 3))

    def _take_scene(self, scene: Scene) -> None:
        """The scene and what the world reads from it (objects' types, shapes, target), the
        gripper open and empty, no validity measure yet."""
        self.scene = scene
        self.num_objects = len(scene.objects)
        # a recreated planning state may not contain the target: -1 then
        self.target_index = next((i for i, o in enumerate(scene.objects) if o.is_target), -1)
        self.type_ids = np.array([o.type_id for o in scene.objects], dtype=np.int64)
        self.nominal_vertices = [np.asarray(o.vertices, dtype=float) for o in scene.objects]
        # the same polygons padded to MAX_VERTICES by repeating the first vertex, for vectorised
        # use, and each object's radius (read only: shared by the worlds of the same shapes)
        self.padded_vertices, self.object_radius = padded_and_radii(self.nominal_vertices)
        self.num_vertices = np.array([len(v) for v in self.nominal_vertices], dtype=np.int64)
        self.opening = C.GRIPPER_STROKE
        self.closed = False
        self.held: int | None = None
        # an object the gripper camera cannot see while it is held (a recreated world whose held
        # target was never seen: see occrl.planners.recreate); None in the execution worlds
        self.unseen_while_held: int | None = None
        self.penetration = 0.0
        self.crossed_wall = False

    # ------------------------------------------------------------------ construction
    def _build(self, scene: Scene) -> None:
        space = self.space = pymunk.Space()
        space.gravity = (0.0, 0.0)
        space.iterations = self.physics.iterations
        if self.physics.collision_slop != space.collision_slop:
            space.collision_slop = self.physics.collision_slop
        if self.physics.collision_bias != space.collision_bias:
            space.collision_bias = self.physics.collision_bias
        self.wall_shapes = []
        for poly in wall_polygons():
            s = pymunk.Poly(space.static_body, poly.tolist())
            s.friction = C.NOMINAL_FRICTION
            space.add(s)
            self.wall_shapes.append(s)
        self._shape_id_base = _cp.cpSpaceGetShapeIDCounter(space._space)

        self.control = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        mass = self.physics.gripper_mass
        self.gripper = pymunk.Body(mass=mass, moment=1.0)
        polys = gripper_polygons(C.GRIPPER_STROKE)
        # the opening the finger shapes were last set to by _set_opening (None: as built, whose
        # vertices pymunk.Poly ordered as their convex hull, and _set_opening does not)
        self._finger_opening: tuple[float, float] | None = None
        self.gripper.moment = gripper_moment(mass)
        self.gripper_shapes = []
        for poly in polys:
            s = pymunk.Poly(self.gripper, poly.tolist())
            s.friction = C.NOMINAL_FRICTION
            s.filter = pymunk.ShapeFilter(group=_GRIPPER_GROUP)
            self.gripper_shapes.append(s)
        self.bodies = []
        self.shapes = []
        self.floor_force = np.zeros(self.num_objects)  # mu * m * g of each object, this action
        self.floor_arm = np.zeros(self.num_objects)  # radius of gyration: torque = force * arm
        self._floor_limits_stale = True  # floor_force / floor_arm changed since the kept joints took them
        for o in scene.objects:
            body = pymunk.Body(mass=1.0, moment=1.0)
            self.bodies.append(body)
            self.shapes.append(pymunk.Poly(body, o.vertices.tolist()))
        space.add(self.control, self.gripper, *self.bodies)
        self._constraints: list[pymunk.Constraint] = []  # the joints built for this action (taken out at the next)
        self._kept_joints: list[pymunk.Constraint] = []  # drive and floor joints kept between actions (joint_reset)
        self._kept_impulses: joint_reset.ImpulseSlots | None = None  # their accumulated impulses, zeroed at every action
        self._shapes_in_space = False
        self._dynamic_shapes = [*self.gripper_shapes, *self.shapes]  # removed and re-added at every action
        # (their and the bodies' Chipmunk pointers, for the calls made at every action)
        self._dynamic_shape_pointers = [shape._shape for shape in self._dynamic_shapes]
        self._body_pointers = [body._body for body in (self.control, self.gripper, *self.bodies)]
        self._filtered: int | None = None  # object whose shape is in the gripper's group
        for i in range(self.num_objects):
            self._set_physics(i, self.nominal_vertices[i], C.NOMINAL_DENSITY, C.NOMINAL_FRICTION)
        # the nominal vertices' bytes of each object shape that has them, with the nominal mass
        # and friction (None once noise changed it): rebuild leaves such shapes as they are
        self._nominal_shapes: list[bytes | None] = [v.tobytes() for v in self.nominal_vertices]
        self._set_poses(np.asarray(scene.gripper_pose, float), np.array([o.pose for o in scene.objects], float))

    def _set_physics(self, i: int, vertices: np.ndarray, density: float, friction: float) -> None:
        body, shape = self.bodies[i], self.shapes[i]
        mass, moment = mass_and_moment(vertices, density)
        # Chipmunk's setters called directly (what pymunk's mass, moment and friction properties call)
        _cp.cpBodySetMass(body._body, mass)
        _cp.cpBodySetMoment(body._body, moment)
        _cp.cpShapeSetFriction(shape._shape, friction)
        self.floor_force[i] = friction * mass * C.GRAVITY
        self.floor_arm[i] = math.sqrt(moment / mass)
        self._floor_limits_stale = True  # the kept floor joints take them at the next cold start

    def _set_poses(self, gripper_pose: np.ndarray, object_poses: np.ndarray) -> None:
        # Chipmunk's setters called directly (what pymunk's properties call, without their overhead)
        # (as Python floats, one conversion each: the same values as float() of each entry)
        gripper = np.asarray(gripper_pose, dtype=float).reshape(3).tolist()
        rows = [gripper, gripper, *np.asarray(object_poses, dtype=float).reshape(-1, 3).tolist()]  # control, gripper, objects
        position, angle = _cp.cpBodySetPosition, _cp.cpBodySetAngle
        for body, (x, y, th) in zip(self._body_pointers, rows):
            position(body, (x, y))
            angle(body, th)
        self._bring_to_rest()

    def _bring_to_rest(self) -> None:
        """Zero every body's velocity and angular velocity."""
        velocity, angular = _cp.cpBodySetVelocity, _cp.cpBodySetAngularVelocity
        for body in self._body_pointers:
            velocity(body, _AT_REST)
            angular(body, 0.0)

    def _cold_start(self) -> None:
        """Put the solver in a canonical state: no cached contacts or joint impulses, fixed shape
        hash ids and insertion order. Makes an action a function of the snapshot alone."""
        space = self.space
        if self._shapes_in_space:
            # The shapes leave Chipmunk's space and come back below in the same order; pymunk's
            # bookkeeping (which shapes the space holds) stays as it is, so Chipmunk is called
            # directly: the same C calls pymunk's remove and add make, without their overhead.
            remove, space_pointer = _cp.cpSpaceRemoveShape, space._space
            for shape in self._dynamic_shape_pointers:
                remove(space_pointer, shape)
            if self._constraints:  # (pymunk's remove and add cost even with nothing to do)
                space.remove(*self._constraints)
        _cp.cpSpaceSetShapeIDCounter(space._space, self._shape_id_base)
        ps = self.physics
        if joint_reset.AVAILABLE:  # the drive and floor joints are kept, their impulses zeroed: as new ones
            if not self._kept_joints:
                self._kept_joints = self._drive_and_floor_joints()
                space.add(*self._kept_joints)
                self._kept_impulses = joint_reset.ImpulseSlots(pivots=self._kept_joints[0::2], gears=self._kept_joints[1::2])
            kept = self._kept_joints
            self._kept_impulses.zero()
            if self._floor_limits_stale:  # the floor friction of this action's (noisy) physics
                for i in range(self.num_objects):
                    force = float(self.floor_force[i])
                    _cp.cpConstraintSetMaxForce(kept[2 + 2 * i]._constraint, force)
                    _cp.cpConstraintSetMaxForce(kept[3 + 2 * i]._constraint, force * float(self.floor_arm[i]))
                self._floor_limits_stale = False
            cons = []
        else:  # new joints every action
            cons = self._drive_and_floor_joints()
        if self.held is not None:
            body = self.bodies[self.held]
            anchor = self.gripper.world_to_local(body.position)
            if ps.finger_contact:  # the closed fingers draw the object to the centre between them
                anchor = (anchor.x + self._centring_shift(self.held), anchor.y)
            cons += grasp_joints(self.gripper, body, anchor, ps)
        if self._filtered != self.held:  # the held object does not collide with the gripper
            if self._filtered is not None:
                self.shapes[self._filtered].filter = _NO_GROUP
            if self.held is not None:
                self.shapes[self.held].filter = _IN_GRIPPER_GROUP
            self._filtered = self.held
        if self._shapes_in_space:
            add, space_pointer = _cp.cpSpaceAddShape, space._space
            for shape in self._dynamic_shape_pointers:
                add(space_pointer, shape)
            if cons:
                space.add(*cons)
        else:
            space.add(*self._dynamic_shapes, *cons)
        self._constraints = cons
        self._shapes_in_space = True
        _cp.cpSpaceSetCurrentTimeStep(space._space, 0.0)
        _cp.cpSpaceSetTimestamp(space._space, 0)
        # Chipmunk carries each body's position-correction ("bias") velocity into the next step;
        # a zero-length position update clears it without moving the body.
        update = _cp.cpBodyUpdatePosition
        for body in self._body_pointers:
            update(body, 0.0)

    def _drive_and_floor_joints(self) -> list[pymunk.Constraint]:
        """New joints: the gripper's drive (pivot, gear) and each object's floor friction (pivot,
        gear), in this order (:func:`~occrl.envs.pymunk2d.joints.drive_and_floor_joints`)."""
        return drive_and_floor_joints(
            self.space.static_body, self.control, self.gripper, self.bodies, self.floor_force, self.floor_arm, self.physics
        )

    # ------------------------------------------------------------------ state
    def gripper_pose(self) -> np.ndarray:
        return np.array(self._gripper_xyth())

    def _gripper_xyth(self) -> tuple[float, float, float]:
        """:meth:`gripper_pose` as Python floats."""
        g = self.gripper._body
        p = _cp.cpBodyGetPosition(g)
        return p.x, p.y, _cp.cpBodyGetAngle(g)

    def object_poses(self) -> np.ndarray:
        """(n, 3) centroid poses of all objects."""
        return np.array(self._object_pose_rows()).reshape(-1, 3)

    def _object_pose_rows(self) -> list[list[float]]:
        """:meth:`object_poses` as Python floats, one [x, y, theta] per object."""
        out = []
        for b in self.bodies:
            p = _cp.cpBodyGetPosition(b._body)
            out.append([p.x, p.y, _cp.cpBodyGetAngle(b._body)])
        return out

    def object_world_polygons(self) -> list[np.ndarray]:
        """Each object's nominal polygon (its type's shape) at its current pose."""
        padded = self.object_world_padded()
        return [padded[i, :n] for i, n in enumerate(self.num_vertices)]

    def object_world_padded(self, poses: np.ndarray | None = None) -> np.ndarray:
        """(n, MAX_VERTICES, 2) shelf-frame polygons, padded by repeating the first vertex."""
        return transform_polygons(self.padded_vertices, self.object_poses() if poses is None else poses)

    def set_gripper_state(self, opening: float, closed: bool, held: int | None) -> None:
        """Set the gripper of a recreated state (planning): opening, last command, held object."""
        if held is not None and not 0 <= held < self.num_objects:
            raise ValueError(f"held must be an object index in [0, {self.num_objects}) or None, got {held}")
        self.closed = bool(closed)
        self.held = held
        self._set_opening(float(opening))

    def set_poses(self, gripper_pose: np.ndarray, object_poses: np.ndarray) -> None:
        """Place the gripper and every object (``(n, 3)``) at rest (planning: a kept world set to
        a new recreated state steps as a newly built one does, bit for bit) and clear the
        validity measures of the last action."""
        object_poses = np.asarray(object_poses, dtype=float).reshape(-1, 3)
        if len(object_poses) != self.num_objects:
            raise ValueError(f"object_poses must have one (x, y, theta) per object ({self.num_objects}), got {len(object_poses)}")
        self._set_poses(np.asarray(gripper_pose, dtype=float), object_poses)
        self.penetration, self.crossed_wall = 0.0, False

    def snapshot(self) -> dict:
        """The complete state: poses, gripper opening and grasp, noise generator."""
        return {
            "gripper_pose": self.gripper_pose(),
            "object_poses": self.object_poses(),
            "opening": self.opening,
            "closed": self.closed,
            "held": self.held,
            "rng": copy.deepcopy(self.rng.bit_generator.state),
        }

    def restore(self, snap: dict) -> None:
        """Return to a :meth:`snapshot`; the next action then gives bit-identical results."""
        self._set_poses(snap["gripper_pose"], snap["object_poses"])
        self.closed = snap["closed"]
        self.held = snap["held"]
        self._set_opening(snap["opening"])
        self.rng.bit_generator.state = copy.deepcopy(snap["rng"])

    # ------------------------------------------------------------------ dynamics
    def step(self, action) -> StepOutcome:
        """Apply one action ``[forward, lateral, rotation, gripper]``; entries are clipped to [-1, 1].

        Raises:
            ValueError: if the action is not 4 finite numbers; the world is left unchanged.
        """
        a = np.asarray(action, dtype=float).reshape(-1)
        if a.shape != (C.ACTION_DIM,):
            raise ValueError(f"action must have {C.ACTION_DIM} entries (forward, lateral, rotation, gripper), got shape {a.shape}")
        # Python floats from here on (the same IEEE values as numpy's, without its per-call cost)
        a = a.tolist()
        if not all(map(math.isfinite, a)):
            raise ValueError(f"action contains NaN or inf: {a}; allowed: finite numbers (clipped to [-1, 1])")
        a = [min(max(v, -1.0), 1.0) for v in a]
        if self.noise > 0.0:
            self._perturb()
        self._actuate_fingers(close=a[3] > 0.0)
        self._cold_start()

        # Target pose of the control body (workspace-limited), reached at constant velocity.
        x, y, th = self._gripper_xyth()
        fwd, lat, rot = a[0] * C.MAX_FORWARD, a[1] * C.MAX_LATERAL, a[2] * C.MAX_ROTATION
        c, s = math.cos(th), math.sin(th)
        tx = min(max(x + c * lat - s * fwd, C.GRIPPER_X_LIMITS[0]), C.GRIPPER_X_LIMITS[1])
        ty = min(max(y + s * lat + c * fwd, C.GRIPPER_Y_LIMITS[0]), C.GRIPPER_Y_LIMITS[1])
        tth = min(max(th + rot, C.GRIPPER_THETA_LIMITS[0]), C.GRIPPER_THETA_LIMITS[1])
        control = self.control._body
        _cp.cpBodySetPosition(control, (x, y))
        _cp.cpBodySetAngle(control, th)
        _cp.cpBodySetVelocity(control, ((tx - x) / C.ACTION_DURATION, (ty - y) / C.ACTION_DURATION))
        _cp.cpBodySetAngularVelocity(control, (tth - th) / C.ACTION_DURATION)
        ps = self.physics
        dt = C.ACTION_DURATION / ps.substeps
        fine = ps.contact_substeps
        # Chipmunk's step called directly: pymunk's wrapper only adds bookkeeping for changes
        # made during a step, and this world makes none.
        space, step = self.space._space, _cp.cpSpaceStep
        if fine > 1 and contact_list.AVAILABLE:  # the fast contact test, inlined (called every substep)
            head, null = contact_list.arbiter_head(self.gripper), contact_list.NULL
            for _ in range(ps.substeps):
                if head[0] != null:  # contact_list.has_arbiters(head)
                    for _ in range(fine):
                        step(space, dt / fine)
                else:
                    step(space, dt)
        else:
            for _ in range(ps.substeps):
                if fine > 1 and self._gripper_touches():
                    for _ in range(fine):
                        step(space, dt / fine)
                else:
                    step(space, dt)
        # Quasi-static: everything comes to rest between actions.
        self._bring_to_rest()
        if ps.measure_validity:
            self.penetration, self.crossed_wall = self._measure_validity()
        else:
            self.penetration, self.crossed_wall = math.nan, False
        if not self.physically_valid():
            logger.debug("physically invalid state: penetration %.4f m, object past a wall: %s", self.penetration, self.crossed_wall)
        return self._outcome()

    # ------------------------------------------------------------------ validity
    def physically_valid(self, max_penetration: float = INVALID_PENETRATION) -> bool:
        """Whether the state after the last action is physically sound: no overlap deeper than
        ``max_penetration`` (m) and no object centroid beyond a wall. True when the world's
        settings do not measure (``PhysicsSettings.measure_validity``)."""
        return not self.penetration > max_penetration and not self.crossed_wall

    def _measure_validity(self) -> tuple[float, bool]:
        """Deepest penetration (pymunk's contact depths between the simulated shapes: objects,
        gripper, walls) and whether the area centroid of an object's simulated (noisy) shape lies
        beyond a wall."""
        buffer = self._contact_buffer
        buffer.clear()
        pymunk.batch.get_space_arbiters(self.space, _CONTACT_DEPTHS, buffer)
        distance = np.frombuffer(buffer.float_buf())  # < 0: overlap; arbiters not touching read 0
        deepest = max(0.0, -float(distance.min())) if distance.size else 0.0
        # The body origin is the nominal centroid; only near a wall is the noisy shape's own
        # centroid worth computing.
        poses = self.object_poses()
        near = (poses[:, 1] > C.SHELF_DEPTH - C.MAX_OBJECT_RADIUS) | (np.abs(poses[:, 0]) > C.SHELF_HALF_WIDTH - C.MAX_OBJECT_RADIUS)
        if not near.any():
            return deepest, False
        polygons = self.simulated_polygons()
        centroids = np.array([polygon_centroid(polygons[i]) for i in np.flatnonzero(near)])
        return deepest, beyond_walls(centroids)

    def _gripper_touches(self, head=None) -> bool:
        """Whether the gripper touches any shape; ``head``: the gripper's
        :func:`~occrl.envs.pymunk2d.contact_list.arbiter_head` (the fast test), or None."""
        if head is not None:
            return contact_list.has_arbiters(head)
        touching = []
        self.gripper.each_arbiter(touching.append)
        return bool(touching)

    def _outcome(self) -> StepOutcome:
        return task_outcome(self._object_pose_rows(), self.held, self.target_index)

    def _perturb(self) -> None:
        lvl, rng = self.noise, self.rng
        for i in range(self.num_objects):
            v = self.nominal_vertices[i]
            noisy = convex_hull(v + rng.normal(0.0, lvl * self.object_radius[i], size=v.shape))
            density = max(rng.normal(C.NOMINAL_DENSITY, lvl * C.NOMINAL_DENSITY), 0.05 * C.NOMINAL_DENSITY)
            friction = max(rng.normal(C.NOMINAL_FRICTION, lvl * C.NOMINAL_FRICTION), 0.0)
            if len(noisy) < 3 or polygon_area(noisy) < 1e-6:  # pragma: no cover - absurd noise levels
                noisy = v
            self.shapes[i].unsafe_set_vertices(noisy.tolist())
            self._set_physics(i, noisy, density, friction)
            self._nominal_shapes[i] = None

    def simulated_polygons(self) -> list[np.ndarray]:
        """Each object's shape as simulated (with this action's noise) at its current pose."""
        out = []
        for body, shape in zip(self.bodies, self.shapes):
            local = np.array([tuple(v) for v in shape.get_vertices()])
            out.append(transform_points(local, (body.position.x, body.position.y, body.angle)))
        return out
