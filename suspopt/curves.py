"""Nonlinear suspension hardware as curves: damper, progressive spring, bump and rebound stops.

Every curve is a small immutable object ``F(x; p)`` with its value, its slope ``dF/dx``
and its derivatives with respect to each of its parameters ``p`` (so that the parameters
can be design variables), vectorized over arrays; :meth:`Curve.evaluate` also takes the
parameters as arrays (one per corner, per node ...) that broadcast against ``x``.

Conventions (those of :func:`suspopt.models.equations.suspension_force`, eq. 9,
``F_S = k (z_W - z_M) + c (v_W - v_M)``, the force of the suspension on the chassis,
positive up; see ``docs/nonlinear_hardware.md``):

* deflection ``x = z_W - z_M`` [m] from the static (design) position, positive in
  **bump** (compression: the wheel moves up towards the body), negative in **rebound**
  (extension, droop);
* velocity ``v = v_W - v_M`` [m/s], positive in bump (the damper is being compressed),
  negative in rebound (it is being extended);
* every curve gives the force on the chassis, positive up: a compressed spring, a
  damper in bump and an engaged bump stop push the chassis up (``F > 0``); in rebound the
  damper and an engaged rebound stop pull it down (``F < 0``). Every curve increases with
  its argument (no negative rates, no negative damping) and passes through ``F(0) = 0``.

Curves:

* :class:`SpringCurve` — polynomial ``Σ_i k_i x^i`` (i = 1 .. n; ``k_S`` is ``k_1``);
  :class:`SpringTable` — points, monotone C¹ cubic (PCHIP) interpolation;
* :class:`DamperCurve` — bump and rebound sides, each with a low-speed slope, a knee
  velocity and a high-speed slope, smoothly blended (below); :class:`DamperTable` —
  points, PCHIP; :class:`LinearDamper` — ``c v``;
* :class:`BumpStop` / :class:`ReboundStop` — ``±Σ_{i≥2} k_i δ^i`` after a gap (``δ`` the
  penetration), so the force and the rate are continuous at contact (C¹);
* :class:`SpringDamperUnit` — one corner's spring, damper and stops together,
  ``F(x, v) = S(x) + D(v) + B(x) + R(x)``;
* :func:`static_deflection` — the deflection under a static load (ride height).

**The damper blend.** :class:`DamperCurve`'s slope is the piecewise-constant slope
(rebound high | rebound low | bump low | bump high) with each step replaced by the C¹
"smoothstep" ``h(u) = 1/2 + 3u/4 - u³/4`` on ``|u| < 1`` (0 below, 1 above): at zero
over ``|v| < v_zero``, at each knee over ``|v - v_knee| < knee_width · v_knee``. The force
is its integral from 0, a piecewise polynomial in closed form (``H = ∫h``, below), so it
is C² in ``v`` and C¹ in the knee velocities. Chosen over a softplus/tanh blend because
the blends have compact support: outside them the curve is exactly the affine lines of
the engineer's data (a softplus never quite reaches them and its tails of the knees
overlap zero), and because the slope is, in every region, a convex combination of two
of the four given slopes, so it is never negative when those are not (no validation of
the blended curve needed). The price of ``F(0) = 0`` with a C¹ zero crossing: outside
the zero blend each side's low-speed line is offset by ``-(c_bump_low - c_rebound_low)
· 3 v_zero / 16`` (a few newtons). With equal slopes the blends multiply zero and the
curve is ``c v`` exactly.

**Tables** are interpolated by the monotone piecewise cubic Hermite scheme of Fritsch
and Carlson (F. N. Fritsch, R. E. Carlson, *Monotone piecewise cubic interpolation*, SIAM
J. Numer. Anal. 17, 1980; the end slopes of C. Moler, *Numerical Computing with MATLAB*,
§3.6), the same interpolant as SciPy's ``PchipInterpolator``: C¹, and monotone for
monotone data (no overshoot between the points). It is written out here because its
derivatives with respect to the table's forces are needed (SciPy gives values only);
outside the table the curve continues along the end tangents (C¹).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import brentq

from suspopt.errors import ConfigError

__all__ = [
    'BumpStop',
    'Curve',
    'CurveValue',
    'DamperCurve',
    'DamperTable',
    'LinearDamper',
    'Parameter',
    'ReboundStop',
    'SpringCurve',
    'SpringDamperUnit',
    'SpringTable',
    'UnitForce',
    'smoothstep',
    'smoothstep_integral',
    'static_deflection',
]


# ---------------------------------------------------------------- the C¹ blend
def smoothstep(u: ArrayLike) -> np.ndarray:
    """``h(u)``: 0 for ``u ≤ -1``, 1 for ``u ≥ 1``, ``1/2 + 3u/4 - u³/4`` between (C¹)."""
    c = np.clip(np.asarray(u, dtype=float), -1.0, 1.0)
    return 0.5 + c * (0.75 - 0.25 * c * c)


def smoothstep_slope(u: ArrayLike) -> np.ndarray:
    """``h'(u) = 3 (1 - u²) / 4`` on ``|u| < 1``, 0 outside."""
    c = np.clip(np.asarray(u, dtype=float), -1.0, 1.0)
    return 0.75 * (1.0 - c * c)


def smoothstep_integral(u: ArrayLike) -> np.ndarray:
    """``H(u) = ∫_{-1}^u h``: 0 for ``u ≤ -1``, ``u`` for ``u ≥ 1`` (a C² ramp ``max(u, 0)``),
    ``(u + 1)/2 + 3 (u² - 1)/8 - (u⁴ - 1)/16`` between."""
    a = np.asarray(u, dtype=float)
    c = np.clip(a, -1.0, 1.0)
    c2 = c * c
    inner = 0.5 * (c + 1.0) + 0.375 * (c2 - 1.0) - 0.0625 * (c2 * c2 - 1.0)
    return np.where(a >= 1.0, a, inner)


#: ``H(0)``
_H0 = 3.0 / 16.0


# ---------------------------------------------------------------- base
@dataclass(frozen=True)
class Parameter:
    """A curve parameter: its name (the design variable's), OpenMDAO units and size (1, or
    the number of points of a table)."""

    name: str
    units: str
    size: int = 1

    def scalar_names(self) -> list[str]:
        """One name per entry: ``name``, or ``name_0`` .. ``name_{size-1}``."""
        return [self.name] if self.size == 1 else [f'{self.name}_{i}' for i in range(self.size)]


@dataclass(frozen=True)
class CurveValue:
    """A curve at an array of arguments: ``value`` and ``slope`` (the shape of the
    broadcast argument and parameters) and ``partials`` by parameter name (the same shape,
    with a trailing axis of the parameter's size for a table)."""

    value: np.ndarray
    slope: np.ndarray
    partials: dict[str, np.ndarray]


