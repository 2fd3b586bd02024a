"""optimize_spectral on the quarter car (analytic optimum, KKT, an independent SciPy
optimization of the closed forms) and the half car."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize
from spectral_vehicles import HALF_CAR_DESIGN, KT, MS, MU, half_car, quarter_car
from test_spectral_closed_form import closed_forms

from suspopt.errors import ConfigError
from suspopt.spectral import RandomRoad
from suspopt.spectral.optimize import optimize_spectral

ROAD = RandomRoad('C', 20.0)
Q = ROAD.velocity_intensity()
LOWER = {'k': 10000.0, 'c': 300.0}
UPPER = {'k': 60000.0, 'c': 8000.0}


@pytest.mark.parametrize('hessian', ['exact', 'limited-memory'])
@pytest.mark.parametrize('travel_limit', [0.012, 0.03])
def test_minimum_acceleration_with_a_travel_limit_is_analytic(hessian, travel_limit):
    """Minimum RMS sprung acceleration with RMS travel <= ℓ: the acceleration variance
    grows with k, so k sits at its lower bound; over c it is convex with its minimum at
    c* = k √((m_s+m_u)/k_t), and the travel variance q(m_s+m_u)/(2c) falls with c, so
    c = max(c*, q(m_s+m_u)/(2ℓ²)): the limit is active (ℓ = 0.012 m) or not (0.03 m)."""
    res = optimize_spectral(
        quarter_car(),
        ROAD,
        {'k': 20000.0, 'c': 1500.0},
        objective={'acc': 1.0},
        lower=LOWER,
        upper=UPPER,
        rms_limits={'travel': travel_limit},
        hessian=hessian,
    )
    assert res.success, res.status_message
    k = LOWER['k']
    c = max(k * np.sqrt((MS + MU) / KT), Q * (MS + MU) / (2.0 * travel_limit**2))
    assert res.design['k'] == pytest.approx(k, rel=1e-7)
    assert res.design['c'] == pytest.approx(c, rel=1e-6)
    active = travel_limit == 0.012
    assert res.rms['travel'] == pytest.approx(travel_limit, rel=1e-6) if active else True
    assert (res.constraint_multipliers['travel'] > 1e-3) == active
    assert res.pade.order == 0


def closed_form_gradients(k: float, c: float) -> np.ndarray:
    """d Var / d(k, c) of the closed forms (rows: acc, travel, tyre), by central
    differences of the closed forms (no model code)."""
    out = []
    for i, h in enumerate((1e-4 * k, 1e-4 * c)):
        e = np.array([h, 0.0]) if i == 0 else np.array([0.0, h])
        out.append(
            (closed_forms(k + e[0], c + e[1], Q) - closed_forms(k - e[0], c - e[1], Q)) / (2 * h)
        )
    return np.array(out).T


@pytest.mark.parametrize('measure', ['variance', 'rms'])
def test_optimum_satisfies_kkt_and_agrees_with_scipy_on_the_closed_forms(measure):
    """Weighted RMS or variances of acceleration and tyre load, travel limited: the KKT
    conditions hold with the returned multipliers (gradients of the closed forms), and
    SciPy's SLSQP on the closed forms finds the same design."""
    weights = {'acc': 1.0, 'tyre': 0.5}
    start = {'k': 25000.0, 'c': 2500.0}
    res = optimize_spectral(
        quarter_car(),
        ROAD,
        start,
        objective=weights,
        lower=LOWER,
        upper=UPPER,
        rms_limits={'travel': 0.011},
        measure=measure,
    )
    assert res.success, res.status_message
    power = 1.0 if measure == 'variance' else 0.5
    v0 = closed_forms(start['k'], start['c'], Q) ** power
    w = np.array([weights['acc'] / v0[0], 0.0, weights['tyre'] / v0[2]])

    def f(x):
        return w @ closed_forms(x[0], x[1], Q) ** power

    def g(x):  # >= 0 for SciPy
        return 1.0 - closed_forms(x[0], x[1], Q)[1] / 0.011**2

    ref = minimize(
        f,
        [start['k'], start['c']],
        method='SLSQP',
        bounds=[(LOWER['k'], UPPER['k']), (LOWER['c'], UPPER['c'])],
        constraints=[{'type': 'ineq', 'fun': g}],
        options={'ftol': 1e-14, 'maxiter': 500},
    )
    assert ref.success
    x = np.array([res.design['k'], res.design['c']])
    np.testing.assert_allclose(x, ref.x, rtol=1e-5)
    assert res.objective == pytest.approx(f(x), rel=1e-10)
    # stationarity: ∇f + λ ∇g + z = 0 (z: bound multipliers, z_U - z_L)
    var = closed_forms(*x, Q)
    G = closed_form_gradients(*x)  # d Var / dp
    grad_f = (w * power * var ** (power - 1.0)) @ G
    lam = res.constraint_multipliers['travel']
    z = np.array([res.bound_multipliers['k'], res.bound_multipliers['c']])
    stationarity = grad_f + lam * G[1] / 0.011**2 + z
    assert np.max(np.abs(stationarity * x)) < 1e-6 * np.max(np.abs(grad_f * x))
    assert lam > 0.0 and res.rms['travel'] == pytest.approx(0.011, rel=1e-7)


