"""The design-only metrics (roll gradient, roll stiffness share, ride frequencies): their
components' partials and sparsity, and closed forms that share no code with them."""

from __future__ import annotations

import math

import numpy as np
import openmdao.api as om
import pytest
from openmdao.utils.assert_utils import assert_check_partials

from suspopt.driver.structure import declared_subjacs
from suspopt.models.design_metrics import (
    SMOOTHING,
    AxleRollStiffnessComp,
    DecayRateComp,
    RideFrequencyComp,
    RideRateComp,
    RollGradientComp,
    RollStiffnessShareComp,
    WheelRateComp,
    axle_roll_stiffness,
    decay_rate,
    ride_modes,
    roll_gradient,
    roll_moment_arm,
)

Y = np.array([0.75, -0.75, 0.74, -0.74])
A = np.array([1.37, 1.37, -1.39, -1.39])
K_T = np.array([310e3, 310e3, 358e3, 358e3])
AXLE = np.array([0, 0, 1, 1])
RNG = np.random.default_rng(7)


def _problem(comp: om.ExplicitComponent, values: dict[str, np.ndarray]) -> om.Problem:
    p = om.Problem(reports=False)
    p.model.add_subsystem('c', comp)
    p.setup(force_alloc_complex=True)
    for name, value in values.items():
        p.set_val(f'c.{name}', value)
    p.run_model()
    return p


def _active_quarter_car():
    """An active quarter car under linear feedback (the default quarter car's masses and
    tyre), its state matrix affine in the design."""
    from suspopt.models.linear import affine_linearize
    from suspopt.spec import config_from_dict
    from suspopt.transcription.vehicle import vehicle_assembly

    cfg = config_from_dict(
        {
            'vehicle': {'model': 'quarter_car'},
            'control': {'kind': 'active', 'law': 'feedback'},
            'maneuver': {'speed': 10.0, 'horizon': 1.0},
            'road': {'profile': 'bump', 'start': 2.0, 'length': 2.0, 'height': 0.04},
        }
    )
    names = cfg.design_names()
    lin = affine_linearize(vehicle_assembly(cfg, cfg.scenarios()[0], 'low'), (), names)
    return cfg, names, lin


def _decay_case():
    cfg, names, lin = _active_quarter_car()
    units = ('N/m', 'N*s/m', 'N*s/m', 'N*s/m', 'N/m', 'N*s/m')
    values = dict(zip(names, (2.4e4, 1400.0, 2500.0, 3000.0, -8000.0, -1500.0)))
    return (
        lambda: DecayRateComp(design=names, units=units, A0=lin.base.A, dA=lin.dA),
        {n: np.array([x]) for n, x in values.items()},
    )


CASES = {
    'closed-loop decay rate': _decay_case(),
    'wheel rate': (
        lambda: WheelRateComp(slope=np.array([0.94, 0.94, 0.30, 0.30]), offset=np.full(4, 50.0)),
        {'k_S': RNG.uniform(1e4, 6e4, 4)},
    ),
    'ride rate': (lambda: RideRateComp(k_T=K_T), {'k_W': RNG.uniform(1e4, 6e4, 4)}),
    'axle roll stiffness': (
        lambda: AxleRollStiffnessComp(y=Y, k_T=K_T, axle=AXLE, bar_axle=np.array([0, 1])),
        {'k_W': RNG.uniform(1e4, 6e4, 4), 'k_R': RNG.uniform(1e3, 1e5, 2)},
    ),
    'axle roll stiffness, rear bar only': (
        lambda: AxleRollStiffnessComp(y=Y, k_T=K_T, axle=AXLE, bar_axle=np.array([1])),
        {'k_W': RNG.uniform(1e4, 6e4, 4), 'k_R': RNG.uniform(1e3, 1e5, 1)},
    ),
    'roll gradient': (
        lambda: RollGradientComp(sprung_mass=1442.1, arm=0.48),
        {'K_roll': RNG.uniform(4e4, 9e4, 2)},
    ),
    'roll stiffness share': (
        lambda: RollStiffnessShareComp(),
        {'K_roll': RNG.uniform(4e4, 9e4, 2)},
    ),
    'ride frequency, full car': (
        lambda: RideFrequencyComp(a=A, sprung_mass=1442.1, pitch_inertia=2487.0),
        {'k_ride': RNG.uniform(1e4, 4e4, 4)},
    ),
    'ride frequency, quarter car': (
        lambda: RideFrequencyComp(a=np.zeros(1), sprung_mass=325.0, pitch=False),
        {'k_ride': RNG.uniform(1e4, 4e4, 1)},
    ),
}


@pytest.mark.parametrize('case', CASES)
def test_partials(case):
    make, values = CASES[case]
    p = _problem(make(), values)
    data = p.check_partials(method='fd', form='central', step=1e-3, out_stream=None)
    assert_check_partials(data, atol=1e-6, rtol=1e-5)


