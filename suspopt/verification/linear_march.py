"""Exact time marching of a linear time-invariant model between road samples.

The low-fidelity vehicles are linear: ``x' = A x + B u``, ``y = C x + D u``
(:mod:`suspopt.models.linear`), ``u`` the road heights under the wheels. On a grid of
sample times the road is replaced by its cubic Hermite interpolant (heights and slopes at
both ends of every step: C¹, and exact wherever the road is itself a cubic spline with
its knots on the grid, as the ISO 8608 and measured roads are); everything else is exact:

* **States.** On a step of length ``h`` the augmented state ``w = [x; u; u'; u''; u''']``
  obeys ``w' = F w`` with ``F = [[A, B, 0, 0, 0], [0, 0, I, 0, 0], [0, 0, 0, I, 0],
  [0, 0, 0, 0, I], 0]``, so ``x(t + h) = [e^{F h} w]_x`` — the first-order hold of
  SciPy's ``cont2discrete(method='foh')`` / ``lsim`` (Franklin, Powell & Workman,
  *Digital Control of Dynamic Systems*, 3rd ed., §6.3.2) carried to a cubic input. One
  matrix exponential per distinct step length (:func:`scipy.linalg.expm`).
* **Objective integrals.** ``∫ y_i² dt`` over all steps of one length ``h`` is the
  ``i``-th diagonal entry of ``G P G^T``, ``G = [C, D, 0, 0, 0]``, with
  ``P = ∫_0^h e^{F s} S e^{F^T s} ds`` and ``S = Σ_k w_k w_k^T`` over those steps' start
  states: one block-triangular matrix exponential (Van Loan, "Computing integrals
  involving the matrix exponential", IEEE Trans. Autom. Control 23(3), 1978, Theorem 1)
  at ``h / 2^s`` small enough for full accuracy, then doubled ``s`` times,
  ``P(2τ) = P(τ) + e^{Fτ} P(τ) e^{F^T τ}`` (every term positive semidefinite).
* **States between grid points** (the trajectory's sample times): ``e^{F τ} w_k`` by
  the Taylor series of the exponential's action, in substeps of unit norm on the
  balanced ``F`` (Al-Mohy & Higham, "Computing the action of the matrix exponential",
  SIAM J. Sci. Comput. 33(2), 2011), truncated below the rounding error.

The cost is linear in the number of steps: one small matrix-vector product per step
(the sequential march) and one outer product per step (the integrals' ``S``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm, matrix_balance

#: the input's polynomial order plus one: u, u', u'', u''' (a cubic per step)
CHAIN = 4

#: steps whose lengths differ by less than this (relative) share one exponential
STEP_GROUPING = 1e-10

#: an integral below this fraction of its magnitude bound is rounding error (zero)
ROUNDING_FLOOR = 1e-12

#: states between grid points at at most this many distinct offsets into their steps are
#: propagated by one exponential per offset (else by the exponential's action)
DISTINCT_SUBSTEPS = 64

#: Taylor terms of the exponential's action per substep of unit norm (1/21! < 1e-19)
TAYLOR_TERMS = 20


def augmented(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``F`` of the state and the input's derivatives ``[x; u; u'; u''; u''']``."""
    n, m = B.shape
    nw = n + CHAIN * m
    F = np.zeros((nw, nw))
    F[:n, :n] = A
    F[:n, n : n + m] = B
    for j in range(CHAIN - 1):
        a = n + j * m
        F[a : a + m, a + m : a + 2 * m] = np.eye(m)
    return F


def hermite_chain(
    t: np.ndarray, u: np.ndarray, slope_start: np.ndarray, slope_end: np.ndarray
) -> np.ndarray:
    """``[u, u', u'', u''']`` (steps, CHAIN · inputs) at the start of every step of the
    cubic Hermite interpolant of heights ``u`` (points, inputs) with slopes
    ``slope_start`` at each step's start and ``slope_end`` at its end (steps, inputs)."""
    h = np.diff(t)[:, None]
    u0, u1 = u[:-1], u[1:]
    p, q = slope_start, slope_end
    secant = (u1 - u0) / h
    a2 = (3.0 * secant - 2.0 * p - q) / h
    a3 = (p + q - 2.0 * secant) / h**2
    return np.concatenate([u0, p, 2.0 * a2, 6.0 * a3], axis=1)


