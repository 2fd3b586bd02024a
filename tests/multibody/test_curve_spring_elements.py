"""Spring-damper elements with curves (spring, damper, stops) in the multibody library:
reading the TOML subtables and their errors, the linear case against the linear element,
the potential against the generalized force, the suspension module's force against the
low-fidelity curves (eq. 12 with curves), and the black box's finite differences of a
curve parameter (against the analytic derivative, with a cost independent of the nodes).
"""

from __future__ import annotations

import copy

import numpy as np
import openmdao.api as om
import pytest
from mechanisms import raw

from suspopt.curves import DamperCurve, LinearDamper, SpringCurve, SpringDamperUnit
from suspopt.errors import ConfigError
from suspopt.multibody.components import SuspensionDynamicsComp
from suspopt.multibody.mechanism import mechanism_from_dict
from suspopt.multibody.solver import PlanarMultibodySolver
from suspopt.multibody.suspension import SuspensionModule

CURVES = {
    'spring_curve': {'coefficients': [30000.0, 0.0, 3.0e7]},
    'damper_curve': {
        'c_bump_low': 3000.0,
        'v_bump_knee': 0.08,
        'c_bump_high': 1200.0,
        'c_rebound_low': 7000.0,
        'v_rebound_knee': 0.12,
        'c_rebound_high': 2800.0,
    },
    'bump_stop': {'gap': 0.03, 'coefficients': [2.0e6, 5.0e7]},
    'rebound_stop': {'gap': 0.04, 'coefficients': [3.0e6]},
}


def with_curves(name: str, curves: dict, drop=('stiffness', 'damping')) -> dict:
    data = copy.deepcopy(raw(name))
    spring = data['suspension']['spring']
    for force in data['forces']:
        if force['name'] == spring:
            for key in drop:
                force.pop(key, None)
            force.update(copy.deepcopy(curves))
    return data


def test_reading_the_curve_subtables():
    mech = mechanism_from_dict(with_curves('double_wishbone', CURVES), suspension=True)
    spec = mech.force('spring')
    assert spec.stiffness == 0.0 and spec.damping == 0.0
    assert spec.curves.spring == SpringCurve((30000.0, 0.0, 3.0e7))
    assert isinstance(spec.curves.damper, DamperCurve)
    assert spec.curves.bump_stop.gap == 0.03 and spec.curves.rebound_stop.coefficients == (3e6,)
    # a stop alone: the linear spring and damper of the file's stiffness and damping
    data = with_curves('double_wishbone', {'bump_stop': CURVES['bump_stop']}, drop=())
    for f in data['forces']:
        if f['name'] == 'spring':
            f['stiffness'], f['damping'] = 25000.0, 2000.0
    spec = mechanism_from_dict(data, suspension=True).force('spring')
    assert spec.curves.spring == SpringCurve((25000.0,)) and spec.curves.damper == LinearDamper(
        2000.0
    )
    # no subtables: the linear element as before
    assert (
        mechanism_from_dict(raw('double_wishbone'), suspension=True).force('spring').curves is None
    )


def test_curve_errors_name_their_keys_and_the_element():
    bad = copy.deepcopy(CURVES)
    bad['damper_curve']['c_bump_hi'] = 1.0
    bad['spring_curve'] = {'coefficients': [-5.0]}
    data = with_curves('double_wishbone', bad, drop=('damping',))
    for f in data['forces']:
        if f['name'] == 'spring':
            f['stiffness'] = 1.0
    with pytest.raises(ConfigError) as err:
        mechanism_from_dict(data, source='dw.toml', suspension=True)
    lines = str(err.value).splitlines()
    expected = [
        "dw.toml: forces[0].stiffness: give stiffness or spring_curve, not both (force 'spring')",
        'dw.toml: forces[0].damper_curve.c_bump_hi: unknown key',
    ]
    for e in expected:
        assert any(line.startswith(e) for line in lines), (e, lines)
    table = copy.deepcopy(CURVES)
    table['damper_curve'] = {'velocities': [-1.0, 0.0, 0.5, 0.4], 'forces': [-9.0, 0.0, 3.0, 4.0]}
    with pytest.raises(ConfigError) as err:
        mechanism_from_dict(with_curves('double_wishbone', table), source='dw.toml')
    assert str(err.value).startswith(
        'dw.toml: forces[0].damper_curve.velocities: must be strictly increasing, got 0.5 then 0.4'
    )


