"""The design-only constraints as the NLP sees them: the group of design metrics fed by
the design variables (values from the pure equations, total derivatives against finite
differences), and the NLP's constraints named after the study file's keys."""

from __future__ import annotations

import numpy as np
import openmdao.api as om
import pytest

from suspopt.models.design import DESIGN_UNITS, design_kind
from suspopt.models.design_metrics import axle_roll_stiffness, ride_modes, roll_gradient
from suspopt.spec.load import config_from_dict
from suspopt.transcription.constraints import (
    DesignMetricsGroup,
    bounds,
    roll_arm,
    wheel_rates,
)

CFG = config_from_dict(
    {
        'vehicle': {'model': 'full_car'},
        'constraints': {
            'roll_gradient': {'max': 4.0, 'front_share': [0.5, 0.8]},
            'ride_frequency': {'heave': [0.8, 1.6], 'pitch': [0.8, 2.0]},
        },
    }
)
DESIGN = {'k_S1': 31000.0, 'k_S2': 35000.0, 'c_S1': 3000.0, 'c_S2': 3500.0}
DESIGN |= {'k_R1': 60000.0, 'k_R2': 9000.0}


@pytest.fixture(scope='module')
def group_problem():
    p = om.Problem(reports=False)
    ivc = p.model.add_subsystem('design', om.IndepVarComp(), promotes=['*'])
    for n in CFG.design_names():
        ivc.add_output(n, DESIGN[n], units=DESIGN_UNITS[design_kind(n)])
    p.model.add_subsystem(
        'metrics',
        DesignMetricsGroup(config=CFG, rates=wheel_rates(CFG, 'low', {})),
        promotes_inputs=['*'],
    )
    p.setup(force_alloc_complex=True)
    p.run_model()
    return p


def test_values_are_the_equations(group_problem):
    p, v, lay = group_problem, CFG.vehicle, CFG.layout()
    k_W = np.array([DESIGN[f'k_S{c.axle + 1}'] for c in lay.corners])
    k_T = np.array([v.axles[c.axle].tyre_stiffness for c in lay.corners])
    axle = [c.axle for c in lay.corners]
    K = axle_roll_stiffness(k_W, [DESIGN['k_R1'], DESIGN['k_R2']], k_T, lay.y, axle, [0, 1])
    phi = roll_gradient(K, v.chassis_mass, roll_arm(CFG))
    assert p.get_val('metrics.roll_gradient')[0] == pytest.approx(float(phi), rel=1e-12)
    assert p.get_val('metrics.front_share')[0] == pytest.approx(K[0] / K.sum(), rel=1e-12)
    k_ride = k_W * k_T / (k_W + k_T)
    f = ride_modes(k_ride, lay.a, v.chassis_mass, v.chassis_pitch_inertia, True)[0]
    got = [p.get_val('metrics.f_heave')[0], p.get_val('metrics.f_pitch')[0]]
    assert got == pytest.approx(list(f), rel=1e-12)


def test_total_derivatives(group_problem):
    of = [f'metrics.{n}' for n in ('roll_gradient', 'front_share', 'f_heave', 'f_pitch')]
    data = group_problem.check_totals(
        of=of, wrt=list(CFG.design_names()), method='fd', form='central', step=1e-5,
        step_calc='rel_avg', out_stream=None,
    )  # fmt: skip
    # (not complex step: numpy's eigh takes a complex matrix as Hermitian)
    assert len(data) == len(of) * len(CFG.design_names())
    for key, d in data.items():  # compared here: assert_check_totals let a sign slip by
        analytic = d['J_fwd'] if d.get('J_fwd') is not None else d['J_rev']
        np.testing.assert_allclose(analytic, d['J_fd'], rtol=1e-6, atol=1e-14, err_msg=str(key))


def test_every_side_is_a_named_bound():
    assert [b.name for b in bounds(CFG) if b.kind == 'design'] == [
        'roll_gradient.max',
        'roll_gradient.front_share.min',
        'roll_gradient.front_share.max',
        'ride_frequency.heave.min',
        'ride_frequency.heave.max',
        'ride_frequency.pitch.min',
        'ride_frequency.pitch.max',
    ]


def test_mixed_fidelity_wheel_rates_are_the_linkages():
    """In the mixed model the wheel rate is each axle's linkage at its reference pose,
    ``a k_S + b``; the design metrics then see the linkage's rate, not ``k_S``."""
    from suspopt.multibody.kinematics import reference_wheel_rate
    from suspopt.transcription.vehicle import multibody_modules

    modules = multibody_modules(CFG)
    rates = wheel_rates(CFG, 'mixed', modules)
    for i, c in enumerate(CFG.layout().corners):
        m = modules[CFG.vehicle.axles[c.axle].mechanism]
        a, b, _ = reference_wheel_rate(getattr(m, 'base_mechanism', m))
        assert (rates.slope[i], rates.offset[i]) == pytest.approx((a, b), rel=1e-12)
    assert not np.allclose(rates.slope, 1.0)  # the linkages' motion ratios are not 1


