"""A time history of a vehicle model: what collocation and time marching both produce."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass
class Trajectory:
    """``t`` [s] and named arrays (first axis: time; per-wheel signals have the corners on
    their last axis), the objective terms ``J`` at the final time (term order), and
    information about how it was computed."""

    t: np.ndarray
    values: dict[str, np.ndarray]
    J: np.ndarray
    info: dict[str, Any] = field(default_factory=dict)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.values[name]
