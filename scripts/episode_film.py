"""A film of one held-out episode of any evaluation method: the true shelf beside what the
decision maker sees, action by action.

    python scripts/episode_film.py --method stochastic-gen --weights W.pt --stage 2 --seed 10000011 --out F.png
    python scripts/episode_film.py --method hybrid-4x4 --stage 2 --seed 10000011 --out F.gif

The episode is the one ``occrl eval --method M --stage S`` plays on task seed ``--seed`` (the same
scene, execution noise and decision seed), run alone instead of in a batch of 16: a network's
batched convolutions round differently, so a long episode can part from the evaluation's after
some steps (the printed outcome says which this one was). ``.png`` writes a film strip of up to
12 evenly spaced frames, ``.gif`` every frame. A planner's frames also show its heat-map and
roots (``occrl demo``'s pictures).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from occrl.envs.episodes import task_scenes
from occrl.eval.film import episode_frames, save_film_strip, save_gif
from occrl.eval.methods import METHODS, is_method, make_method, method_network
from occrl.pretrained import weights_file


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--method", required=True, help=f"an occrl eval method ({', '.join(METHODS)}, hybrid-MxH, ...)")
    parser.add_argument("--weights", default=None, help="weights file or shipped network name (default: the method's own)")
    parser.add_argument("--stage", type=int, default=2, choices=(1, 2, 3))
    parser.add_argument("--seed", type=int, required=True, help="task seed (held-out tasks: 10000000 onwards)")
    parser.add_argument("--out", required=True, help="film strip (.png) or animation (.gif)")
    parser.add_argument("--fps", type=float, default=4.0, help="frames per second of a GIF")
    args = parser.parse_args()
    out = Path(args.out)
    if out.suffix not in (".png", ".gif"):
        raise SystemExit(f"--out must end in .png (a film strip) or .gif (an animation), got {args.out!r}")
    if not is_method(args.method):
        raise SystemExit(f"unknown --method {args.method!r}; one of {', '.join(METHODS)} or hybrid-MxH")
    if args.weights and method_network(args.method)[0] is None:
        raise SystemExit(f"--weights applies to methods with a network; {args.method!r} has none")
    method = make_method(args.method, weights_file(args.weights) if args.weights else None)
    captured = []
    [result] = method.run_episodes(task_scenes(args.stage, [args.seed]), [args.seed], batch_size=1, on_rollout=captured.append)
    episode = captured[0][0][: result.actions]
    decisions = getattr(method.policy, "decisions", None)
    frames = episode_frames(episode, decisions=list(decisions)[-result.actions :] if decisions else None)
    path = save_gif(frames, out, fps=args.fps) if out.suffix == ".gif" else save_film_strip(frames, out)
    outcome = "success" if result.success else ("dropped an object" if result.dropped else "not retrieved")
    print(f"{args.method}, stage {args.stage}, task {args.seed}: {outcome} after {result.actions} actions; wrote {path}")


if __name__ == "__main__":
    main()