@pytest.mark.parametrize('case', CASES)
def test_declared_sparsity_is_the_true_sparsity(case):
    """The declared pattern against the nonzeros of a full finite-difference Jacobian of
    ``compute`` over every (output, input) pair (``check_partials`` masks its Jacobian to
    the declared pattern, so it cannot see a missing nonzero)."""
    make, values = CASES[case]
    p = _problem(make(), values)
    comp = p.model.c
    declared = {(sj.of.split('.')[-1], sj.wrt.split('.')[-1]): sj for sj in declared_subjacs(comp)}
    ins = {k: np.array(v, dtype=float) for k, v in values.items()}
    outs = {k: np.array(p.get_val(f'c.{k}')) for k in _outputs(comp)}

    def run(x):
        o = {k: np.zeros_like(v) for k, v in outs.items()}
        comp.compute(x, o)
        return o

    base = run(ins)
    for wrt, x in ins.items():
        cols = []
        for j in range(x.size):
            xp = {k: v.copy() for k, v in ins.items()}
            xp[wrt][j] += 1e-4 * abs(x[j])
            cols.append({k: run(xp)[k] - base[k] for k in outs})
        for of in outs:
            true = np.stack([c[of].ravel() for c in cols], axis=1) != 0.0
            decl = np.zeros_like(true)
            if (of, wrt) in declared:
                decl[declared[of, wrt].rows, declared[of, wrt].cols] = True
            assert np.array_equal(true, decl), (of, wrt, true, decl)


def _outputs(comp: om.ExplicitComponent) -> list[str]:
    return list(comp.list_outputs(out_stream=None, prom_name=False, return_format='dict'))


# ---------------------------------------------------------------------------- closed forms
def _roll_plane_gradient(k_W, k_R, k_T, y, axle, bar_axle, mass, arm):
    """An independent roll-plane statics: the body rolls by φ and each axle by φ_u under
    one g of lateral acceleration; wheel by wheel, the spring deflects by ``y (φ - φ_u)``,
    the tyre by ``y φ_u``, the bar twists by ``φ - φ_u``; the body's moments balance the
    lateral force ``W h'`` and gravity's ``W h' φ``, each axle's the spring's and the
    tyre's moments. One linear solve for (φ, φ_u1, φ_u2); returns φ in degrees."""
    W = mass * 9.80665
    n = 3
    A, b = np.zeros((n, n)), np.zeros(n)
    for c in range(len(y)):
        i = 1 + axle[c]
        spring = k_W[c] * y[c] ** 2  # moment per unit relative roll of this wheel's spring
        A[0, 0] += spring
        A[0, i] -= spring
        A[i, i] += spring + k_T[c] * y[c] ** 2
        A[i, 0] -= spring
    for r, ax in zip(k_R, bar_axle):
        i = 1 + ax
        A[0, 0] += r
        A[0, i] -= r
        A[i, i] += r
        A[i, 0] -= r
    A[0, 0] -= W * arm
    b[0] = W * arm
    return math.degrees(np.linalg.solve(A, b)[0])


def test_roll_gradient_matches_the_roll_plane_statics():
    k_W, k_R = np.array([29770.0, 25000.0, 37130.0, 40000.0]), np.array([75745.0, 4030.0])
    K = axle_roll_stiffness(k_W, k_R, K_T, Y, AXLE, [0, 1])
    got = roll_gradient(K, 1442.1, 0.48)
    want = _roll_plane_gradient(k_W, k_R, K_T, Y, AXLE, [0, 1], 1442.1, 0.48)
    assert got == pytest.approx(want, rel=1e-12)


def test_default_full_car_rolls_as_chronos_bmw_was_fit_to():
    """Chrono's BMW E90 (``BMW_E90_Vehicle.cpp``) was fit to SAE 2007-01-0817's test:
    2.0 deg of roll at 0.6 g, 3.33 deg/g; the default car at its initial design (the
    BMW's springs and bars, its CG height and its linkages' roll centres) rolls as much."""
    from suspopt.spec.load import full_car_defaults
    from suspopt.transcription.constraints import roll_arm

    cfg = full_car_defaults()
    v, lay, d = cfg.vehicle, cfg.layout(), cfg.design.initial()
    k_W = np.array([d[f'k_S{c.axle + 1}'] for c in lay.corners])
    k_T = np.array([v.axles[c.axle].tyre_stiffness for c in lay.corners])
    phi = _roll_plane_gradient(
        k_W, [d['k_R1'], d['k_R2']], k_T, lay.y, [c.axle for c in lay.corners], [0, 1],
        v.chassis_mass, roll_arm(cfg),
    )  # fmt: skip
    assert phi == pytest.approx(2.0 / 0.6, rel=0.02)


