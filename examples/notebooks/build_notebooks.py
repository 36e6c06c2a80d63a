"""Write the example notebooks (without outputs) from the cells below.

    python examples/notebooks/build_notebooks.py

Edit the cells here, rebuild, commit the .ipynb files (without outputs). The docs build
(docs/conf.py) and CI (tests/examples/test_notebooks.py) execute every notebook top to bottom with
``OCCRL_NOTEBOOK_FAST=1``, which shortens the slow cells; each notebook must show a picture.
"""

from __future__ import annotations

from pathlib import Path

import nbformat
from nbformat.v4 import new_code_cell, new_markdown_cell, new_notebook

HERE = Path(__file__).parent

SETUP = """import os

import matplotlib.pyplot as plt
import numpy as np
import torch

FAST = os.environ.get("OCCRL_NOTEBOOK_FAST") == "1"  # the docs build and CI set this: shorter runs, same steps"""

TOUR = [
    new_markdown_cell("""# 1. A tour of the shelf environment

The robot sees the shelf from a camera on its gripper. Objects more than 50 % visible are
*detected*; everything else is unknown. `make_env` builds the TorchRL pipeline the network and the
planners use: the batched pymunk `ShelfEnv`, the `OcclusionRender` transform (an abstract top-down
label map of what is known, seen free, and occluded) and the `RobotCentricCrop` (the 64 x 64
network input around the gripper)."""),
    new_code_cell(SETUP),
    new_code_cell("""from occrl.envs import make_env

env = make_env(batch_size=1, stage=2, seed=7)
td = env.reset()
print(env.action_spec)
print(sorted(k if isinstance(k, str) else "/".join(k) for k in td.keys(include_nested=True, leaves_only=True)))"""),
    new_markdown_cell("""Observation entries are what a perception system reports (gripper pose, detected objects,
the target's shape as a task prior). Ground truth lives under `"privileged"`: losses, the
scripted expert and pictures use it, no policy does. Here is what the robot knows against what
is there:"""),
    new_code_cell("""priv = td["privileged"][0]
print("objects on the shelf:", int(priv["object_present"].sum()))
print("detected (> 50 % visible):", int(td["objects", "detected"][0].sum()))
print("target detected:", bool((td["objects", "detected"][0] & (td["objects", "type_id"][0] == td["target_type"][0])).any()))"""),
    new_code_cell("""from occrl.eval.film import frame

plt.figure(figsize=(9, 4))
plt.imshow(frame(td[0], "left: the true shelf (target red)   right: the network input (robot-centric)"))
plt.axis("off");"""),
    new_markdown_cell("""## The transforms one at a time

`OcclusionRender` draws the shelf-frame label map; `RobotCentricCrop` resamples it around the
gripper. Both are TorchRL transforms and can be called on a tensordict directly."""),
    new_code_cell("""from occrl.envs import ShelfEnv
from occrl.envs.render import labels_to_rgb
from occrl.envs.transforms import OcclusionRender, RobotCentricCrop

bare = ShelfEnv(batch_size=1, stage=2, seed=7)
raw = bare.reset()
rendered = OcclusionRender()(raw.clone())
cropped = RobotCentricCrop()(rendered.clone())
fig, axes = plt.subplots(1, 2, figsize=(8, 4))
axes[0].imshow(labels_to_rgb(rendered["shelf_labels"][0].numpy())); axes[0].set_title("OcclusionRender: shelf frame")
axes[1].imshow(cropped["pixels"][0].permute(1, 2, 0)); axes[1].set_title("RobotCentricCrop: 64 x 64 input")
for a in axes: a.axis("off")"""),
    new_markdown_cell("""## An episode

Actions are `(forward, lateral, rotation, gripper)` in [-1, 1] in the gripper frame. The
privileged scripted retriever (the imitation expert) reads the ground truth and pulls the target
out; `env.rollout` runs it and `episode_frames` turns the rollout into pictures."""),
    new_code_cell("""from occrl.baselines import ScriptedRetriever
from occrl.eval.film import episode_frames, save_gif

rollout = env.rollout(50, ScriptedRetriever())[0]
end = rollout[-1]["next"]
print(f"{rollout.shape[0]} actions, success {bool(end['success'])}, dropped {bool(end['dropped'])}, return {rollout['next', 'reward'].sum():.0f}")
frames = episode_frames(rollout)
picks = np.linspace(0, len(frames) - 1, 4).round().astype(int)
fig, axes = plt.subplots(2, 2, figsize=(12, 6))
for a, k in zip(axes.flat, picks):
    a.imshow(frames[k]); a.axis("off")
save_gif(frames, "tour_episode.gif")"""),
    new_markdown_cell("""## Batched worlds and bad input

One `ShelfEnv` steps many worlds (one network call serves them all). A NaN action is refused with
a clear error and leaves every world as it was."""),
    new_code_cell("""batch = make_env(batch_size=8, stage=1, seed=0)
out = batch.rollout(5, ScriptedRetriever())
print(out.batch_size)
try:
    batch.step(out[:, -1].set("action", torch.full((8, 4), float("nan"))))
except ValueError as err:
    print("refused:", err)"""),
]

