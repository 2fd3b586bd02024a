"""check_partials for every analytic component, at random (non-zero) inputs.

At the all-zero initial state several partials are exactly zero (e.g. dF_S/dk_S), so the
inputs here are random and the declared sparsity is also checked against a dense FD
Jacobian: no true nonzero may lie outside the declared pattern.
"""
from __future__ import annotations

import numpy as np
import openmdao.api as om
import pytest
from openmdao.utils.assert_utils import assert_check_partials

from suspopt.models.chassis import ChassisHeaveComp, ChassisPitchComp
from suspopt.models.forces import SuspensionForceComp, TyreForceComp
from suspopt.models.objective import (ObjectiveIntegrandComp, ObjectiveQuadratureComp,
                                      WeightedObjectiveComp)
from suspopt.models.wheel import WheelDynamicsComp
from suspopt.problem import radau_grid, radau_quadrature_weights
from suspopt.road import ISO8608_CLASSES, CosineBumps, ISO8608Road, RoadInputComp, SmoothStep

NN = 7


def _random_problem(comp: om.ExplicitComponent, seed: int = 0) -> om.Problem:
    p = om.Problem(reports=False)
    p.model.add_subsystem('comp', comp)
    p.setup(force_alloc_complex=True)
    rng = np.random.default_rng(seed)
    for name, meta in comp.list_inputs(out_stream=None, prom_name=False, shape=True,
                                       return_format='dict').items():
        shape = meta['shape']
        p.set_val(f'comp.{name}', rng.uniform(0.5, 2.0, shape) * rng.choice([-1, 1], shape)
                  if name not in ('M', 'I', 'm', 'k_T', 'k_S', 'c_S', 'scales', 'time')
                  else rng.uniform(0.5, 2.0, shape))
    p.run_model()
    return p


COMPONENTS = {
    'suspension_force': lambda: SuspensionForceComp(num_nodes=NN),
    'tyre_force': lambda: TyreForceComp(num_nodes=NN),
    'chassis_heave': lambda: ChassisHeaveComp(num_nodes=NN),
    'chassis_pitch': lambda: ChassisPitchComp(num_nodes=NN),
    'wheel_dynamics': lambda: WheelDynamicsComp(num_nodes=NN),
    'objective_integrand': lambda: ObjectiveIntegrandComp(num_nodes=NN),
    'weighted_objective': lambda: WeightedObjectiveComp(),
    'objective_quadrature': lambda: ObjectiveQuadratureComp(
        weights=radau_quadrature_weights(2, 3, 5.0)),
    'road_two_bumps': lambda: RoadInputComp(num_nodes=NN, road=CosineBumps(), speed=10.0,
                                            offsets=(0.0, 2.984)),
    'road_step': lambda: RoadInputComp(num_nodes=NN, road=SmoothStep(position=5.0,
                                                                     ramp_length=20.0),
                                       speed=10.0, offsets=(0.0, 2.984)),
    'road_iso8608': lambda: RoadInputComp(num_nodes=NN, road=ISO8608Road(fade_in=1.0),
                                          speed=10.0, offsets=(0.0, 2.984)),
}


@pytest.mark.parametrize('name', sorted(COMPONENTS))
def test_check_partials(name):
    comp = COMPONENTS[name]()
    p = _random_problem(comp)
    if name.startswith('road'):
        # put the nodes on the road features (bumps at s = 5..7 and 10..12 m, s = v t)
        p.set_val('comp.time', np.linspace(0.52, 0.68, NN))
        p.run_model()
    if name.startswith('road'):
        # road profiles are real-valued (clip/where): central differences, error ~ 1e-9
        data = p.check_partials(method='fd', form='central', step=1e-7, out_stream=None,
                                compact_print=True)
        assert_check_partials(data, atol=1e-6, rtol=1e-6)
    else:
        data = p.check_partials(method='cs', out_stream=None, compact_print=True)
        assert_check_partials(data, atol=1e-10, rtol=1e-10)


@pytest.mark.parametrize('name', sorted(COMPONENTS))
def test_declared_sparsity_holds_away_from_zero(name):
    """Every true nonzero of the (complex-step) Jacobian is inside the declared pattern."""
    comp = COMPONENTS[name]()
    p = _random_problem(comp, seed=3)
    data = p.check_partials(method='fd' if name.startswith('road') else 'cs',
                            form='central', out_stream=None)
    for (of, wrt), d in data['comp'].items():
        J_true = np.asarray(d['J_fd'])
        J_decl = np.asarray(d['J_fwd'])
        outside = (np.abs(J_true) > 1e-12) & (J_decl == 0.0)
        assert not np.any(outside), f'{of} wrt {wrt}: nonzeros outside the declared sparsity'