def _fmt(x: Any) -> str:
    a = np.asarray(x, dtype=float)
    return f'{float(a):g}' if a.ndim == 0 else '[' + ', '.join(f'{v:g}' for v in a.ravel()) + ']'


class Curve:
    """``F(x; p)`` with its slope and parameter derivatives (see the module docstring)."""

    #: what the argument is (messages)
    argument: ClassVar[str] = 'deflection'

    def parameters(self) -> tuple[Parameter, ...]:
        raise NotImplementedError

    def parameter_values(self) -> dict[str, np.ndarray]:
        """The curve's own parameter values by name."""
        raise NotImplementedError

    def structure(self) -> tuple:
        """Everything but the parameter values (hashable): curves with the same structure
        evaluate together with their parameters as arrays."""
        return (type(self).__name__, tuple((p.name, p.size) for p in self.parameters()))

    def _params(self, params: Mapping[str, ArrayLike] | None) -> dict[str, np.ndarray]:
        p = self.parameter_values()
        if params:
            unknown = set(params) - set(p)
            if unknown:
                raise ValueError(
                    f'{type(self).__name__} has no parameters {sorted(unknown)} '
                    f'(parameters: {", ".join(p)})'
                )
            p.update({k: np.asarray(v, dtype=float) for k, v in params.items()})
        return p

    def evaluate(
        self,
        x: ArrayLike,
        params: Mapping[str, ArrayLike] | None = None,
        partials: bool = True,
    ) -> CurveValue:
        """Value, slope and (with ``partials``) parameter derivatives at ``x``, with the
        curve's parameters or ``params`` (arrays broadcasting against ``x``; a table's
        with a trailing axis of its points)."""
        raise NotImplementedError

    def value(self, x: ArrayLike, params: Mapping[str, ArrayLike] | None = None) -> np.ndarray:
        return self.evaluate(x, params, partials=False).value

    def derivative(self, x: ArrayLike, params: Mapping[str, ArrayLike] | None = None) -> np.ndarray:
        """``dF/dx``."""
        return self.evaluate(x, params, partials=False).slope

    def parameter_derivatives(
        self, x: ArrayLike, params: Mapping[str, ArrayLike] | None = None
    ) -> dict[str, np.ndarray]:
        """``dF/dp`` for every parameter ``p``."""
        return self.evaluate(x, params).partials

    def problems(self, key: str, travel: tuple[float, float] | None = None) -> list[str]:
        """What is wrong with the curve, one line each naming its key (``key.field``);
        ``travel``: the range of the argument it must serve, (min, max) from static."""
        raise NotImplementedError

    def check(self, key: str, travel: tuple[float, float] | None = None) -> Curve:
        """Raise :class:`~suspopt.errors.ConfigError` listing :meth:`problems`; the curve."""
        found = self.problems(key, travel)
        if found:
            raise ConfigError(found)
        return self

    def replace(self, **values: Any) -> Curve:
        """A copy with some parameter (or setting) values replaced."""
        return dataclasses.replace(self, **values)  # type: ignore[type-var]


def _problems_nonnegative(key: str, values: dict[str, Any], why: str) -> list[str]:
    out = []
    for name, v in values.items():
        a = np.asarray(v, dtype=float)
        if not np.all(np.isfinite(a)):
            out.append(f'{key}.{name}: must be finite, got {_fmt(a)}')
        elif np.any(a < 0.0):
            out.append(f'{key}.{name}: must be >= 0{why}, got {_fmt(a)}')
    return out


# ---------------------------------------------------------------- polynomial springs
def _horner(coef: list[np.ndarray], x: np.ndarray) -> np.ndarray:
    """``Σ_j coef[j] x^j`` by Horner's rule."""
    out = coef[-1]
    for c in coef[-2::-1]:
        out = c + x * out
    return np.asarray(out, dtype=float)


@dataclass(frozen=True)
class SpringCurve(Curve):
    """Progressive (or linear) spring ``S(x) = Σ_{i=1..n} k_i x^i`` [N], ``x`` the
    deflection from static [m], positive in bump; ``coefficients = (k_1, .., k_n)`` in
    N/m^i. Parameters ``k_S`` (= k_1, the rate at static), ``k_S2``, ``k_S3``, ..
    ``SpringCurve((k,))`` is ``k x`` exactly (rounded as ``k_S (z_W - z_M)``)."""

    coefficients: tuple[float, ...]

    @classmethod
    def linear(cls, k: float) -> SpringCurve:
        return cls((k,))

    @staticmethod
    def names(n: int) -> list[str]:
        return ['k_S'] + [f'k_S{i}' for i in range(2, n + 1)]

    def parameters(self) -> tuple[Parameter, ...]:
        return tuple(
            Parameter(name, 'N/m' if i == 1 else f'N/m**{i}')
            for i, name in enumerate(self.names(len(self.coefficients)), start=1)
        )

    def parameter_values(self) -> dict[str, np.ndarray]:
        return {
            n: np.asarray(c, dtype=float)
            for n, c in zip(self.names(len(self.coefficients)), self.coefficients)
        }

    def evaluate(self, x, params=None, partials=True) -> CurveValue:
        p = self._params(params)
        x = np.asarray(x, dtype=float)
        k = [p[n] for n in self.names(len(self.coefficients))]
        value = x * _horner(k, x)
        slope = _horner([i * c for i, c in enumerate(k, start=1)], x)
        value, slope = np.broadcast_arrays(value, slope)
        out: dict[str, np.ndarray] = {}
        if partials:
            power = np.broadcast_to(x, value.shape)
            for name in self.names(len(k)):
                out[name] = np.array(power)
                power = power * x
        return CurveValue(np.array(value), np.array(slope), out)

    def integral(self, x: ArrayLike, params: Mapping[str, ArrayLike] | None = None) -> np.ndarray:
        """``∫_0^x S`` [J]: the elastic energy."""
        p = self._params(params)
        x = np.asarray(x, dtype=float)
        k = [p[n] / (i + 1) for i, n in enumerate(self.names(len(self.coefficients)), start=1)]
        return x * x * _horner(k, x)

    def about(self, x0: float) -> SpringCurve:
        """The curve about deflection ``x0``: ``S(x0 + x) - S(x0)`` (its ``k_S`` is the rate
        at ``x0``), e.g. about the static deflection of :func:`static_deflection`."""
        P = np.polynomial.Polynomial([0.0, *self.coefficients])
        Q = P(np.polynomial.Polynomial([x0, 1.0])).coef
        coef = np.zeros(len(self.coefficients))
        coef[: len(Q) - 1] = Q[1:]
        return SpringCurve(tuple(float(c) for c in coef))

    def problems(self, key, travel=None):
        if not self.coefficients:
            return [f'{key}.coefficients: must give at least the rate k_S (N/m)']
        bad = _problems_nonnegative(
            key, {'coefficients': self.coefficients[:1]}, ' (the rate at static)'
        )
        if bad or not all(math.isfinite(c) for c in self.coefficients):
            return bad or [f'{key}.coefficients: must be finite, got {_fmt(self.coefficients)}']
        lo, hi = (-math.inf, math.inf) if travel is None else travel
        x, rate = _min_slope(self.coefficients, lo, hi)
        if rate < 0.0:
            return [
                f'{key}.coefficients: the rate dS/dx must be >= 0 over the travel '
                f'[{lo:g}, {hi:g}] m; it is {rate:g} N/m at x = {x:g} m'
            ]
        return []


