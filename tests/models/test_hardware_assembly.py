"""The hardware's curves in the low-fidelity vehicle: the per-corner force component
(corners of different forms, linear corners exactly eq. 9, only the design's curve
parameters as inputs), the settings component's curve signals, and the assembly's choice
of component (docs/nonlinear_hardware.md)."""

from __future__ import annotations

import numpy as np
import openmdao.api as om
import pytest
from openmdao.utils.assert_utils import assert_check_partials

from suspopt.curves import (
    BumpStop,
    DamperCurve,
    DamperTable,
    ReboundStop,
    SpringCurve,
    SpringDamperUnit,
)
from suspopt.driver.structure import declared_subjacs
from suspopt.models.assembly import assemble
from suspopt.models.forces import SuspensionForceComp
from suspopt.models.nonlinear_forces import NonlinearSuspensionForceComp
from suspopt.models.settings import SuspensionSettingsComp
from suspopt.spec.load import config_from_dict, full_car_defaults
from suspopt.transcription.vehicle import vehicle_spec
from suspopt.verification.timemarching import simulate

NN = 6
CURVES = SpringDamperUnit(
    SpringCurve((30000.0, 1.0e5, 4.0e6)),
    DamperCurve(3000.0, 0.08, 1200.0, 7000.0, 0.12, 2800.0),
    BumpStop(0.03, (2.0e6, 3.0e8)),
    ReboundStop(0.04, (5.0e6,)),
)
TABLE = SpringDamperUnit(
    SpringCurve((25000.0,)),
    DamperTable((-1.0, -0.3, 0.0, 0.3, 1.0), (-4200, -2100, 0, 520, 1300)),
    BumpStop(0.02, (1.0e6,)),
)
#: front left and right with curves, rear left linear, rear right a damper table
UNITS = (CURVES, CURVES, None, TABLE)
DESIGNED = ('k_S', 'c_S', 'c_bump_low', 'v_rebound_knee', 'bump_gap', 'damper_forces')


def problem(comp, seed: int = 0) -> om.Problem:
    p = om.Problem(reports=False)
    p.model.add_subsystem('comp', comp, promotes=['*'])
    p.setup(force_alloc_complex=True)
    rng = np.random.default_rng(seed)
    for name in ('z_W', 'z_M'):
        p.set_val(name, rng.uniform(-0.08, 0.08, (NN, 4)))
    for name in ('v_W', 'v_M'):
        p.set_val(name, rng.uniform(-0.5, 0.5, (NN, 4)))
    p.set_val('k_S', [31000.0, 29000.0, 27000.0, 26000.0])
    p.set_val('c_S', [0.0, 0.0, 2500.0, 0.0])
    return p


def per_corner() -> NonlinearSuspensionForceComp:
    return NonlinearSuspensionForceComp(num_nodes=NN, corners=4, units=UNITS, settings=DESIGNED)


def test_only_the_designs_parameters_are_inputs_each_at_its_corners():
    comp = per_corner()
    problem(comp).final_setup()
    declared = {sj.wrt.split('.', 1)[1]: sj for sj in declared_subjacs(comp)}
    assert set(declared) == {'z_W', 'v_W', 'z_M', 'v_M', *DESIGNED}
    corner = np.tile(np.arange(4), NN)
    where = {n: sorted(set(corner[declared[n].rows])) for n in DESIGNED}
    assert where == {
        'k_S': [0, 1, 2, 3],
        'c_S': [2],
        'c_bump_low': [0, 1],
        'v_rebound_knee': [0, 1],
        'bump_gap': [0, 1, 3],
        'damper_forces': [3],
    }
    # an input's default is each corner's own value (0 where the corner has none)
    p = problem(per_corner())
    np.testing.assert_array_equal(p.get_val('bump_gap'), [0.03, 0.03, 0.0, 0.02])


def test_check_partials_per_corner():
    p = problem(per_corner())
    p.set_val('c_bump_low', [3500.0, 2500.0, 0.0, 0.0])
    p.run_model()
    data = p.check_partials(method='fd', form='central', step=1e-7, out_stream=None)
    assert_check_partials(data, atol=2e-4, rtol=1e-6)


