"""Evaluation: episode pictures (film strips, GIFs); the evaluation harness arrives with the planner."""

from occrl.eval.film import episode_frames, frame, save_film_strip, save_gif

__all__ = ["episode_frames", "frame", "save_film_strip", "save_gif"]