@pytest.mark.parametrize('name', ['double_wishbone', 'macpherson'])
def test_linear_curves_give_the_linear_elements_forces(name):
    """A curve element with a linear spring and damper (and stops out of reach) applies
    the linear element's generalized forces (to rounding)."""
    linear = {'stiffness': 31000.0, 'damping': 2700.0}
    data_lin = copy.deepcopy(raw(name))
    spring = data_lin['suspension']['spring']
    for f in data_lin['forces']:
        if f['name'] == spring:
            f.update(linear)
    curves = {
        'spring_curve': {'coefficients': [31000.0]},
        'damper_curve': {k: 2700.0 for k in CURVES['damper_curve'] if k.startswith('c_')}
        | {'v_bump_knee': 0.1, 'v_rebound_knee': 0.1},
        'bump_stop': {'gap': 0.5, 'coefficients': [1e9]},
    }
    s_lin = PlanarMultibodySolver(mechanism_from_dict(data_lin, suspension=True))
    s_cur = PlanarMultibodySolver(mechanism_from_dict(with_curves(name, curves), suspension=True))
    z = np.linspace(-0.08, 0.08, 9)[:, None] + s_lin.q0[s_lin.ind]
    q = s_lin.positions(z)
    qd = s_lin.velocities(q, np.linspace(-0.6, 0.6, 9)[:, None])
    Q_lin, Q_cur = s_lin.generalized_forces(q, qd=qd), s_cur.generalized_forces(q, qd=qd)
    assert np.max(np.abs(Q_lin)) > 100.0
    np.testing.assert_allclose(Q_cur, Q_lin, rtol=0, atol=1e-11 * np.max(np.abs(Q_lin)))


def test_potential_is_the_elastic_force():
    """``Q = -∂V/∂q`` of the elastic curves (no velocity), by central differences of V
    along the linkage's motion: ``dV/dz = -Qᵀ dq/dz``."""
    s = PlanarMultibodySolver(
        mechanism_from_dict(with_curves('macpherson', CURVES), suspension=True)
    )
    nodamp = {'strut_spring': {'c_bump_low': 0.0, 'c_bump_high': 0.0}}
    nodamp['strut_spring'] |= {'c_rebound_low': 0.0, 'c_rebound_high': 0.0}
    z0 = s.q0[s.ind] + np.linspace(-0.09, 0.09, 13)[:, None]
    h = 1e-6
    V = [s.potential_energy(s.positions(z0 + d), nodamp) for d in (-h, h)]
    q = s.positions(z0)
    tangent = s.velocities(q, np.ones_like(z0))  # dq/dz
    Q = s.generalized_forces(q, qd=np.zeros_like(q), params=nodamp)
    dV = (V[1] - V[0]) / (2 * h)
    np.testing.assert_allclose(dV, -np.sum(Q * tangent, axis=1), rtol=1e-6, atol=1e-3)
    assert np.max(np.abs(dV)) > 500.0  # the stops engaged


def test_module_force_is_eq_12_with_curves():
    """The double wishbone's vertical spring: the module's F_S is the unit's force at the
    spring point's travel relative to the chassis mount, ``F(q^z_U - z_M, q̇^z_U - v_M)``,
    the low-fidelity ``F_S`` with the same curves (eq. 12)."""
    mech = mechanism_from_dict(with_curves('double_wishbone', CURVES), suspension=True)
    mod = SuspensionModule(mech)
    unit: SpringDamperUnit = mech.force('spring').curves
    assert mod.settings == tuple(unit.scalar_parameters())
    rng = np.random.default_rng(0)
    n = 40
    z_W, v_W = rng.uniform(-0.08, 0.08, n), rng.uniform(-0.6, 0.6, n)
    z_M, v_M = rng.uniform(-0.02, 0.02, n), rng.uniform(-0.3, 0.3, n)
    settings = {'c_bump_low': np.full(n, 2500.0), 'bump_gap': np.full(n, 0.02)}
    kin = mod.kinematics(z_W, v_W)
    _, F_S, _ = mod.dynamics(kin.state, z_M, v_M, np.full(n, 28000.0), None, np.zeros(n), settings)
    s = mod.solver
    k = s.marker_names.index('spring_point')
    q_U = s.marker_positions(kin.state.q)[:, k, 1] - s.marker_reference()[k, 1]
    qd_U = s.marker_velocities(kin.state.q, kin.state.qd)[:, k, 1]
    ref = unit.force(q_U - z_M, qd_U - v_M, {'k_S': 28000.0, **settings}, partials=False).value
    np.testing.assert_allclose(F_S, ref, rtol=1e-11, atol=1e-8)
    x = q_U - z_M
    assert x.max() > 0.02 and x.min() < -0.04  # both stops engaged somewhere
    with pytest.raises(ValueError, match='no settings'):
        mod.dynamics(kin.state, z_M, v_M, None, None, np.zeros(n), {'c_S': np.ones(n)})


