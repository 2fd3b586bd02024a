"""Design derivatives of the stationary variances by the adjoint Lyapunov equation,
against the closed forms' derivatives and central finite differences; the complex-step
Hessian against differences of the gradient."""

from __future__ import annotations

import numpy as np
import pytest
from spectral_vehicles import (
    FULL_CAR_DESIGN,
    HALF_CAR_DESIGN,
    KT,
    MS,
    MU,
    full_car,
    half_car,
    quarter_car,
)

from suspopt.spectral import RandomRoad, StationaryModel


def central_jacobian(f, p: np.ndarray, rel: float = 1e-4) -> np.ndarray:
    """Central differences of steps ``rel·|p_i|`` (the variances are accurate to ~1e-12
    relative: truncation and rounding balance near 1e-4)."""
    cols = []
    for i in range(p.size):
        h = rel * abs(p[i])
        e = np.zeros(p.size)
        e[i] = h
        cols.append((f(p + e) - f(p - e)) / (2.0 * h))
    return np.array(cols).T


def test_quarter_car_gradients_are_the_closed_forms_derivatives():
    """d/dk and d/dc of (q/2)(k_t c/m_s² + k²(m_s+m_u)/(c m_s²)), (q/2)(m_s+m_u)/c and
    the tyre-load form, differentiated by hand."""
    road = RandomRoad('C', 20.0)
    q = road.velocity_intensity()
    k, c = 22000.0, 1300.0
    m = MS + MU
    expected = (q / 2.0) * np.array(
        [
            [2 * k * m / (c * MS**2), KT / MS**2 - k**2 * m / (c**2 * MS**2)],
            [0.0, -m / c**2],
            [
                2 * k * m**3 / (c * MS**2) - 2 * KT * MU * m / (c * MS),
                KT * m**2 / MS**2
                - (k**2 * m**3 / MS**2 - 2 * k * KT * MU * m / MS + KT**2 * MU) / c**2,
            ],
        ]
    )
    J = StationaryModel(quarter_car(), road).variance_jacobian(np.array([k, c]))
    np.testing.assert_allclose(J, expected, rtol=1e-9, atol=1e-14 * np.abs(expected).max())


def test_half_car_jacobian_with_delay_matches_finite_differences():
    """Every output's adjoint gradient against central differences and against the
    complex-step derivative of the variances (forward, no adjoint)."""
    model = StationaryModel(half_car(), RandomRoad('C', 20.0), 12)
    p = HALF_CAR_DESIGN
    J = model.variance_jacobian(p)
    scale = np.abs(J).max(axis=1, keepdims=True)
    fd = central_jacobian(lambda x: model.variances(x).copy(), p)
    np.testing.assert_allclose(J / scale, fd / scale, atol=1e-6)
    cs = np.array(
        [model.variances(p + 1e-30j * p[i] * np.eye(4)[i]).imag / (1e-30 * p[i]) for i in range(4)]
    ).T
    np.testing.assert_allclose(J / scale, cs / scale, atol=1e-9)


@pytest.mark.parametrize('tracks', ['independent', 'isotropic'])
def test_full_car_weighted_gradient_matches_finite_differences(tracks):
    system = full_car()
    model = StationaryModel(system, RandomRoad('D', 15.0, tracks, 1.5), 8)
    p = FULL_CAR_DESIGN
    var = model.variances(p)
    w = np.random.default_rng(3).uniform(0.5, 2.0, var.size) / var  # normalized terms
    g = model.gradient(p, w)
    fd = central_jacobian(lambda x: np.array([w @ model.variances(x)]), p)[0]
    np.testing.assert_allclose(g * p, fd * p, rtol=1e-5, atol=1e-6 * np.abs(g * p).max())


