"""The curve objects of suspopt.curves: exact reduction to the linear spring and
damper, C¹ continuity at the knees, at zero and at stop contact (one-sided differences),
parameter derivatives against central differences, PCHIP against SciPy's, the static
deflection, and every bad input with its key in the message."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import PchipInterpolator

from suspopt.curves import (
    BumpStop,
    DamperCurve,
    DamperTable,
    LinearDamper,
    ReboundStop,
    SpringCurve,
    SpringDamperUnit,
    SpringTable,
    smoothstep,
    smoothstep_integral,
    static_deflection,
)
from suspopt.errors import ConfigError
from suspopt.models import equations as eq

#: a digressive, asymmetric damper (rebound about 2.3x bump at the same speed)
DAMPER = DamperCurve(
    c_bump_low=3000.0,
    v_bump_knee=0.08,
    c_bump_high=1200.0,
    c_rebound_low=7000.0,
    v_rebound_knee=0.12,
    c_rebound_high=2800.0,
)
DAMPER_TABLE = DamperTable(
    velocities=(-1.0, -0.3, -0.1, 0.0, 0.05, 0.1, 0.3, 1.0),
    forces=(-4200.0, -2100.0, -800.0, 0.0, 160.0, 260.0, 520.0, 1300.0),
)
SPRING = SpringCurve((30000.0, 1.5e5, 4.0e6))
SPRING_TABLE = SpringTable(
    deflections=(-0.1, -0.04, 0.0, 0.03, 0.07, 0.1),
    forces=(-2600.0, -1150.0, 0.0, 950.0, 2600.0, 4800.0),
)
BUMP = BumpStop(gap=0.05, coefficients=(2.0e6, 3.0e8))
REBOUND = ReboundStop(gap=0.07, coefficients=(5.0e6,))
CURVES = {
    'damper': DAMPER,
    'damper_table': DAMPER_TABLE,
    'spring': SPRING,
    'spring_table': SPRING_TABLE,
    'bump_stop': BUMP,
    'rebound_stop': REBOUND,
    'linear_damper': LinearDamper(2500.0),
}
#: arguments covering every region of each curve (blends, knees, stops, extrapolation)
ARGS = {
    'damper': np.concatenate([np.linspace(-0.6, 0.6, 61), [-0.013, 0.004, 0.075, 0.1, -0.15]]),
    'damper_table': np.linspace(-1.3, 1.3, 53) + 0.0013,
    'spring': np.linspace(-0.12, 0.12, 25),
    'spring_table': np.linspace(-0.13, 0.13, 27) + 0.0011,
    'bump_stop': np.linspace(-0.1, 0.12, 23) + 0.0007,
    'rebound_stop': np.linspace(-0.12, 0.1, 23) + 0.0007,
    'linear_damper': np.linspace(-1.0, 1.0, 9),
}


# ---------------------------------------------------------------- exact reduction
def test_damper_curve_reduces_exactly_to_the_linear_damper():
    v = np.random.default_rng(0).normal(scale=0.5, size=200)
    for c in (0.0, 1234.5678, 3000.0):
        lin = DamperCurve.linear(c, knee=0.07)
        np.testing.assert_array_equal(lin.value(v), c * v)
        np.testing.assert_array_equal(lin.derivative(v), np.full_like(v, c))
        np.testing.assert_array_equal(LinearDamper(c).value(v), c * v)


def test_spring_curve_and_unit_reduce_exactly_to_eq_9():
    rng = np.random.default_rng(1)
    z_W, z_M, v_W, v_M = rng.normal(scale=0.05, size=(4, 30, 2))
    k, c = np.array([31000.0, 27000.0]), np.array([2900.0, 3300.0])
    np.testing.assert_array_equal(SpringCurve((k[0],)).value(z_W - z_M), k[0] * (z_W - z_M))
    np.testing.assert_array_equal(SpringCurve((k[0], 0.0, 0.0)).value(z_W), k[0] * z_W)
    unit = SpringDamperUnit.linear(1.0, 1.0)
    f = unit.force(z_W - z_M, v_W - v_M, {'k_S': k, 'c_S': c})
    np.testing.assert_array_equal(f.value, eq.suspension_force(k, c, z_W, v_W, z_M, v_M))
    np.testing.assert_array_equal(f.d_x, np.broadcast_to(k, f.d_x.shape))
    np.testing.assert_array_equal(f.d_v, np.broadcast_to(c, f.d_v.shape))
    # equal slopes on both sides of a DamperCurve and stops that never engage: still k x + c v
    full = SpringDamperUnit(
        SpringCurve((k[0],)),
        DamperCurve.linear(c[0]),
        BumpStop(0.5, (1e8,)),
        ReboundStop(0.5, (1e8,)),
    )
    ref = eq.suspension_force(k[0], c[0], z_W, v_W, z_M, v_M)
    np.testing.assert_array_equal(full.force(z_W - z_M, v_W - v_M).value, ref)


def test_every_curve_passes_through_zero():
    for name, curve in CURVES.items():
        assert curve.value(0.0) == 0.0, name


# ---------------------------------------------------------------- smoothness
def one_sided(curve, x0: float, h: float) -> tuple[float, float]:
    """Left and right difference quotients of the curve at ``x0``."""
    f0 = float(curve.value(x0))
    return (f0 - float(curve.value(x0 - h))) / h, (float(curve.value(x0 + h)) - f0) / h


def kinks(name: str) -> list[float]:
    """The points where a piecewise definition switches: blend ends, knees, nodes, contact."""
    if name == 'damper':
        d, r = DAMPER, DAMPER.knee_width
        return [
            0.0,
            d.v_zero,
            -d.v_zero,
            d.v_bump_knee,
            (1 - r) * d.v_bump_knee,
            (1 + r) * d.v_bump_knee,
            -d.v_rebound_knee,
            -(1 - r) * d.v_rebound_knee,
            -(1 + r) * d.v_rebound_knee,
        ]
    if name in ('damper_table', 'spring_table'):
        return list(CURVES[name].nodes)
    if name == 'bump_stop':
        return [BUMP.gap]
    if name == 'rebound_stop':
        return [-REBOUND.gap]
    return [0.0]


def c1_at(curve, x0: float) -> bool:
    """One-sided difference quotients agree with each other and with the slope to O(h),
    and their gap shrinks with h (linearly for a C¹ curve; at a kink it stays at the jump
    of the slope)."""
    scale = max(abs(float(curve.derivative(x0 + s))) for s in (-0.01, 0.0, 0.01)) + 1.0
    gaps = []
    for h in (1e-4, 1e-5):
        left, right = one_sided(curve, x0, h)
        gaps.append(abs(right - left))
        if abs(left - curve.derivative(x0)) > 0.05 * scale * h / 1e-4:
            return False
    return gaps[1] < 0.2 * gaps[0] + 1e-6 * scale


@pytest.mark.parametrize('name', sorted(CURVES))
def test_c1_at_knees_zero_nodes_and_contact(name):
    curve = CURVES[name]
    for x0 in kinks(name):
        assert c1_at(curve, x0), (name, x0)


def test_the_c1_check_sees_a_kink():
    """The check fails for kinked curves: an asymmetric damper without the zero blend and
    a stop whose force rises linearly from contact."""

    class Kinked:
        def __init__(self, f, df):
            self.value, self.derivative = f, df

    damper = Kinked(
        lambda v: np.where(np.asarray(v) > 0, 3000.0, 7000.0) * v,
        lambda v: np.where(np.asarray(v) > 0, 3000.0, 7000.0),
    )
    stop = Kinked(
        lambda x: 1e5 * np.maximum(np.asarray(x) - 0.05, 0.0),
        lambda x: np.where(np.asarray(x) > 0.05, 1e5, 0.0),
    )
    assert not c1_at(damper, 0.0)
    assert not c1_at(stop, 0.05)
    assert c1_at(DAMPER, 0.0) and c1_at(BUMP, 0.05)


def test_damper_slope_is_never_negative_and_follows_the_given_lines():
    rng = np.random.default_rng(2)
    v = np.linspace(-2.0, 2.0, 4001)
    for _ in range(50):
        c = rng.uniform(0.0, 8000.0, 4)
        knees = rng.uniform(0.02, 0.3, 2)
        d = DamperCurve(c[0], knees[0], c[1], c[2], knees[1], c[3]).check('damper')
        assert np.all(d.derivative(v) >= 0.0)
        assert np.all(np.diff(d.value(v)) >= -1e-9)
    # outside the blends each side is affine with its given slope
    d = DAMPER
    offset = -(d.c_bump_low - d.c_rebound_low) * 3 * d.v_zero / 16
    v_low = np.array([0.02, 0.03])  # between the zero blend and the bump knee's blend
    np.testing.assert_allclose(d.value(v_low), d.c_bump_low * v_low + offset, rtol=1e-12)
    np.testing.assert_allclose(d.derivative([0.2, 0.5, -0.2, -0.5]), [1200, 1200, 2800, 2800])
    np.testing.assert_allclose(d.derivative([0.02, -0.02]), [3000, 7000])


def test_smoothstep_integral_is_the_integral():
    u = np.linspace(-1.5, 1.5, 301)
    h = 1e-6
    np.testing.assert_allclose(
        (smoothstep_integral(u + h) - smoothstep_integral(u - h)) / (2 * h),
        smoothstep(u),
        atol=1e-8,
    )
    assert smoothstep_integral(-1.0) == 0.0 and smoothstep_integral(1.0) == 1.0


# ---------------------------------------------------------------- derivatives
@pytest.mark.parametrize('name', sorted(CURVES))
def test_slope_and_parameter_derivatives_against_central_differences(name):
    curve = CURVES[name]
    x = ARGS[name]
    ev = curve.evaluate(x)
    h = 1e-7 * max(1.0, np.max(np.abs(x)))
    fd = (curve.value(x + h) - curve.value(x - h)) / (2 * h)
    scale = np.max(np.abs(ev.slope)) + 1.0
    np.testing.assert_allclose(ev.slope, fd, atol=1e-6 * scale)
    base = curve.parameter_values()
    assert set(ev.partials) == set(base)
    for pname, p0 in base.items():
        p0 = np.asarray(p0, dtype=float)
        for j in np.ndindex(p0.shape):
            step = 1e-6 * max(abs(float(p0[j])), 1.0)
            up, dn = p0.copy(), p0.copy()
            up[j] += step
            dn[j] -= step
            fd = (curve.value(x, {pname: up}) - curve.value(x, {pname: dn})) / (2 * step)
            an = ev.partials[pname][(...,) + j] if p0.ndim else ev.partials[pname]
            tol = 1e-6 * (np.max(np.abs(an)) + np.max(np.abs(fd)) + 1e-3)
            np.testing.assert_allclose(an, fd, atol=tol, err_msg=f'{name}: d/d{pname}{j}')


def test_parameters_broadcast_as_arrays():
    """One call for several corners: parameters (corners,) against x (nodes, corners)."""
    x = np.linspace(-0.4, 0.4, 12).reshape(6, 2)
    params = {'c_bump_low': np.array([3000.0, 2000.0]), 'v_bump_knee': np.array([0.08, 0.1])}
    ev = DAMPER.evaluate(x, params)
    for c in range(2):
        one = DAMPER.replace(
            c_bump_low=params['c_bump_low'][c], v_bump_knee=params['v_bump_knee'][c]
        )
        np.testing.assert_array_equal(ev.value[:, c], one.value(x[:, c]))
    forces = np.array(DAMPER_TABLE.forces)
    ev = DAMPER_TABLE.evaluate(x, {'damper_forces': np.stack([forces, 2 * forces])})
    np.testing.assert_allclose(ev.value[:, 1], 2 * DAMPER_TABLE.value(x[:, 1]), rtol=1e-14)
    assert ev.partials['damper_forces'].shape == (6, 2, forces.size)


# ---------------------------------------------------------------- tables
@pytest.mark.parametrize('name', ['damper_table', 'spring_table'])
def test_tables_are_scipys_pchip(name):
    """Inside the table: SciPy's PchipInterpolator (an independent implementation)."""
    t = CURVES[name]
    x = np.linspace(t.nodes[0], t.nodes[-1], 401)
    ref = PchipInterpolator(t.nodes, t.forces)
    np.testing.assert_allclose(t.value(x), ref(x), rtol=1e-13, atol=1e-9)
    np.testing.assert_allclose(t.derivative(x), ref(x, 1), rtol=1e-12, atol=1e-7)
    # beyond it, the end tangents
    for end, s in ((0, -0.05), (-1, 0.05)):
        x_out = t.nodes[end] + s
        np.testing.assert_allclose(t.value(x_out), t.forces[end] + s * ref(t.nodes[end], 1))