def _min_slope(coefficients: Sequence[float], lo: float, hi: float) -> tuple[float, float]:
    """Where on [lo, hi] the polynomial ``Σ k_i x^i``'s slope is least, and that slope
    (-inf at an unbounded end where the slope goes to -inf)."""
    d = np.polynomial.Polynomial([i * c for i, c in enumerate(coefficients, start=1)])
    d = d.trim()
    lead, deg = d.coef[-1], d.degree()
    for end, sign in ((lo, -1.0), (hi, 1.0)):
        if not math.isfinite(end) and deg > 0 and lead * sign**deg < 0.0:
            return end, -math.inf
    cand = [x for x in (lo, hi) if math.isfinite(x)]
    if deg > 1:
        cand += [
            complex(r).real
            for r in d.deriv().roots()
            if abs(complex(r).imag) < 1e-12 and lo < complex(r).real < hi
        ]
    if not cand:
        cand = [0.0]
    vals = [float(d(x)) for x in cand]
    i = int(np.argmin(vals))
    return cand[i], vals[i]


# ---------------------------------------------------------------- tables (PCHIP)
def _edge_slope(h0: float, h1: float, m0: np.ndarray, m1: np.ndarray):
    """End slope of PCHIP (one-sided three-point estimate, shape-preserving) and its
    derivatives with respect to ``m0``, ``m1``."""
    a, b = (2.0 * h0 + h1) / (h0 + h1), -h0 / (h0 + h1)
    d = a * m0 + b * m1
    zero = d * m0 < 0.0  # the estimate's sign is not the secant's (the secant is not 0)
    if m0.ndim == 0 or m0.size:
        clip = ~zero & (m0 * m1 < 0.0) & (np.abs(d) > 3.0 * np.abs(m0))
        if not (np.any(zero) or np.any(clip)):
            return d, a, b
        d = np.where(zero, 0.0, np.where(clip, 3.0 * m0, d))
        return d, np.where(zero, 0.0, np.where(clip, 3.0, a)), np.where(zero | clip, 0.0, b)
    return d, a, b


@functools.lru_cache(maxsize=64)
def _grid(xs: tuple[float, ...]) -> tuple[np.ndarray, ...]:
    """What PCHIP on the nodes ``xs`` needs besides the data: the nodes, the spacings ``h``,
    the weights of the interior slopes, ``∂m/∂y`` (n-1, n) and the start of each of the
    n + 1 segments (the extrapolation before the first node, the n - 1 intervals, the
    extrapolation after the last)."""
    x = np.array(xs, dtype=float)
    n = x.size
    h = np.diff(x)
    M = np.zeros((n - 1, n))
    M[np.arange(n - 1), np.arange(n - 1)] = -1.0 / h
    M[np.arange(n - 1), np.arange(1, n)] = 1.0 / h
    starts = np.concatenate([x[:1], x[:-1], x[-1:]])
    out = (x, h, 2.0 * h[1:] + h[:-1], h[1:] + 2.0 * h[:-1], M, starts)
    for arr in out:
        arr.flags.writeable = False
    return out


def pchip_slopes(
    xs: np.ndarray, y: np.ndarray, jacobian: bool = True
) -> tuple[np.ndarray, np.ndarray | None]:
    """PCHIP's slopes ``d`` (…, n) at the nodes ``xs`` (n,) of data ``y`` (…, n) and (with
    ``jacobian``) ``∂d/∂y`` (…, n, n) (Fritsch–Carlson; SciPy's ``PchipInterpolator``)."""
    _, h, w1, w2, M, _ = _grid(tuple(float(v) for v in xs))
    n = h.size + 1
    m = np.diff(y, axis=-1) / h  # (…, n-1)
    dm = np.zeros(y.shape + (n - 1,)) if jacobian else None  # ∂d_k/∂m_j
    d = np.empty(y.shape)
    if n == 2:
        d[..., 0] = d[..., 1] = m[..., 0]
        if dm is not None:
            dm[..., 0, 0] = dm[..., 1, 0] = 1.0
    else:
        ma, mb = m[..., :-1], m[..., 1:]
        ok = (ma * mb) > 0.0  # same sign, neither zero (else the slope is 0)
        every = bool(np.all(ok))
        if not every:
            ma, mb = np.where(ok, ma, 1.0), np.where(ok, mb, 1.0)
        den = w1 / ma + w2 / mb
        inner = (w1 + w2) / den
        d[..., 1:-1] = inner if every else np.where(ok, inner, 0.0)
        if dm is not None:
            k = np.arange(1, n - 1)
            dm[..., k, k - 1] = np.where(ok, (w1 + w2) * w1 / (ma * ma * den * den), 0.0)
            dm[..., k, k] = np.where(ok, (w1 + w2) * w2 / (mb * mb * den * den), 0.0)
        first = _edge_slope(h[0], h[1], m[..., 0], m[..., 1])
        last = _edge_slope(h[-1], h[-2], m[..., -1], m[..., -2])
        d[..., 0], d[..., -1] = first[0], last[0]
        if dm is not None:
            dm[..., 0, 0], dm[..., 0, 1] = first[1], first[2]
            dm[..., -1, -1], dm[..., -1, -2] = last[1], last[2]
    return d, (None if dm is None else dm @ M)


def _segment_coefficients(h, y, d, m):
    """Monomial coefficients ``c_0 .. c_3`` of the n + 1 segments in ``s = x - start``
    (…, n + 1, 4): the end tangents outside, the cubic Hermite interpolant inside,
    ``c_2 = (3 m_k - 2 d_k - d_{k+1}) / h_k``, ``c_3 = (d_k + d_{k+1} - 2 m_k) / h_k²``."""
    c = np.zeros(y.shape[:-1] + (y.shape[-1] + 1, 4))
    c[..., 0, 0], c[..., 0, 1] = y[..., 0], d[..., 0]
    c[..., -1, 0], c[..., -1, 1] = y[..., -1], d[..., -1]
    c[..., 1:-1, 0], c[..., 1:-1, 1] = y[..., :-1], d[..., :-1]
    c[..., 1:-1, 2] = (3.0 * m - 2.0 * d[..., :-1] - d[..., 1:]) / h
    c[..., 1:-1, 3] = (d[..., :-1] + d[..., 1:] - 2.0 * m) / (h * h)
    return c


