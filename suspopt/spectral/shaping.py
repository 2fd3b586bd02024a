"""Rational filters of the road input: the wheelbase delay (Padé) and the isotropic
coherence of two tracks (docs/spectral.md).

Both are small state-space systems ``ξ' = A ξ + B u, y = C ξ + D u`` built once per road
and vehicle geometry; they do not depend on the design.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import factorial

import numpy as np

#: highest order of one Padé approximant; a longer delay approximation is a cascade of
#: them (beyond it the roots of ``Q`` lose digits)
MAX_PADE_SECTION = 16


@dataclass(frozen=True)
class StateSpace:
    """``ξ' = A ξ + B u, y = C ξ + D u`` (single input and output: ``B`` (k,), ``C`` (k,),
    ``D`` scalar)."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: float

    @property
    def order(self) -> int:
        return self.A.shape[0]

    def response(self, s: np.ndarray) -> np.ndarray:
        """The transfer function at the complex frequencies ``s``."""
        s = np.asarray(s, dtype=complex)
        k = self.order
        if k == 0:
            return np.full(s.shape, self.D, dtype=complex)
        M = s.reshape(-1, 1, 1) * np.eye(k) - self.A
        x = np.linalg.solve(M, np.broadcast_to(self.B, (s.size, k))[..., None])[..., 0]
        return (x @ self.C + self.D).reshape(s.shape)


def pade_coefficients(order: int) -> np.ndarray:
    """Coefficients ``c_k`` of the diagonal Padé approximant of ``e^{-ŝ}``,
    ``Q(-ŝ)/Q(ŝ)`` with ``Q(ŝ) = Σ_k c_k ŝ^k``, ``c_k = (2N-k)! N! / ((2N)! k! (N-k)!)``."""
    N = order
    return np.array(
        [
            factorial(2 * N - k)
            * factorial(N)
            / (factorial(2 * N) * factorial(k) * factorial(N - k))
            for k in range(N + 1)
        ]
    )


def _pade_section(order: int, tau: float) -> StateSpace:
    """One diagonal Padé approximant of ``e^{-s τ}``, ``Q(-sτ)/Q(sτ) = Π_i (-s - π_i) /
    (s - π_i)`` over the roots ``π_i`` of ``Q(sτ)``, realized as a cascade of all-pass
    factors: first order for a real root (``-1 - 2π/(s - π)``), second order for a complex
    pair (``1 + 4 Re(π) s / ((s - π)(s - π̄))``, a real 2×2 block). Each factor is all-pass
    with unit gain at ``s = 0`` to rounding (a partial-fraction form of the whole
    approximant would lose digits to cancelling residues)."""
    roots = np.asarray(np.polynomial.Polynomial(pade_coefficients(order)).roots(), dtype=complex)
    poles = roots / tau
    out: StateSpace | None = None
    for p in poles:
        if abs(p.imag) <= 1e-12 * abs(p):
            sec = StateSpace(np.array([[p.real]]), np.array([1.0]), np.array([-2.0 * p.real]), -1.0)
        elif p.imag > 0.0:
            sig, beta = p.real, p.imag
            sec = StateSpace(
                np.array([[sig, beta], [-beta, sig]]),
                np.array([1.0, 0.0]),
                np.array([4.0 * sig, -4.0 * sig**2 / beta]),
                1.0,
            )
        else:
            continue
        out = sec if out is None else cascade(out, sec)
    assert out is not None
    return out


def cascade(first: StateSpace, second: StateSpace) -> StateSpace:
    """``second`` driven by ``first``'s output."""
    k1, k2 = first.order, second.order
    A = np.zeros((k1 + k2, k1 + k2))
    A[:k1, :k1] = first.A
    A[k1:, :k1] = np.outer(second.B, first.C)
    A[k1:, k1:] = second.A
    B = np.concatenate([first.B, second.B * first.D])
    C = np.concatenate([second.D * first.C, second.C])
    return StateSpace(A, B, C, second.D * first.D)


