"""``occrl demo``: a method plays a few cluttered shelves whose target starts hidden; a short
table of the results, a GIF of every action with titled panels, a picture strip and a summary."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from occrl.atomic_files import write_text_atomic
from occrl.cli.options import checked_weights_file

__all__ = ["run_demo", "demo_seeds", "hidden_target_seeds", "DEMO_STAGE", "DEMO_FIRST_SEED", "PRIVILEGED_LABELS"]


def _gl_available() -> bool:
    """MuJoCo camera images need an OpenGL backend (EGL headless); without one the demo still runs."""
    from occrl.envs.mujoco3d.camera import gl_available

    ok, why = gl_available()
    if not ok:
        print(f"no OpenGL backend for MuJoCo ({why}): the GIF shows no gripper-camera images (detection uses rays)")
    return ok


# what the demo says of the privileged methods it can show
PRIVILEGED_LABELS = {
    "scripted": "the privileged scripted retriever (it reads the true target pose)",
    "clearing": "the privileged clearing retriever (it reads the true state and carries blockers aside)",
}
DEMO_STAGE = 2  # the demo's shelves: 5 to 10 objects
DEMO_FIRST_SEED = 2024  # the demo looks at task seeds from this one on


def demo_seeds(stage: int, count: int, first_seed: int, hidden_target: bool = True, world: str = "pymunk") -> list[int]:
    """The task seeds the demo plays: from ``first_seed`` on, the first ``count`` whose first
    observation in ``world`` does not show the target (:func:`hidden_target_seeds`), or the next ``count`` seeds as they come when ``hidden_target`` is False.

    Raises:
        ValueError: when fewer than ``count`` of the next ``50 * count`` shelves start with their target hidden.

    Examples:
        >>> from occrl.cli.demo import demo_seeds
        >>> demo_seeds(2, 3, 2024)  # 2025, 2026 and 2028 show their target in the first observation
        [2024, 2027, 2029]
        >>> demo_seeds(2, 3, 2024, hidden_target=False)
        [2024, 2025, 2026]
    """
    if not hidden_target:
        return list(range(first_seed, first_seed + count))
    seeds: list[int] = []
    end = first_seed + 50 * count
    for start in range(first_seed, end, 8):
        seeds += hidden_target_seeds(stage, range(start, min(start + 8, end)), world)
        if len(seeds) >= count:
            return seeds[:count]
    raise ValueError(
        f"only {len(seeds)} of the {50 * count} stage-{stage} shelves from seed {first_seed} on start with their target hidden; "
        "give --seed to play shelves as they come"
    )


def hidden_target_seeds(stage: int, seeds: range | list[int], world: str = "pymunk") -> list[int]:
    """The task seeds among ``seeds`` (:func:`occrl.envs.episodes.task_scenes`) whose first
    observation in ``world`` ("pymunk" or "mujoco", whose camera sees in 3D) does not report the
    target, in seed order.

    Examples:
        >>> from occrl.cli.demo import hidden_target_seeds
        >>> hidden_target_seeds(2, range(2024, 2030))
        [2024, 2027, 2029]
    """
    from occrl.envs import make_env
    from occrl.envs.episodes import task_scenes
    from occrl.planners.recreate import recreate

    seeds = [int(s) for s in seeds]
    env = make_env(batch_size=len(seeds), scenes=task_scenes(stage, seeds), seed=seeds, heatmap_target=False, world=world)
    first = env.reset()
    env.close()
    return [seed for b, seed in enumerate(seeds) if not recreate(first[b]).target_detected]


def run_demo(args: argparse.Namespace) -> int:
    from occrl.envs import Scene, make_env
    from occrl.eval import episode_frames, save_film_strip, save_gif
    from occrl.pretrained import available, network_name

    out = Path(args.out)
    method = args.method
    if method not in PRIVILEGED_LABELS and not args.weights and "occnet" not in available():
        print("no shipped network in this installation: showing the privileged scripted retriever instead")
        method = "scripted"
    primers, size, remembered = [], None, False
    if method in PRIVILEGED_LABELS:
        from occrl.eval.methods import make_method

        policy, label = make_method(method).policy, PRIVILEGED_LABELS[method]
    else:
        from occrl.modules.weights import load_weights
        from occrl.planners import HybridPlanner
        from occrl.pretrained import load_pretrained

        weights = checked_weights_file(args.weights) if args.weights else None
        net = load_weights(weights) if weights else load_pretrained("occnet")
        m, h = (int(v) for v in method.split("-")[-1].split("x"))
        policy = HybridPlanner(net, m=m, h=h)  # reseeded per shelf
        primers, size, remembered = [net.make_primer()], net.config.image_size, net.config.remembered_detections
        name = args.weights or "occnet"
        if Path(name).exists():
            network = f"the network in {name}"
        else:
            network = f"the shipped network {name}" + (f" ({network_name(name)})" if network_name(name) != name else "")
        label = f"the hybrid planner {m}x{h} with {network}"
    hidden = args.seed is None  # the default shelves: their target starts hidden
    seeds = demo_seeds(args.stage, args.tasks, DEMO_FIRST_SEED if hidden else args.seed, hidden_target=hidden, world=args.world)
    record_camera = args.world == "mujoco" and _gl_available()  # asked once, said once
    world = "the 2D pymunk world" if args.world == "pymunk" else "the 3D MuJoCo shelf"
    which = "whose target starts hidden" if hidden else "as given"
    print(f"occrl demo: {label}, in {world}")
    shelves, task_seeds = ("shelf", "task seed") if args.tasks == 1 else ("shelves", "task seeds")
    print(f"{args.tasks} stage-{args.stage} {shelves} {which} ({task_seeds} {', '.join(map(str, seeds))})\n")
    print(f"{'task':>4}  {'seed':>6}  {'objects':>7}  {'result':<8}  {'actions':>7}  {'seconds':>7}")
    rows, frames_all, first_frames = [], [], 0
    for k, seed in enumerate(seeds):
        scene = Scene.sample(args.stage, seed=seed)
        extra = {"world": "mujoco", "record_camera": record_camera} if args.world == "mujoco" else {}
        if size is not None:  # the network's image size (the privileged methods read no image)
            extra["size"] = size
        env = make_env(batch_size=1, scenes=[scene], heatmap_target=False, remembered_detections=remembered, **extra)
        for p in primers:
            env.append_transform(p.clone())
        if hasattr(policy, "reseed"):
            policy.reseed(seed)
            policy.decisions.clear()
        t = time.time()
        td = env.rollout(50, policy=policy)[0]
        dt = time.time() - t
        nxt = td.get("next")
        result = "success" if bool(nxt["success"].any()) else ("dropped" if bool(nxt["dropped"].any()) else "failed")
        rows.append({"task": k + 1, "seed": seed, "objects": len(scene), "result": result, "actions": td.shape[0], "seconds": round(dt, 3)})
        print(f"{k + 1:>4}  {seed:>6}  {len(scene):>7}  {result:<8}  {td.shape[0]:>7}  {dt:>7.1f}")
        frames_all.extend(episode_frames(td, decisions=getattr(policy, "decisions", None)))
        first_frames = first_frames or len(frames_all)
    successes = sum(r["result"] == "success" for r in rows)
    summary = {
        "method": method,
        "description": label,
        "stage": args.stage,
        "world": args.world,
        "target_hidden_at_start": hidden,
        "tasks": rows,
        "success_rate": successes / len(rows),
    }
    write_text_atomic(out / "demo_summary.json", json.dumps(summary, indent=2))
    gif = save_gif(frames_all, out / "demo.gif", fps=args.fps)
    strip = save_film_strip(frames_all[:first_frames], out / "demo_strip.png")
    print(f"\nretrieved {successes} of {len(rows)} targets")
    print(f"GIF:     {gif} ({len(frames_all)} frames, one per action and the last state: the true scene beside what the network sees)")
    print(f"also:    {strip} (the first shelf), {out / 'demo_summary.json'}")
    return 0