def _take(c: np.ndarray, j: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """``c[..., j, :]`` (c: P + (n + 1, k) with P broadcasting to ``shape``; j: ``shape``)."""
    if c.ndim == 2:
        return c[j]
    c = np.broadcast_to(c, shape + c.shape[-2:])
    return np.take_along_axis(c, j[..., None, None], -2)[..., 0, :]


def _pchip(xs: np.ndarray, x: np.ndarray, y: np.ndarray, partials: bool, integral: bool = False):
    """PCHIP through (xs, y) at ``x``, continued along the end tangents: value, slope and
    ``∂value/∂y`` (…, n) (or, with ``integral``, ``∫_{xs[0]}^x``)."""
    nodes, h, _, _, M, starts = _grid(tuple(float(v) for v in xs))
    n = nodes.size
    shape = np.broadcast_shapes(x.shape, y.shape[:-1])
    x = np.broadcast_to(x, shape)
    d, D = pchip_slopes(nodes, y, jacobian=partials)  # at the parameters' own shape
    m = np.diff(y, axis=-1) / h
    c = _segment_coefficients(h, y, d, m)
    j = np.searchsorted(nodes, x, side='right')  # 0: before the table, n: after it
    s = x - starts[j]
    cj = _take(c, j, shape)
    if integral:
        whole = h * (
            c[..., 1:-1, 0]
            + h * (c[..., 1:-1, 1] / 2 + h * (c[..., 1:-1, 2] / 3 + h * c[..., 1:-1, 3] / 4))
        )
        before = np.zeros(c.shape[:-1])
        before[..., 2:] = np.cumsum(whole, -1)
        b = _take(before[..., None], j, shape)[..., 0]
        return b + s * (
            cj[..., 0] + s * (cj[..., 1] / 2 + s * (cj[..., 2] / 3 + s * cj[..., 3] / 4))
        )
    value = cj[..., 0] + s * (cj[..., 1] + s * (cj[..., 2] + s * cj[..., 3]))
    slope = cj[..., 1] + s * (2.0 * cj[..., 2] + 3.0 * s * cj[..., 3])
    dv = None
    if D is not None:
        # ∂c/∂y (…, n + 1, 4, n) from ∂d/∂y = D and ∂m/∂y = M
        E = np.eye(n)
        dc = np.zeros(D.shape[:-2] + (n + 1, 4, n))
        dc[..., 0, 0, :], dc[..., 0, 1, :] = E[0], D[..., 0, :]
        dc[..., -1, 0, :], dc[..., -1, 1, :] = E[-1], D[..., -1, :]
        dc[..., 1:-1, 0, :], dc[..., 1:-1, 1, :] = E[:-1], D[..., :-1, :]
        hh = h[:, None]
        dc[..., 1:-1, 2, :] = (3.0 * M - 2.0 * D[..., :-1, :] - D[..., 1:, :]) / hh
        dc[..., 1:-1, 3, :] = (D[..., :-1, :] + D[..., 1:, :] - 2.0 * M) / (hh * hh)
        dcj = _take(dc.reshape(dc.shape[:-2] + (4 * n,)), j, shape).reshape(shape + (4, n))
        sv = s[..., None]
        dv = dcj[..., 0, :] + sv * (dcj[..., 1, :] + sv * (dcj[..., 2, :] + sv * dcj[..., 3, :]))
    return value, slope, dv


@dataclass(frozen=True)
class _Table(Curve):
    """A monotone table through (0, 0), interpolated by PCHIP (see the module docstring)."""

    #: name of the point coordinate field, its unit; the forces' parameter name
    axis_name: ClassVar[str] = 'points'
    axis_units: ClassVar[str] = 'm'
    forces_name: ClassVar[str] = 'forces'
    why: ClassVar[str] = ''
    if TYPE_CHECKING:
        forces: tuple[float, ...]

    @property
    def nodes(self) -> np.ndarray:
        return np.asarray(getattr(self, self.axis_name), dtype=float)

    def parameters(self) -> tuple[Parameter, ...]:
        return (Parameter(self.forces_name, 'N', len(self.forces)),)

    def parameter_values(self) -> dict[str, np.ndarray]:
        return {self.forces_name: np.asarray(self.forces, dtype=float)}

    def structure(self) -> tuple:
        return super().structure() + (tuple(self.nodes),)

    def evaluate(self, x, params=None, partials=True) -> CurveValue:
        y = self._params(params)[self.forces_name]
        value, slope, dv = _pchip(self.nodes, np.asarray(x, dtype=float), y, partials)
        return CurveValue(value, slope, {self.forces_name: dv} if partials else {})

    def problems(self, key, travel=None):
        xs, ys = self.nodes, np.asarray(self.forces, dtype=float)
        ax, fk = f'{key}.{self.axis_name}', f'{key}.forces'
        if xs.ndim != 1 or xs.size < 2 or ys.shape != xs.shape:
            return [
                f'{key}: {self.axis_name} and forces must be two lists of the same length '
                f'>= 2, got {xs.size} and {ys.size}'
            ]
        if not (np.all(np.isfinite(xs)) and np.all(np.isfinite(ys))):
            return [f'{key}: {self.axis_name} and forces must be finite']
        if np.any(np.diff(xs) <= 0.0):
            i = int(np.argmax(np.diff(xs) <= 0.0))
            return [
                f'{ax}: must be strictly increasing, got {xs[i]:g} then {xs[i + 1]:g} '
                f'(entries {i}, {i + 1})'
            ]
        out = []
        if np.any(np.diff(ys) <= 0.0):
            i = int(np.argmax(np.diff(ys) <= 0.0))
            out.append(
                f'{fk}: must increase with the {self.argument}{self.why}: {ys[i]:g} N at '
                f'{xs[i]:g} then {ys[i + 1]:g} N at {xs[i + 1]:g}'
            )
        zero = np.flatnonzero(xs == 0.0)
        if zero.size == 0 or ys[zero[0]] != 0.0:
            at = 'no point at 0' if zero.size == 0 else f'{ys[zero[0]]:g} N at 0'
            out.append(
                f'{fk}: the curve must pass through zero force at zero {self.argument} '
                f'(a point (0, 0)); it has {at}'
            )
        return out


@dataclass(frozen=True)
class SpringTable(_Table):
    """Spring force [N] at deflections [m] (from static, bump positive): a strictly
    increasing table through (0, 0), PCHIP between the points, the end tangents beyond.
    Parameter ``spring_forces`` (one per point)."""

    deflections: tuple[float, ...]
    forces: tuple[float, ...]
    axis_name: ClassVar[str] = 'deflections'
    forces_name: ClassVar[str] = 'spring_forces'
    why: ClassVar[str] = ' (a negative rate)'

    def integral(self, x: ArrayLike, params: Mapping[str, ArrayLike] | None = None) -> np.ndarray:
        """``∫_0^x S`` [J]."""
        y = self._params(params)[self.forces_name]
        x = np.asarray(x, dtype=float)
        at = _pchip(self.nodes, x, y, False, integral=True)
        return at - _pchip(self.nodes, np.zeros_like(x), y, False, integral=True)


@dataclass(frozen=True)
class DamperTable(_Table):
    """Damper force [N] at velocities [m/s] (bump positive): a strictly increasing table
    through (0, 0), PCHIP between the points, the end tangents beyond. Parameter
    ``damper_forces`` (one per point)."""

    velocities: tuple[float, ...]
    forces: tuple[float, ...]
    argument: ClassVar[str] = 'velocity'
    axis_name: ClassVar[str] = 'velocities'
    axis_units: ClassVar[str] = 'm/s'
    forces_name: ClassVar[str] = 'damper_forces'
    why: ClassVar[str] = ' (negative damping)'


# ---------------------------------------------------------------- dampers
@dataclass(frozen=True)
class LinearDamper(Curve):
    """The linear symmetric damper ``c v`` (parameter ``c_S``, N s/m)."""

    c: float
    argument: ClassVar[str] = 'velocity'

    def parameters(self):
        return (Parameter('c_S', 'N*s/m'),)

    def parameter_values(self):
        return {'c_S': np.asarray(self.c, dtype=float)}

    def evaluate(self, x, params=None, partials=True):
        c = self._params(params)['c_S']
        v = np.asarray(x, dtype=float)
        value, slope = np.broadcast_arrays(c * v, c)
        out = {'c_S': np.array(np.broadcast_to(v, value.shape))} if partials else {}
        return CurveValue(np.array(value), np.array(slope), out)

    def problems(self, key, travel=None):
        return _problems_nonnegative(key, {'c': self.c}, ' (negative damping)')


#: the six design parameters of :class:`DamperCurve`, their units
DAMPER_PARAMETERS = (
    ('c_bump_low', 'N*s/m'),
    ('v_bump_knee', 'm/s'),
    ('c_bump_high', 'N*s/m'),
    ('c_rebound_low', 'N*s/m'),
    ('v_rebound_knee', 'm/s'),
    ('c_rebound_high', 'N*s/m'),
)


@dataclass(frozen=True)
class DamperCurve(Curve):
    """Digressive/progressive asymmetric damper, ``v`` bump positive (module docstring):

        F(v) = c_rl v + (c_bl - c_rl) v_0 (H(v/v_0) - 3/16)
               + (c_bh - c_bl) w_b H((v - v_bk)/w_b) - (c_rh - c_rl) w_r H((-v - v_rk)/w_r)

    with ``w = knee_width · v_knee`` and ``H`` :func:`smoothstep_integral`: slope
    ``c_bump_low`` from 0 to the bump knee ``v_bump_knee``, then ``c_bump_high``;
    ``c_rebound_low`` from 0 to ``-v_rebound_knee``, then ``c_rebound_high`` (slopes in
    N s/m, knees in m/s, both knees > 0). Digressive: high < low. The six are the
    parameters; the blend widths ``v_zero`` [m/s] and ``knee_width`` [-] are settings."""

    c_bump_low: float
    v_bump_knee: float
    c_bump_high: float
    c_rebound_low: float
    v_rebound_knee: float
    c_rebound_high: float
    v_zero: float = 0.01
    knee_width: float = 0.5
    argument: ClassVar[str] = 'velocity'

    @classmethod
    def linear(cls, c: float, knee: float = 0.1, **settings: float) -> DamperCurve:
        """``c v`` (all four slopes ``c``)."""
        return cls(c, knee, c, c, knee, c, **settings)

    def parameters(self):
        return tuple(Parameter(n, u) for n, u in DAMPER_PARAMETERS)

    def parameter_values(self):
        return {n: np.asarray(getattr(self, n), dtype=float) for n, _ in DAMPER_PARAMETERS}

    def structure(self):
        return super().structure() + (self.v_zero, self.knee_width)

    def evaluate(self, x, params=None, partials=True):
        p = self._params(params)
        v = np.asarray(x, dtype=float)
        c_bl, v_bk, c_bh = p['c_bump_low'], p['v_bump_knee'], p['c_bump_high']
        c_rl, v_rk, c_rh = p['c_rebound_low'], p['v_rebound_knee'], p['c_rebound_high']
        v0, rho = self.v_zero, self.knee_width
        w_b, w_r = rho * v_bk, rho * v_rk
        u0, ub, ur = v / v0, (v - v_bk) / w_b, (-v - v_rk) / w_r
        H0, Hb, Hr = smoothstep_integral(u0) - _H0, smoothstep_integral(ub), smoothstep_integral(ur)
        hb, hr = smoothstep(ub), smoothstep(ur)
        d0, db, dr = c_bl - c_rl, c_bh - c_bl, c_rh - c_rl
        value = c_rl * v + d0 * (v0 * H0) + db * (w_b * Hb) - dr * (w_r * Hr)
        slope = c_rl + d0 * smoothstep(u0) + db * hb + dr * hr
        value, slope = np.broadcast_arrays(value, slope)
        out: dict[str, np.ndarray] = {}
        if partials:
            shape = value.shape

            def b(a):
                return np.array(np.broadcast_to(a, shape))

            # ∂(w H(u))/∂v_knee = ρ H(u) - (1 + ρ u) h(u) for w = ρ v_knee (either side)
            out['c_bump_low'] = b(v0 * H0 - w_b * Hb)
            out['c_bump_high'] = b(w_b * Hb)
            out['c_rebound_low'] = b(v - v0 * H0 + w_r * Hr)
            out['c_rebound_high'] = b(-w_r * Hr)
            out['v_bump_knee'] = b(db * (rho * Hb - (1.0 + rho * ub) * hb))
            out['v_rebound_knee'] = b(-dr * (rho * Hr - (1.0 + rho * ur) * hr))
        return CurveValue(np.array(value), np.array(slope), out)

    def problems(self, key, travel=None):
        out = _problems_nonnegative(
            key,
            {n: getattr(self, n) for n in ('c_bump_low', 'c_bump_high')},
            ' (negative damping)',
        )
        out += _problems_nonnegative(
            key,
            {n: getattr(self, n) for n in ('c_rebound_low', 'c_rebound_high')},
            ' (negative damping)',
        )
        if not (math.isfinite(self.v_zero) and self.v_zero > 0.0):
            out.append(f'{key}.v_zero: must be > 0 (m/s), got {self.v_zero!r}')
        if not (math.isfinite(self.knee_width) and 0.0 < self.knee_width < 1.0):
            out.append(f'{key}.knee_width: must be in (0, 1), got {self.knee_width!r}')
        if out:
            return out
        least = self.v_zero / (1.0 - self.knee_width)
        for side in ('bump', 'rebound'):
            vk = getattr(self, f'v_{side}_knee')
            if not (math.isfinite(vk) and vk >= least):
                out.append(
                    f'{key}.v_{side}_knee: must be >= v_zero / (1 - knee_width) = {least:g} '
                    f'm/s (the knee blend must not reach the zero blend), got {vk!r}'
                )
        return out


# ---------------------------------------------------------------- stops
@dataclass(frozen=True)
class _Stop(Curve):
    """A stop engaging after ``gap`` [m] (>= 0) of travel from static, with force
    ``Σ_{i=2..n+1} k_i δ^i`` for the penetration ``δ`` (coefficients ``(k_2, k_3, ..)`` in
    N/m^i, >= 0): zero force and zero rate at contact (C¹), progressive after."""

    gap: float
    coefficients: tuple[float, ...]
    #: +1 bump (δ = x - gap), -1 rebound (δ = -x - gap)
    side: ClassVar[float] = 1.0
    prefix: ClassVar[str] = ''

    def names(self) -> list[str]:
        return [f'{self.prefix}_gap'] + [
            f'{self.prefix}_k{i}' for i in range(2, len(self.coefficients) + 2)
        ]

    def parameters(self):
        names = self.names()
        return (Parameter(names[0], 'm'),) + tuple(
            Parameter(n, f'N/m**{i}') for i, n in enumerate(names[1:], start=2)
        )

    def parameter_values(self):
        vals = (self.gap, *self.coefficients)
        return {n: np.asarray(v, dtype=float) for n, v in zip(self.names(), vals)}

    def _penetration(self, x, p):
        names = self.names()
        delta = np.maximum(self.side * np.asarray(x, dtype=float) - p[names[0]], 0.0)
        return delta, [p[n] for n in names[1:]]

    def evaluate(self, x, params=None, partials=True):
        p = self._params(params)
        delta, k = self._penetration(x, p)
        force = delta * delta * _horner(k, delta)  # Σ k_i δ^i
        rate = delta * _horner([i * c for i, c in enumerate(k, start=2)], delta)  # dF/dδ
        value, slope = np.broadcast_arrays(self.side * force, rate)
        out: dict[str, np.ndarray] = {}
        if partials:
            names = self.names()
            # ∂δ/∂gap = -1 where engaged (δ is 0 and flat elsewhere)
            out[names[0]] = np.array(np.broadcast_to(-self.side * rate, value.shape))
            power = np.broadcast_to(delta * delta, value.shape)
            for n in names[1:]:
                out[n] = np.array(self.side * power)
                power = power * delta
        return CurveValue(np.array(value), np.array(slope), out)

    def integral(self, x: ArrayLike, params: Mapping[str, ArrayLike] | None = None) -> np.ndarray:
        """``∫_0^x F`` [J] (>= 0)."""
        delta, k = self._penetration(x, self._params(params))
        return delta**3 * _horner([c / (i + 1) for i, c in enumerate(k, start=2)], delta)

    def about(self, x0: float) -> _Stop:
        """The stop about deflection ``x0`` (its gap less ``side · x0``); the stop must
        not be engaged at ``x0``."""
        gap = self.gap - self.side * x0
        if gap < 0.0:
            raise ValueError(f'the stop is engaged at x = {x0:g} m (gap {self.gap:g} m)')
        return dataclasses.replace(self, gap=gap)

    def problems(self, key, travel=None):
        out = _problems_nonnegative(key, {'gap': self.gap}, ' (m)')
        out += _problems_nonnegative(
            key, {'coefficients': self.coefficients}, ' (a progressive stop)'
        )
        if out or travel is None:
            return out
        reach = travel[1] if self.side > 0 else -travel[0]
        if self.gap > reach:
            which = 'bump' if self.side > 0 else 'rebound'
            out.append(
                f'{key}.gap: {self.gap:g} m is larger than the {which} travel {reach:g} m '
                '(the stop never engages)'
            )
        return out


@dataclass(frozen=True)
class BumpStop(_Stop):
    """Bump stop: ``F = Σ k_i δ^i`` (pushes the chassis up), ``δ = max(x - gap, 0)``.
    Parameters ``bump_gap`` [m], ``bump_k2`` [N/m²], ``bump_k3`` [N/m³], .."""

    side: ClassVar[float] = 1.0
    prefix: ClassVar[str] = 'bump'


@dataclass(frozen=True)
class ReboundStop(_Stop):
    """Rebound (droop) stop: ``F = -Σ k_i δ^i`` (pulls the chassis down),
    ``δ = max(-x - gap, 0)``. Parameters ``rebound_gap`` [m], ``rebound_k2``, .."""

    side: ClassVar[float] = -1.0
    prefix: ClassVar[str] = 'rebound'


# ---------------------------------------------------------------- one corner's unit
@dataclass(frozen=True)
class UnitForce:
    """:meth:`SpringDamperUnit.force`: the force, ``∂F/∂x``, ``∂F/∂v`` and the parameter
    derivatives by name."""

    value: np.ndarray
    d_x: np.ndarray
    d_v: np.ndarray
    partials: dict[str, np.ndarray]


#: the slots of a :class:`SpringDamperUnit`: its TOML subtable names
SLOTS = ('spring_curve', 'damper_curve', 'bump_stop', 'rebound_stop')


@dataclass(frozen=True)
class SpringDamperUnit:
    """One corner's suspension hardware, ``F(x, v) = S(x) + D(v) + B(x) + R(x)`` on the
    chassis (positive up; ``x``, ``v`` bump positive). ``spring``: :class:`SpringCurve` or
    :class:`SpringTable`; ``damper``: :class:`DamperCurve`, :class:`DamperTable` or
    :class:`LinearDamper`; the stops optional. With ``SpringCurve((k,))`` and
    ``LinearDamper(c)`` and no stops it is ``k x + c v`` exactly."""

    spring: Curve
    damper: Curve
    bump_stop: BumpStop | None = None
    rebound_stop: ReboundStop | None = None

    @classmethod
    def linear(cls, k: float, c: float) -> SpringDamperUnit:
        return cls(SpringCurve((k,)), LinearDamper(c))

    @property
    def elastic(self) -> list[Curve]:
        """The curves of the deflection: the spring and the stops."""
        return [c for c in (self.spring, self.bump_stop, self.rebound_stop) if c is not None]

    def curves(self) -> dict[str, Curve]:
        """The curves by slot (:data:`SLOTS`)."""
        return {
            s: c
            for s, c in zip(SLOTS, (self.spring, self.damper, self.bump_stop, self.rebound_stop))
            if c is not None
        }

    def parameters(self) -> tuple[Parameter, ...]:
        return tuple(p for c in self.curves().values() for p in c.parameters())

    def parameter_values(self) -> dict[str, np.ndarray]:
        out: dict[str, np.ndarray] = {}
        for c in self.curves().values():
            out.update(c.parameter_values())
        return out

    def scalar_parameters(self) -> dict[str, float]:
        """Every parameter entry by scalar name (:meth:`Parameter.scalar_names`)."""
        out = {}
        vals = self.parameter_values()
        for p in self.parameters():
            for name, v in zip(p.scalar_names(), np.ravel(vals[p.name])):
                out[name] = float(v)
        return out

    @functools.cached_property
    def _layout(self) -> list[tuple[str, list[str]]]:
        return [(p.name, p.scalar_names()) for p in self.parameters()]

    def gather(self, scalars: Mapping[str, ArrayLike]) -> dict[str, np.ndarray]:
        """Parameter arrays from scalar entries (:meth:`scalar_parameters` names; missing:
        the unit's values); a table's points stacked on a trailing axis."""
        own: dict[str, float] | None = None
        out = {}
        for name, scalar_names in self._layout:
            if not all(n in scalars for n in scalar_names):
                own = self.scalar_parameters() if own is None else own
            vals = [
                np.asarray(scalars[n] if n in scalars else own[n], dtype=float)  # type: ignore[index]
                for n in scalar_names
            ]
            if len(vals) == 1:
                out[name] = vals[0]
            elif all(v.shape == vals[0].shape for v in vals):
                out[name] = np.stack(vals, -1)
            else:
                out[name] = np.stack(np.broadcast_arrays(*vals), -1)
        return out

    def structure(self) -> tuple:
        return tuple((s, c.structure()) for s, c in self.curves().items())

    @functools.cached_property
    def _names(self) -> dict[int, list[str]]:
        return {id(c): [p.name for p in c.parameters()] for c in self.curves().values()}

    def _split(self, params: Mapping[str, ArrayLike] | None, curve: Curve):
        if not params:
            return None
        return {k: params[k] for k in self._names[id(curve)] if k in params}

    def force(
        self,
        x: ArrayLike,
        v: ArrayLike,
        params: Mapping[str, ArrayLike] | None = None,
        partials: bool = True,
    ) -> UnitForce:
        """``F(x, v)`` with ``∂F/∂x``, ``∂F/∂v`` and the parameter derivatives; ``params``
        by parameter name (:meth:`Curve.evaluate`)."""
        s = self.spring.evaluate(x, self._split(params, self.spring), partials)
        d = self.damper.evaluate(v, self._split(params, self.damper), partials)
        value, d_x = s.value + d.value, s.slope
        out = {**s.partials, **d.partials}
        for stop in (self.bump_stop, self.rebound_stop):
            if stop is not None:
                e = stop.evaluate(x, self._split(params, stop), partials)
                value, d_x = value + e.value, d_x + e.slope
                out.update(e.partials)
        shape = np.broadcast_shapes(value.shape, d_x.shape, d.slope.shape)
        return UnitForce(
            np.array(np.broadcast_to(value, shape)),
            np.array(np.broadcast_to(d_x, shape)),
            np.array(np.broadcast_to(d.slope, shape)),
            {
                k: np.array(np.broadcast_to(a, shape + a.shape[len(shape) :]))
                for k, a in out.items()
            },
        )

    def elastic_force(
        self, x: ArrayLike, params: Mapping[str, ArrayLike] | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """``S + B + R`` at ``x`` and its slope (no damper)."""
        value = slope = np.zeros(np.shape(x))
        for c in self.elastic:
            e = c.evaluate(x, self._split(params, c), partials=False)
            value, slope = value + e.value, slope + e.slope
        return np.asarray(value), np.asarray(slope)

    def elastic_energy(
        self, x: ArrayLike, params: Mapping[str, ArrayLike] | None = None
    ) -> np.ndarray:
        """``∫_0^x (S + B + R)`` [J]."""
        return sum(
            (c.integral(x, self._split(params, c)) for c in self.elastic),  # type: ignore[attr-defined]
            np.zeros(np.shape(x)),
        )

    def problems(self, key: str, travel: tuple[float, float] | None = None) -> list[str]:
        """Every curve's problems, keyed ``key.<slot>`` (:data:`SLOTS`); ``travel``: the
        deflection range (min, max) from static (it checks the spring's rate and the
        stops' gaps)."""
        out = []
        for slot, c in self.curves().items():
            out += c.problems(
                f'{key}.{slot}' if key else slot, None if slot == 'damper_curve' else travel
            )
        return out

    def check(self, key: str, travel: tuple[float, float] | None = None) -> SpringDamperUnit:
        found = self.problems(key, travel)
        if found:
            raise ConfigError(found)
        return self

    # ------------------------------------------------------------ from a table of keys
    @classmethod
    def from_dict(
        cls,
        data: Mapping[str, Any],
        key: str,
        stiffness: float | None = None,
        damping: float | None = None,
        travel: tuple[float, float] | None = None,
    ) -> SpringDamperUnit:
        """Read the subtables :data:`SLOTS` of ``data`` (a ``[[forces]]`` element or a
        vehicle's suspension table), e.g.::

            spring_curve = {coefficients = [30000.0, 0.0, 4.0e6]}   # or deflections, forces
            damper_curve = {c_bump_low = 3000.0, v_bump_knee = 0.1, c_bump_high = 1500.0,
                            c_rebound_low = 7000.0, v_rebound_knee = 0.1,
                            c_rebound_high = 3500.0}                  # or velocities, forces
            bump_stop = {gap = 0.06, coefficients = [0.0, 2.0e8]}   # k_2, k_3
            rebound_stop = {gap = 0.08, coefficients = [5.0e6]}

        Without ``spring_curve`` the spring is linear, ``stiffness`` [N/m]; without
        ``damper_curve`` the damper is linear, ``damping`` [N s/m] (0 if None; the caller
        checks those two under its own keys). Raises :class:`~suspopt.errors.ConfigError`
        listing every problem of the subtables (keys ``key.<slot>.*``)."""
        rd = _UnitReader(data, key)
        spring = rd.spring(stiffness)
        damper = rd.damper(damping)
        bump, rebound = rd.stop('bump_stop', BumpStop), rd.stop('rebound_stop', ReboundStop)
        unit = cls(spring, damper, bump, rebound)
        errors = rd.errors
        if not errors:
            # the curves given (a linear spring or damper from stiffness or damping is the
            # caller's to check, under its own key)
            errors = [
                line
                for line in unit.problems(key, travel)
                if any(line.startswith(f'{rd.where(slot)}.') for slot in SLOTS if slot in data)
            ]
        if errors:
            raise ConfigError(errors)
        return unit


class _UnitReader:
    """The subtables of :meth:`SpringDamperUnit.from_dict` (a ``[[forces]]`` element or a
    vehicle's suspension table ``data`` under ``key``), every problem collected in
    ``errors``."""

    def __init__(self, data: Mapping[str, Any], key: str):
        self.data, self.key = data, key
        self.errors: list[str] = []

    def where(self, slot: str) -> str:
        return f'{self.key}.{slot}' if self.key else slot

    def numbers(self, table: Mapping[str, Any], name: str, slot: str, required=True) -> tuple:
        val = table.get(name)
        if val is None and not required:
            return ()
        if (
            not isinstance(val, list)
            or not val
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in val)
        ):
            self.errors.append(f'{self.where(slot)}.{name}: must be a list of numbers, got {val!r}')
            return ()
        return tuple(float(v) for v in val)

    def number(self, table: Mapping[str, Any], name: str, slot: str, default=None) -> float:
        val = table.get(name, default)
        if isinstance(val, bool) or not isinstance(val, (int, float)):
            self.errors.append(
                f'{self.where(slot)}.{name}: '
                + ('missing value' if val is None else f'must be a number, got {val!r}')
            )
            return math.nan
        return float(val)

    def table(self, slot: str, allowed: set[str]) -> Mapping[str, Any] | None:
        t = self.data.get(slot)
        if t is None:
            return None
        if not isinstance(t, Mapping):
            self.errors.append(f'{self.where(slot)}: must be a table, got {t!r}')
            return None
        for k in t:
            if k not in allowed:
                self.errors.append(
                    f'{self.where(slot)}.{k}: unknown key (keys: {", ".join(sorted(allowed))})'
                )
        return t

    def spring(self, stiffness: float | None) -> Curve:
        """``spring_curve``, else a linear spring of rate ``stiffness`` (0 if None)."""
        t = self.table('spring_curve', {'coefficients', 'deflections', 'forces'})
        if t is None:
            return SpringCurve((0.0 if stiffness is None else float(stiffness),))
        if 'coefficients' in t and ('deflections' in t or 'forces' in t):
            self.errors.append(
                f'{self.where("spring_curve")}: give coefficients or deflections and forces, '
                'not both'
            )
            return SpringCurve((0.0,))
        if 'coefficients' in t:
            return SpringCurve(self.numbers(t, 'coefficients', 'spring_curve') or (0.0,))
        return SpringTable(
            self.numbers(t, 'deflections', 'spring_curve') or (0.0, 1.0),
            self.numbers(t, 'forces', 'spring_curve') or (0.0, 1.0),
        )

    def damper(self, damping: float | None) -> Curve:
        """``damper_curve``, else a linear damper of rate ``damping`` (0 if None)."""
        names = [n for n, _ in DAMPER_PARAMETERS]
        t = self.table('damper_curve', {*names, 'v_zero', 'knee_width', 'velocities', 'forces'})
        if t is None:
            return LinearDamper(0.0 if damping is None else float(damping))
        if 'velocities' in t or 'forces' in t:
            extra = [k for k in t if k not in ('velocities', 'forces')]
            if extra:
                self.errors.append(
                    f'{self.where("damper_curve")}: give the slopes and knees or velocities '
                    f'and forces, not both (also given: {", ".join(extra)})'
                )
            return DamperTable(
                self.numbers(t, 'velocities', 'damper_curve') or (0.0, 1.0),
                self.numbers(t, 'forces', 'damper_curve') or (0.0, 1.0),
            )
        vals = {n: self.number(t, n, 'damper_curve') for n in names}
        return DamperCurve(
            **vals,
            v_zero=self.number(t, 'v_zero', 'damper_curve', 0.01),
            knee_width=self.number(t, 'knee_width', 'damper_curve', 0.5),
        )

    def stop(self, slot: str, kind: Any) -> Any:
        """The stop ``slot`` (``kind``: its class), or None."""
        t = self.table(slot, {'gap', 'coefficients'})
        if t is None:
            return None
        return kind(self.number(t, 'gap', slot), self.numbers(t, 'coefficients', slot) or (0.0,))


# ---------------------------------------------------------------- static deflection
def static_deflection(
    load: float,
    spring: Curve,
    bump_stop: BumpStop | None = None,
    rebound_stop: ReboundStop | None = None,
    preload: float = 0.0,
    travel: tuple[float, float] = (-0.5, 0.5),
    key: str = 'spring',
) -> float:
    """The deflection ``x_s`` [m] at which the springs carry a static ``load`` [N]:
    ``preload + S(x_s) + B(x_s) + R(x_s) = load``, for curves given about the unloaded
    (zero-deflection) position, the root in ``travel`` (the curves increase, so it is
    unique; Brent's method, SciPy's ``brentq``). The ride height is then the unloaded
    one less ``x_s`` (at the wheel, for curves at the wheel), and the curves about the
    static position are ``spring.about(x_s)``, ``stop.about(x_s)``: what the ride model,
    whose deflection is measured from static, takes. Raises
    :class:`~suspopt.errors.ConfigError` (key ``key``) if the load is outside what the
    springs carry over ``travel``."""
    curves = [c for c in (spring, bump_stop, rebound_stop) if c is not None]

    def residual(x: float) -> float:
        return preload + sum(float(c.value(x)) for c in curves) - load

    lo, hi = travel
    f_lo, f_hi = residual(lo), residual(hi)
    if f_lo == 0.0:
        return float(lo)
    if f_hi == 0.0:
        return float(hi)
    if not (f_lo < 0.0 < f_hi):
        raise ConfigError(
            f'{key}: the static load {load:g} N is outside the force the springs carry '
            f'over the travel [{lo:g}, {hi:g}] m ({f_lo + load:g} .. {f_hi + load:g} N)'
        )
    return float(brentq(residual, lo, hi, xtol=1e-15, rtol=4 * np.finfo(float).eps))
