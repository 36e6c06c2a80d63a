"""OMPL low-level planning of the hierarchical baseline: propagations per second and plan time.

For a few stage-1 scenes (gripper where the Search sweep ends, outside the shelf on the right),
plans Retrieve's two queries in the nominal pymunk world: *reach* (open gripper until the target
is alone between the fingers) and then, from the reach plan's end state, *extract* (closed gripper
until the target is past the retrieval line). Prints per query: success, OMPL path length, length
after shortcutting, propagations, seconds; then propagations/s of the bare propagator and the
mean plan time per low-level call.

    python benchmarks/ompl_planning.py --scenes 8 --seconds 3
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from occrl.baselines.goals import HoldGoal, ReachGoal, grasp_poses
from occrl.baselines.kinodynamic import SimControlProblem, ompl_seed
from occrl.baselines.motion import CLOSE, OPEN
from occrl.envs import Scene, ShelfWorld
from occrl.envs import world_constants as C


def propagation_rate(world: ShelfWorld, goal, n: int = 500, seed: int = 0) -> float:
    """Propagations/s through the OMPL propagator callback (restore, step, snapshot, write state)."""
    problem = SimControlProblem(world, goal, OPEN)
    rng = np.random.default_rng(seed)
    start, result = problem.start_state(), problem.space.allocState()
    control = problem.si.allocControl()
    t = time.perf_counter()
    for _ in range(n):
        for k, v in enumerate(rng.uniform(-1, 1, C.ACTION_DIM)):
            control[k] = float(min(v, -0.5)) if k == 3 else float(v)
        problem.propagate(start, control, 1.0, result)
    rate = n / (time.perf_counter() - t)
    problem.close()  # the state and control wrappers free themselves
    return rate


def _describe(plan) -> str:
    ok = "ok" if plan.success else "FAIL"
    return f"{ok} {plan.raw_length}->{len(plan.actions)} actions, {plan.propagations} prop, {plan.seconds:.2f}s"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--first", type=int, default=10_000_000)
    ap.add_argument("--scenes", type=int, default=8)
    ap.add_argument("--seconds", type=float, default=3.0, help="time budget of one query")
    ap.add_argument("--planner", default="rrt", choices=["rrt", "kpiece"])
    args = ap.parse_args()
    ompl_seed(0)
    rates, times, ok, props = [], [], [], []
    for seed in range(args.first, args.first + args.scenes):
        base = Scene.sample(1, seed=seed)
        world = ShelfWorld(Scene.unchecked(base.objects, (0.2, -0.1, 0.0)))
        t = world.target_index
        reach = ReachGoal(t, world.nominal_vertices, grasp_poses(world, t), world.object_poses()[t])
        rates.append(propagation_rate(world, reach))
        problem = SimControlProblem(world, reach, OPEN, planner=args.planner, seed=seed)
        plan = problem.solve(args.seconds)
        line = [f"{seed} n={len(base)} reach: {_describe(plan)}"]
        times.append(plan.seconds)
        ok.append(plan.success)
        props.append(plan.propagations)
        problem.close()
        if plan.success:
            world.restore(plan.final.snap)
            extract = HoldGoal(t, world.gripper_pose(), world.object_poses()[t], max_y=C.RETRIEVED_Y - 0.01)
            problem = SimControlProblem(world, extract, CLOSE, planner=args.planner, seed=seed)
            plan = problem.solve(args.seconds)
            line.append(f"extract: {_describe(plan)}")
            times.append(plan.seconds)
            ok.append(plan.success)
            props.append(plan.propagations)
            problem.close()
        print(" | ".join(line), flush=True)
    print(f"propagations/s (propagator callback): {np.mean(rates):.0f} (min {np.min(rates):.0f}, max {np.max(rates):.0f})")
    print(f"propagations/s while planning (OMPL, goal checks and shortcutting included): {sum(props) / sum(times):.0f}")
    print(
        f"low-level calls: {len(times)}, solved {sum(ok)}, mean plan time {np.mean(times):.3f} s "
        f"(median {np.median(times):.3f} s, budget {args.seconds} s)"
    )


if __name__ == "__main__":
    main()
