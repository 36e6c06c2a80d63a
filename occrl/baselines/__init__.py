"""Baseline policies: the privileged scripted retriever (more arrive with the planner issues)."""

from occrl.baselines.scripted import ScriptedRetriever

__all__ = ["ScriptedRetriever"]