def test_roll_moment_arm_interpolates_the_roll_axis_at_the_cg():
    # CG 1 m behind the front axle of a 3 m wheelbase: a third of the way to the rear
    assert roll_moment_arm(0.5, 0.03, 0.09, 1.0, -2.0) == pytest.approx(0.5 - 0.05)


def _gillespie(K_f, K_r, b, c, M, I):
    """Gillespie, Fundamentals of Vehicle Dynamics, ch. 5: the pitch-plane frequencies of
    a sprung mass on front and rear ride rates, CG b behind the front and c ahead of the
    rear axle, radius of gyration k = sqrt(I/M)."""
    k2 = I / M
    alpha = (K_f + K_r) / M
    beta = (K_r * c - K_f * b) / M
    gamma = (K_f * b**2 + K_r * c**2) / (M * k2)
    root = math.sqrt((alpha - gamma) ** 2 / 4 + beta**2 / k2)
    return [
        math.sqrt(w2) / (2 * math.pi)
        for w2 in ((alpha + gamma) / 2 - root, (alpha + gamma) / 2 + root)
    ]


@pytest.mark.parametrize('inertia', [800.0, 2487.0, 6000.0])
def test_ride_frequencies_are_the_two_axle_closed_form(inertia):
    k = np.array([21000.0, 26000.0])
    f = ride_modes(k, np.array([1.271, -1.713]), 1414.0, inertia, True)[0]
    assert sorted(f) == pytest.approx(
        _gillespie(21000.0, 26000.0, 1.271, 1.713, 1414.0, inertia), rel=1e-12
    )


@pytest.mark.parametrize('inertia', [1000.0, 5000.0])
def test_modes_are_named_by_their_motion_not_their_order(inertia):
    """Axles with equal K a (no heave-pitch coupling): pure heave at sqrt(ΣK/M), pure
    pitch at sqrt(ΣK a²/I), whichever is lower."""
    a, k = np.array([1.5, -1.0]), np.array([20000.0, 30000.0])
    f_heave, f_pitch = ride_modes(k, a, 1400.0, inertia, True)[0]
    assert f_heave == pytest.approx(math.sqrt(50000.0 / 1400.0) / (2 * math.pi), rel=1e-12)
    assert f_pitch == pytest.approx(math.sqrt(k @ a**2 / inertia) / (2 * math.pi), rel=1e-12)


def test_quarter_car_heave_frequency():
    f = ride_modes(np.array([18000.0]), np.zeros(1), 325.0, 0.0, False)[0]
    assert f == pytest.approx([math.sqrt(18000.0 / 325.0) / (2 * math.pi)], rel=1e-14)


def test_decay_rate_is_the_quarter_cars_characteristic_polynomial():
    """The quarter car under ``u = -g_sky v_M + g_gnd v_W + g_tr s + g_rt (v_W - v_M)``:
    with ``k = k_S + g_tr``, ``a = c_S + g_rt + g_sky``, ``b = c_S + g_rt + g_gnd``, its
    characteristic polynomial is ``m M s⁴ + (m b + M a) s³ + (m (k + k_T) + M k) s² +
    a k_T s + k k_T`` (M sprung, m unsprung; derived by hand, sharing no code with the
    assembly): the decay rate is the smoothed minimum of minus its roots' real parts,
    within ``log(4) / SMOOTHING`` below the slowest, over stable and unstable designs —
    the benchmark's feedback optimum without the constraint among them (a negative spring
    and damper: unstable)."""
    cfg, names, lin = _active_quarter_car()
    v = cfg.vehicle
    M, m, k_T = v.chassis_mass, v.front.wheel_mass, v.front.tyre_stiffness
    rng = np.random.default_rng(3)
    designs = [
        rng.uniform([1e4, 500, 0, 0, -5e4, -5e3], [4e4, 3e3, 5e3, 5e3, 2e4, 2e3]) for _ in range(20)
    ]
    designs.append(np.array([176.5, 1700.0, 0.0023, 5004.0, -26430.0, -5000.0]))
    signs = set()
    for p in designs:
        k, c = p[0] + p[4], p[1] + p[5]
        a, b = c + p[2], c + p[3]
        roots = np.roots([M * m, M * b + m * a, M * (k + k_T) + m * k, a * k_T, k * k_T])
        sigma = decay_rate(lin.at(dict(zip(names, p))).A)[0]
        smooth = -np.log(np.sum(np.exp(SMOOTHING * roots.real))) / SMOOTHING
        assert sigma == pytest.approx(smooth, rel=1e-9, abs=1e-9)
        assert -max(roots.real) - np.log(4) / SMOOTHING <= sigma <= -max(roots.real) + 1e-9
        signs.add(sigma > 0)
    assert signs == {True, False}
    assert sigma < -10.0  # the benchmark's unconstrained feedback optimum diverges