TRAIN = [
    new_markdown_cell("""# 2. Train a small network for a few minutes

`Trainer` runs the whole loop of `occrl train`: TorchRL collectors, the DAgger warm start on the
scripted expert (the `cpu` preset), PPO + heat-map loss afterwards, the curriculum, checkpoints
every few minutes and exact resume. Here: a few minutes of the `cpu` preset's warm start with
fewer environments, then the learning curves and the learned policy on a few shelves. (A network
worth shipping takes hours: see *Training* in the user guide.)"""),
    new_code_cell(SETUP),
    new_code_cell("""import tempfile

from occrl.training import Trainer, get_train_config

run_dir = tempfile.mkdtemp(prefix="occrl-notebook-")
if FAST:
    config = get_train_config("tiny", imitation_iters=4, imitation_updates=2)
    budget = dict(iterations=4)
else:
    config = get_train_config("cpu", num_envs=16)
    budget = dict(max_seconds=180)
print(config)
trainer = Trainer(config, run_dir, seed=0, progress=True, tensorboard=False)
try:
    summary = trainer.train(**budget)
finally:
    trainer.close()
print({k: summary[k] for k in ("iteration", "frames", "phase", "success_rate", "loss_imitation")})"""),
    new_markdown_cell("""Every iteration appends a row to `metrics.jsonl` in the run folder; the trainer also writes
CSV and TensorBoard logs and a learning-curve PNG. Plot any column yourself:"""),
    new_code_cell("""import json

rows = [json.loads(line) for line in open(f"{run_dir}/metrics.jsonl")]
frames = [r["frames"] for r in rows]
fig, axes = plt.subplots(1, 3, figsize=(13, 3))
axes[0].plot(frames, [r["success_rate"] for r in rows]); axes[0].set_title("training-episode success (expert mixed in)")
axes[1].plot(frames, [r["loss_imitation"] for r in rows]); axes[1].set_title("imitation NLL")
axes[2].plot(frames, [r.get("loss_heatmap", np.nan) for r in rows]); axes[2].set_title("heat-map BCE")
for a in axes: a.set_xlabel("frames")"""),
    new_markdown_cell("""The checkpoint resumes exactly (same weights as an uninterrupted run); the weights file loads
into any method of `occrl eval`:"""),
    new_code_cell("""from occrl.eval.runner import EVAL_SEED_BASE, run_tasks, summarize

results = run_tasks("greedy", stage=1, seeds=list(range(EVAL_SEED_BASE, EVAL_SEED_BASE + (4 if FAST else 16))),
                    weights=f"{run_dir}/weights.pt", progress=False)
print(summarize(results))"""),
    new_code_cell("""from occrl.envs import make_env
from occrl.eval.film import episode_frames
from occrl.modules.weights import load_weights
from torchrl.envs.utils import ExplorationType, set_exploration_type

net = load_weights(f"{run_dir}/weights.pt")
env = make_env(batch_size=1, stage=1, seed=3).append_transform(net.make_primer())
with torch.no_grad(), set_exploration_type(ExplorationType.DETERMINISTIC):
    rollout = env.rollout(8 if FAST else 50, net.policy)[0]
frames = episode_frames(rollout)
fig, axes = plt.subplots(1, 3, figsize=(15, 3.5))
for a, k in zip(axes, [0, len(frames) // 2, len(frames) - 1]):
    a.imshow(frames[k]); a.axis("off")"""),
]

