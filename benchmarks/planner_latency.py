"""Hybrid-planner decision time on one core, and batched RHP against the sequential reference.

Usage:
    python benchmarks/planner_latency.py [--decisions 30] [--weights PATH_OR_NAME] [--physics-change]
                                         [--worlds-together] [--inference onnxruntime]

Decisions are taken on observations from stage-2 episodes (the scripted retriever drives, so the
states are realistic; the target is often hidden, giving up to 3 heat-map roots). Uses
``--weights`` (a file or a shipped name), else the shipped default network when present, else an
untrained paper net (says which).
``--worlds-together`` only compares batches of 8 worlds planned together
(``HybridPlanner.decide_many``) with the same worlds decided one at a time.
``--physics-change`` only prints 4x4 decision times with the default physics and with occrl
0.1.0's (``LEGACY_PHYSICS``) in the planner's imagined worlds, alternated in rounds in this run.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import importlib
from dataclasses import replace

import numpy as np
import torch

from occrl.baselines import ScriptedRetriever
from occrl.envs import Scene, make_env
from occrl.modules import make_occnet
from occrl.planners import HybridPlanner


def load_net(weights: str | None):
    from occrl.pretrained import available, load_pretrained, network_name, weights_file
    from occrl.modules.weights import load_weights

    if weights:
        return load_weights(weights_file(weights)), network_name(weights)
    if "occnet" in available():
        return load_pretrained("occnet"), f"shipped occnet ({network_name('occnet')})"
    torch.manual_seed(0)
    return make_occnet("paper").eval(), "untrained paper net"


def observations(net, count: int):
    """(observation, hidden) pairs along scripted stage-2 episodes."""
    out = []
    seed = 0
    while len(out) < count:
        env = make_env(batch_size=1, scenes=[Scene.sample(2, seed=20_000 + seed)], heatmap_target=False).append_transform(net.make_primer())
        seed += 1
        td = env.rollout(12, ScriptedRetriever())
        for t in range(0, td.shape[1], 3):
            out.append(td[:, t].exclude("privileged"))
    return out[:count]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--decisions", type=int, default=30)
    parser.add_argument("--weights", default=None)
    parser.add_argument("--physics-change", action="store_true", help="4x4 decisions with the default and the 0.1.0 physics")
    parser.add_argument("--worlds-together", action="store_true", help="only: 8 worlds planned together against one at a time")
    parser.add_argument(
        "--inference",
        default="torch",
        choices=("torch", "onnxruntime"),
        help="the batched planners' network (the sequential reference always runs torch)",
    )
    args = parser.parse_args()
    torch.set_num_threads(1)
    net, name = load_net(args.weights)
    obs = observations(net, args.decisions)
    print(f"network: {name}; {len(obs)} decisions on stage-2 states; one core; batched planners' inference: {args.inference}")
    if args.physics_change:
        physics_change(net, obs)
        return
    if args.worlds_together:
        worlds_together(net, obs, inference=args.inference)
        return
    for m, h in ((2, 2), (4, 4), (6, 6)):
        planner = HybridPlanner(net, m=m, h=h, seed=0, inference=args.inference)
        times, roots = [], []
        for td in obs:
            planner(td.clone())
            times.append(planner.decisions[-1].seconds)
            roots.append(len(planner.decisions[-1].roots))
        times = np.array(times) * 1e3
        print(
            f"hybrid {m}x{h}: p50 {np.percentile(times, 50):6.1f} ms, p95 {np.percentile(times, 95):6.1f} ms (roots per decision: mean {np.mean(roots):.2f}, max {max(roots)})"
        )
    # batched against sequential on the same decisions and noise (decision k draws from seed k):
    # a new batched planner per decision (its world pool empty), and one batched planner
    # reseeded per decision, as in an episode (the pool keeps the roll-out worlds between
    # decisions); the sequential reference builds its worlds per roll-out either way
    tb = tk = ts = 0.0
    same = same_kept = 0
    kept = HybridPlanner(net, m=4, h=4, seed=0, inference=args.inference)
    for k, td in enumerate(obs):
        a = HybridPlanner(net, m=4, h=4, seed=k, inference=args.inference)
        b = HybridPlanner(net, m=4, h=4, seed=k, batched=False)
        kept.reseed(k)
        t = time.perf_counter()
        act_a = a(td.clone())["action"]
        tb += time.perf_counter() - t
        t = time.perf_counter()
        act_kept = kept(td.clone())["action"]
        tk += time.perf_counter() - t
        t = time.perf_counter()
        act_b = b(td.clone())["action"]
        ts += time.perf_counter() - t
        same += bool(torch.allclose(act_a, act_b, atol=1e-5))
        same_kept += bool(torch.allclose(act_kept, act_b, atol=1e-5))
    n = len(obs)
    print(
        f"4x4 batched {1e3 * tb / n:.1f} ms (a new planner per decision) / {1e3 * tk / n:.1f} ms (one planner, its worlds kept) "
        f"vs sequential {1e3 * ts / n:.1f} ms per decision: {ts / tb:.1f}x / {ts / tk:.1f}x faster; "
        f"same action in {same}/{n} / {same_kept}/{n} decisions"
    )
    floor(net, obs, inference=args.inference)
    if args.inference == "torch":  # the profile compares with the sequential reference, which runs torch
        breakdown(net, obs)


def physics_change(net, obs, rounds: int = 2) -> None:
    """4x4 decision times with the planner's worlds on the default and on occrl 0.1.0's physics."""
    from occrl.envs import LEGACY_PHYSICS

    recreate = importlib.import_module("occrl.planners.recreate")  # the package re-exports a function of that name
    settings = {"default physics": recreate.PLANNING_PHYSICS, "0.1.0 physics": LEGACY_PHYSICS}
    times: dict[str, list[float]] = {k: [] for k in settings}
    try:
        for _ in range(rounds):
            for label, physics in settings.items():
                recreate.PLANNING_PHYSICS = replace(physics, measure_validity=False)
                planner = HybridPlanner(net, m=4, h=4, seed=0)
                for td in obs:
                    planner(td.clone())
                    times[label].append(planner.decisions[-1].seconds * 1e3)
    finally:
        recreate.PLANNING_PHYSICS = settings["default physics"]
    for label, t in times.items():
        print(f"hybrid 4x4, {label}: p50 {np.percentile(t, 50):6.1f} ms, p95 {np.percentile(t, 95):6.1f} ms")
    new, old = times["default physics"], times["0.1.0 physics"]
    print(f"ratio p50 {np.percentile(new, 50) / np.percentile(old, 50):.2f}x, p95 {np.percentile(new, 95) / np.percentile(old, 95):.2f}x")


def worlds_together(net, obs, worlds: int = 8, rounds: int = 3, inference: str = "torch") -> None:
    """A batch of ``worlds`` observations (as a training collector or a batched evaluation has
    them): one planner call deciding them together (``HybridPlanner.decide_many``, one RHP over
    every world's roots) against deciding them one world at a time, alternated in rounds."""
    import torch

    batches = [torch.cat(obs[i : i + worlds]) for i in range(0, len(obs) - worlds + 1, worlds)]
    spent = {"together": 0.0, "one at a time": 0.0}
    same = total = 0
    for r in range(rounds):
        together = HybridPlanner(net, m=4, h=4, seed=r, inference=inference, batch_worlds=True)
        alone = HybridPlanner(net, m=4, h=4, seed=r, inference=inference)
        for td in batches:
            t = time.perf_counter()
            a = together(td.clone())["action"]
            spent["together"] += time.perf_counter() - t
            t = time.perf_counter()
            b = torch.cat([alone(td[i : i + 1].clone())["action"] for i in range(td.shape[0])])
            spent["one at a time"] += time.perf_counter() - t
            same += int(torch.isclose(a, b, atol=1e-5).all(-1).sum())
            total += td.shape[0]
    n = total
    print(
        f"4x4 ({inference}), batches of {worlds} worlds: together {1e3 * spent['together'] / n:.1f} ms vs one at a time "
        f"{1e3 * spent['one at a time'] / n:.1f} ms per world's decision: {spent['one at a time'] / spent['together']:.2f}x; "
        f"same action in {same}/{n}"
    )


def floor(net, obs, inference: str = "torch") -> None:
    """How close a 4x4 decision is to the floor of its work: the roll-outs' physics steps
    (``ShelfWorld.step``; of it, Chipmunk's own ``cpSpaceStep``) plus the batched network calls
    (``NetworkStepper.step`` on the ``inference`` backend), timed inside unprofiled decisions of
    one planner; everything else (rendering, world building, glue) is above the floor. Then the
    bound the observation pipeline's cost per world sets: a decision that paid only that for its
    roll-outs' observations (no cost per call, as if one call rendered them all) and its world
    building, and nothing else above the floor; and the batched RHP's largest speed-up over the
    sequential reference (timed here too, its observation calls counted) with no cost per call
    on either side: the two share the observation pipeline."""
    import occrl.envs.pymunk2d.world as world_module
    from occrl.envs.pymunk2d.world import ShelfWorld
    from occrl.planners import rhp
    from occrl.planners.recreate import WorldPool
    from occrl.planners.rhp import NetworkStepper

    spent = {"physics": 0.0, "network": 0.0, "engine": 0.0, "rendering": 0.0, "world building": 0.0}
    # above the floor: the roll-outs' observations (rhp.render_pixels, counted per call and per
    # world) and the roll-out worlds taken from the pool (built or set to the root states)
    originals = {
        "physics": (ShelfWorld, "step"),
        "network": (NetworkStepper, "step"),
        "rendering": (rhp, "render_pixels"),
        "world building": (WorldPool, "take"),
    }
    renders = {"calls": 0, "worlds": 0}
    saved = {k: getattr(cls, name) for k, (cls, name) in originals.items()}
    chipmunk = world_module._cp

    def timed(part, fn):
        def wrapper(*a, **kw):
            if part == "rendering":
                renders["calls"] += 1
                renders["worlds"] += len(a[0])
            t = time.perf_counter()
            try:
                return fn(*a, **kw)
            finally:
                spent[part] += time.perf_counter() - t

        return wrapper

    class TimedChipmunk:  # the C library with its space step timed
        cpSpaceStep = staticmethod(timed("engine", chipmunk.cpSpaceStep))

        def __getattr__(self, name):
            return getattr(chipmunk, name)

    try:
        for part, (cls, name) in originals.items():
            setattr(cls, name, timed(part, saved[part]))
        world_module._cp = TimedChipmunk()
        total = 0.0
        planner = HybridPlanner(net, m=4, h=4, seed=0, inference=inference)
        for td in obs:
            planner(td.clone())
            total += planner.decisions[-1].seconds
        batched_spent, batched_renders = dict(spent), dict(renders)
        renders.update(calls=0, worlds=0)
        sequential_total = 0.0  # the sequential reference, its observation calls counted
        planner = HybridPlanner(net, m=4, h=4, seed=0, batched=False)
        for td in obs:
            planner(td.clone())
            sequential_total += planner.decisions[-1].seconds
        sequential_renders, renders = dict(renders), batched_renders
        spent.update(batched_spent)  # the parts above are the batched planner's
    finally:
        for part, (cls, name) in originals.items():
            setattr(cls, name, saved[part])
        world_module._cp = chipmunk
    n = len(obs)
    low = spent["physics"] + spent["network"]
    print(
        f"4x4 floor ({inference}): physics {1e3 * spent['physics'] / n:.1f} ms (of it the engine's own steps {1e3 * spent['engine'] / n:.1f} ms) "
        f"+ network {1e3 * spent['network'] / n:.1f} ms = {1e3 * low / n:.1f} ms of a {1e3 * total / n:.1f} ms decision; "
        f"{100 * (1 - low / total):.0f} % above the floor ({100 * (1 - (spent['engine'] + spent['network']) / total):.0f} % above "
        "the engine + network)"
    )
    above = total - low
    other = above - spent["rendering"] - spent["world building"]
    print(
        f"  above the floor, {1e3 * above / n:.1f} ms: rendering the roll-outs' observations {1e3 * spent['rendering'] / n:.1f} ms "
        f"({renders['calls'] / n:.1f} calls of {renders['worlds'] / max(renders['calls'], 1):.1f} worlds per decision), "
        f"world building {1e3 * spent['world building'] / n:.1f} ms, other {1e3 * other / n:.1f} ms"
    )
    fixed, per_world, calls_fixed, calls_per_world = perception_cost()
    print(
        f"  the observation pipeline (occrl.envs.observation.world_pixels) costs {fixed:.2f} ms per call + {per_world:.2f} ms per world "
        f"({calls_fixed:.0f} + {calls_per_world:.0f} per world Python-level calls): at {renders['calls'] / n:.1f} calls and "
        f"{renders['worlds'] / n:.1f} worlds per decision, {renders['calls'] / n * fixed:.1f} ms + {renders['worlds'] / n * per_world:.1f} ms"
    )
    # the bound: only the per-world cost of the observations, the world building and the floor
    bound = (low + spent["world building"]) / n + 1e-3 * renders["worlds"] / n * per_world
    line = (
        f"  bound at this per-world cost (no per-call cost, nothing else above the floor): {1e3 * bound:.1f} ms a decision, "
        f"{100 * (1 - low / n / bound):.0f} % above the floor"
    )
    print(line)
    # the sequential reference pays the same pipeline, per call of one world: without per-call costs it is faster too
    sequential = sequential_total / n - 1e-3 * sequential_renders["calls"] / n * fixed
    print(
        f"  the sequential reference ({1e3 * sequential_total / n:.1f} ms a decision, {sequential_renders['calls'] / n:.1f} observation calls "
        f"of {sequential_renders['worlds'] / max(sequential_renders['calls'], 1):.1f} worlds) without per-call costs: {1e3 * sequential:.1f} ms; "
        f"the batched RHP at that bound at most {sequential / bound:.1f}x faster"
    )


def perception_cost(sizes=(1, 2, 4, 8, 16), repeats: int = 20) -> tuple[float, float, float, float]:
    """The observation pipeline's cost as a fixed part per call plus a part per world: a least-squares
    line through its median time on 1-16 stage-2 worlds, and the same for the number of
    Python-level function calls it makes (cProfile's count: the interpreter's work, which is what
    a call of a few worlds mostly pays for)."""
    import cProfile
    import pstats

    from occrl.envs import ShelfWorld
    from occrl.envs.observation import world_pixels

    worlds = [ShelfWorld(Scene.sample(2, seed=30_000 + s)) for s in range(max(sizes))]
    times, calls = [], []
    for size in sizes:
        world_pixels(worlds[:size])
        runs = []
        for _ in range(repeats):
            t = time.perf_counter()
            world_pixels(worlds[:size])
            runs.append(time.perf_counter() - t)
        times.append(1e3 * float(np.median(runs)))
        prof = cProfile.Profile()
        prof.runcall(world_pixels, worlds[:size])
        calls.append(pstats.Stats(prof).total_calls)
    per_world, fixed = np.polyfit(sizes, times, 1)
    calls_per_world, calls_fixed = np.polyfit(sizes, calls, 1)
    return float(fixed), float(per_world), float(calls_fixed), float(calls_per_world)


# where a decision's time goes (cProfile cumulative time of these functions)
PARTS = {
    "network": ("rhp.py", "step"),
    "rendering": ("rhp.py", "render_pixels"),
    "physics": ("world.py", "step"),
    "world building": ("recreate.py", "make_world"),
}


def breakdown(net, obs) -> None:
    """Share of network calls, rendering (visibility + raster), pymunk stepping and world building
    in both implementations, and the speed-up the batched RHP could reach if its network calls
    took no time at all (the per-world parts are the same work in both)."""
    import cProfile
    import pstats

    parts = {}
    for batched in (True, False):
        prof = cProfile.Profile()
        prof.enable()
        for k, td in enumerate(obs):
            HybridPlanner(net, m=4, h=4, seed=k, batched=batched)(td.clone())
        prof.disable()
        stats = pstats.Stats(prof).stats
        total = sum(v[3] for key, v in stats.items() if key[0].endswith("hybrid.py") and key[2] == "forward")
        got = {name: sum(v[3] for key, v in stats.items() if key[0].endswith(f) and key[2] == fn) for name, (f, fn) in PARTS.items()}
        got["other"] = total - sum(got.values())
        parts[batched] = (total, got)
        shares = ", ".join(f"{name} {100 * v / total:.0f} %" for name, v in got.items())
        print(f"4x4 {'batched' if batched else 'sequential'} (profiled, {1e3 * total / len(obs):.1f} ms per decision): {shares}")
    (tb, pb), (ts, _) = parts[True], parts[False]
    print(f"batched with free network calls: at most {ts / (tb - pb['network']):.1f}x faster than the sequential reference")


if __name__ == "__main__":
    main()