def input_at(chain: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """The input (points, inputs) at ``tau`` (points,) into steps whose derivatives
    ``chain`` (points, CHAIN · inputs) are given (:func:`hermite_chain`)."""
    m = chain.shape[1] // CHAIN
    out = chain[:, (CHAIN - 1) * m :].copy()
    for j in range(CHAIN - 2, -1, -1):  # Horner in tau with the Taylor coefficients
        out = out * (tau[:, None] / (j + 1)) + chain[:, j * m : (j + 1) * m]
    return out


def group_steps(h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Labels (steps,) and lengths (groups,) of the distinct step lengths of ``h``."""
    order = np.argsort(h, kind='stable')
    hs = h[order]
    new = np.concatenate([[True], np.diff(hs) > STEP_GROUPING * hs[1:]])
    group_sorted = np.cumsum(new) - 1
    labels = np.empty(h.size, dtype=np.int64)
    labels[order] = group_sorted
    lengths = np.bincount(group_sorted, weights=hs) / np.bincount(group_sorted)
    return labels, lengths


def gramian(F: np.ndarray, S: np.ndarray, h: float) -> np.ndarray:
    """``∫_0^h e^{F s} S e^{F^T s} ds`` by Van Loan's block exponential at ``h / 2^s``
    (norm at most 1/2) and ``s`` doublings."""
    nw = F.shape[0]
    norm = float(np.linalg.norm(F, 1)) * h
    s = max(0, math.ceil(math.log2(norm / 0.5))) if norm > 0.5 else 0
    tau = h / 2.0**s
    c = float(np.trace(S)) or 1.0
    M = np.zeros((2 * nw, 2 * nw))
    M[:nw, :nw] = -F * tau
    M[:nw, nw:] = S * (tau / c)
    M[nw:, nw:] = F.T * tau
    E = expm(M)
    Phi = E[nw:, nw:].T
    P = Phi @ E[:nw, nw:]
    for _ in range(s):
        P = P + Phi @ P @ Phi.T
        Phi = Phi @ Phi
    return c * 0.5 * (P + P.T)


@dataclass(frozen=True)
class Marched:
    """A linear model marched over a grid: the times ``t`` (points,), the states ``x``
    (points, n) at them, each step's augmented start state ``w`` (steps, nw), its step
    group ``labels`` and the groups' ``lengths``."""

    F: np.ndarray
    t: np.ndarray
    x: np.ndarray
    w: np.ndarray
    labels: np.ndarray
    lengths: np.ndarray

    @property
    def n(self) -> int:
        return self.x.shape[1]

    def integrals(self, G: np.ndarray) -> np.ndarray:
        """``∫ (G w)_i² dt`` over the grid for every row of ``G`` (rows, nw), exactly for
        the piecewise-cubic input (on the balanced ``F``). A value within the rounding
        error of its own evaluation (:data:`ROUNDING_FLOOR` of the same integral with
        every product taken in magnitude: an output that cancels exactly, e.g. the roll
        of a car on a road equal under both tracks) is zero."""
        _, (scale, _) = matrix_balance(self.F, permute=False, separate=True)
        W = self.w / scale
        Fb = self.F * (scale[None, :] / scale[:, None])
        Gb = G * scale[None, :]
        P = np.zeros_like(Fb)
        for g, h in enumerate(self.lengths):
            Wg = W[self.labels == g]
            P += gramian(Fb, Wg.T @ Wg, float(h))
        J = np.einsum('ij,jk,ik->i', Gb, P, Gb)
        magnitude = self.lengths[self.labels] @ (np.abs(self.w) @ np.abs(G).T) ** 2
        return np.where(J > ROUNDING_FLOOR * magnitude, J, 0.0)

    def states_at(self, times: np.ndarray) -> np.ndarray:
        """The exact states (len(times), n) at ``times`` within the grid: ``e^{F τ} w_k``
        from the step's start, by one exponential per distinct ``τ`` where they are few
        (e.g. fixed fractions of the steps), else by the exponential's action."""
        t = self.t
        times = np.asarray(times, dtype=float)
        at = np.clip(np.searchsorted(t, times), 0, t.size - 1)
        on_grid = t[at] == times
        out = np.empty((times.size, self.n))
        out[on_grid] = self.x[at[on_grid]]
        inner = np.flatnonzero(~on_grid)
        if inner.size:
            k = np.clip(np.searchsorted(t, times[inner], side='right') - 1, 0, t.size - 2)
            tau = times[inner] - t[k]
            labels, taus = group_steps(tau)
            if taus.size <= DISTINCT_SUBSTEPS:
                Phi = expm(self.F[None] * taus[:, None, None])[:, : self.n]
                for g in range(taus.size):
                    rows = labels == g
                    out[inner[rows]] = self.w[k[rows]] @ Phi[g].T
            else:
                out[inner] = expm_action(self.F, self.w[k].T, tau)[: self.n].T
        return out


def expm_action(F: np.ndarray, W: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """``e^{F τ_j} W[:, j]`` for every column ``j``: truncated Taylor series on the
    balanced ``F`` in substeps of norm at most one."""
    Fb, (scale, _) = matrix_balance(F, permute=False, separate=True)
    X = W / scale[:, None]
    theta = float(np.linalg.norm(Fb, 1)) * float(np.max(tau, initial=0.0))
    r = max(1, math.ceil(theta))
    step = tau / r
    for _ in range(r):
        term, acc = X, X.copy()
        for j in range(1, TAYLOR_TERMS + 1):
            term = (Fb @ term) * (step / j)
            acc += term
        X = acc
    return X * scale[:, None]


class Propagator:
    """``x' = A x + B u`` stepped over the grid ``t``: one matrix exponential of ``F`` per
    distinct step length, made once and kept for any number of inputs (:meth:`march`)."""

    def __init__(self, A: np.ndarray, B: np.ndarray, t: np.ndarray):
        self.n = n = A.shape[0]
        self.F = augmented(A, B)
        self.t = t
        self.labels, self.lengths = group_steps(np.diff(t))
        Phi = expm(self.F[None] * self.lengths[:, None, None])
        self._steps = [np.ascontiguousarray(P[:n, :n]) for P in Phi]
        self._forcing = [P[:n, n:].T for P in Phi]
        self._members = [self.labels == g for g in range(self.lengths.size)]
        self._order = self.labels.tolist()

    def march(self, chain: np.ndarray) -> Marched:
        """March from rest with the input's derivatives ``chain`` (steps, CHAIN · inputs)
        at each step's start (:func:`hermite_chain`)."""
        x = np.zeros((self.t.size, self.n))
        for rows, forcing in zip(self._members, self._forcing):
            x[1:][rows] = chain[rows] @ forcing
        steps = self._steps
        views = list(x)  # the sequential part: one small product per step
        for k, g in enumerate(self._order):
            views[k + 1] += steps[g].dot(views[k])
        w = np.concatenate([x[:-1], chain], axis=1)
        return Marched(F=self.F, t=self.t, x=x, w=w, labels=self.labels, lengths=self.lengths)


def march(A: np.ndarray, B: np.ndarray, t: np.ndarray, chain: np.ndarray) -> Marched:
    """March ``x' = A x + B u`` from rest over the grid ``t`` with the input's
    derivatives ``chain`` (steps, CHAIN · inputs) at each step's start
    (:func:`hermite_chain`)."""
    return Propagator(A, B, t).march(chain)
