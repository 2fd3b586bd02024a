"""Peer and reference for suspopt's control co-design: the simple-suspension benchmark,
written by hand as a CasADi direct collocation and solved by IPOPT with an exact Hessian.

The problem is the simple-suspension co-design example of the DT QP Project
(``examples/nonlin/simple-suspension``: ``SimpleSuspensionProblemParameters.m``,
``SimpleSuspensionSimultaneous.m``, ``assets/code.tex``; D. R. Herber and A. K.
Sundarrajan, "On the uses of linear-quadratic methods in solving nonlinear dynamic
optimization problems with direct transcription", ASME IMECE2020-23885), whose quarter car,
weights and road are those of J. T. Allison, T. Guo and Z. Han, "Co-design of an active
suspension using simultaneous dynamic optimization", J. Mech. Des. 136(8) 081003 (2014).
Nothing of suspopt is used: the model, the transcriptions, the NLP and the checks are here.

Model (a quarter car without tyre damping; the states are those of the original)::

    x1 = z_u - z_0      tyre deflection (z_0: road height under the wheel)
    x2 = ż_u            wheel velocity
    x3 = z_s - z_u      suspension deflection (rattlespace)
    x4 = ż_s            body velocity

    ẋ1 = x2 - ż_0(t)
    ẋ2 = (-k_t x1 - b x2 + k x3 + b x4 - u) / m_u
    ẋ3 = x4 - x2
    ẋ4 = ( b x2 - k x3 - b x4 + u) / m_s            (= z̈_s)

with m_s = 325 kg, m_u = 65 kg, k_t = 232.5 kN/m, x(0) = 0, horizon 3 s. Plant variables
b ∈ [1e2, 1e5] N s/m and k ∈ [1e2, 1e6] N/m, control u(t) in N (u ≡ 0 in the passive
problem), path constraint |x3| ≤ 0.04 m and objective

    J = ∫₀³ [1e5 x1² + 0.5 ẋ4² + 1e-5 u²] dt.

Road: the measured profile ``examples/data/iri_737b.csv`` (height against distance, 1 cm
spacing), read as SciPy's ``CubicSpline(bc_type='not-a-knot')`` (MATLAB's ``spline``, as the
original), driven at v = 10 m/s from distance 0 at t = 0: ż_0(t) = v z_0'(v t). The road
enters only through ż_0; x(0) = 0 means the wheel starts on the road, undeflected.

Plant variables in the NLP: one copy of b and of k per node at which the dynamics are
evaluated, chained by equality constraints (b_{i+1} = b_i), with the bounds on the first copy
only. A single scalar would couple every node in the Hessian (CasADi then spends most of
the build on the dense rows); bounding every copy would make the bound constraints
linearly dependent where the optimum sits on a bound.

Transcriptions (the rattlespace bound holds at the state nodes):

* ``radau``: Legendre-Gauss-Radau collocation on S uniform segments of order n (the grid of
  Dymos' ``Radau(compressed=True)``): n LGR points per segment (τ = -1 included) plus the
  right end shared with the next segment; states are degree-n polynomials, the defects
  ``D X_seg - (h/2) f(X_col) = 0`` hold at the n LGR points, the objective is the n-point
  LGR quadrature. The control is a value at each LGR point; its own representation is the
  degree-(n-1) Lagrange polynomial through a segment's n values (discontinuous between
  segments). With segments of 1 ms or a divisor of it, every knot of the road spline is a
  segment end, so ż_0 is a polynomial inside each segment.
* ``trapezoid``: trapezoidal defects and trapezoidal quadrature on nt equidistant points
  (the original's ``TR``/``CTR``/``ED`` options, which it runs with nt = 1000); the control
  is piecewise linear between the points.

Verification: ``solve_ivp`` (DOP853, rtol 1e-11) marches the same ODE, with the three
objective terms as more states, under the collocation's own control representation,
piece by piece between the road's knots and the segment ends (where the control may jump);
it reports J, the largest state difference at the nodes and the largest |x3| along the
march. The passive optimum is also checked by marching at b*, k* and at ±1 % in each, and
both optima are marched once more from x1(0) = -z_0(0) (a model in absolute coordinates
with a zero initial state on the unshifted road) to show what that start changes.

Run ``python benchmarks/codesign_peer.py`` (writes ``benchmarks/results/codesign_peer.json``
and ``benchmarks/results/codesign_reference.json``); ``--quick`` for a short check.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import re
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np
import scipy.sparse as sps
from numpy.typing import ArrayLike
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import RESULTS_DIR, machine, versions, write_result  # noqa: E402

ROAD_CSV = Path(__file__).resolve().parent.parent / 'examples' / 'data' / 'iri_737b.csv'
REFERENCE_JSON = RESULTS_DIR / 'codesign_reference.json'
STATE_NAMES = ('z_u - z_0', 'dz_u/dt', 'z_s - z_u', 'dz_s/dt')


@dataclass(frozen=True)
class QuarterCar:
    """The benchmark's data (``SimpleSuspensionProblemParameters.m``), SI units."""

    m_s: float = 325.0  # sprung mass [kg]
    m_u: float = 65.0  # unsprung mass [kg]
    k_t: float = 232.5e3  # tyre stiffness [N/m]
    w1: float = 1e5  # weight of x1² [1/(m² s)]
    w2: float = 0.5  # weight of z̈_s² [s³/m²]
    w3: float = 1e-5  # weight of u² [1/(N² s)]
    r_max: float = 0.04  # rattlespace |z_s - z_u| [m]
    b_bounds: tuple[float, float] = (1e2, 1e5)  # damper [N s/m]
    k_bounds: tuple[float, float] = (1e2, 1e6)  # spring [N/m]
    speed: float = 10.0  # [m/s]
    horizon: float = 3.0  # [s]


# nominal magnitudes: the NLP works with variables / scale and defects / state scale
STATE_SCALE = np.array([0.004, 0.4, 0.04, 0.04])
CONTROL_SCALE = 400.0
PLANT_SCALE = np.array([1e3, 1e4])