def test_an_evaluation_reports_the_constraints_a_fixed_design_violates():
    """Found: evaluating a design outside a constraint (here the full car's roll gradient,
    bars removed) failed as infeasible: a fixed design cannot move to meet it. The
    evaluation now solves the collocation and reports the violation."""
    from suspopt.studies.run import evaluate

    cfg = config_from_dict(
        {
            'vehicle': {'model': 'full_car'},
            'maneuver': {'horizon': 0.5},
            'road': {'profile': 'bump', 'height': 0.02, 'length': 1.0, 'start': 1.0},
            'transcription': {'segments': 10},
            'objective': {
                'normalization': 'custom',
                'scales': {
                    t: 1.0
                    for t in (
                        'tyre_load_1L',
                        'tyre_load_1R',
                        'tyre_load_2L',
                        'tyre_load_2R',
                        'comfort_driver',
                    )
                },
            },
        }
    )
    design = {**cfg.design.initial(), 'k_R1': 0.0, 'k_R2': 0.0}
    rec = evaluate(cfg, 'low', design, verify=False)
    assert rec.success, rec.status
    (roll,) = [c for c in rec.constraints if c.name == 'roll_gradient.max']
    assert roll.value > roll.bound


def _controlled(control: dict, constraints: dict | None = None):
    return config_from_dict(
        {
            'vehicle': {'model': 'quarter_car'},
            'control': control,
            'constraints': constraints or {},
            'maneuver': {'speed': 10.0, 'horizon': 1.0},
            'road': {'profile': 'bump', 'start': 2.0, 'length': 2.0, 'height': 0.04},
        }
    )


@pytest.mark.parametrize(
    ('control', 'constraints', 'applies'),
    [
        ({'kind': 'active', 'law': 'feedback'}, None, True),
        ({'kind': 'active', 'law': 'feedback'}, {'stability': {'enabled': False}}, False),
        ({'kind': 'active', 'law': 'feedback', 'force_max': 2000.0}, None, False),
        ({'kind': 'active', 'law': 'open_loop'}, None, False),
        (
            {'kind': 'semi_active', 'law': 'feedback', 'c_min': 0.0, 'c_max': 3000.0},
            None,
            False,
        ),
    ],
)
def test_the_stability_constraint_binds_only_a_linear_active_feedback_law(
    control, constraints, applies
):
    """The only closed loop that can be unstable: an active suspension under a linear
    feedback law (on by default, in both models)."""
    cfg = _controlled(control, constraints)
    names = [b.name for b in bounds(cfg)]
    assert ('stability.margin' in names) is applies


def test_an_unstable_feedback_design_reports_its_negative_decay_rate():
    """Evaluated at the benchmark's unconstrained feedback optimum (a negative spring and
    damper in the strut), the design-only value names the instability."""
    from suspopt.studies.run import evaluate

    cfg = _controlled({'kind': 'active', 'law': 'feedback'})
    bad = dict(zip(cfg.design_names(), (176.5, 1700.0, 0.0023, 5004.0, -26430.0, -5000.0)))
    rec = evaluate(cfg, 'low', bad, verify=False)
    (v,) = [v for v in rec.constraints if v.name == 'stability.margin']
    assert v.value < -10.0 and v.margin < 0.0 and v.units == '1/s'


def test_the_rest_jacobian_by_differences_is_the_exact_linear_one():
    """The central-difference Jacobian at rest (any fidelity) against the low-fidelity
    model's exact state matrix (read at unit states: another route)."""
    from suspopt.models.linear import linearize, rest_jacobian
    from suspopt.transcription.vehicle import vehicle_assembly

    cfg = _controlled({'kind': 'active', 'law': 'feedback'})
    asm = vehicle_assembly(cfg, cfg.scenarios()[0], 'low')
    design = dict(zip(cfg.design_names(), (2.4e4, 1400.0, 2500.0, 3000.0, -8000.0, -1500.0)))
    exact = linearize(asm, design).A
    np.testing.assert_allclose(rest_jacobian(asm, design), exact, rtol=1e-6, atol=1e-6)


def test_the_mixed_models_closed_loop_is_affine_in_the_design():
    """The mixed model's state matrix at rest (each linkage reduced to its travel) is
    affine in the spring, damper and feedback gains at any geometry: the affine model
    read at the initial design predicts it at another design."""
    from suspopt.models.linear import affine_rest_jacobian, rest_jacobian
    from suspopt.multibody.reduced import reduced_modules
    from suspopt.transcription.vehicle import multibody_modules, vehicle_assembly

    cfg = config_from_dict(
        {
            'control': {'kind': 'active', 'law': 'feedback'},
            'maneuver': {'speed': 10.0, 'horizon': 0.5},
        }
    )
    asm = vehicle_assembly(
        cfg, cfg.scenarios()[0], 'mixed', reduced_modules(multibody_modules(cfg))
    )
    names = cfg.design_names()
    A0, dA = affine_rest_jacobian(asm, cfg.design.initial(), names)
    other = {
        n: v * (1.3 if i % 2 else 0.8) + 100.0
        for i, (n, v) in enumerate(cfg.design.initial().items())
    }
    predicted = A0 + np.tensordot([other[n] for n in names], dA, axes=1)
    actual = rest_jacobian(asm, other)
    np.testing.assert_allclose(predicted, actual, rtol=1e-5, atol=1e-5 * np.abs(actual).max())
