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

from suspopt.driver.structure import declared_subjacs
from suspopt.models.chassis import ChassisHeaveComp, ChassisPitchComp, ChassisRollComp
from suspopt.models.forces import (
    AntiRollBarComp,
    MountMotionComp,
    SuspensionForceComp,
    TyreForceComp,
    WheelLoadComp,
)
from suspopt.models.metric_components import (
    SquaredSignalsComp,
    SuspensionTravelComp,
    TyreLoadRatioComp,
)
from suspopt.models.mount import ChassisMountComp, MountResponseComp, MountRotationComp
from suspopt.models.objective import (
    ObjectiveQuadratureComp,
    ScenarioObjectiveComp,
    WeightedObjectiveComp,
    WorstCaseGapComp,
)
from suspopt.models.road_input import RoadInputComp
from suspopt.models.settings import SuspensionSettingsComp
from suspopt.models.wheel import WheelDynamicsComp
from suspopt.road import ISO8608_CLASSES, CosineBumps, ISO8608Road, SmoothStep, road_tracks
from suspopt.transcription.grid import radau_grid, radau_quadrature_weights

NN = 7
FULL = dict(a=np.array([1.3, 1.3, -1.4, -1.4]), y=np.array([0.75, -0.75, 0.74, -0.74]))
HALF = dict(a=np.array([1.271, -1.713]), y=np.zeros(2))
SIDES = {
    'full': dict(side=np.array([1.0, -1.0, 1.0, -1.0]), roll=True, corners=4, **FULL),
    'half': dict(side=np.zeros(2), roll=False, corners=2, **HALF),
    'quarter': dict(
        side=np.zeros(1), roll=False, pitch=False, corners=1, a=np.zeros(1), y=np.zeros(1)
    ),
}
#: the integrand signals of a full car with two seats: chassis, wheels, tyres, travel, seats
SIGNALS = (
    ('zdd_C', 'm/s**2', 0),
    ('thdd_C', 'rad/s**2', 0),
    ('phidd_C', 'rad/s**2', 0),
    ('z_W', 'm', 4),
    ('F_T', 'N', 4),
    ('travel', 'm', 4),
    ('a_w', 'm/s**2', 2),
)
#: inputs drawn positive (masses, rates, scales, times)
POSITIVE = ('k_S', 'c_S', 'k_R', 'scales', 'time', 'weights')


def _random_problem(comp: om.ExplicitComponent, seed: int = 0) -> om.Problem:
    p = om.Problem(reports=False)
    p.model.add_subsystem('comp', comp)
    p.setup(force_alloc_complex=True)
    rng = np.random.default_rng(seed)
    for name, meta in comp.list_inputs(
        out_stream=None, prom_name=False, shape=True, return_format='dict'
    ).items():
        shape = meta['shape']
        sign = (
            1.0 if name in POSITIVE or name.startswith(('k_', 'c_')) else rng.choice([-1, 1], shape)
        )
        p.set_val(f'comp.{name}', rng.uniform(0.5, 2.0, shape) * sign)
    p.run_model()
    return p


