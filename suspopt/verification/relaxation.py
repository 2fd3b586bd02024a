"""Time marching of a mildly nonlinear model by waveform relaxation around its
linearization (the mixed-fidelity vehicle, whose linkages depart from a linear spring
and wheel by their geometry only).

With ``A, B`` the model's Jacobians at rest, ``x' = f(t, x) = A x + B δ + r(t, x)``. Over
the whole horizon, iterate

    x_{k+1}' = A x_{k+1} + B δ(t) + r(t, x_k(t))

(Picard iteration of whole trajectories, "waveform relaxation": Lelarasmee, Ruehli &
Sangiovanni-Vincentelli, IEEE Trans. CAD 1(3), 1982; Miekkala & Nevanlinna, SIAM J. Sci.
Stat. Comput. 8(4), 1987, for its convergence on linear splittings). Each iteration
evaluates the model once at every grid point, vectorized, and marches the linear part
exactly (:mod:`suspopt.verification.linear_march`) with the remainder ``r`` as a second
input, its cubic Hermite interpolant between the grid points with slopes from the quartic
through the five nearest samples (within each stretch between the road's breakpoints,
where ``r`` is smooth). It contracts by about the remainder's share of
the forces times the resonance gain, so a geometric nonlinearity converges in a few
iterations; an iteration that does not contract enough stops it (:class:`NotConverged`:
the caller integrates otherwise). At convergence the states are exact for the road's
cubic interpolant and the remainder's spline, and the objective integrals are summed by
three-point Gauss-Legendre quadrature on every step, the model evaluated there.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from suspopt.verification import linear_march

#: converged when no state changes by more than this, relative to its largest magnitude
#: (by default)
TOLERANCE = 1e-10

#: at most this many iterations
MAX_ITERATIONS = 40

#: from the third iteration on, each must shrink the change at least by this factor
CONTRACTION = 0.5

#: points of the polynomial whose derivative is a remainder's slope
STENCIL = 5

#: Gauss-Legendre nodes per step of the objective integrals
GAUSS_NODES = 3

Rates = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]


class NotConverged(RuntimeError):
    """The relaxation did not contract (a strong nonlinearity)."""


def jacobians(rates: Rates, refs: np.ndarray, n_inputs: int, input_ref: float):
    """``A = ∂f/∂x`` and ``B = ∂f/∂δ`` at rest by central differences of
    ``rates(t, X, U)`` (all probes in one vectorized call; from rest, so a rate that is a
    state, ``z' = v``, is read exactly and its remainder is zero)."""
    n = refs.size
    step = 1e-6 * refs
    du = 1e-6 * input_ref
    X = np.concatenate([np.diag(step), -np.diag(step), np.zeros((n, 2 * n_inputs))], axis=1)
    U = np.concatenate(
        [np.zeros((n_inputs, 2 * n)), du * np.eye(n_inputs), -du * np.eye(n_inputs)], axis=1
    )
    R = rates(np.zeros(X.shape[1]), X, U)
    A = (R[:, :n] - R[:, n : 2 * n]) / (2.0 * step)
    B = (R[:, 2 * n : 2 * n + n_inputs] - R[:, 2 * n + n_inputs :]) / (2.0 * du)
    return A, B


def _derivative_weights(nodes: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Weights (points, width) of the derivative at ``x`` (points,) of the polynomial
    through the values at ``nodes`` (points, width): Lagrange's basis differentiated."""
    width = nodes.shape[1]
    w = np.zeros(nodes.shape)
    for j in range(width):
        others = [k for k in range(width) if k != j]
        denom = np.prod([nodes[:, j] - nodes[:, k] for k in others], axis=0)
        deriv = np.zeros(x.shape)
        for m in others:
            deriv += np.prod(
                [x - nodes[:, k] for k in others if k != m] or [np.ones_like(x)], axis=0
            )
        w[:, j] = deriv / denom
    return w


class LocalSlopes:
    """Slopes at each step's start and end of values sampled on ``t``: at each point, the
    derivative of the quartic through the five nearest points of the step's stretch of
    ``t`` between ``breaks`` (where the values are smooth; a point on a break has a slope
    on each side). Their error is O(h⁴), so the Hermite interpolant with them is O(h⁴)
    accurate, like a spline, and local. The weights depend on ``t`` only: made once."""

    def __init__(self, t: np.ndarray, breaks: np.ndarray):
        cuts = np.unique(np.concatenate([[0, t.size - 1], np.searchsorted(t, breaks)]))
        self.stretches = []
        for a, b in zip(cuts[:-1], cuts[1:]):
            ts = t[a : b + 1]
            M = ts.size
            width = min(STENCIL, M)
            first = np.clip(np.arange(M) - width // 2, 0, M - width)
            idx = first[:, None] + np.arange(width)
            self.stretches.append((a, b, a + idx, _derivative_weights(ts[idx], ts)))
        self.steps = t.size - 1

    def __call__(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Slopes at each step's start and end (steps, columns) of ``values`` (points,
        columns)."""
        start = np.empty((self.steps, values.shape[1]))
        end = np.empty_like(start)
        for a, b, idx, w in self.stretches:
            slope = np.einsum('mj,mjc->mc', w, values[idx])
            start[a:b], end[a:b] = slope[:-1], slope[1:]
        return start, end


@dataclass(frozen=True)
class Relaxed:
    """The converged relaxation: the marched linear part with the remainder as input
    (``marched``: states at the grid and between), the model's signals at the grid (the
    last evaluation, at states within the tolerance of the final ones) and the
    iterations' relative changes."""

    marched: linear_march.Marched
    signals: dict
    iterations: int
    changes: tuple[float, ...]


def relax(
    A: np.ndarray,
    B: np.ndarray,
    t: np.ndarray,
    road: tuple[np.ndarray, np.ndarray, np.ndarray],
    breaks: np.ndarray,
    evaluate: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, dict]],
    remainder_rows: np.ndarray,
    tolerance: float = TOLERANCE,
) -> Relaxed:
    """Iterate to convergence from rest. ``road``: heights (points, inputs) and one-sided
    slopes (steps, inputs) at the grid ``t``; ``evaluate(t, x)``: the model's rates
    (points, n) and signals at states ``x`` (points, n); ``remainder_rows``: the rates
    that can depart from ``A x + B δ`` (the others are linear); ``tolerance``: the
    largest relative change of a state in the last iteration."""
    u, p, q = road
    n = A.shape[0]
    E = np.zeros((n, remainder_rows.size))
    E[remainder_rows, np.arange(remainder_rows.size)] = 1.0
    propagator = linear_march.Propagator(A, np.concatenate([B, E], axis=1), t)
    slopes = LocalSlopes(t, breaks)
    x = np.zeros((t.size, n))
    changes: list[float] = []
    for k in range(MAX_ITERATIONS):
        rates, signals = evaluate(t, x)
        r = (rates - x @ A.T - u @ B.T)[:, remainder_rows]
        rs, re = slopes(r)
        chain = linear_march.hermite_chain(
            t,
            np.concatenate([u, r], axis=1),
            np.concatenate([p, rs], axis=1),
            np.concatenate([q, re], axis=1),
        )
        marched = propagator.march(chain)
        size = np.max(np.abs(marched.x), axis=0)
        diff = np.max(np.abs(marched.x - x), axis=0)
        change = float(np.max(np.where(size > 0.0, diff / np.where(size > 0, size, 1.0), diff)))
        changes.append(change)
        x = marched.x
        if not np.isfinite(change):
            raise NotConverged('the relaxation produced NaN/inf')
        if change <= tolerance:  # the signals of the last evaluation are as close
            return Relaxed(marched, signals, k + 1, tuple(changes))
        if k >= 2 and change > CONTRACTION * changes[-2]:
            history = ', '.join(f'{c:.1e}' for c in changes)
            raise NotConverged(f'the relaxation does not contract (changes {history})')
    raise NotConverged(f'the relaxation did not converge in {MAX_ITERATIONS} iterations')


def gauss_points(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The :data:`GAUSS_NODES`-point Gauss-Legendre nodes of every step of ``t`` and
    their weights (flattened, in time order)."""
    xg, wg = np.polynomial.legendre.leggauss(GAUSS_NODES)
    a, b = t[:-1], t[1:]
    nodes = (0.5 * (a + b)[:, None] + 0.5 * (b - a)[:, None] * xg).ravel()
    weights = (0.5 * (b - a)[:, None] * wg).ravel()
    return nodes, weights
