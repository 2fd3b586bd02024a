"""Stationary variances by the spectral integral, with the wheelbase delay and the
coherence of the tracks exact: the independent reference of the Lyapunov route
(docs/spectral.md).

    Var y_k = ∫_{-∞}^{∞} h_k(jω) S_δ(ω) h_k(jω)ᴴ dω,
    h(jω) = C (jωI - A)⁻¹ B + D,   S_δ,cd(ω) = S_r(ω) Γ_cd(ω) e^{-jω(τ_c - τ_d)},

with ``S_r(ω) = q / (2π ω²)`` the two-sided height PSD in rad/s, ``τ_c`` the corners'
delays and ``Γ_cd`` 1 on one track and the tracks' coherence across them. The integrand
is even. Over ``ω_min < ω < ω_max`` it is integrated by 20-point Gauss-Legendre rules on
panels spaced logarithmically (``per_decade`` a decade), the panels where a 10-point rule
disagrees most halved until the summed disagreement is below ``rtol`` (the delays make
the integrand oscillate: those panels are refined). Below ``ω_min`` the integrand is
taken constant; above ``ω_max``, ``h → D`` and the tail ``∫ cos(ωΔτ)/ω² dω`` is exact
(sine integral). It shares no code with :mod:`suspopt.spectral.lyapunov` beyond the
system's matrices.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike
from scipy.special import sici

from suspopt.errors import ConfigError
from suspopt.spectral.road import RandomRoad
from suspopt.spectral.shaping import isotropic_coherence_approximation
from suspopt.spectral.system import AffineLinearSystem

#: frequencies per batch of transfer-function solves (memory: batch × n² complex)
_BATCH = 2048


def _coherence(road: RandomRoad, omega: np.ndarray, coherence: str) -> np.ndarray:
    """Cross-track coherence at ``omega`` [rad/s]."""
    if road.tracks == 'identical':
        return np.ones_like(omega)
    if road.tracks == 'independent':
        return np.zeros_like(omega)
    if coherence == 'rational':
        return isotropic_coherence_approximation(omega * road.separation / road.speed)
    return road.coherence(omega)


def _cos_tail(a: np.ndarray, w: float) -> np.ndarray:
    """``∫_w^∞ cos(a ω) / ω² dω = cos(a w)/w - a (π/2 - Si(a w))`` (a >= 0)."""
    si, _ = sici(a * w)
    return np.cos(a * w) / w - a * (0.5 * np.pi - si)


class _Integrand:
    """``2 h S_δ hᴴ`` (n_y,) at many frequencies (the factor 2: both signs of ω)."""

    def __init__(self, system: AffineLinearSystem, road: RandomRoad, p: np.ndarray, coh: str):
        self.A, self.B, self.C, self.D = system.matrices(p)
        self.tau = np.array([c.delay(road.speed) for c in system.corners])
        tracks = np.array([c.track for c in system.corners])
        self.same = tracks[:, None] == tracks[None, :]
        self.road, self.coh = road, coh
        self.q = road.velocity_intensity()

    def __call__(self, omega: np.ndarray) -> np.ndarray:
        """The integrand (n_ω, n_y) and, after it, its bound without cancellation
        ``(Σ_c |C||X_c| + |D_c|)²`` (n_ω, n_y), the scale of its rounding."""
        ny = self.C.shape[0]
        out = np.empty((omega.size, 2 * ny))
        n = self.A.shape[0]
        absC, absD = np.abs(self.C), np.abs(self.D)
        for i in range(0, omega.size, _BATCH):
            w = omega[i : i + _BATCH]
            M = 1j * w[:, None, None] * np.eye(n) - self.A
            X = np.linalg.solve(M, np.broadcast_to(self.B, (w.size, *self.B.shape)))
            h = (self.C @ X + self.D) * np.exp(-1j * w[:, None, None] * self.tau)
            g = _coherence(self.road, w, self.coh)
            G = np.where(self.same, 1.0, g[:, None, None])
            quad = np.einsum('wkc,wcd,wkd->wk', h, G, h.conj()).real
            bound = np.sum(absC @ np.abs(X) + absD, axis=2) ** 2
            S = (2.0 * self.q / (2.0 * np.pi)) / w[:, None] ** 2
            out[i : i + _BATCH, :ny] = S * quad
            out[i : i + _BATCH, ny:] = S * bound
        return out


def _rule(f: _Integrand, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per panel ``[a, b]``: the 20-point Gauss-Legendre value (panels, n_y) and its
    difference from the 10-point one."""
    out = []
    for order in (20, 10):
        x, wts = np.polynomial.legendre.leggauss(order)
        half, mid = 0.5 * (b - a)[:, None], 0.5 * (b + a)[:, None]
        vals = f((half * x + mid).ravel()).reshape(a.size, order, -1)
        out.append(np.einsum('pnk,n,p->pk', vals, wts, half[:, 0]))
    return out[0], out[0] - out[1]