COMPONENTS = {
    'mount_motion_half': lambda: MountMotionComp(num_nodes=NN, corners=2, **HALF),
    'mount_motion_full': lambda: MountMotionComp(num_nodes=NN, corners=4, roll=True, **FULL),
    'mount_motion_quarter': lambda: MountMotionComp(
        num_nodes=NN, corners=1, pitch=False, a=np.zeros(1), y=np.zeros(1)
    ),
    'suspension_travel': lambda: SuspensionTravelComp(num_nodes=NN, corners=4),
    'tyre_load_ratio': lambda: TyreLoadRatioComp(
        num_nodes=NN, corners=4, static=np.array([4e3, 4e3, 3.5e3, 3.6e3])
    ),
    'suspension_force': lambda: SuspensionForceComp(num_nodes=NN, corners=4),
    'anti_roll_bar': lambda: AntiRollBarComp(
        num_nodes=NN, corners=4, left=(0, 2), right=(1, 3), track=(1.5, 1.48)
    ),
    'tyre_force': lambda: TyreForceComp(
        num_nodes=NN, corners=4, k_T=np.array([2e5, 2e5, 3e5, 3e5])
    ),
    'wheel_load': lambda: WheelLoadComp(num_nodes=NN, corners=4),
    'chassis_heave': lambda: ChassisHeaveComp(
        num_nodes=NN, corners=4, M=1442.0, forces=('F_S', 'F_R')
    ),
    'chassis_pitch': lambda: ChassisPitchComp(num_nodes=NN, corners=2, a=HALF['a'], I=2782.0),
    'chassis_roll': lambda: ChassisRollComp(
        num_nodes=NN, corners=4, y=FULL['y'], I_x=572.0, forces=('F_S', 'F_R')
    ),
    'wheel_dynamics': lambda: WheelDynamicsComp(
        num_nodes=NN, corners=4, m=np.array([60.0, 60.0, 75.0, 75.0]), forces=('F_S', 'F_R')
    ),
    'settings_axle': lambda: SuspensionSettingsComp(
        design=('k_S1', 'k_S2', 'c_S1', 'c_S2', 'k_R1'), labels=('1L', '1R', '2L', '2R')
    ),
    'settings_corner': lambda: SuspensionSettingsComp(
        design=('k_S1L', 'k_S1R', 'k_S2L', 'k_S2R', 'c_S1L', 'c_S1R', 'c_S2L', 'c_S2R'),
        labels=('1L', '1R', '2L', '2R'),
    ),
    'objective_integrand_quarter': lambda: SquaredSignalsComp(
        num_nodes=NN, corners=1, signals=(('zdd_C', 'm/s**2', 0), ('z_W', 'm', 1))
    ),
    'objective_integrand_full': lambda: SquaredSignalsComp(
        num_nodes=NN, corners=4, signals=SIGNALS
    ),
    'weighted_objective': lambda: WeightedObjectiveComp(terms=7),
    'objective_quadrature': lambda: ObjectiveQuadratureComp(
        weights=radau_quadrature_weights(2, 3, 5.0), terms=4
    ),
    'scenario_objective': lambda: ScenarioObjectiveComp(weights=(1.0, 0.5, 2.0)),
    'worst_case_gap': lambda: WorstCaseGapComp(n=3),
    'mount_rotation': lambda: MountRotationComp(
        num_nodes=NN, corners=4, side=SIDES['full']['side']
    ),
    # small masses: the couplings through the mount (e.g. pitch from a roll moment) are then
    # of order one, well above the exact-sparsity check's threshold
    'chassis_mount_half': lambda: ChassisMountComp(
        num_nodes=NN, width=8, M=14.0, I=27.0, **SIDES['half']
    ),
    'chassis_mount_full': lambda: ChassisMountComp(
        num_nodes=NN, width=8, M=14.0, I=24.0, I_x=5.7, forces=('F_R',), **SIDES['full']
    ),
    'chassis_mount_quarter': lambda: ChassisMountComp(
        num_nodes=NN, width=8, M=14.0, **SIDES['quarter']
    ),
    'mount_response_quarter': lambda: MountResponseComp(num_nodes=NN, width=8, **SIDES['quarter']),
    'mount_response_half': lambda: MountResponseComp(num_nodes=NN, width=8, **SIDES['half']),
    'mount_response_full': lambda: MountResponseComp(num_nodes=NN, width=8, **SIDES['full']),
    'road_two_bumps': lambda: RoadInputComp(
        num_nodes=NN, tracks=(CosineBumps(),), speed=10.0, offsets=(0.0, 2.984), track_of=(0, 0)
    ),
    'road_step': lambda: RoadInputComp(
        num_nodes=NN,
        tracks=(SmoothStep(position=5.0, ramp_length=20.0),),
        speed=10.0,
        offsets=(0.0, 2.984),
        track_of=(0, 0),
    ),
    'road_iso8608_two_tracks': lambda: RoadInputComp(
        num_nodes=NN,
        tracks=road_tracks({'profile': 'iso8608', 'fade_in': 1.0}, 2, 1.5),
        speed=10.0,
        offsets=(0.0, 0.0, 2.8, 2.8),
        track_of=(0, 1, 0, 1),
    ),
}


