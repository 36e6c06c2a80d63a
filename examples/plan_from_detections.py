"""Plan one action from a real robot's detections, without any simulator env.

A perception system (AR tags in the paper) reports the objects it sees more than 50 %: type id,
planar pose on the shelf and, from the task priors, the type's polygon. The gripper pose comes
from forward kinematics. That is all the hybrid planner needs: it recreates a pymunk state from
it, renders the abstract observation, asks the network for the heat-map and plans.

    python examples/plan_from_detections.py
"""

from __future__ import annotations

import numpy as np
import torch

from occrl.envs import observation_from_detections
from occrl.envs.transforms import OcclusionRender, RobotCentricCrop
from occrl.planners import HybridPlanner


def load_network():
    from occrl.modules import make_occnet
    from occrl.pretrained import available, load_pretrained

    if "occnet" in available():
        return load_pretrained("occnet")
    torch.manual_seed(0)
    return make_occnet("paper")  # untrained: the example still runs end to end


def main() -> None:
    box = [[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]]
    triangle = [[-0.025, -0.015], [0.025, -0.015], [0.0, 0.03]]
    detections = [  # what the camera sees now (the target, type 1, is not among them)
        {"type_id": 3, "pose": (0.02, 0.12, 0.3), "vertices": box},
        {"type_id": 5, "pose": (-0.12, 0.2, 1.0), "vertices": triangle},
    ]
    obs = observation_from_detections(
        gripper_pose=(0.0, -0.1, 0.0),
        gripper_opening=0.085,
        detections=detections,
        target_type=1,
        target_vertices=np.array(box),
    )
    # the network input, rendered from the detections exactly as in the simulated pipeline
    obs = RobotCentricCrop()(OcclusionRender()(obs))
    net = load_network()
    # the LSTM's state before this observation: zeros at the start of a task
    obs["is_init"] = torch.ones(1, 1, dtype=torch.bool)
    obs["recurrent_state_h"] = torch.zeros(1, 1, net.config.lstm_hidden)
    obs["recurrent_state_c"] = torch.zeros(1, 1, net.config.lstm_hidden)
    planner = HybridPlanner(net, m=4, h=4, seed=0)
    out = planner(obs)
    d = planner.decisions[-1]
    print(f"root states: {len(d.roots)} (weights {[round(r.weight, 2) for r in d.roots]}); planning took {d.seconds * 1000:.0f} ms")
    a = out["action"][0].tolist()
    print(f"action: forward {a[0]:+.2f}, lateral {a[1]:+.2f}, rotation {a[2]:+.2f}, gripper {'close' if a[3] > 0 else 'open'}")
    # carry the LSTM state to the next decision: out["next", "recurrent_state_h"], ("next", "recurrent_state_c")


if __name__ == "__main__":
    main()