def test_road_profiles_match_formula():
    """SPEC §4: two 1-cos bumps, h = 0.05, l = 2, at 5 and 10 m; rear wheel a wheelbase behind."""
    road = CosineBumps()
    s = np.array([0.0, 5.0, 6.0, 7.0, 8.0, 11.0, 12.5])
    expected = np.array([0.0, 0.0, 0.05, 0.0, 0.0, 0.05, 0.0])
    np.testing.assert_allclose(road.r(s), expected, atol=1e-15)
    from suspopt.road import wheel_road_inputs
    h, _ = wheel_road_inputs(road, np.array([0.6, 0.6 + 2.984 / 10.0]), 10.0, (0.0, 2.984))
    np.testing.assert_allclose(h[0, 0], 0.05)
    np.testing.assert_allclose(h[1, 1], 0.05)


def test_iso8608_road_has_the_class_variance():
    """The random road's height variance over the band equals the integral of the ISO
    8608 PSD, G_d(n0) n0² (1/n_min - 1/n_max), and four times more per class letter."""
    s = np.linspace(50.0, 2000.0, 200001)  # the whole road, after the fade-in
    variances = {}
    for cls in 'BC':
        road = ISO8608Road(road_class=cls, seed=7)
        variances[cls] = np.var(road.r(s))
        expected = ISO8608_CLASSES[cls] * 0.1**2 * (1.0 / road.n_min - 1.0 / road.n_max)
        assert abs(variances[cls] / expected - 1.0) < 0.05, (cls, variances[cls], expected)
    assert abs(variances['C'] / variances['B'] - 4.0) < 1e-9  # same seed: same shape
    road = ISO8608Road(road_class='C', seed=7, fade_in=2.0)
    assert road.r(np.array([0.0]))[0] == 0.0 and road.dr_ds(np.array([0.0]))[0] == 0.0


@pytest.mark.parametrize('segments, order', [(1, 3), (4, 5), (80, 5), (7, 6)])
def test_radau_quadrature_is_exact_for_polynomials(segments, order):
    """The objective's quadrature weights integrate t^k exactly for k <= 2 order - 2 (LGR
    with ``order`` points), on the node times of Dymos' own compressed Radau grid, and
    suspopt's nodes are Dymos' nodes."""
    from dymos.transcriptions.grid_data import GridData
    T = 5.0
    w = radau_quadrature_weights(segments, order, T)
    gd = GridData(num_segments=segments, transcription='radau-ps', transcription_order=order,
                  compressed=True)
    t = 0.5 * (gd.node_ptau + 1.0) * T
    assert w.shape == t.shape and np.all(w >= 0.0)
    np.testing.assert_allclose(radau_grid(segments, order)[0], gd.node_ptau, atol=1e-14)
    for k in range(2 * order - 1):
        np.testing.assert_allclose(w @ t**k, T ** (k + 1) / (k + 1), rtol=1e-12)
    # a non-polynomial integrand converges: sin over the horizon
    if segments >= 4:
        np.testing.assert_allclose(w @ np.sin(t), 1.0 - np.cos(T), rtol=1e-9)


def test_quadrature_equals_a_dymos_integrated_state():
    """SPEC §5 accumulates J_k as integrated states (rate = integrand). The objective's
    quadrature is the same number: a Dymos Radau state x' = g(t) (collocation equations
    solved by Dymos' own Newton solver) ends at exactly ``weights @ g(nodes)``."""
    import dymos as dm

    class Integrand(om.ExplicitComponent):
        def initialize(self):
            self.options.declare('num_nodes', types=int)

        def setup(self):
            nn = self.options['num_nodes']
            self.add_input('time', shape=(nn,), units='s')
            self.add_output('g', shape=(nn,), units='1/s')
            self.declare_partials('g', 'time', diagonal=True)

        def compute(self, inputs, outputs):
            t = inputs['time']
            outputs['g'] = np.sin(5.0 * t) ** 2 + np.exp(-t)

        def compute_partials(self, inputs, partials):
            t = inputs['time']
            partials['g', 'time'] = 5.0 * np.sin(10.0 * t) - np.exp(-t)

    segments, order, T = 7, 5, 5.0
    p = om.Problem(reports=False)
    phase = dm.Phase(ode_class=Integrand,
                     transcription=dm.Radau(num_segments=segments, order=order, compressed=True))
    phase.set_time_options(fix_initial=True, fix_duration=True, targets=['time'], units='s')
    phase.add_state('x', rate_source='g', fix_initial=True, solve_segments='forward')
    phase.add_timeseries_output('g')
    p.model.add_subsystem('phase', phase)
    p.model.linear_solver = om.DirectSolver()
    p.setup()
    phase.set_time_val(initial=0.0, duration=T)
    phase.set_state_val('x', [0.0, 0.0])
    p.run_model()
    x_T = p.get_val('phase.timeseries.x')[-1, 0]
    g = p.get_val('phase.timeseries.g')[:, 0]
    assert abs(x_T - radau_quadrature_weights(segments, order, T) @ g) < 1e-12 * abs(x_T)
    assert abs(x_T - 3.5063808) < 1e-4  # and it is the integral (SciPy quad: 3.50638080)