def test_half_car_optimization():
    """Four design variables, delayed rear wheel: converges with the Padé order chosen
    automatically; both Hessians reach the same optimum; the travel limit holds."""
    system = half_car()
    start = dict(zip(system.design, HALF_CAR_DESIGN))
    kwargs = dict(
        objective={'heave_acc': 1.0, 'pitch_acc': 1.0, 'tyre_0': 0.3, 'tyre_1': 0.3},
        lower={'k1': 10000.0, 'k2': 10000.0, 'c1': 500.0, 'c2': 500.0},
        upper={'k1': 80000.0, 'k2': 80000.0, 'c1': 8000.0, 'c2': 8000.0},
        rms_limits={'travel_0': 0.01, 'travel_1': 0.01},
    )
    exact = optimize_spectral(system, ROAD, start, **kwargs)
    lbfgs = optimize_spectral(system, ROAD, start, hessian='limited-memory', **kwargs)
    assert exact.success and lbfgs.success
    assert exact.pade.order > 0 and exact.pade.error <= 1e-4
    for name in system.design:
        assert exact.design[name] == pytest.approx(lbfgs.design[name], rel=1e-5)
    # the start exceeds the travel limit; at the optimum both limits are active
    assert exact.rms_initial['travel_0'] > 0.01
    for limit in ('travel_0', 'travel_1'):
        assert exact.rms[limit] == pytest.approx(0.01, rel=1e-6)
        assert exact.constraint_multipliers[limit] > 0.0


def test_bad_input_names_the_key():
    system = quarter_car()
    base = dict(objective={'acc': 1.0}, lower=LOWER, upper=UPPER)
    with pytest.raises(ConfigError, match='objective.accel'):
        optimize_spectral(
            system, ROAD, {'k': 2e4, 'c': 1e3}, **{**base, 'objective': {'accel': 1.0}}
        )
    with pytest.raises(ConfigError, match='start.c'):
        optimize_spectral(system, ROAD, {'k': 2e4, 'c': 9e3}, **base)
    with pytest.raises(ConfigError, match='rms_limits.travel'):
        optimize_spectral(system, ROAD, {'k': 2e4, 'c': 1e3}, rms_limits={'travel': -1.0}, **base)
    with pytest.raises(ConfigError, match='upper.q'):
        optimize_spectral(system, ROAD, {'k': 2e4, 'c': 1e3}, **{**base, 'upper': {'q': 1.0}})


def test_pade_order_is_raised_when_the_optimum_needs_it():
    """At 8 m/s the start needs 16 Padé states for 1e-4 but the (lightly damped) optimum
    24: the order is checked again at the optimum and the problem re-solved; the RMS
    reported are within 1e-4 of the spectral integral with the delay exact."""
    from suspopt.spectral import StationaryModel, choose_pade_order, spectral_variances

    system = half_car()
    road = RandomRoad('C', 8.0)
    res = optimize_spectral(
        system,
        road,
        dict(zip(system.design, HALF_CAR_DESIGN)),
        objective={'heave_acc': 1.0, 'pitch_acc': 1.0},
        lower={'k1': 1e4, 'k2': 1e4, 'c1': 300.0, 'c2': 300.0},
        upper={'k1': 8e4, 'k2': 8e4, 'c1': 8000.0, 'c2': 8000.0},
        rms_limits={'travel_0': 0.015, 'travel_1': 0.015},
    )
    assert res.success
    first = choose_pade_order(system, road, HALF_CAR_DESIGN, rtol=1e-4)
    assert res.pade.order > first.order and res.pade.error <= 1e-4
    p = np.array([res.design[k] for k in system.design])
    ref = np.sqrt(spectral_variances(system, road, p))
    rms = np.array([res.rms[k] for k in system.outputs])
    np.testing.assert_allclose(rms, ref, rtol=1e-4)
    np.testing.assert_allclose(rms, StationaryModel(system, road, res.pade.order).rms(p))