def _place_on_road(p, name):
    if name.startswith('road'):
        # put the nodes on the road features (bumps at s = 5..7 and 10..12 m, s = v t)
        p.set_val('comp.time', np.linspace(0.52, 0.68, NN))
        p.run_model()


@pytest.mark.parametrize('name', sorted(COMPONENTS))
def test_check_partials(name):
    comp = COMPONENTS[name]()
    p = _random_problem(comp)
    _place_on_road(p, name)
    if name.startswith('road'):
        # road profiles are real-valued (clip/where): central differences, error ~ 1e-9
        data = p.check_partials(
            method='fd', form='central', step=1e-7, out_stream=None, compact_print=True
        )
        assert_check_partials(data, atol=1e-6, rtol=1e-6)
    else:
        data = p.check_partials(method='cs', out_stream=None, compact_print=True)
        assert_check_partials(data, atol=1e-10, rtol=1e-10)


def sparsity_mismatches(comp: om.ExplicitComponent, seed: int = 3, exact: bool = True) -> list[str]:
    """The component's true Jacobian pattern against its declared one.

    The true pattern comes from differences of ``compute`` itself, one input entry at a
    time, at random inputs, over *every* (output, input) pair: OpenMDAO 3.45's
    ``check_partials`` only compares entries inside the declared pattern, and its
    ``check_sparsity`` skips undeclared pairs and vectors, so neither sees a missing true
    nonzero. Returns one line per pair whose patterns differ (empty: exact sparsity);
    with ``exact=False`` only undeclared true nonzeros count (a road is flat in places, so
    some structural nonzeros of its input are zero at a given time)."""
    p = _random_problem(comp, seed)
    ins = {
        k: np.array(p.get_val(f'comp.{k}'), dtype=float)
        for k in comp.list_inputs(out_stream=None, prom_name=False, return_format='dict')
    }
    outs = {
        k: np.array(p.get_val(f'comp.{k}'))
        for k in comp.list_outputs(out_stream=None, prom_name=False, return_format='dict')
    }
    if 'time' in ins:
        ins['time'] = np.linspace(0.52, 0.68, ins['time'].size)

    def run(values):
        o = {k: np.zeros_like(v) for k, v in outs.items()}
        comp.compute(values, o)
        return o

    base = run(ins)
    declared = {
        (sj.of.split('.', 1)[1], sj.wrt.split('.', 1)[1]): sj for sj in declared_subjacs(comp)
    }
    problems = []
    for wrt, x in ins.items():
        cols = []
        for j in range(x.size):
            xp = {k: v.copy() for k, v in ins.items()}
            h = 1e-6 * max(1.0, abs(x.flat[j]))
            xp[wrt].flat[j] += h
            out = run(xp)
            cols.append({k: (out[k] - base[k]).ravel() / h for k in outs})
        for of in outs:
            true = np.abs(np.stack([c[of] for c in cols], axis=1)) > 1e-9 * max(
                1.0, max(np.max(np.abs(c[of])) for c in cols)
            )
            decl = np.zeros_like(true)
            sj = declared.get((of, wrt))
            if sj is not None:
                decl[sj.rows, sj.cols] = True
            missing, extra = int((true & ~decl).sum()), int((decl & ~true).sum())
            if missing or (exact and extra):
                problems.append(
                    f'd{of}/d{wrt}: {missing} true nonzeros not declared, '
                    f'{extra} declared entries that are zero'
                )
    return problems


@pytest.mark.parametrize('name', sorted(COMPONENTS))
def test_declared_sparsity_is_the_true_sparsity(name):
    """Every true nonzero is declared and nothing else (at random inputs)."""
    mismatches = sparsity_mismatches(COMPONENTS[name](), exact=not name.startswith('road'))
    assert not mismatches, mismatches


