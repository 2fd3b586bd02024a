"""The collocation grid: Dymos' compressed Radau nodes and quadrature weights (the
number of segments of each scenario is resolved with the study, :mod:`suspopt.spec.resolve`)."""

from __future__ import annotations

import numpy as np
from dymos.utils.lgr import lgr


def radau_grid(segments: int, order: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes (phase τ in [-1, 1]) and quadrature weights (in τ) of Dymos' compressed Radau
    grid of ``segments`` uniform segments: each segment has the ``order`` LGR points and
    its right end (weight zero: not a collocation point), which repeats the next segment's
    first node. ``weights @ g(nodes)`` is what Radau collocation integrates ``x' = g`` to."""
    x, w = lgr(order, include_endpoint=True)
    ends = np.linspace(-1.0, 1.0, segments + 1)
    half = 0.5 * np.diff(ends)[:, None]
    return (ends[:-1, None] + half * (x + 1.0)).ravel(), (half * w).ravel()


def radau_quadrature_weights(segments: int, order: int, duration: float) -> np.ndarray:
    """Quadrature weight [s] of every node of the compressed Radau grid over ``duration``
    (see :func:`radau_grid`)."""
    return radau_grid(segments, order)[1] * (0.5 * duration)
