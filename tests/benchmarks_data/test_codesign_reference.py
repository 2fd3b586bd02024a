"""The co-design reference (``benchmarks/results/codesign_reference.json``, written by
``benchmarks/codesign_peer.py``) checked by a computation that shares nothing with it.

The benchmark's quarter car is linear and time-invariant for fixed b, k; on each 1 cm of
road (1 ms at 10 m/s) the road rate ż_0 of the not-a-knot cubic spline is a quadratic in
time, and so is the reference control (one degree-2 polynomial per 1 ms Radau segment).
Carrying ż_0, u and their first two time derivatives as extra states makes the whole
system ξ' = M ξ on every piece, so the state and the objective follow exactly from one
matrix exponential: ξ(t_i + h) = e^{Mh} ξ(t_i) and ∫ ξᵀQξ dt = ξ(t_i)ᵀ W ξ(t_i), with W
from C. F. Van Loan, "Computing integrals involving the matrix exponential", IEEE Trans.
Autom. Control 23(3), 1978 (W = F₂ᵀG₁ of expm([[-Mᵀ, Q], [0, M]] h)). No collocation, no
adaptive integrator."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.interpolate import CubicSpline
from scipy.linalg import expm

ROOT = Path(__file__).resolve().parents[2]
REFERENCE = ROOT / 'benchmarks' / 'results' / 'codesign_reference.json'
PROFILE = ROOT / 'examples' / 'data' / 'iri_737b.csv'


@pytest.fixture(scope='module')
def ref() -> dict:
    return json.loads(REFERENCE.read_text())


@pytest.fixture(scope='module')
def road() -> CubicSpline:
    data = np.loadtxt(PROFILE, delimiter=',', skiprows=1)
    return CubicSpline(data[:, 0], data[:, 1], bc_type='not-a-knot')


def exact_objective(
    p: dict, road: CubicSpline, b: float, k: float, u_lgr: np.ndarray | None, tau: np.ndarray
) -> float:
    """J of the benchmark for plant (b, k) and a control that is a quadratic on each road
    piece (given at the LGR points ``tau`` of each piece), by exact discretization."""
    ms, mu, kt, v = p['m_s'], p['m_u'], p['k_t'], p['speed']
    h = (road.x[1] - road.x[0]) / v
    n = round(p['horizon'] / h)
    A = np.array(
        [
            [0.0, 1.0, 0.0, 0.0],
            [-kt / mu, -b / mu, k / mu, b / mu],
            [0.0, -1.0, 0.0, 1.0],
            [0.0, b / ms, -k / ms, -b / ms],
        ]
    )
    # ξ = [x (4), ż_0 and its two time derivatives, u and its two time derivatives]
    M = np.zeros((10, 10))
    M[:4, :4] = A
    M[0, 4] = -1.0  # ẋ1 = x2 - ż_0
    M[1, 7], M[3, 7] = -1.0 / mu, 1.0 / ms  # the actuator force between body and wheel
    M[4, 5] = M[5, 6] = M[7, 8] = M[8, 9] = 1.0
    acc = np.r_[0.0, b, -k, -b, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0] / ms  # z̈_s = acc · ξ
    Q = p['w2'] * np.outer(acc, acc)
    Q[0, 0] += p['w1']
    Q[7, 7] += p['w3']
    C = np.zeros((20, 20))
    C[:10, :10], C[:10, 10:], C[10:, 10:] = -M.T, Q, M
    E = expm(C * h)
    Phi = E[10:, 10:]
    W = Phi.T @ E[:10, 10:]

    c = road.c[:, :n]  # the spline piece i: Σ c[m, i] (s - s_i)^(3 - m)
    xi = np.zeros((n, 10))
    xi[:, 4], xi[:, 5], xi[:, 6] = v * c[2], 2.0 * v**2 * c[1], 6.0 * v**3 * c[0]
    if u_lgr is not None:  # the quadratic through the three LGR values of each piece
        s = 0.5 * h * (tau + 1.0)
        coef = np.linalg.solve(np.vander(s, 3, increasing=True), u_lgr.reshape(n, 3).T)
        xi[:, 7], xi[:, 8], xi[:, 9] = coef[0], coef[1], 2.0 * coef[2]
    x = np.zeros(4)
    for i in range(n):
        xi[i, :4] = x
        x = Phi[:4] @ xi[i]
    return float(np.einsum('ij,jk,ik->', xi, W, xi))


def test_reference_is_converged_and_feasible(ref: dict) -> None:
    p = ref['problem']
    for name in ('codesign', 'passive'):
        r = ref[name]
        assert r['ipopt_status'] == 'Solve_Succeeded'
        assert p['b_bounds'][0] <= r['b'] <= p['b_bounds'][1]
        assert p['k_bounds'][0] <= r['k'] <= p['k_bounds'][1]
        assert r['J_converged_to'] < 1e-3  # the refined grids agree to 0.1 %
        assert abs(r['time_marching']['relative_difference']) < 1e-6
        assert r['max_rattle_m'] <= p['r_max']
    assert ref['codesign']['J'] < ref['passive']['J']  # the actuator can only help


def test_passive_reference_exact(ref: dict, road: CubicSpline) -> None:
    p, r = ref['problem'], ref['passive']
    J = exact_objective(p, road, r['b'], r['k'], None, np.zeros(3))
    assert J == pytest.approx(r['J'], rel=1e-8)
    # a minimum in (b, k) by the exact evaluation alone
    for fb, fk in ((0.995, 1.0), (1.005, 1.0), (1.0, 0.995), (1.0, 1.005)):
        assert exact_objective(p, road, r['b'] * fb, r['k'] * fk, None, np.zeros(3)) > J


def test_codesign_reference_exact(ref: dict, road: CubicSpline) -> None:
    p, r = ref['problem'], ref['codesign']
    u = np.asarray(r['control_lgr']['u'])
    tau = np.asarray(r['control_lgr']['tau'])
    J = exact_objective(p, road, r['b'], r['k'], u, tau)
    assert J == pytest.approx(r['J'], rel=1e-8)
    # stationary in (b, k) at the optimal control (b* is interior, 0.5 % stays inside)
    for fb, fk in ((0.995, 1.0), (1.005, 1.0), (1.0, 0.995), (1.0, 1.005)):
        assert exact_objective(p, road, r['b'] * fb, r['k'] * fk, u, tau) > J