def test_sparsity_check_fails_on_a_component_missing_a_nonzero():
    """The check can fail: a suspension force that declares dF_S/dk_S at only the first
    corner (check_partials passes it) and one that forgets dF_S/dv_M are both caught."""

    class FirstCornerOnly(SuspensionForceComp):
        """Declares dF_S/dk_S at the first corner only (a pattern bug in the rows/cols);
        its values fill that pattern consistently, so check_partials sees no error."""

        def _setting_partials(self, of, wrt):
            nn, nc = self._shape
            if wrt == 'k_S':
                self.declare_partials(
                    of, wrt, rows=np.arange(0, nn * nc, nc), cols=np.zeros(nn, dtype=int)
                )
            else:
                super()._setting_partials(of, wrt)

        def compute_partials(self, inputs, partials):
            nn = self.options['num_nodes']
            k, c = np.tile(inputs['k_S'], nn), np.tile(inputs['c_S'], nn)
            partials['F_S', 'z_W'], partials['F_S', 'z_M'] = k, -k
            partials['F_S', 'v_W'], partials['F_S', 'v_M'] = c, -c
            partials['F_S', 'k_S'] = (inputs['z_W'] - inputs['z_M'])[:, 0]
            partials['F_S', 'c_S'] = (inputs['v_W'] - inputs['v_M']).ravel()

    p = _random_problem(FirstCornerOnly(num_nodes=NN, corners=4))
    assert_check_partials(p.check_partials(method='cs', out_stream=None))  # blind to it
    mismatches = sparsity_mismatches(FirstCornerOnly(num_nodes=NN, corners=4))
    assert any('dF_S/dk_S' in m and '21 true nonzeros not declared' in m for m in mismatches)

    class Forgetful(SuspensionForceComp):
        """Forgets the pair dF_S/dv_M altogether."""

        def setup(self):
            super().setup()
            self.declare_partials('F_S', 'v_M', dependent=False)

        def compute_partials(self, inputs, partials):
            nn = self.options['num_nodes']
            k, c = np.tile(inputs['k_S'], nn), np.tile(inputs['c_S'], nn)
            partials['F_S', 'z_W'], partials['F_S', 'z_M'] = k, -k
            partials['F_S', 'v_W'] = c
            partials['F_S', 'k_S'] = (inputs['z_W'] - inputs['z_M']).ravel()
            partials['F_S', 'c_S'] = (inputs['v_W'] - inputs['v_M']).ravel()

    assert any(
        'dF_S/dv_M' in m and 'not declared' in m
        for m in sparsity_mismatches(Forgetful(num_nodes=NN, corners=4))
    )


def test_road_profiles_match_formula():
    """docs/roads.md: two 1-cos bumps, h = 0.05, l = 2, at 5 and 10 m; the rear wheel a
    wheelbase behind."""
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
    gd = GridData(
        num_segments=segments, transcription='radau-ps', transcription_order=order, compressed=True
    )
    t = 0.5 * (gd.node_ptau + 1.0) * T
    assert w.shape == t.shape and np.all(w >= 0.0)
    np.testing.assert_allclose(radau_grid(segments, order)[0], gd.node_ptau, atol=1e-14)
    for k in range(2 * order - 1):
        np.testing.assert_allclose(w @ t**k, T ** (k + 1) / (k + 1), rtol=1e-12)
    # a non-polynomial integrand converges: sin over the horizon
    if segments >= 4:
        np.testing.assert_allclose(w @ np.sin(t), 1.0 - np.cos(T), rtol=1e-9)


def test_quadrature_equals_a_dymos_integrated_state():
    """docs/model.md accumulates J_k as integrated states (rate = integrand). The objective's
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
    phase = dm.Phase(
        ode_class=Integrand,
        transcription=dm.Radau(num_segments=segments, order=order, compressed=True),
    )
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
