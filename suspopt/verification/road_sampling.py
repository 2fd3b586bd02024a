"""Where the exact time marching samples the road (:mod:`suspopt.verification.linear_march`).

Between samples the road under every wheel is its cubic Hermite interpolant (heights and
one-sided slopes at both ends of each step). The samples are placed at the road's
breakpoints (where its second derivative jumps), at its spline knots if it is a cubic
spline (ISO 8608 and measured roads: then represented exactly), at steps of at most a
given length, and wherever else the interpolant's own error demands
(:func:`sample_grid`).
"""

from __future__ import annotations

import numpy as np

from suspopt.models.assembly import VehicleSpec
from suspopt.road import RoadProfile, wheel_road_inputs
from suspopt.verification import linear_march

#: the road's cubic interpolant may depart from it by this much, relative to its largest
#: height under the wheels (checked inside every step), by default
ROAD_TOLERANCE = 1e-11

#: the first samples of a road that is not piecewise cubic: this many per period of its
#: highest frequency, before its interpolation error refines them
SAMPLES_PER_ROAD_PERIOD = 8


def corner_roads(spec: VehicleSpec) -> list[tuple[RoadProfile, tuple[int, ...], float]]:
    """Every distinct road under the wheels: (profile, corners, offset behind the front
    axle [m])."""
    offsets = spec.layout.offsets()
    groups: dict[tuple[int, float], list[int]] = {}
    for c, corner in enumerate(spec.layout.corners):
        groups.setdefault((corner.track, offsets[c]), []).append(c)
    return [(spec.tracks[tr], tuple(cs), off) for (tr, off), cs in groups.items()]


def road_samples(spec: VehicleSpec, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The road heights under every corner at ``t`` (points, corners) and their slopes
    at each step's start and end (steps, corners), one-sided (inside the step: a slope
    that jumps at a breakpoint is taken on the step's own side)."""
    inward = 1e-9 * np.diff(t)
    u = np.empty((t.size, spec.layout.n))
    start = np.empty((t.size - 1, spec.layout.n))
    end = np.empty_like(start)
    for road, corners, off in corner_roads(spec):
        h, _ = wheel_road_inputs(road, t, spec.speed, (off,), rates=False)
        _, p = wheel_road_inputs(road, t[:-1] + inward, spec.speed, (off,))
        _, q = wheel_road_inputs(road, t[1:] - inward, spec.speed, (off,))
        assert p is not None and q is not None
        for c in corners:
            u[:, c], start[:, c], end[:, c] = h[0], p[0], q[0]
    return u, start, end


def sample_grid(
    spec: VehicleSpec, horizon: float, max_step: float, tolerance: float = ROAD_TOLERANCE
) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """The times at which the exact marching samples the road: 0, the horizon, every
    breakpoint and spline knot of the road under each wheel, steps of at most
    ``max_step`` (and, on a road that is not piecewise cubic, at most
    1/:data:`SAMPLES_PER_ROAD_PERIOD` of the period of its highest frequency), every step
    then halved until the cubic interpolant is within ``tolerance`` of the road
    at its quarter, half and three-quarter points (the interpolation error's even part
    peaks at the midpoint, its odd part off it). Returns the times and the road there
    (:func:`road_samples`)."""
    v, T = spec.speed, horizon
    points = [np.array([0.0, T])]
    step = max_step
    for road, _, off in corner_roads(spec):
        lo, hi = -off, v * T - off
        marks = np.asarray(road.breakpoints(), dtype=float)
        knots = road.knots()
        if knots is None:
            step = min(step, 1.0 / (SAMPLES_PER_ROAD_PERIOD * road.max_frequency() * v))
        else:
            marks = np.concatenate([marks, knots])
        marks = marks[(marks > lo) & (marks < hi)]
        points.append((marks + off) / v)
    pts = np.unique(np.concatenate(points))
    pts = pts[np.concatenate([[True], np.diff(pts) > 1e-9 * T])]
    pts[-1] = T
    count = np.maximum(1, np.ceil(np.diff(pts) / step * (1.0 - 1e-12)).astype(np.int64))
    first = np.repeat(pts[:-1], count)
    width = np.repeat(np.diff(pts) / count, count)
    j = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    t = np.append(first + j * width, T)
    for _ in range(60):
        u, p, q = road_samples(spec, t)
        chain = linear_march.hermite_chain(t, u, p, q)
        h = np.diff(t)
        # the error's even part peaks at the midpoint, its odd part off it
        frac = np.array([0.25, 0.5, 0.75])
        where = (t[:-1, None] + h[:, None] * frac).ravel()
        cubic = linear_march.input_at(
            np.repeat(chain, frac.size, axis=0), where - np.repeat(t[:-1], frac.size)
        )
        true = np.empty_like(cubic)
        for road, corners, off in corner_roads(spec):
            r, _ = wheel_road_inputs(road, where, v, (off,), rates=False)
            true[:, list(corners)] = r[0][:, None]
        err = np.max(np.abs(true - cubic), axis=1).reshape(-1, frac.size).max(axis=1)
        tol = tolerance * max(float(np.max(np.abs(u))), float(np.max(np.abs(true))), 1e-12)
        bad = err > tol
        if not np.any(bad):
            break
        t = np.sort(np.concatenate([t, 0.5 * (t[:-1] + t[1:])[bad]]))
    return t, (u, p, q)


def breakpoint_times(spec: VehicleSpec, horizon: float) -> np.ndarray:
    """The times in ``(0, horizon)`` at which the road under some wheel has a breakpoint."""
    out = []
    for road, _, off in corner_roads(spec):
        marks = np.asarray(road.breakpoints(), dtype=float)
        out.append((marks + off) / spec.speed)
    t = np.concatenate(out) if out else np.zeros(0)
    return np.unique(t[(t > 0.0) & (t < horizon)])


def refine_stretches(t: np.ndarray, breaks: np.ndarray, min_steps: int) -> np.ndarray:
    """``t`` with every stretch between consecutive ``breaks`` (and the ends) split into
    at least ``min_steps`` steps, its steps halved as often as needed."""
    cuts = np.unique(np.concatenate([[0, t.size - 1], np.searchsorted(t, breaks)]))
    extra = []
    for a, b in zip(cuts[:-1], cuts[1:]):
        steps = b - a
        if steps < min_steps:
            parts = 2 ** int(np.ceil(np.log2(min_steps / steps)))
            frac = np.arange(1, parts) / parts
            extra.append((t[a:b, None] + np.diff(t[a : b + 1])[:, None] * frac).ravel())
    return np.sort(np.concatenate([t, *extra])) if extra else t