@pytest.mark.parametrize('name', ['spring', 'spring_table', 'bump_stop', 'rebound_stop'])
def test_integrals_are_the_elastic_energy(name):
    curve = CURVES[name]
    x = ARGS[name]
    h = 1e-6
    dE = (curve.integral(x + h) - curve.integral(x - h)) / (2 * h)
    np.testing.assert_allclose(dE, curve.value(x), atol=1e-6 * (np.max(np.abs(curve.value(x))) + 1))
    assert curve.integral(0.0) == 0.0
    assert np.all(curve.integral(x) >= -1e-12)


# ---------------------------------------------------------------- static deflection
def test_static_deflection_and_curves_about_it():
    k = 30000.0
    assert static_deflection(4500.0, SpringCurve((k,))) == pytest.approx(4500.0 / k, rel=1e-14)
    x_s = static_deflection(4500.0, SPRING, preload=300.0)
    assert 300.0 + SPRING.value(x_s) == pytest.approx(4500.0, rel=1e-13)
    about = SPRING.about(x_s)
    x = np.linspace(-0.05, 0.05, 11)
    np.testing.assert_allclose(about.value(x), SPRING.value(x_s + x) - SPRING.value(x_s), atol=1e-9)
    assert about.coefficients[0] == pytest.approx(float(SPRING.derivative(x_s)), rel=1e-12)
    # a load beyond the bump stop's reach within the travel
    with pytest.raises(ConfigError, match=r'^spring\.front: the static load'):
        static_deflection(1e6, SPRING, travel=(-0.1, 0.1), key='spring.front')
    x_b = static_deflection(9000.0, SpringCurve((k,)), BUMP)
    assert k * x_b + BUMP.value(x_b) == pytest.approx(9000.0, rel=1e-12) and x_b > BUMP.gap