def test_gradient_with_design_dependent_static_response():
    """Front and rear tracks of different width on independent tracks: one track's rise
    warps the car, so the static response K = A⁻¹ B E depends on the springs and bars
    (dK ≠ 0; a rigid motion, dK = 0, with equal tracks or a single reference). The warp
    grows with the tracks' random-walk difference: travel and tyre loads have no
    stationary variance there, the accelerations do."""
    from spectral_vehicles import rigid_body_car

    full = rigid_body_car(
        mass=1400.0,
        pitch_inertia=2400.0,
        roll_inertia=550.0,
        a=[1.35, 1.35, -1.4, -1.4],
        y=[0.75, -0.75, 0.68, -0.68],
        m=[45.0, 45.0, 50.0, 50.0],
        kt=[2.5e5] * 4,
        springs={'k1': [0, 1], 'k2': [2, 3]},
        dampers={'c1': [0, 1], 'c2': [2, 3]},
        bars={'kR1': (0, 1), 'kR2': (2, 3)},
        tracks=[0, 1, 0, 1],
    )
    p = FULL_CAR_DESIGN
    road = RandomRoad('C', 20.0, 'independent')
    infinite = StationaryModel(full, road, 8).infinite_outputs(p)
    assert len(infinite) == 8 and all(('travel' in x or 'tyre' in x) for x in infinite)
    system = full.select_outputs(['heave_acc', 'pitch_acc', 'roll_acc'])
    model = StationaryModel(system, road, 8)

    def K(x):
        A, B, _, _ = system.matrices(x)
        return np.linalg.solve(A, B @ model.road_model.E)

    assert np.abs(K(1.1 * p) - K(p)).max() > 1e-5 * np.abs(K(p)).max()
    w = 1.0 / model.variances(p)
    g = model.gradient(p, w)
    fd = central_jacobian(lambda x: np.array([w @ model.variances(x)]), p)[0]
    np.testing.assert_allclose(g * p, fd * p, rtol=1e-5, atol=1e-6 * np.abs(g * p).max())


def test_matrix_gradients_for_any_parametrization():
    """⟨dA, Ā⟩ + ⟨dB, B̄⟩ + ⟨dC, C̄⟩ + ⟨dD, D̄⟩ is the change of J under a perturbation
    of the matrices outside the affine terms (here a change of the wheel masses)."""
    from spectral_vehicles import rigid_body_car

    def car(m_front: float):
        return rigid_body_car(
            mass=1200.0,
            pitch_inertia=1800.0,
            a=[1.2, -1.5],
            y=[0.0, 0.0],
            m=[m_front, 45.0],
            kt=[2e5, 2e5],
            springs={'k1': [0], 'k2': [1]},
            dampers={'c1': [0], 'c2': [1]},
        )

    road, p = RandomRoad('C', 20.0), HALF_CAR_DESIGN
    model = StationaryModel(car(40.0), road, 12)
    w = 1.0 / model.variances(p)
    bars = model.matrix_gradients(p, w)
    h = 1e-4
    plus, minus = car(40.0 + h), car(40.0 - h)
    dJ = sum(
        np.sum((mp - mm) / (2 * h) * bar)
        for mp, mm, bar in zip(plus.matrices(p), minus.matrices(p), bars)
    )

    def J(s):
        return w @ StationaryModel(s, road, 12).variances(p)

    assert dJ == pytest.approx((J(plus) - J(minus)) / (2 * h), rel=1e-6)


def test_complex_step_hessian_matches_differences_of_the_gradient():
    model = StationaryModel(half_car(), RandomRoad('C', 20.0), 8)
    p = HALF_CAR_DESIGN
    w = 1.0 / model.variances(p)
    H = np.array(
        [
            model.gradient(p + 1e-30j * p[j] * np.eye(4)[j], w).imag / (1e-30 * p[j])
            for j in range(4)
        ]
    ).T
    fd = central_jacobian(lambda x: model.gradient(x, w), p, rel=1e-4)
    np.testing.assert_allclose(H, fd, rtol=1e-5, atol=1e-7 * np.abs(H).max())
    np.testing.assert_allclose(H, H.T, rtol=1e-8, atol=1e-12 * np.abs(H).max())
