"""The training curriculum (paper Sec. V): stages 1 -> 2 -> 3, promoted on success rate."""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

__all__ = ["Curriculum"]

LAST_STAGE = 3


@dataclass
class Curriculum:
    """Promote to the next stage when the success rate over the last ``window`` episodes exceeds
    ``threshold`` (paper: hybrid 4x4 success > 80 %; here the rate is measured on the learner's
    own episodes, a proxy the trainer documents).

    Examples:
        >>> from occrl.training import Curriculum
        >>> c = Curriculum(stage=1, threshold=0.8, window=4)
        >>> c.record([True, True, True, True])
        True
        >>> c.stage
        2
    """

    stage: int = 1
    threshold: float = 0.8
    window: int = 300
    history: deque = field(default_factory=deque)

    def record(self, successes, promote: bool = True) -> bool:
        """Add finished episodes' outcomes; returns True when this promoted the stage (never with
        ``promote=False``: the window is then only a statistic, another rule promotes)."""
        for s in successes:
            self.history.append(bool(s))
            while len(self.history) > self.window:
                self.history.popleft()
        if promote and len(self.history) >= self.window and self.success_rate > self.threshold:
            return self.promote()
        return False

    def promote(self) -> bool:
        """Move to the next stage (False at the last stage); the window starts afresh."""
        if self.stage >= LAST_STAGE:
            return False
        self.stage += 1
        self.history.clear()
        return True

    @property
    def success_rate(self) -> float:
        return sum(self.history) / len(self.history) if self.history else 0.0

    def state_dict(self) -> dict:
        return {"stage": self.stage, "threshold": self.threshold, "window": self.window, "history": list(self.history)}

    def load_state_dict(self, state: dict) -> None:
        self.stage, self.threshold, self.window = int(state["stage"]), float(state["threshold"]), int(state["window"])
        self.history = deque(bool(x) for x in state["history"])
