"""Adversarial pushing: how well a shelf world keeps solids apart when the gripper pushes hard.

Full-speed random actions (every entry of magnitude 0.5 to 1 with a random sign, the gripper
closing and opening at random) on sampled shelves; after every action the world's own validity
measure is read: the deepest overlap between two bodies or a body and a wall, and whether an
object has crossed a wall. ``benchmarks/physics_validity.py`` prints the trade-off between
settings; tests/envs/test_physics_validity.py holds the statistical check of the defaults.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from occrl.envs.pymunk2d.physics_settings import DEFAULT_PHYSICS, PhysicsSettings
from occrl.envs.scene import Scene
from occrl.envs.pymunk2d.world import ShelfWorld

__all__ = ["PushingReport", "adversarial_pushing", "pymunk_world_factory"]

# Episodes of random pushing end after this many actions (or when the world reports a terminal
# state: an object off the shelf, the target out), then a new shelf is sampled.
PUSHES_PER_SHELF = 30


@dataclass
class PushingReport:
    """Penetration (m) after every action, wall crossings and physics seconds per action.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.pymunk2d.physics_validity import PushingReport
        >>> r = PushingReport(penetration=np.array([0.0, 0.001, 0.003]), crossings=0, seconds_per_action=1e-3)
        >>> round(r.share_above(0.002), 3), r.worst_mm
        (0.333, 3.0)
    """

    penetration: np.ndarray
    crossings: int
    seconds_per_action: float

    @property
    def states(self) -> int:
        return len(self.penetration)

    def share_above(self, depth: float) -> float:
        """Fraction of states with an overlap deeper than ``depth`` (m)."""
        return float(np.mean(self.penetration > depth)) if self.states else 0.0

    @property
    def worst_mm(self) -> float:
        return round(1000.0 * float(self.penetration.max()), 1) if self.states else 0.0


def pymunk_world_factory(physics: PhysicsSettings = DEFAULT_PHYSICS) -> Callable[[Scene, float, int], ShelfWorld]:
    """A ``(scene, noise, seed) -> world`` factory of pymunk worlds with the given settings."""

    def make(scene: Scene, noise: float, seed: int) -> ShelfWorld:
        return ShelfWorld(scene, noise=noise, rng=np.random.default_rng(seed), physics=physics)

    return make


def adversarial_pushing(
    make_world: Callable[[Scene, float, int], object],
    stage: int,
    noise: float,
    states: int,
    seed: int = 0,
) -> PushingReport:
    """Push ``states`` times at full speed on shelves of ``stage`` and read the validity measure.

    ``make_world(scene, noise, seed)`` builds a world that offers ``step``, ``penetration`` and
    ``crossed_wall`` (both the pymunk and the MuJoCo world do). Shelf ``k`` is
    ``Scene.sample(stage, seed=seed + k)``; the actions come from ``seed`` too, so a report is
    a function of its arguments.

    Examples:
        >>> from occrl.envs.pymunk2d.physics_validity import adversarial_pushing, pymunk_world_factory
        >>> report = adversarial_pushing(pymunk_world_factory(), stage=2, noise=0.0, states=20)
        >>> report.states, report.crossings
        (20, 0)
    """
    if states < 1:
        raise ValueError(f"states must be >= 1, got {states}")
    rng = np.random.default_rng([seed, stage, int(round(noise * 1000))])
    depths: list[float] = []
    crossings = 0
    seconds = 0.0
    shelf = 0
    while len(depths) < states:
        world = make_world(Scene.sample(stage, seed=seed + shelf), noise, seed + shelf)
        shelf += 1
        for _ in range(PUSHES_PER_SHELF):
            action = rng.uniform(0.5, 1.0, 4) * rng.choice([-1.0, 1.0], 4)
            t = time.perf_counter()
            out = world.step(action)
            seconds += time.perf_counter() - t
            depths.append(world.penetration)
            crossings += bool(world.crossed_wall)
            if out.terminal or len(depths) >= states:
                break
        close = getattr(world, "close", None)
        if close is not None:
            close()
    return PushingReport(np.asarray(depths), crossings, seconds / len(depths))