PLANNER = [
    new_markdown_cell("""# 3. The hybrid planner, step by step

One decision of `HybridPlanner` (paper Alg. 1), taken apart:

1. the network reads the observation and predicts a **heat-map** of where the hidden target may be;
2. the known state is **recreated** in pymunk from the detections (never from ground truth);
3. heat-map peaks become **root states**, each with the target placed there and a weight;
4. from every root, **m roll-outs of depth h** (the network's policy, in lock-step) are scored
   by their returns plus the value at the horizon;
5. the executed action is the first action of the best roll-out of the root with the highest
   `w x (R - L)`."""),
    new_code_cell(SETUP),
    new_code_cell("""import occrl
from occrl.envs import make_env

net = occrl.load_pretrained("occnet")
env = make_env(batch_size=1, stage=2, seed=11).append_transform(net.make_primer())
td = env.reset()
with torch.no_grad():
    out = net.heatmap(td.clone())
heat = out["heatmap"][0, 0].numpy()
fig, axes = plt.subplots(1, 2, figsize=(8, 4))
axes[0].imshow(td["pixels"][0].permute(1, 2, 0)); axes[0].set_title("observation")
axes[1].imshow(td["pixels"][0].permute(1, 2, 0)); axes[1].contour(heat, levels=4, cmap="magma"); axes[1].set_title("heat-map contours")
for a in axes: a.axis("off")"""),
    new_code_cell("""from occrl.planners import generate_states, recreate

state = recreate(td[0])  # reads only the detections, gripper and task priors
print(f"recreated: {len(state.objects)} detected objects, target detected: {state.target_detected}")
roots = generate_states(heat, state, max_roots=3)
for k, root in enumerate(roots):
    print(f"root {k}: weight {root.weight:.2f}, heat-map peak {root.peak_pixel}, target pose {np.round(root.target_pose, 3) if root.target_pose else None}")"""),
    new_code_cell("""from occrl.eval.film import decision_panels
from occrl.planners import HybridPlanner

planner = HybridPlanner(net, m=4, h=4, seed=0)
hidden = (td["recurrent_state_h"][0:1], td["recurrent_state_c"][0:1])
decision = planner.decide(td[0], heat, hidden)
print("returns per root and roll-out:\\n", np.round(decision.result.returns, 2))
print("chosen root", decision.chosen_root, "action", np.round(decision.action, 2), f"({decision.seconds * 1000:.0f} ms)")
panels = decision_panels(decision)
fig, axes = plt.subplots(1, len(panels), figsize=(4.5 * len(panels), 5), squeeze=False)
for a, p in zip(axes[0], panels):
    a.imshow(p); a.axis("off")"""),
    new_markdown_cell("""The panels are the planner's own belief: only detected objects, the target where a root
hypothesises it (red), grey roll-outs, the root's best in blue and the executed one in orange.

## A whole task

`HybridPlanner` is a TorchRL policy: `env.rollout(policy=planner)` runs a task, and
`planner.decisions` keeps every decision for pictures."""),
    new_code_cell("""from occrl.eval.film import episode_frames, save_gif

planner = HybridPlanner(net, m=4, h=4, seed=0)
env = make_env(batch_size=1, stage=2, seed=11).append_transform(net.make_primer())
rollout = env.rollout(6 if FAST else 50, planner)[0]
end = rollout[-1]["next"]
print(f"{rollout.shape[0]} actions{' (the fast setting stops at 6)' if FAST else ''}, success {bool(end['success'])}")
frames = episode_frames(rollout, decisions=planner.decisions)
save_gif(frames, "planner_episode.gif")
fig, axes = plt.subplots(1, 3, figsize=(15, 3.5))
for a, k in zip(axes, [0, len(frames) // 2, len(frames) - 1]):
    a.imshow(frames[k]); a.axis("off")"""),
]


def build() -> list[Path]:
    written = []
    for name, cells in (("01_env_tour", TOUR), ("02_train_small_net", TRAIN), ("03_hybrid_planner_step_by_step", PLANNER)):
        for k, cell in enumerate(cells):
            cell["id"] = f"{name[:2]}-{k:02d}"  # stable ids: a rebuild changes only what was edited
        nb = new_notebook(cells=cells, metadata={"kernelspec": {"name": "python3", "display_name": "Python 3", "language": "python"}})
        path = HERE / f"{name}.ipynb"
        nbformat.write(nb, path)
        written.append(path)
    return written


if __name__ == "__main__":
    for p in build():
        print("wrote", p)
