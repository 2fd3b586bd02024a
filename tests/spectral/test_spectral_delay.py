"""The wheelbase delay: Padé realizations, and the half car's Lyapunov variances with a
Padé delay against the spectral integral with the delay exact."""

from __future__ import annotations

import numpy as np
import pytest
from spectral_vehicles import HALF_CAR_DESIGN, half_car

from suspopt.spectral import RandomRoad, StationaryModel
from suspopt.spectral.accuracy import choose_pade_order, rms_error
from suspopt.spectral.integral import spectral_variances
from suspopt.spectral.shaping import lag_map, pade_coefficients, pade_delay


@pytest.mark.parametrize('order', [1, 2, 5, 8, 12, 16, 24, 48])
def test_pade_realization_is_the_pade_approximant(order):
    """Each section's transfer function is Q(-sτ)/Q(sτ) (evaluated from the
    coefficients), the cascade their product; all-pass; P(0) = 1."""
    tau = 0.3
    w = np.linspace(0.01, 3.0 * order / tau, 400)
    d = pade_delay(tau, order)
    assert d.order == order
    m = -(-order // 16)
    P = np.ones(w.size, dtype=complex)
    for k in [order // m + (1 if i < order % m else 0) for i in range(m)]:
        c = pade_coefficients(k)
        x = 1j * w * tau / m
        P *= np.polynomial.polynomial.polyval(-x, c) / np.polynomial.polynomial.polyval(x, c)
    np.testing.assert_allclose(d.response(1j * w), P, atol=1e-8)
    np.testing.assert_allclose(np.abs(d.response(1j * w)), 1.0, atol=1e-8)
    assert d.response(np.array([0.0]))[0] == pytest.approx(1.0, abs=1e-12)
    assert np.all(np.linalg.eigvals(d.A).real < 0.0)


def test_pade_phase_converges_to_the_delay():
    tau = 0.2
    w = np.linspace(0.0, 40.0, 200)  # ωτ up to 8
    err = [
        np.max(np.abs(pade_delay(tau, n).response(1j * w) - np.exp(-1j * w * tau)))
        for n in (4, 8, 16)
    ]
    assert err[0] > err[1] > err[2] and err[2] < 1e-6


def test_lag_map_gives_the_height_lag():
    """L (sI - A)⁻¹ B = (P(s) - 1)/s."""
    d = pade_delay(0.25, 10)
    L = lag_map(d)
    s = 1j * np.linspace(0.1, 60.0, 50)
    lag = np.array([L @ np.linalg.solve(si * np.eye(d.order) - d.A, d.B) for si in s])
    np.testing.assert_allclose(lag, (d.response(s) - 1.0) / s, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize('speed', [12.0, 25.0])
def test_half_car_lyapunov_with_pade_matches_the_spectral_integral(speed):
    """The order chosen by self-convergence to 1e-4 gives every RMS within 2e-4 of the
    spectral integral with the delay exact; a low order does not (the delay matters)."""
    system, p = half_car(), HALF_CAR_DESIGN
    road = RandomRoad('C', speed)
    ref = np.sqrt(spectral_variances(system, road, p, rtol=1e-9))
    choice = choose_pade_order(system, road, p, rtol=1e-4)
    rms = StationaryModel(system, road, choice.order).rms(p)
    assert rms_error(rms, ref) < 2e-4
    low = StationaryModel(system, road, 2).rms(p)
    assert rms_error(low, ref) > 1e-2


def test_spectral_check_chooses_the_order_against_the_integral():
    system, p = half_car(), HALF_CAR_DESIGN
    road = RandomRoad('B', 20.0)
    choice = choose_pade_order(system, road, p, rtol=1e-5, check='spectral')
    assert choice.error <= 1e-5
    assert all(e > 1e-5 for k, e in choice.errors.items() if k < choice.order)


def test_no_delay_needs_no_pade_states():
    from spectral_vehicles import quarter_car

    choice = choose_pade_order(quarter_car(), RandomRoad(), np.array([2e4, 1.5e3]))
    assert choice.order == 0
    assert StationaryModel(quarter_car(), RandomRoad(), 0).n_states == 4
