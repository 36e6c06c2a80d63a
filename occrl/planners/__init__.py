"""Planners: the hybrid planner (batched RHP over heat-map roots) and its parts."""

from occrl.planners.hybrid import Decision, HybridPlanner, select_root
from occrl.planners.recreate import RecreatedState, WorldPool, make_world, recreate, with_target
from occrl.planners.rhp import RHPResult, render_pixels, rhp_batched, rhp_sequential
from occrl.planners.states import Root, generate_states, heatmap_peaks

__all__ = [
    "HybridPlanner",
    "Decision",
    "select_root",
    "RecreatedState",
    "recreate",
    "with_target",
    "make_world",
    "WorldPool",
    "RHPResult",
    "rhp_batched",
    "rhp_sequential",
    "render_pixels",
    "Root",
    "generate_states",
    "heatmap_peaks",
]