def test_declared_sparsity_is_the_true_sparsity_per_corner():
    """Differences of the whole output by each input entry: no true nonzero outside the
    declared pattern, at states spanning knees, stops and table ends."""
    for seed in range(2):
        comp = per_corner()
        p = problem(comp, seed)
        p.run_model()
        declared = {sj.wrt.split('.', 1)[1]: sj for sj in declared_subjacs(comp)}
        for wrt, sj in declared.items():
            x = np.array(p.get_val(wrt), dtype=float)
            base = p.get_val('F_S').ravel().copy()
            true = np.zeros(sj.shape, dtype=bool)
            for j in range(x.size):
                moved = x.copy()
                moved.flat[j] += 1e-6 * max(1.0, abs(x.flat[j]))
                p.set_val(wrt, moved)
                p.run_model()
                true[:, j] = np.abs(p.get_val('F_S').ravel() - base) > 1e-9
            p.set_val(wrt, x)
            p.run_model()
            decl = np.zeros(sj.shape, dtype=bool)
            decl[sj.rows, sj.cols] = True
            assert not (true & ~decl).any(), f'dF_S/d{wrt}: undeclared nonzeros (seed {seed})'


def test_a_linear_corner_is_eq_9_to_the_last_bit():
    """Beside corners with curves, a corner without is SuspensionForceComp's, values and
    partials."""
    ref = problem(SuspensionForceComp(num_nodes=NN, corners=4))
    new = problem(per_corner())
    for p in (ref, new):
        p.run_model()
    np.testing.assert_array_equal(new.get_val('F_S')[:, 2], ref.get_val('F_S')[:, 2])
    J_ref = ref.compute_totals('F_S', ['z_W', 'v_W', 'k_S', 'c_S'])
    J_new = new.compute_totals('F_S', ['z_W', 'v_W', 'k_S', 'c_S'])
    rows = np.arange(NN) * 4 + 2
    for key, val in J_ref.items():
        np.testing.assert_array_equal(J_new[key][rows], val[rows], err_msg=str(key))


def test_settings_give_each_corner_its_variable_or_its_hardware_value():
    """``c_bump_low_1L`` sets the front left's ``curve_c_bump_low``; the other corners keep
    the hardware's (the defaults), and every partial is exact."""
    design = ('k_S1', 'k_S2', 'c_S2', 'c_bump_low_1L', 'bump_gap_1')
    comp = SuspensionSettingsComp(
        design=design,
        labels=('1L', '1R', '2L', '2R'),
        curve_defaults={
            'curve_c_bump_low': np.array([3000.0, 3100.0, 0.0, 0.0]),
            'curve_bump_gap': np.array([0.03, 0.03, 0.0, 0.0]),
        },
    )
    p = om.Problem(reports=False)
    p.model.add_subsystem('s', comp, promotes=['*'])
    p.setup(force_alloc_complex=True)
    p.set_val('c_bump_low_1L', 2000.0)
    p.set_val('bump_gap_1', 0.05)
    p.run_model()
    np.testing.assert_array_equal(p.get_val('curve_c_bump_low'), [2000.0, 3100.0, 0.0, 0.0])
    np.testing.assert_array_equal(p.get_val('curve_bump_gap'), [0.05, 0.05, 0.0, 0.0])
    assert_check_partials(p.check_partials(method='cs', out_stream=None))


def _hardware_car(front: dict, design: dict) -> dict:
    d = full_car_defaults().to_dict()
    d['vehicle']['front'].update(front)
    d['design'] = {'per_corner': False, **design}
    d['maneuver'] = {'speed': 20.0, 'horizon': 1.0}
    return d