# ----------------------------------------------------------------------------------- road
def road_spline(path: Path = ROAD_CSV) -> CubicSpline:
    """Road height [m] against distance [m]: not-a-knot cubic spline through the samples."""
    data = np.loadtxt(path, delimiter=',', skiprows=1)
    return CubicSpline(data[:, 0], data[:, 1], bc_type='not-a-knot')


def road_rate(spline: CubicSpline, speed: float) -> Callable[[ArrayLike], np.ndarray]:
    """ż_0(t) = v z_0'(v t)."""
    slope = spline.derivative()
    return lambda t: speed * slope(speed * np.asarray(t, dtype=float))


def road_knot_times(spline: CubicSpline, speed: float, horizon: float) -> np.ndarray:
    """Times at which the wheel passes a sample of the profile, within [0, horizon]."""
    t = np.asarray(spline.x) / speed
    return t[(t >= 0.0) & (t <= horizon + 1e-12)]


# ----------------------------------------------------------------------------------- model
def quarter_car_function(car: QuarterCar) -> ca.Function:
    """(x[4], b, k, u, ż_0) -> (ẋ[4], objective integrand) of the model above."""
    x = ca.SX.sym('x', 4)
    b, k, u, zd = ca.SX.sym('b'), ca.SX.sym('k'), ca.SX.sym('u'), ca.SX.sym('zd')
    susp = b * (x[1] - x[3]) - k * x[2]  # force of spring and damper on the body [N]
    acc_s = (susp + u) / car.m_s
    xdot = ca.vertcat(x[1] - zd, (-car.k_t * x[0] - susp - u) / car.m_u, x[3] - x[1], acc_s)
    g = ca.vertcat(car.w1 * x[0] ** 2, car.w2 * acc_s**2, car.w3 * u**2)
    return ca.Function('quarter_car', [x, b, k, u, zd], [xdot, g])


def rhs_numpy(car: QuarterCar, x: np.ndarray, b: float, k: float, u: float, zd: float):
    """The same model in NumPy for time marching (ẋ, integrand terms)."""
    susp = b * (x[1] - x[3]) - k * x[2]
    acc_s = (susp + u) / car.m_s
    xdot = np.array([x[1] - zd, (-car.k_t * x[0] - susp - u) / car.m_u, x[3] - x[1], acc_s])
    return xdot, np.array([car.w1 * x[0] ** 2, car.w2 * acc_s**2, car.w3 * u**2])


# ----------------------------------------------------------------------------------- grids
def lgr_nodes(n: int) -> tuple[np.ndarray, np.ndarray]:
    """The n Legendre-Gauss-Radau points on [-1, 1) (roots of P_{n-1} + P_n, τ = -1
    included) and their quadrature weights (exact for degree 2n - 2)."""
    c = np.zeros(n + 1)
    c[n - 1] = c[n] = 1.0
    tau = np.sort(np.real(np.polynomial.legendre.legroots(c)))
    tau[0] = -1.0
    moments = np.zeros(n)
    moments[0] = 2.0  # ∫ P_0 = 2, ∫ P_j = 0 for j > 0
    w = np.linalg.solve(np.polynomial.legendre.legvander(tau, n - 1).T, moments)
    return tau, w


def barycentric_weights(nodes: np.ndarray) -> np.ndarray:
    diff = nodes[:, None] - nodes[None, :]
    np.fill_diagonal(diff, 1.0)
    return 1.0 / np.prod(diff, axis=1)


def differentiation_matrix(nodes: np.ndarray) -> np.ndarray:
    """D[i, j] = l_j'(τ_i) for the Lagrange basis through ``nodes``."""
    bw = barycentric_weights(nodes)
    diff = nodes[:, None] - nodes[None, :]
    np.fill_diagonal(diff, 1.0)
    D = (bw[None, :] / bw[:, None]) / diff
    np.fill_diagonal(D, 0.0)
    np.fill_diagonal(D, -D.sum(axis=1))
    return D