def spectral_variances(
    system: AffineLinearSystem,
    road: RandomRoad,
    p: ArrayLike,
    *,
    coherence: str = 'exact',
    rtol: float = 1e-9,
    omega_min: float | None = None,
    omega_max: float | None = None,
    per_decade: int = 20,
    band: tuple[float, float] | None = None,
) -> np.ndarray:
    """``Var y`` (n_y,) of ``system`` at design ``p`` on ``road`` by the spectral integral
    (module docstring); ``inf`` for an output whose integrand grows like ``1/ω²`` at low
    frequency (it follows the road height). ``coherence``: ``exact`` (``x K₁(x)`` for
    isotropic tracks) or ``rational`` (the approximation of the Lyapunov route, to isolate
    the delay's error). ``omega_min``/``omega_max`` [rad/s] default to ``10⁻⁶`` times the
    slowest and ``10³`` times the fastest eigenvalue modulus of ``A``. ``band``: the
    variance of the road's content between these two circular frequencies only [rad/s]
    (a band-limited road such as :class:`suspopt.road.ISO8608Road`'s; nothing is
    extrapolated beyond them)."""
    if coherence not in ('exact', 'rational'):
        raise ConfigError(f"coherence: must be 'exact' or 'rational', got {coherence!r}")
    pv = system.design_vector(p) if isinstance(p, Mapping) else np.asarray(p, dtype=float)
    f = _Integrand(system, road, pv, coherence)
    eig = np.linalg.eigvals(f.A)
    if not np.all(eig.real < 0.0):
        raise ConfigError('A(p): not stable, the outputs have no stationary variance')
    lam = np.abs(eig)
    if band is not None:
        if not (np.all(np.isfinite(band)) and 0.0 < band[0] < band[1]):
            raise ConfigError(f'band: need 0 < lower < upper [rad/s], got {band}')
        w_lo, w_hi = float(band[0]), float(band[1])
    else:
        w_lo = float(omega_min) if omega_min is not None else 1e-6 * lam.min()
        w_hi = float(omega_max) if omega_max is not None else 1e3 * lam.max()
    # adaptive: log-spaced panels, those whose two rules disagree most halved until the
    # summed disagreement is within rtol of every output's integral
    edges = np.geomspace(w_lo, w_hi, int(np.ceil(per_decade * np.log10(w_hi / w_lo))) + 1)
    a, b = edges[:-1], edges[1:]
    ny = len(system.outputs)
    val, err = _rule(f, a, b)
    for _ in range(60):
        total = val.sum(axis=0)
        # relative to each variance, and absolutely to its rounding level (zero
        # variance: an output the road does not excite, e.g. roll on identical tracks)
        tol = rtol * np.abs(total[:ny]) + 1e-13 * total[ny:]
        e = np.max(np.abs(err[:, :ny]) / np.where(tol > 0.0, tol, 1.0), axis=1)
        if e.sum() <= 1.0:
            break
        split = e > 1.0 / e.size
        mid = 0.5 * (a[split] + b[split])
        na = np.concatenate([a[split], mid])
        nb = np.concatenate([mid, b[split]])
        nv, ne = _rule(f, na, nb)
        keep = ~split
        a, b = np.concatenate([a[keep], na]), np.concatenate([b[keep], nb])
        val, err = np.concatenate([val[keep], nv]), np.concatenate([err[keep], ne])
    else:
        raise ConfigError(f'rtol: the spectral integral did not reach {rtol:g}')
    fine, bound = val.sum(axis=0)[:ny], val.sum(axis=0)[ny:]
    if band is not None:
        return fine

    # below ω_min: the integrand's value there (constant for a finite variance)
    lo = f(np.array([w_lo, 0.1 * w_lo]))[:, :ny]
    low = lo[0] * w_lo
    diverges = (0.1 * w_lo * lo[1] > 3.0 * low) & (
        low > 1e-9 * np.maximum(np.abs(fine), 1e-12 * bound)
    )
    # above ω_max: h → D, the pairs on one track (unit coherence; across isotropic tracks
    # it vanishes exponentially), cos(ω Δτ) exactly
    dtau = np.abs(f.tau[:, None] - f.tau[None, :])
    G = np.ones_like(dtau) if road.tracks == 'identical' else f.same.astype(float)
    tail = (2.0 * f.q / (2.0 * np.pi)) * np.einsum(
        'kc,cd,kd->k', f.D, G * _cos_tail(dtau, w_hi), f.D
    )
    return np.where(diverges, np.inf, low + fine + tail)