def test_the_assembly_takes_the_curves_component_only_where_there_are_curves():
    linear = full_car_defaults()
    sc = linear.scenarios()[0]
    blocks = {b.name: b for b in assemble(vehicle_spec(linear, sc, 'low'), 'low').blocks}
    assert isinstance(blocks['suspension'].make(2), SuspensionForceComp)
    cfg = config_from_dict(
        _hardware_car(
            {'damper_curve': dict(zip(DAMPER_KEYS, (3000.0, 0.1, 1500.0, 6000.0, 0.1, 3000.0)))},
            {'c_bump_low_1': {}},
        )
    )
    spec = vehicle_spec(cfg, cfg.scenarios()[0], 'low')
    assert spec.curve_settings == ('c_bump_low',)
    block = {b.name: b for b in assemble(spec, 'low').blocks}['suspension']
    comp = block.make(2)
    assert isinstance(comp, NonlinearSuspensionForceComp)
    assert comp.options['settings'] == ('k_S', 'c_S', 'c_bump_low')
    assert dict(block.inputs) == {'c_bump_low': 'curve_c_bump_low'}


DAMPER_KEYS = (
    'c_bump_low',
    'v_bump_knee',
    'c_bump_high',
    'c_rebound_low',
    'v_rebound_knee',
    'c_rebound_high',
)


@pytest.mark.parametrize('per_corner', [False, True])
def test_a_damper_curve_with_equal_slopes_marches_as_the_linear_damper(per_corner):
    """The exact reduction through the whole vehicle: every damper a curve with its four
    slopes c_S (and a stop that never engages) marches to the same objective terms, bit
    for bit, as the linear car (the force is ``c v`` to the last bit, the RHS identical)."""
    linear = full_car_defaults()
    c1, c2 = linear.design['c_S1'].initial, linear.design['c_S2'].initial

    def curve(c: float) -> dict:
        return dict(zip(DAMPER_KEYS, (c, 0.1, c, c, 0.1, c)))

    d = linear.to_dict()
    d['maneuver'] = {'speed': 10.0, 'horizon': 1.0}
    d['road'] = {
        'profile': 'two_tracks',
        'left': {'profile': 'bump', 'height': 0.04, 'length': 2.0, 'start': 1.0},
        'right': {'profile': 'bump', 'height': 0.02, 'length': 2.0, 'start': 2.0},
    }
    d['design'] = {'per_corner': per_corner}
    lin = config_from_dict(d)
    d['vehicle']['front']['damper_curve'] = curve(c1)
    d['vehicle']['rear']['damper_curve'] = curve(c2)
    d['vehicle']['rear']['bump_stop'] = {'gap': 0.048, 'coefficients': [1.0e7]}
    d['design'] = {'per_corner': per_corner, 'c_rebound_low_2': {}, 'bump_gap_2': {}}
    hw = config_from_dict(d)
    assert 'c_S1' not in hw.design_names()
    t = np.array([0.0, 1.0])
    # one integrator for both (by default the linear car is marched exactly)
    J_lin = simulate(lin, 'low', t_eval=t, rtol=1e-5, atol=1e-8, method='DOP853').J
    J_hw = simulate(hw, 'low', t_eval=t, rtol=1e-5, atol=1e-8, method='DOP853').J
    assert np.all(J_lin > 0.0)
    np.testing.assert_array_equal(J_hw, J_lin)


def test_the_linear_state_space_refuses_curves():
    """A vehicle with curves is not linear: the state space (and the spectral toolkit
    built on it) refuses it; without curves it is read as before."""
    from suspopt.models.linear import linearize

    d = _hardware_car({'bump_stop': {'gap': 0.03, 'coefficients': [1.0e6]}}, {})
    cfg = config_from_dict(d)
    spec = vehicle_spec(cfg, cfg.scenarios()[0], 'low')
    with pytest.raises(ValueError, match='the suspension has curves'):
        linearize(assemble(spec, 'low'), cfg.design.initial(), ('z_C',))
    linear = full_car_defaults()
    spec = vehicle_spec(linear, linear.scenarios()[0], 'low')
    assert linearize(assemble(spec, 'low'), linear.design.initial(), ('z_C',)).A.shape[0] > 0