# ---------------------------------------------------------------- bad input
BAD = [
    (
        DAMPER.replace(c_bump_low=-3.0),
        None,
        'damper.front.c_bump_low: must be >= 0 (negative damping), got -3',
    ),
    (DAMPER.replace(c_rebound_high=-1.0), None, 'damper.front.c_rebound_high: must be >= 0'),
    (DAMPER.replace(v_bump_knee=0.01), None, 'damper.front.v_bump_knee: must be >= v_zero'),
    (DAMPER.replace(knee_width=1.2), None, 'damper.front.knee_width: must be in (0, 1)'),
    (LinearDamper(-5.0), None, 'damper.front.c: must be >= 0 (negative damping)'),
    (
        DamperTable((-0.1, 0.0, 0.3, 0.2), (-500.0, 0.0, 300.0, 400.0)),
        None,
        'damper.front.velocities: must be strictly increasing, got 0.3 then 0.2',
    ),
    (
        DamperTable((-0.1, 0.0, 0.2, 0.3), (-500.0, 0.0, 300.0, 250.0)),
        None,
        'damper.front.forces: must increase with the velocity (negative damping): 300 N at 0.2',
    ),
    (
        DamperTable((-0.1, 0.0, 0.2), (-500.0, 20.0, 300.0)),
        None,
        'damper.front.forces: the curve must pass through zero force at zero velocity',
    ),
    (
        DamperTable((-0.1, 0.05, 0.2), (-500.0, 0.0, 300.0)),
        None,
        'damper.front.forces: the curve must pass through zero force at zero velocity '
        '(a point (0, 0)); it has no point at 0',
    ),
    (
        SpringTable((-0.1, 0.0, 0.1), (-900.0, 0.0, -100.0)),
        None,
        'damper.front.forces: must increase with the deflection (a negative rate)',
    ),
    (SpringCurve((-100.0,)), None, 'damper.front.coefficients: must be >= 0 (the rate at static)'),
    (
        SpringCurve((30000.0, 3.0e5)),
        (-0.1, 0.1),
        'damper.front.coefficients: the rate dS/dx must be >= 0 over the travel [-0.1, 0.1] m',
    ),
    (
        BumpStop(0.12, (1e6,)),
        (-0.1, 0.1),
        'damper.front.gap: 0.12 m is larger than the bump travel 0.1 m',
    ),
    (
        ReboundStop(0.09, (1e6,)),
        (-0.08, 0.1),
        'damper.front.gap: 0.09 m is larger than the rebound travel 0.08 m',
    ),
    (BumpStop(-0.01, (1e6,)), None, 'damper.front.gap: must be >= 0'),
    (
        BumpStop(0.01, (1e6, -2.0)),
        None,
        'damper.front.coefficients: must be >= 0 (a progressive stop)',
    ),
]