def black_box(nn: int) -> tuple[om.Problem, SuspensionModule]:
    mech = mechanism_from_dict(with_curves('double_wishbone', CURVES), suspension=True)
    mod = SuspensionModule(mech)
    comp = SuspensionDynamicsComp(num_nodes=nn, corners=1, modules=(mod,))
    p = om.Problem(reports=False)
    p.model.add_subsystem('comp', comp, promotes=['*'])
    p.setup()
    rng = np.random.default_rng(nn)
    p.set_val('z_W', rng.uniform(-0.06, 0.06, (nn, 1)))
    p.set_val('v_W', rng.uniform(-0.5, 0.5, (nn, 1)))
    for name in ('z_M', 'v_M', 'F_T'):
        p.set_val(name, 0.0)
    p.set_val('k_S', 30000.0)
    return p, mod


def test_black_box_differences_a_curve_parameter_at_a_cost_independent_of_the_nodes():
    """The component adds one per-corner input per curve parameter (besides k_S, c_S);
    its forward differences of ∂F_S/∂(parameter) match the curves' analytic derivative,
    and a Jacobian costs as many augmented solves at 4 nodes as at 16."""
    calls = {}
    for nn in (4, 16):
        p, mod = black_box(nn)
        names = set(p.model.comp._var_rel_names['input'])
        assert {'c_bump_low', 'v_bump_knee', 'bump_gap', 'k_S3', 'rebound_k2'} <= names
        p.run_model()
        before = mod.solver.calls['augmented']
        J = p.compute_totals('F_S', ['c_bump_low', 'v_bump_knee', 'bump_gap', 'k_S3'])
        calls[nn] = mod.solver.calls['augmented'] - before
        s = mod.solver
        kin = mod.kinematics(p.get_val('z_W').ravel(), p.get_val('v_W').ravel())
        k = s.marker_names.index('spring_point')
        q_U = s.marker_positions(kin.state.q)[:, k, 1] - s.marker_reference()[k, 1]
        qd_U = s.marker_velocities(kin.state.q, kin.state.qd)[:, k, 1]
        exact = mod.unit.force(q_U, qd_U, {'k_S': 30000.0}).partials
        for name in ('c_bump_low', 'v_bump_knee', 'bump_gap', 'k_S3'):
            fd = J['F_S', name].ravel()
            scale = np.max(np.abs(exact[name])) + 1e-9
            np.testing.assert_allclose(fd, exact[name], atol=1e-4 * scale, err_msg=name)
    assert calls[4] == calls[16] > 0, calls


@pytest.mark.parametrize('mount', ['ground', 'chassis'])
def test_parallelogram_spring_force_closed_form(mount):
    """The paper's parallelogram with a curve spring: the spring point travels
    ``m = 0.15/0.33`` of the wheel, so the spring's compression is ``m z_W - z_M`` with the
    ground mount (the chassis' motion along the spring, eq. 12) and ``m (z_W - z_M)`` with
    the chassis mount (the frame carries the linkage): ``F_S = F(x, v)`` of the curves."""
    mech = mechanism_from_dict(with_curves('double_wishbone', CURVES), suspension=True)
    mod = SuspensionModule(mech, mount=mount)
    unit: SpringDamperUnit = mech.force('spring').curves
    m = 0.15 / 0.33
    rng = np.random.default_rng(1)
    n = 30
    z_W, v_W = rng.uniform(-0.08, 0.08, n), rng.uniform(-0.6, 0.6, n)
    z_M, v_M = rng.uniform(-0.03, 0.03, n), rng.uniform(-0.3, 0.3, n)
    settings = {'k_S3': np.full(n, 1.0e7), 'rebound_gap': np.full(n, 0.03)}
    params = {'k_S': 26000.0, **settings}
    if mount == 'ground':
        kin = mod.kinematics(z_W, v_W)
        F_S = mod.dynamics(kin.state, z_M, v_M, np.full(n, 26000.0), None, np.zeros(n), settings)[1]
        x, v = m * z_W - z_M, m * v_W - v_M
    else:
        zero = np.zeros(n)
        kin = mod.kinematics(z_W, v_W, pose=(z_M, v_M, zero, zero))
        F_S = mod.mount_response(kin, np.full(n, 26000.0), None, zero, settings=settings)[1]
        x, v = m * (z_W - z_M), m * (v_W - v_M)
    np.testing.assert_allclose(F_S, unit.force(x, v, params, partials=False).value, rtol=1e-10)
    assert np.max(np.abs(F_S)) > 1000.0
