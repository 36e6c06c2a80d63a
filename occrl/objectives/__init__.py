"""Training objectives: PPO + heat-map BCE, advantages, imitation warm start."""

from occrl.objectives.ppo_heatmap import PPOHeatmapLoss, belief_detached, compute_advantages, heatmap_bce, heatmap_loss, imitation_nll

__all__ = ["PPOHeatmapLoss", "belief_detached", "compute_advantages", "heatmap_bce", "heatmap_loss", "imitation_nll"]