@pytest.mark.parametrize(
    'curve, travel, message', BAD, ids=[m.split(':')[1][:40] for _, _, m in BAD]
)
def test_bad_curves_raise_config_error_naming_the_key(curve, travel, message):
    with pytest.raises(ConfigError) as err:
        curve.check('damper.front', travel)
    lines = str(err.value).splitlines()
    assert any(line.startswith(message) for line in lines), lines
    assert all(line.startswith('damper.front.') for line in lines), lines


def test_valid_curves_pass_their_checks():
    for name, curve in CURVES.items():
        assert curve.problems(name, (-0.1, 0.1)) == [], name
    # a spring with an x² term is fine where its rate stays positive
    assert SpringCurve((30000.0, 1.0e5)).problems('s', (-0.1, 0.1)) == []


def test_unit_from_dict_reads_every_form_and_names_bad_keys():
    data = {
        'spring_curve': {'coefficients': [30000.0, 0.0, 4.0e6]},
        'damper_curve': {
            'c_bump_low': 3000.0,
            'v_bump_knee': 0.1,
            'c_bump_high': 1500.0,
            'c_rebound_low': 7000.0,
            'v_rebound_knee': 0.1,
            'c_rebound_high': 3500.0,
        },
        'bump_stop': {'gap': 0.06, 'coefficients': [0.0, 2.0e8]},
        'rebound_stop': {'gap': 0.08, 'coefficients': [5.0e6]},
    }
    unit = SpringDamperUnit.from_dict(data, 'front', travel=(-0.1, 0.1))
    assert [p.name for p in unit.parameters()] == [
        'k_S', 'k_S2', 'k_S3',
        'c_bump_low', 'v_bump_knee', 'c_bump_high',
        'c_rebound_low', 'v_rebound_knee', 'c_rebound_high',
        'bump_gap', 'bump_k2', 'bump_k3', 'rebound_gap', 'rebound_k2',
    ]  # fmt: skip
    tables = SpringDamperUnit.from_dict(
        {
            'spring_curve': {'deflections': [-0.1, 0.0, 0.1], 'forces': [-3000.0, 0.0, 3500.0]},
            'damper_curve': {'velocities': [-1.0, 0.0, 1.0], 'forces': [-3000.0, 0.0, 1000.0]},
        },
        'rear',
    )
    assert tables.scalar_parameters() == {
        'spring_forces_0': -3000.0, 'spring_forces_1': 0.0, 'spring_forces_2': 3500.0,
        'damper_forces_0': -3000.0, 'damper_forces_1': 0.0, 'damper_forces_2': 1000.0,
    }  # fmt: skip
    linear = SpringDamperUnit.from_dict({}, 'x', stiffness=3e4, damping=3e3)
    assert linear == SpringDamperUnit.linear(3e4, 3e3)
    bad = dict(data, damper_curve={**data['damper_curve'], 'c_bump_hi': 1.0, 'c_bump_low': -2.0})
    bad['bump_stop'] = {'gap': 0.2, 'coefficients': [1e6]}
    with pytest.raises(ConfigError) as err:
        SpringDamperUnit.from_dict(bad, 'vehicle.front', travel=(-0.1, 0.1))
    lines = str(err.value).splitlines()
    assert any(
        line.startswith('vehicle.front.damper_curve.c_bump_hi: unknown key') for line in lines
    )
    with pytest.raises(ConfigError) as err:
        SpringDamperUnit.from_dict(
            dict(bad, damper_curve=data['damper_curve']), 'vehicle.front', travel=(-0.1, 0.1)
        )
    assert str(err.value).startswith(
        'vehicle.front.bump_stop.gap: 0.2 m is larger than the bump travel'
    )
    with pytest.raises(
        ConfigError, match=r'vehicle\.front\.damper_curve\.c_bump_low: must be >= 0'
    ):
        del bad['damper_curve']['c_bump_hi']
        SpringDamperUnit.from_dict(dict(bad, bump_stop=data['bump_stop']), 'vehicle.front')