def pade_delay(tau: float, order: int) -> StateSpace:
    """A rational approximation of the delay ``e^{-s τ}`` with ``order`` states: one
    diagonal Padé approximant of that order if at most :data:`MAX_PADE_SECTION`, else a
    cascade of ``m = ⌈order/16⌉`` of them (orders as equal as possible), each of delay
    ``τ/m``. Every section is all-pass (``|P(jω)| = 1``) with ``P(0) = 1``."""
    if order < 1:
        raise ValueError(f'pade order must be >= 1, got {order}')
    m = -(-order // MAX_PADE_SECTION)
    orders = [order // m + (1 if i < order % m else 0) for i in range(m)]
    out = _pade_section(orders[0], tau / m)
    for n in orders[1:]:
        out = cascade(out, _pade_section(n, tau / m))
    return out


def lag_map(delay: StateSpace) -> np.ndarray:
    """``L`` with ``(P(s) - 1)/s = L (sI - A)^{-1} B`` for a delay approximation ``P``
    (``P(0) = 1``): ``L = C A^{-1}``. Driven by the road velocity, the delay's state gives
    the height lag ``δ(t - τ) - δ(t) ≈ L ξ``, a stationary signal although the heights
    are not."""
    return np.linalg.solve(delay.A.T, delay.C)


# ------------------------------------------------------------------ isotropic coherence
#: Zeros and poles (in ``x = ω B / v``) of the rational approximation of the isotropic
#: road's difference channel, ``|F₋(jx)|² = ½ x² Π(x² + z_i²) / Π(x² + p_i²)`` ≈
#: ``(1 - x K₁(x))/2``, fitted by least squares on the logarithm over
#: ``x ∈ [10⁻³, 10^2.5]`` (:func:`fit_isotropic_difference`); its accuracy is a test.
ISOTROPIC_ZEROS = np.array(
    [
        0.002064707449781838,
        0.011096769721142135,
        0.05296147254460727,
        0.23880759131893792,
        1.0382018282845056,
        4.302552707183571,
    ]
)
ISOTROPIC_POLES = np.array(
    [
        0.0018051583852470867,
        0.009571697346262696,
        0.04362146398170353,
        0.18029441273349675,
        0.6508580124593023,
        1.8992916203412555,
        3.8655875599270195,
    ]
)


@dataclass(frozen=True)
class CoherenceFilters:
    """The two tracks' road velocities from two independent white noises ``w₊``, ``w₋``
    of the road's intensity: ``u_L = F₊ w₊ + F₋ w₋``, ``u_R = F₊ w₊ - F₋ w₋``, so that
    ``S_LL = S_RR = q (|F₊|² + |F₋|²) = q`` exactly and the coherence is
    ``γ̂ = |F₊|² - |F₋|²``. ``F₋(s) = s R(s)`` vanishes at ``s = 0``, so the right track's
    height relative to the left one, ``d = -2 R w₋``, is stationary.

    State ``ξ = (ξ₊, ξ₋)`` (2N), ``ξ' = A ξ + B w``; ``C_u`` (2, 2N), ``D_u`` (2, 2) give
    ``(u_L, u_R)``, ``C_d`` (2N,) gives ``d``."""

    A: np.ndarray
    B: np.ndarray
    C_u: np.ndarray
    D_u: np.ndarray
    C_d: np.ndarray

    @property
    def order(self) -> int:
        return self.A.shape[0]


def _residues(zeros: np.ndarray, poles: np.ndarray, gain: float) -> np.ndarray:
    """Residues of ``gain Π(s + z_j) / Π(s + p_i)`` (distinct real poles) at ``s = -p_i``."""
    out = np.empty(poles.size, dtype=complex)
    for i, p in enumerate(poles):
        others = np.delete(poles, i)
        out[i] = gain * np.prod(zeros - p) / np.prod(others - p)
    return out.real


def sum_channel_zeros(zeros: np.ndarray, poles: np.ndarray) -> np.ndarray:
    """Zeros ``a_r`` (Re > 0) of the spectral factor ``F₊ = Π(s + a_r) / (√2 Π(s + p_i))``
    of ``1 - |F₋(jω)|²``: with ``λ = ω²``, the numerator ``Π(λ + p_i²) - ½ λ Π(λ + z_j²)``
    is ``½ Π(λ - λ_r)``, and ``λ - λ_r = (jω + a_r)(-jω + a_r)`` for ``a_r = √(-λ_r)``."""
    Pp = np.polynomial.Polynomial.fromroots(-(poles**2))
    Pz = np.polynomial.Polynomial.fromroots(-(zeros**2))
    num = Pp - 0.5 * np.polynomial.Polynomial([0.0, 1.0]) * Pz
    lam = num.roots()
    return np.sqrt(-lam.astype(complex))


def isotropic_filters(speed: float, separation: float) -> CoherenceFilters:
    """The :class:`CoherenceFilters` of an isotropic road at ``speed`` [m/s] whose tracks
    are ``separation`` [m] apart (poles and zeros scaled by ``v/B``)."""
    scale = speed / separation
    z, p = ISOTROPIC_ZEROS * scale, ISOTROPIC_POLES * scale
    a = sum_channel_zeros(z, p)
    g = 1.0 / np.sqrt(2.0)
    r_minus = _residues(z, p, g)  # R(s) = F₋(s)/s
    r_plus = _residues(a, p, g)  # F₊(s) - 1/√2
    N = p.size
    A = np.zeros((2 * N, 2 * N))
    A[:N, :N] = A[N:, N:] = np.diag(-p)
    B = np.zeros((2 * N, 2))
    B[:N, 0] = B[N:, 1] = 1.0
    # F₊ w₊ = r₊·ξ₊ + w₊/√2 ;  F₋ w₋ = d/dt (r₋·ξ₋) = -(r₋ p)·ξ₋ + Σ r₋ w₋
    plus = np.concatenate([r_plus, np.zeros(N)])
    minus = np.concatenate([np.zeros(N), -r_minus * p])
    C_u = np.vstack([plus + minus, plus - minus])
    D_u = np.array([[g, r_minus.sum()], [g, -r_minus.sum()]])
    C_d = np.concatenate([np.zeros(N), -2.0 * r_minus])
    return CoherenceFilters(A, B, C_u, D_u, C_d)


def isotropic_coherence_approximation(x: np.ndarray) -> np.ndarray:
    """The coherence ``γ̂(x) = 1 - 2|F₋(jx)|²`` of :func:`isotropic_filters`, ``x = ωB/v``."""
    x = np.asarray(x, dtype=float)
    x2 = x[..., None] ** 2
    f2 = (
        0.5
        * x**2
        * np.prod(x2 + ISOTROPIC_ZEROS**2, axis=-1)
        / np.prod(x2 + ISOTROPIC_POLES**2, axis=-1)
    )
    return 1.0 - 2.0 * f2


def fit_isotropic_difference(
    zeros: np.ndarray, poles: np.ndarray, x: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Fit :data:`ISOTROPIC_ZEROS`/``POLES`` from the starting ``zeros`` (N - 1) and
    ``poles`` (N): least squares on ``log |F₋(jx)|² - log((1 - x K₁(x))/2)`` over ``x``
    (default 1100 points log-spaced on [10⁻³, 10^2.5]) in the logarithms of the zeros and
    poles (``scipy.optimize.least_squares``, Levenberg-Marquardt)."""
    from scipy.optimize import least_squares
    from scipy.special import k1

    x = np.logspace(-3.0, 2.5, 1100) if x is None else np.asarray(x, dtype=float)
    target = np.log(0.5 * (1.0 - x * k1(x)))
    x2 = x[:, None] ** 2
    nz = len(zeros)

    def resid(theta: np.ndarray) -> np.ndarray:
        z, p = np.exp(theta[:nz]), np.exp(theta[nz:])
        model = (
            np.log(0.5)
            + 2.0 * np.log(x)
            + np.sum(np.log(x2 + z**2), axis=1)
            - np.sum(np.log(x2 + p**2), axis=1)
        )
        return model - target

    theta0 = np.log(np.concatenate([zeros, poles]))
    r = least_squares(resid, theta0, method='lm', xtol=1e-15, ftol=1e-15, max_nfev=20000)
    return np.sort(np.exp(r.x[:nz])), np.sort(np.exp(r.x[nz:]))