@dataclass(frozen=True)
class Grid:
    """A transcription: states at ``t_state``; dynamics, control, plant copies and the
    objective integrand at ``t_eval`` (the first ``len(t_eval)`` state nodes); defects
    ``X A^T - F B^T = 0``; objective ``F_g · quad``."""

    name: str  # e.g. 'radau 1 ms x 3'
    kind: str  # 'radau' | 'trapezoid'
    t_state: np.ndarray
    t_eval: np.ndarray
    defect_state: sps.csr_matrix  # A (m x N)
    defect_rate: sps.csr_matrix  # B (m x E)
    quad: np.ndarray  # (E,)
    segments: int
    order: int  # Radau order n; 1 for the trapezoid
    step: float  # segment length / grid step [s]

    def control_function(self, u_eval: np.ndarray) -> Callable[[float, float], float]:
        """The collocation's own control representation: u(t, t_piece), where ``t_piece``
        (any time strictly inside the piece being marched) picks the Radau segment whose
        polynomial applies, so that a segment's polynomial is used on its closed interval
        (the control may jump at segment ends)."""
        if self.kind == 'trapezoid':
            t, u_lin = self.t_eval, np.asarray(u_eval)
            return lambda s, _piece: float(np.interp(s, t, u_lin))
        n, h = self.order, self.step
        tau, _ = lgr_nodes(n)
        bw = barycentric_weights(tau)
        u = np.asarray(u_eval).reshape(self.segments, n)

        def u_of_t(s: float, piece: float) -> float:
            j = min(int(piece // h), self.segments - 1)
            d = (2.0 * (s - j * h) / h - 1.0) - tau
            hit = np.flatnonzero(np.abs(d) < 1e-14)
            if hit.size:
                return float(u[j, hit[0]])
            c = bw / d
            return float(np.dot(c, u[j]) / c.sum())

        return u_of_t

    def breakpoints(self) -> np.ndarray:
        """Where the control representation may be non-smooth (segment ends)."""
        if self.kind == 'trapezoid':
            return np.array([self.t_state[0], self.t_state[-1]])
        return self.step * np.arange(self.segments + 1)


def radau_grid(segments: int, order: int, horizon: float) -> Grid:
    n, h = order, horizon / segments
    tau, w = lgr_nodes(n)
    D = differentiation_matrix(np.append(tau, 1.0))[:n, :]  # n x (n + 1)
    t_eval = (h * np.arange(segments)[:, None] + 0.5 * h * (tau[None, :] + 1.0)).ravel()
    n_eval = segments * n
    rows = np.repeat(np.arange(n_eval), n + 1)
    cols = (np.arange(segments)[:, None, None] * n + np.arange(n + 1)[None, None, :]).repeat(
        n, axis=1
    )
    A = sps.csr_matrix(
        (np.tile(D.ravel(), segments), (rows, cols.ravel())), shape=(n_eval, n_eval + 1)
    )
    B = sps.identity(n_eval, format='csr') * (0.5 * h)
    h_ms = 1e3 * h
    return Grid(
        name=f'radau {h_ms:g} ms x {n}',
        kind='radau',
        t_state=np.append(t_eval, horizon),
        t_eval=t_eval,
        defect_state=A,
        defect_rate=sps.csr_matrix(B),
        quad=np.tile(0.5 * h * w, segments),
        segments=segments,
        order=n,
        step=h,
    )


def trapezoid_grid(points: int, horizon: float) -> Grid:
    t = np.linspace(0.0, horizon, points)
    h = t[1] - t[0]
    m = points - 1
    i = np.arange(m)
    A = sps.csr_matrix(
        (np.r_[-np.ones(m), np.ones(m)], (np.r_[i, i], np.r_[i, i + 1])), shape=(m, points)
    )
    B = sps.csr_matrix((np.full(2 * m, 0.5 * h), (np.r_[i, i], np.r_[i, i + 1])), shape=(m, points))
    quad = np.full(points, h)
    quad[[0, -1]] = 0.5 * h
    return Grid(
        name=f'trapezoid nt = {points} (h = {1e3 * h:.4g} ms)',
        kind='trapezoid',
        t_state=t,
        t_eval=t,
        defect_state=A,
        defect_rate=B,
        quad=quad,
        segments=m,
        order=1,
        step=h,
    )


# ----------------------------------------------------------------------------------- NLP
@dataclass
class Solution:
    """One solve: the optimum and its trajectory on the grid."""

    grid: str
    problem: str  # 'codesign' | 'passive'
    b: float
    k: float
    J: float
    terms: dict[str, float]  # the three parts of J
    success: bool
    status: str
    iterations: int
    n_variables: int
    n_constraints: int
    build_s: float
    solve_s: float
    max_rattle_nodes: float  # max |x3| at the state nodes [m]
    max_abs: dict[str, float]  # largest magnitude of each state and of u at the nodes
    plant_copy_spread: float  # max |copy - first copy| / first copy
    start: tuple[float, float]
    t_state: np.ndarray = field(repr=False)
    x_state: np.ndarray = field(repr=False)  # 4 x N
    t_eval: np.ndarray = field(repr=False)
    u_eval: np.ndarray = field(repr=False)  # E (zeros for the passive problem)

    def summary(self) -> dict[str, Any]:
        out = {
            k: v
            for k, v in asdict(self).items()
            if k not in ('t_state', 'x_state', 't_eval', 'u_eval')
        }
        out['start'] = list(self.start)
        return out


def solve(
    grid: Grid,
    car: QuarterCar,
    zdot: Callable[[ArrayLike], np.ndarray],
    active: bool,
    start: tuple[float, float] = (1e3, 1e4),
    tol: float = 1e-10,
) -> Solution:
    """Build the NLP on ``grid`` and solve it with IPOPT (exact Hessian by CasADi's AD).

    ``build_s`` runs from the road samples at the nodes to the created ``nlpsol`` and its
    start point; ``solve_s`` is the solver call. Start: zero states and control, the plant
    variables at ``start``."""
    t0 = time.perf_counter()
    n_state, n_eval = grid.t_state.size, grid.t_eval.size
    zd = np.asarray(zdot(grid.t_eval)).reshape(1, n_eval)
    sx = ca.DM(STATE_SCALE)

    X_free = ca.MX.sym('X', 4, n_state - 1)  # node 0 is the fixed zero state
    X = ca.horzcat(ca.MX.zeros(4, 1), X_free) * ca.repmat(sx, 1, n_state)
    B_hat = ca.MX.sym('B', 1, n_eval)
    K_hat = ca.MX.sym('K', 1, n_eval)
    U_hat = ca.MX.sym('U', 1, n_eval) if active else None
    U = U_hat * CONTROL_SCALE if U_hat is not None else ca.DM.zeros(1, n_eval)

    model = quarter_car_function(car).map(n_eval)
    F, G = model(X[:, :n_eval], B_hat * PLANT_SCALE[0], K_hat * PLANT_SCALE[1], U, ca.DM(zd))
    A = ca.DM(grid.defect_state)
    Bm = ca.DM(grid.defect_rate)
    defects = (ca.mtimes(X, A.T) - ca.mtimes(F, Bm.T)) / ca.repmat(sx, 1, A.size1())
    chain = ca.vertcat(ca.vec(B_hat[:, 1:] - B_hat[:, :-1]), ca.vec(K_hat[:, 1:] - K_hat[:, :-1]))
    rattle = ca.vec(X_free[2, :])  # scaled x3 at nodes 1..N-1
    terms = ca.mtimes(G, ca.DM(grid.quad))
    J = ca.sum1(terms)

    parts = [ca.vec(X_free), ca.vec(B_hat), ca.vec(K_hat)]
    if U_hat is not None:
        parts.append(ca.vec(U_hat))
    w = ca.vertcat(*parts)
    g = ca.vertcat(ca.vec(defects), chain, rattle)
    opts: dict[str, Any] = {
        'expand': False,  # MX throughout: expanding to SX took most of the build
        'print_time': False,
        'ipopt.print_level': 0,
        'ipopt.sb': 'yes',
        'ipopt.tol': tol,
        'ipopt.max_iter': 1000,
    }
    nlp: dict[str, Any] = {'x': w, 'f': J, 'g': g}
    solver = ca.nlpsol('codesign', 'ipopt', nlp, opts)
    n_w, n_def, n_chain = w.numel(), defects.numel(), chain.numel()
    i_b, i_k = 4 * (n_state - 1), 4 * (n_state - 1) + n_eval
    lbx, ubx = np.full(n_w, -np.inf), np.full(n_w, np.inf)
    lbx[i_b], ubx[i_b] = np.array(car.b_bounds) / PLANT_SCALE[0]
    lbx[i_k], ubx[i_k] = np.array(car.k_bounds) / PLANT_SCALE[1]
    x0 = np.zeros(n_w)
    x0[i_b : i_b + n_eval] = start[0] / PLANT_SCALE[0]
    x0[i_k : i_k + n_eval] = start[1] / PLANT_SCALE[1]
    r = car.r_max / STATE_SCALE[2]
    lbg = np.r_[np.zeros(n_def + n_chain), np.full(n_state - 1, -r)]
    ubg = np.r_[np.zeros(n_def + n_chain), np.full(n_state - 1, r)]
    terms_fn = ca.Function('terms', [w], [terms])
    build_s = time.perf_counter() - t0

    t1 = time.perf_counter()
    sol = solver(x0=x0, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
    solve_s = time.perf_counter() - t1

    stats = solver.stats()
    w_opt = np.asarray(sol['x']).ravel()
    x_state = np.hstack([np.zeros((4, 1)), w_opt[:i_b].reshape(n_state - 1, 4).T])
    x_state *= STATE_SCALE[:, None]
    b_copies = w_opt[i_b : i_b + n_eval] * PLANT_SCALE[0]
    k_copies = w_opt[i_k : i_k + n_eval] * PLANT_SCALE[1]
    spread = max(
        float(np.abs(b_copies / b_copies[0] - 1.0).max()),
        float(np.abs(k_copies / k_copies[0] - 1.0).max()),
    )
    u_eval = w_opt[i_k + n_eval :] * CONTROL_SCALE if active else np.zeros(n_eval)
    t_val = np.asarray(terms_fn(w_opt)).ravel()
    return Solution(
        grid=grid.name,
        problem='codesign' if active else 'passive',
        b=float(b_copies[0]),
        k=float(k_copies[0]),
        J=float(sol['f']),
        terms={'tyre': float(t_val[0]), 'comfort': float(t_val[1]), 'control': float(t_val[2])},
        success=bool(stats['success']),
        status=str(stats['return_status']),
        iterations=int(stats['iter_count']),
        n_variables=int(n_w),
        n_constraints=int(g.numel()),
        build_s=build_s,
        solve_s=solve_s,
        max_rattle_nodes=float(np.abs(x_state[2]).max()),
        max_abs={
            **{n: float(np.abs(x_state[i]).max()) for i, n in enumerate(STATE_NAMES)},
            'u': float(np.abs(u_eval).max()),
        },
        plant_copy_spread=spread,
        start=(float(start[0]), float(start[1])),
        t_state=grid.t_state,
        x_state=x_state,
        t_eval=grid.t_eval,
        u_eval=u_eval,
    )


# ----------------------------------------------------------------------------- marching
MARCH_RTOL = 1e-11
#: absolute tolerances: states relative to their nominal magnitudes, then the three
#: objective terms (each of order 1)
MARCH_ATOL = np.r_[1e-11 * STATE_SCALE, 1e-13, 1e-13, 1e-13]


@dataclass
class MarchCheck:
    """Time marching of a collocation solution under its own control representation."""

    J_march: float
    J_collocation: float
    relative_difference: float  # (J_collocation - J_march) / J_march
    terms_march: dict[str, float]
    max_state_difference: list[float]  # per state, at the nodes, / max |x_i|
    max_rattle: float  # max |x3| along the march (10 samples per piece) [m]
    pieces: int
    method: str
    rtol: float
    atol: list[float]
    control: str  # how u(t) was represented
    wall_s: float


@dataclass
class Marched:
    J: float
    terms: np.ndarray  # the three parts of J
    x_nodes: np.ndarray | None  # 4 x len(t_nodes)
    max_rattle: float
    pieces: int
    wall_s: float


def march(
    car: QuarterCar,
    spline: CubicSpline,
    b: float,
    k: float,
    u_of_t: Callable[[float, float], float] | None = None,
    extra_breaks: np.ndarray | None = None,
    t_nodes: np.ndarray | None = None,
    x0: Sequence[float] = (0.0, 0.0, 0.0, 0.0),
) -> Marched:
    """March from ``x0`` (the benchmark's is zero) with the three objective integrands as
    extra states, one ``solve_ivp`` call per piece between the road's knots and
    ``extra_breaks`` (inside a piece the road rate and the control are smooth)."""
    t0 = time.perf_counter()
    T = car.horizon
    zdot = road_rate(spline, car.speed)
    cand = np.sort(
        np.r_[0.0, road_knot_times(spline, car.speed, T), T]
        if extra_breaks is None
        else np.r_[0.0, road_knot_times(spline, car.speed, T), T, extra_breaks]
    )
    cand = cand[(cand >= 0.0) & (cand <= T)]
    breaks = cand[np.r_[True, np.diff(cand) > 1e-9]]  # knots and segment ends coincide
    breaks[-1] = T

    y = np.r_[np.asarray(x0, dtype=float), 0.0, 0.0, 0.0]
    x_nodes = None
    if t_nodes is not None:
        x_nodes = np.repeat(y[:4, None], np.asarray(t_nodes).size, axis=1)  # t <= 0: x0
    max_rattle = 0.0
    for a, c in zip(breaks[:-1], breaks[1:]):
        mid = 0.5 * (a + c)

        def f(t: float, yy: np.ndarray, _mid: float = mid) -> np.ndarray:
            u = 0.0 if u_of_t is None else u_of_t(t, _mid)
            xdot, g = rhs_numpy(car, yy[:4], b, k, u, float(zdot(t)))
            return np.r_[xdot, g]

        sol = solve_ivp(
            f, (a, c), y, method='DOP853', rtol=MARCH_RTOL, atol=MARCH_ATOL, dense_output=True
        )
        if not sol.success:
            raise RuntimeError(f'time marching failed on [{a}, {c}]: {sol.message}')
        max_rattle = max(max_rattle, float(np.abs(sol.sol(np.linspace(a, c, 10))[2]).max()))
        if t_nodes is not None and x_nodes is not None:
            inside = (t_nodes > a + 1e-12) & (t_nodes <= c + 1e-12)
            if inside.any():
                x_nodes[:, inside] = sol.sol(np.clip(t_nodes[inside], a, c))[:4]
        y = sol.y[:, -1]
    return Marched(
        J=float(y[4:].sum()),
        terms=y[4:].copy(),
        x_nodes=x_nodes,
        max_rattle=max_rattle,
        pieces=breaks.size - 1,
        wall_s=time.perf_counter() - t0,
    )


def check_by_marching(
    sol: Solution, grid: Grid, car: QuarterCar, spline: CubicSpline
) -> MarchCheck:
    """March ``sol``'s plant and control and compare J and the states at the nodes."""
    active = sol.problem == 'codesign'
    m = march(
        car,
        spline,
        sol.b,
        sol.k,
        grid.control_function(sol.u_eval) if active else None,
        grid.breakpoints() if active else None,
        sol.t_state,
    )
    assert m.x_nodes is not None
    scale = np.abs(sol.x_state).max(axis=1)
    diff = (np.abs(m.x_nodes - sol.x_state).max(axis=1) / scale).tolist()
    if not active:
        control = 'none (u = 0)'
    elif grid.kind == 'radau':
        control = (
            f'per segment, the degree-{grid.order - 1} Lagrange polynomial through the '
            f'control values at its {grid.order} LGR points (jumps at segment ends)'
        )
    else:
        control = 'piecewise linear between the grid points (np.interp)'
    return MarchCheck(
        J_march=m.J,
        J_collocation=sol.J,
        relative_difference=(sol.J - m.J) / m.J,
        terms_march=dict(zip(('tyre', 'comfort', 'control'), map(float, m.terms))),
        max_state_difference=diff,
        max_rattle=m.max_rattle,
        pieces=m.pieces,
        method='scipy.integrate.solve_ivp, DOP853, one call per piece',
        rtol=MARCH_RTOL,
        atol=MARCH_ATOL.tolist(),
        control=control,
        wall_s=m.wall_s,
    )


# ----------------------------------------------------------------------------- studies
#: the reference transcription: Radau order 3 on 1 ms segments (3000 over 3 s), so that
#: every knot of the road spline is a segment end
REFERENCE_GRID = ('radau', 3000, 3)
#: the grid sequences of the convergence study: (kind, segments or points, order)
RADAU_SEQUENCE = [(300, 3), (600, 3), (1500, 3), (3000, 3), (6000, 3), (3000, 4), (3000, 5)]
TRAPEZOID_SEQUENCE = [1000, 3001, 6001, 12001]  # nt = 1000: the published setting
QUICK_RADAU = [(300, 3), (600, 3), (3000, 3)]
QUICK_TRAPEZOID = [1000, 3001]
STARTS = [(1e3, 1e4), (1e2, 1e2), (1e5, 1e6), (1e4, 1e3)]


def make_grid(kind: str, size: int, order: int, car: QuarterCar) -> Grid:
    if kind == 'radau':
        return radau_grid(size, order, car.horizon)
    return trapezoid_grid(size, car.horizon)


@dataclass
class GridRow:
    """One row of a grid-convergence table."""

    solution: dict[str, Any]
    march: dict[str, Any] | None
    dJ_vs_reference: float  # (J - J_ref) / J_ref
    refines_reference: bool  # a Radau grid with segments and order both >= the reference's


@dataclass
class ProblemStudy:
    """Everything measured for one problem (co-design or passive)."""

    problem: str
    reference: dict[str, Any]
    reference_march: dict[str, Any]
    samples_10ms: dict[str, list[float | None]]
    control_lgr: list[float]  # the reference control at the LGR points, segment by segment
    off_road_start: dict[str, float]  # J when the wheel starts at height 0, not on the road
    rows: list[GridRow]
    richardson_J: float  # from the two finest trapezoid grids (second order)
    starts: list[dict[str, Any]]
    timing: dict[str, list[float]]  # build / solve / iterations of the reference grid
    neighbours: list[dict[str, float]] = field(default_factory=list)  # passive only
    #: the minimum of J by marching alone (parabola through b*, k* and ±1 %), passive only
    marching_vertex: dict[str, float] = field(default_factory=dict)


def _round(v: float) -> float:
    """Ten significant digits (the solution is accurate to about that; smaller files)."""
    return float(f'{v:.10g}')


def samples_every_10ms(sol: Solution, grid: Grid) -> dict[str, list[float | None]]:
    """States and control at t = 0, 0.01, ..., 3 s: the nodes at segment starts (exact
    nodal values of the solution, no interpolation)."""
    if grid.kind != 'radau' or abs(0.01 / grid.step - round(0.01 / grid.step)) > 1e-9:
        raise ValueError('samples need a Radau grid whose segments divide 10 ms')
    stride = round(0.01 / grid.step) * grid.order
    idx = np.arange(0, sol.t_state.size, stride)
    u_idx = np.minimum(idx, sol.u_eval.size - 1)
    out: dict[str, list[float | None]] = {'t': [_round(t) for t in sol.t_state[idx]]}
    for i, name in enumerate(STATE_NAMES):
        out[name] = [_round(x) for x in sol.x_state[i, idx]]
    u = sol.u_eval[u_idx].copy()
    u[-1] = np.nan  # no control value at t = T (it is not a collocation node)
    out['u'] = [None if np.isnan(v) else _round(v) for v in u]
    return out


def study_problem(
    active: bool,
    car: QuarterCar,
    spline: CubicSpline,
    radau_seq: Sequence[tuple[int, int]],
    trap_seq: Sequence[int],
    repeat: int,
    log: Callable[[str], None],
) -> ProblemStudy:
    zdot = road_rate(spline, car.speed)
    name = 'codesign' if active else 'passive'
    kind, size, order = REFERENCE_GRID

    # the reference solve, repeated for its timing, from the default start
    ref_grid = make_grid(kind, size, order, car)
    runs = [solve(ref_grid, car, zdot, active) for _ in range(max(1, repeat))]
    ref = runs[-1]
    ref_march = check_by_marching(ref, ref_grid, car, spline)
    log(
        f'{name}: reference {ref_grid.name}: b = {ref.b:.8g}, k = {ref.k:.8g}, '
        f'J = {ref.J:.10g} ({ref.status}), march J = {ref_march.J_march:.10g}'
    )

    rows: list[GridRow] = []
    entries = [('radau', s, n) for s, n in radau_seq] + [('trapezoid', p, 1) for p in trap_seq]
    for k_, s, n in entries:
        g = make_grid(k_, s, n, car)
        sol = ref if (k_, s, n) == REFERENCE_GRID else solve(g, car, zdot, active)
        chk = ref_march if sol is ref else check_by_marching(sol, g, car, spline)
        finer = k_ == 'radau' and s >= size and n >= order and (k_, s, n) != REFERENCE_GRID
        rows.append(GridRow(sol.summary(), asdict(chk), (sol.J - ref.J) / ref.J, finer))
        log(
            f'{name}: {g.name}: b = {sol.b:.8g}, k = {sol.k:.8g}, J = {sol.J:.10g}, '
            f'dJ = {rows[-1].dJ_vs_reference:+.2e}, march dJ = {chk.relative_difference:+.2e}'
        )
    richardson = float('nan')
    if len(trap_seq) >= 2:  # the two finest trapezoid grids, second order in the step
        (j1, j2), (p1, p2) = [r.solution['J'] for r in rows[-2:]], trap_seq[-2:]
        richardson = j2 + (j2 - j1) / (((p2 - 1) / (p1 - 1)) ** 2 - 1.0)

    starts = []
    for st in STARTS:
        sol = ref if st == ref.start else solve(ref_grid, car, zdot, active, start=st)
        starts.append({'start': list(st), 'b': sol.b, 'k': sol.k, 'J': sol.J, 'status': sol.status})
        log(f'{name}: start {st}: b = {sol.b:.8g}, k = {sol.k:.8g}, J = {sol.J:.10g}')

    # the same design and control marched with the wheel at height 0 and the road at
    # z_0(0) (absolute coordinates, zero state, unshifted road): x1(0) = -z_0(0)
    z00 = float(spline(0.0))
    m_off = march(
        car,
        spline,
        ref.b,
        ref.k,
        ref_grid.control_function(ref.u_eval) if active else None,
        ref_grid.breakpoints() if active else None,
        x0=(-z00, 0.0, 0.0, 0.0),
    )
    off_road = {
        'z_0(0)': z00,
        'J_march': m_off.J,
        'relative_to_reference': (m_off.J - ref_march.J_march) / ref_march.J_march,
    }
    log(f'{name}: started off the road (x1(0) = {-z00:.3g} m): J = {m_off.J:.10g}')

    neighbours = []
    vertex: dict[str, float] = {}
    if not active:  # the passive optimum by marching alone: J at b*, k* and ±1 % in each
        for fb, fk in ((1, 1), (0.99, 1), (1.01, 1), (1, 0.99), (1, 1.01)):
            m = march(car, spline, ref.b * fb, ref.k * fk)
            neighbours.append(
                {'b': ref.b * fb, 'k': ref.k * fk, 'J_march': m.J, 'max_rattle': m.max_rattle}
            )
        j0, jb_m, jb_p, jk_m, jk_p = (n_['J_march'] for n_ in neighbours)
        # vertex of the parabola through the three values, as a relative offset from b*, k*
        vertex = {
            'b_relative_offset': 0.01 * 0.5 * (jb_m - jb_p) / (jb_m + jb_p - 2.0 * j0),
            'k_relative_offset': 0.01 * 0.5 * (jk_m - jk_p) / (jk_m + jk_p - 2.0 * j0),
        }
        log(f'{name}: neighbours ' + ', '.join(f'{n_["J_march"]:.10g}' for n_ in neighbours))

    return ProblemStudy(
        problem=name,
        reference=ref.summary(),
        reference_march=asdict(ref_march),
        samples_10ms=samples_every_10ms(ref, ref_grid),
        control_lgr=[_round(v) for v in ref.u_eval] if active else [],
        off_road_start=off_road,
        rows=rows,
        richardson_J=richardson,
        starts=starts,
        timing={
            'build_s': [r.build_s for r in runs],
            'solve_s': [r.solve_s for r in runs],
            'iterations': [float(r.iterations) for r in runs],
        },
        neighbours=neighbours,
        marching_vertex=vertex,
    )


# ----------------------------------------------------------------------------- output
def _median(v: Sequence[float]) -> str:
    if len(v) == 1:
        return f'{v[0]:.2f}'
    return f'{statistics.median(v):.2f} ({min(v):.2f}–{max(v):.2f})'


def convergence_table(st: ProblemStudy) -> str:
    out = [
        '| grid | NLP variables | b* [N s/m] | k* [N/m] | J* | (J* − J_ref)/J_ref '
        '| J by time marching | (J* − J_march)/J_march | iterations | build [s] | solve [s] |',
        '|---|---|---|---|---|---|---|---|---|---|---|',
    ]
    for r in st.rows:
        s, m = r.solution, r.march or {}
        out.append(
            f'| {s["grid"]} | {s["n_variables"]} | {s["b"]:.6g} | {s["k"]:.7g} | '
            f'{s["J"]:.9f} | {r.dJ_vs_reference:+.1e} | {m.get("J_march", float("nan")):.9f} | '
            f'{m.get("relative_difference", float("nan")):+.1e} | {s["iterations"]} | '
            f'{s["build_s"]:.2f} | {s["solve_s"]:.2f} |'
        )
    return '\n'.join(out)


def markdown(studies: list[ProblemStudy], car: QuarterCar) -> str:
    kind, size, order = REFERENCE_GRID
    parts = [
        'The simple-suspension control co-design benchmark (DT QP Project, '
        '`examples/nonlin/simple-suspension`; Herber & Sundarrajan, IMECE2020-23885; after '
        'Allison, Guo & Han, J. Mech. Des. 136(8) 2014) written by hand in CasADi and solved '
        'by IPOPT with an exact Hessian: quarter car m_s = 325 kg, m_u = 65 kg, '
        'k_t = 232.5 kN/m; b ∈ [1e2, 1e5] N s/m, k ∈ [1e2, 1e6] N/m; '
        'J = ∫₀³ [1e5 (z_u − z_0)² + 0.5 z̈_s² + 1e-5 u²] dt, |z_s − z_u| ≤ 0.04 m, zero '
        'initial state, the measured road `examples/data/iri_737b.csv` (not-a-knot cubic '
        'spline) at 10 m/s. Reference transcription: '
        f'{make_grid(kind, size, order, car).name} (LGR collocation, every road knot a '
        'segment end). The trapezoid with nt = 1000 is the setting of the original '
        '(`SimpleSuspensionSimultaneous.m`: TR defects, CTR quadrature, 1000 equidistant '
        'points). Timings on a shared 2-core machine: compare within this table only.',
        '',
        '| problem | b* [N s/m] | k* [N/m] | J* | ∫1e5 x1² | ∫0.5 z̈_s² | ∫1e-5 u² '
        '| J by time marching | largest z_s − z_u [m] | build [s] | solve [s] | iterations |',
        '|---|---|---|---|---|---|---|---|---|---|---|---|',
    ]
    for st in studies:
        r, m = st.reference, st.reference_march
        parts.append(
            f'| {st.problem} | {r["b"]:.6g} | {r["k"]:.7g} | {r["J"]:.9f} | '
            f'{r["terms"]["tyre"]:.6f} | {r["terms"]["comfort"]:.6f} | '
            f'{r["terms"]["control"]:.6f} | {m["J_march"]:.9f} | {m["max_rattle"]:.5f} | '
            f'{_median(st.timing["build_s"])} | {_median(st.timing["solve_s"])} | '
            f'{", ".join(str(int(i)) for i in st.timing["iterations"])} |'
        )
    for st in studies:
        rich = (st.richardson_J - st.reference['J']) / st.reference['J']
        parts += [
            '',
            f'Grid convergence, {st.problem} (reference: {st.reference["grid"]}; '
            f'Richardson extrapolation of the two finest trapezoid grids: J = '
            f'{st.richardson_J:.9f}, {rich:+.1e} from the reference):',
            '',
            convergence_table(st),
            '',
            f'Starts ({st.problem}, reference grid; states and control start at zero): '
            + '; '.join(
                f'(b, k) = ({s["start"][0]:.0e}, {s["start"][1]:.0e}) → b = {s["b"]:.6g}, '
                f'k = {s["k"]:.7g}, J = {s["J"]:.9f}'
                for s in st.starts
            )
            + '.',
        ]
        off = st.off_road_start
        parts += [
            '',
            f'Started off the road ({st.problem}): the reference design and control marched '
            f'from x1(0) = −z_0(0) = {-off["z_0(0)"]:.3g} m (a wheel at height 0 on the '
            f'unshifted road) give J = {off["J_march"]:.9f}, '
            f'{off["relative_to_reference"]:+.1e} relative.',
        ]
        if st.neighbours:
            c = st.neighbours[0]['J_march']
            parts += [
                '',
                'Passive optimum by time marching alone (no collocation): J at (b*, k*) = '
                f'{c:.9f}; at b* ∓ 1 %: '
                f'{st.neighbours[1]["J_march"] - c:+.2e}, {st.neighbours[2]["J_march"] - c:+.2e}; '
                f'at k* ∓ 1 %: {st.neighbours[3]["J_march"] - c:+.2e}, '
                f'{st.neighbours[4]["J_march"] - c:+.2e}; the vertices of the parabolas lie at '
                f'b* (1 {st.marching_vertex["b_relative_offset"]:+.1e}) and '
                f'k* (1 {st.marching_vertex["k_relative_offset"]:+.1e}).',
            ]
    co, pa = studies[0], studies[-1]
    mx = co.reference['max_abs']
    published = (
        "Published values: the DT QP example reports no optimum (its README's solution "
        'section is commented out, and so are the lines of `SimpleSuspension_output.m` that '
        'printed bs, ks and F). What it gives is a scaling "with knowledge of the solution" '
        '(`SimpleSuspensionSimultaneous.m`): u 400, states [0.004 0.4 0.04 0.04], plant '
        f'[1e2; 1e4]. The co-design reference has b* = {co.reference["b"]:.4g}, '
        f'k* = {co.reference["k"]:.4g}, largest |u| = {mx["u"]:.0f} N and largest states '
        + ', '.join(f'{mx[n]:.2g}' for n in STATE_NAMES)
        + ', the same magnitudes.'
    )
    tr = {
        st.problem: r
        for st in studies
        for r in st.rows
        if r.solution['grid'].startswith('trapezoid nt = 1000 ')
    }
    if len(tr) == 2:
        c_, p_ = tr['codesign'], tr['passive']
        published += (
            " The original's own discretization (trapezoid, nt = 1000, steps of 3.003 ms that "
            "straddle the road's 1 ms knots) gives J "
            f'{100 * c_.dJ_vs_reference:+.2f} % (co-design) and '
            f'{100 * p_.dJ_vs_reference:+.2f} % (passive) from the converged values, with '
            f'b* {100 * (c_.solution["b"] / co.reference["b"] - 1):+.1f} % and '
            f'k* {100 * (c_.solution["k"] / co.reference["k"] - 1):+.1f} % (co-design), '
            f'b* {100 * (p_.solution["b"] / pa.reference["b"] - 1):+.2f} % and '
            f'k* {100 * (p_.solution["k"] / pa.reference["k"] - 1):+.2f} % (passive).'
        )
    parts += ['', published]
    m = studies[0].reference_march
    parts += [
        '',
        "Time marching: `solve_ivp` (DOP853, rtol 1e-11, atol 1e-11 × the states' nominal "
        'magnitudes) of the same ODE with the integrand as extra states, one call per piece '
        "between the road's knots and the segment ends; the control is the collocation's "
        f'own representation ({m["control"]}). Largest state difference at the nodes '
        "(relative to each state's largest magnitude), co-design reference: "
        + ', '.join(f'{d:.1e}' for d in m['max_state_difference'])
        + '.',
    ]
    return '\n'.join(parts)


def reference_record(studies: list[ProblemStudy], car: QuarterCar) -> dict[str, Any]:
    """The converged reference solution that suspopt's tests and benchmark compare with."""
    kind, size, order = REFERENCE_GRID
    grid = make_grid(kind, size, order, car)
    rec: dict[str, Any] = {
        'benchmark': 'codesign_reference',
        'description': (
            'Converged optimum of the simple-suspension control co-design benchmark (DT QP '
            'Project examples/nonlin/simple-suspension; Herber & Sundarrajan IMECE2020-23885; '
            'after Allison, Guo & Han, J. Mech. Des. 136(8) 2014), co-design (b, k, u(t)) and '
            'passive (u = 0; b, k), from benchmarks/codesign_peer.py'
        ),
        'date': datetime.datetime.now().isoformat(timespec='seconds'),
        'machine': machine(),
        'versions': versions(),
        'command': 'python ' + ' '.join([os.path.relpath(sys.argv[0])] + sys.argv[1:]),
        'problem': {
            **asdict(car),
            'b_t': 0.0,
            'states': list(STATE_NAMES),
            'initial_state': [0.0, 0.0, 0.0, 0.0],
            'objective': 'integral over [0, horizon] of w1 x1^2 + w2 (dx4/dt)^2 + w3 u^2',
            'path_constraint': '|x3| <= r_max',
            'road': 'examples/data/iri_737b.csv',
            'road_interpolation': (
                "scipy CubicSpline(bc_type='not-a-knot') of height [m] against distance [m]; "
                'distance = speed * t from 0 at t = 0; the road enters as dz_0/dt only'
            ),
            'units': 'SI (m, s, kg, N); J as defined, unnormalized',
        },
        'grid': {
            'transcription': 'Legendre-Gauss-Radau collocation (Dymos Radau grid, compressed)',
            'segments': size,
            'order': order,
            'segment_length_s': grid.step,
            'state_nodes': int(grid.t_state.size),
            'road_knots_are_segment_ends': bool(
                abs(0.01 / car.speed / grid.step - round(0.01 / car.speed / grid.step)) < 1e-9
            ),
        },
    }
    for st in studies:
        ref, m = st.reference, st.reference_march
        rec[st.problem] = {
            'b': ref['b'],
            'k': ref['k'],
            'J': ref['J'],
            'terms': ref['terms'],
            'max_rattle_m': m['max_rattle'],
            'rattlespace_active': bool(m['max_rattle'] > 0.999 * car.r_max),
            'ipopt_status': ref['status'],
            'grid_convergence': [
                {
                    'grid': r.solution['grid'],
                    'b': r.solution['b'],
                    'k': r.solution['k'],
                    'J': r.solution['J'],
                    'relative_dJ': r.dJ_vs_reference,
                }
                for r in st.rows
            ],
            # largest |J - J_ref| / J_ref over the refinements of the reference grid
            'J_converged_to': max(
                (abs(r.dJ_vs_reference) for r in st.rows if r.refines_reference),
                default=float('nan'),
            ),
            'richardson_trapezoid_J': st.richardson_J,
            'time_marching': m,
            'starts': st.starts,
            'samples_10ms': st.samples_10ms,
            'off_road_start': st.off_road_start,
        }
        if st.control_lgr:
            tau, _ = lgr_nodes(order)
            rec[st.problem]['control_lgr'] = {
                'description': (
                    'u [N] at the LGR points of each 1 ms segment, segment by segment: '
                    't = h (j + (tau_i + 1) / 2); the control of segment j is the '
                    'degree-(order - 1) polynomial through its values'
                ),
                'tau': tau.tolist(),
                'u': st.control_lgr,
            }
        if st.neighbours:
            rec[st.problem]['marching_neighbours'] = st.neighbours
            rec[st.problem]['marching_vertex'] = st.marching_vertex
    rec['published'] = PUBLISHED
    return rec


#: what the original reports (read at github.com/danielrherber/dt-qp-project, master)
PUBLISHED = {
    'source': 'github.com/danielrherber/dt-qp-project examples/nonlin/simple-suspension',
    'numbers_reported': None,
    'notes': [
        'README.md: formulation only; its "Solution" section is commented out.',
        'SimpleSuspension_output.m: returns the objective, timings and iteration counts; the '
        'lines printing bs, ks and F are commented out.',
        'SimpleSuspensionSimultaneous.m: TR defects, CTR quadrature, nt = 1000 equidistant '
        'points, IPOPT through IPFMINCON, tolerance 1e-14; guess: zero states and control, '
        'plant at its lower bounds; scaling "with knowledge of the solution": u 400, states '
        '[0.004 0.4 0.04 0.04], plant [1e2; 1e4].',
        'SimpleSuspensionNested.m: the same problem as an outer fmincon over (b, k) scaled '
        'to [0, 1] around an LQDO inner loop (TR, nt = 1000).',
    ],
}


def compact_json(record: dict[str, Any]) -> str:
    """Indented JSON with every flat list of numbers on one line."""
    text = json.dumps(record, indent=1, default=float)
    return re.sub(r'\[([^\[\]{}"]*)\]', lambda m: '[' + ' '.join(m.group(1).split()) + ']', text)


def main(argv: Sequence[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--quick', action='store_true', help='fewer grids; writes nothing')
    ap.add_argument('--repeat', type=int, default=3, help='solves of the reference grid')
    ap.add_argument('--no-write', action='store_true')
    args = ap.parse_args(argv)

    car, spline = QuarterCar(), road_spline()
    radau_seq = QUICK_RADAU if args.quick else RADAU_SEQUENCE
    trap_seq = QUICK_TRAPEZOID if args.quick else TRAPEZOID_SEQUENCE
    studies = [
        study_problem(active, car, spline, radau_seq, trap_seq, args.repeat, print)
        for active in (True, False)
    ]
    md = markdown(studies, car)
    print(md)
    if args.quick or args.no_write:
        return
    data = {st.problem: asdict(st) for st in studies}
    path = write_result('codesign_peer', 'Co-design benchmark: CasADi peer and reference', md, data)
    REFERENCE_JSON.parent.mkdir(exist_ok=True)
    tmp = REFERENCE_JSON.with_suffix('.json.tmp')
    tmp.write_text(compact_json(reference_record(studies, car)) + '\n')
    os.replace(tmp, REFERENCE_JSON)
    print(f'wrote {path} and {REFERENCE_JSON}')


if __name__ == '__main__':
    main()
