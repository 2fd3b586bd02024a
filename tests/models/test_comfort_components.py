"""The ride-comfort components (suspopt.models.comfort): partials, exact sparsity, the
seat kinematics' signs, the filter component against the weighting's transfer function,
and the filter states integrated by Dymos' Radau collocation."""

from __future__ import annotations

import dataclasses

import numpy as np
import openmdao.api as om
import pytest
from openmdao.core.analysis_error import AnalysisError
from openmdao.utils.assert_utils import assert_check_partials
from scipy.linalg import expm

from suspopt.driver.structure import declared_subjacs
from suspopt.errors import ConfigError
from suspopt.models import equations as eq
from suspopt.models import iso2631 as iso
from suspopt.models.comfort import SeatAccelerationComp, WeightingFilterComp

NN = 6
SEATS = dict(x=np.array([0.45, 0.45, -0.55, 0.0]), y=np.array([0.37, -0.37, 0.0, 0.0]))
WJ_NO_LOW_PASS = iso.Weighting('Wj*', f2=None, f5=3.75, Q5=0.91, f6=5.32, Q6=0.91)

COMPONENTS = {
    'seats_half': lambda: SeatAccelerationComp(num_nodes=NN, x=SEATS['x']),
    'seats_full': lambda: SeatAccelerationComp(num_nodes=NN, roll=True, **SEATS),
    'filter_wk': lambda: WeightingFilterComp(num_nodes=NN, weightings=('Wk',)),
    # a feedthrough D (Wj without its low pass) and mixed channels
    'filter_bank': lambda: WeightingFilterComp(
        num_nodes=NN, weightings=('Wk', 'Wk', 'We', WJ_NO_LOW_PASS), units=None
    ),
}


def _problem(comp: om.ExplicitComponent, seed: int = 0) -> om.Problem:
    p = om.Problem(reports=False)
    p.model.add_subsystem('comp', comp)
    p.setup(force_alloc_complex=True)
    rng = np.random.default_rng(seed)
    for name, meta in comp.list_inputs(
        out_stream=None, prom_name=False, shape=True, return_format='dict'
    ).items():
        p.set_val(f'comp.{name}', rng.normal(size=meta['shape']))
    p.run_model()
    return p


def _pattern_mismatches(comp: om.ExplicitComponent) -> list[str]:
    """The true Jacobian pattern (complex step of ``compute``, one input entry at a
    time: exact for these linear components) against the declared rows/cols, for every
    (output, input) pair, declared or not."""
    p = _problem(comp)
    ins = {
        k: np.array(p.get_val(f'comp.{k}'), dtype=complex)
        for k in comp.list_inputs(out_stream=None, prom_name=False, return_format='dict')
    }
    outs = {
        k: np.array(p.get_val(f'comp.{k}'), dtype=complex)
        for k in comp.list_outputs(out_stream=None, prom_name=False, return_format='dict')
    }
    declared = {(s.of.split('.', 1)[1], s.wrt.split('.', 1)[1]): s for s in declared_subjacs(comp)}
    problems = []
    for wrt, x in ins.items():
        cols = []
        for j in range(x.size):
            xp = {k: v.copy() for k, v in ins.items()}
            xp[wrt].flat[j] += 1e-30j
            o = {k: np.zeros_like(v) for k, v in outs.items()}
            comp.compute(xp, o)
            cols.append({k: o[k].imag.ravel() / 1e-30 for k in outs})
        for of in outs:
            true = np.stack([c[of] for c in cols], axis=1) != 0.0
            decl = np.zeros_like(true)
            sj = declared.get((of, wrt))
            if sj is not None:
                decl[sj.rows, sj.cols] = True
            missing, extra = int((true & ~decl).sum()), int((decl & ~true).sum())
            if missing or extra:
                problems.append(f'd{of}/d{wrt}: {missing} missing, {extra} extra')
    return problems


@pytest.mark.parametrize('name', sorted(COMPONENTS))
def test_check_partials(name):
    p = _problem(COMPONENTS[name]())
    data = p.check_partials(method='cs', out_stream=None, compact_print=True)
    assert_check_partials(data, atol=1e-10, rtol=1e-10)


@pytest.mark.parametrize('name', sorted(COMPONENTS))
def test_declared_sparsity_is_the_true_sparsity(name):
    """Every true nonzero is declared and nothing else (a seat on the CG declares no
    pitch or roll entry; only the filters' nonzero matrix entries are declared)."""
    assert _pattern_mismatches(COMPONENTS[name]()) == []


def test_sparsity_check_sees_a_missing_entry():
    """The pattern check can fail: a filter component that forgets the input's entry into
    the state rates (check_partials alone only compares declared entries)."""

    class Forgetful(WeightingFilterComp):
        def setup(self):
            super().setup()
            self.declare_partials('filter_x_dot', 'signal', dependent=False)

    assert _pattern_mismatches(Forgetful(num_nodes=NN, weightings=('Wd',))) == [
        f'dfilter_x_dot/dsignal: {NN} missing, 0 extra'
    ]


def test_filter_partials_are_block_diagonal_per_node():
    """dx'/dx holds A's nonzeros once per node, nothing across nodes."""
    comp = WeightingFilterComp(num_nodes=NN, weightings=('Wk', 'We'))
    _problem(comp)
    (sj,) = [
        s
        for s in declared_subjacs(comp)
        if s.of.endswith('filter_x_dot') and s.wrt.endswith('filter_x')
    ]
    n = comp.bank.n_states
    assert np.array_equal(sj.rows // n, sj.cols // n)
    assert sj.rows.size == NN * np.count_nonzero(comp.bank.system.A)


def test_seat_at_the_cg_is_the_heave_and_ahead_sees_pitch_nose_down():
    """A seat at the CG moves with the heave; a seat 1 m ahead drops by 1 m/s² under a
    nose-down pitch acceleration of 1 rad/s²; a left seat rises with the roll (left side
    up); and the equation agrees with the chassis mount kinematics of the vehicle model."""
    zdd, thdd, phidd = np.array([0.3, -1.1]), np.array([1.0, 0.4]), np.array([0.0, 2.0])
    x, y = np.array([0.0, 1.0, -0.8, 0.5]), np.array([0.0, 0.0, 0.4, -0.6])
    a = eq.seat_acceleration(zdd, thdd, phidd, x, y)
    np.testing.assert_allclose(a[:, 0], zdd)
    assert a[0, 1] == pytest.approx(0.3 - 1.0)  # 1 m ahead, 1 rad/s² nose down
    assert a[1, 2] == pytest.approx(-1.1 + 0.8 * 0.4 + 0.4 * 2.0)  # behind, left
    np.testing.assert_allclose(a, eq.mount_motion(zdd, thdd, phidd, x, y), rtol=1e-15)
    p = om.Problem(reports=False)
    p.model.add_subsystem('seats', SeatAccelerationComp(num_nodes=2, x=x, y=y, roll=True))
    p.setup()
    for name, val in (('zdd_C', zdd), ('thdd_C', thdd), ('phidd_C', phidd)):
        p.set_val(f'seats.{name}', val)
    p.run_model()
    np.testing.assert_allclose(p.get_val('seats.a_seat'), a, rtol=1e-15)


def test_seat_options_must_match():
    p = om.Problem(reports=False)
    p.model.add_subsystem('s', SeatAccelerationComp(num_nodes=2, x=np.zeros(2), y=np.zeros(3)))
    with pytest.raises(ConfigError, match=r'seats\.y: 3 positions for 2 seats'):
        p.setup()


def test_filter_component_on_a_sinusoidal_steady_state():
    """At the steady state of a sine input u = Re(U e^{jωt}), x = Re(X e^{jωt}) with
    X = (jωI - A)⁻¹ B U, the component's rates are Re(jω X e^{jωt}) and its output is
    Re(W(jω) U e^{jωt}), W the product of the standard's factors (not the realization)."""
    f, nn = 4.0, 9
    comp = WeightingFilterComp(num_nodes=nn, weightings=('Wk', 'We'))
    p = om.Problem(reports=False)
    p.model.add_subsystem('w', comp, promotes=['*'])
    p.setup()
    bank = comp.bank
    ss, jw = bank.system, 2j * np.pi * f
    U = np.array([1.0 + 0.5j, -0.3 + 0.8j])
    X = np.linalg.solve(jw * np.eye(ss.n_states) - ss.A, ss.B @ U)
    t = np.linspace(0.0, 0.3, nn)[:, None]
    phase = np.exp(jw * t)
    p.set_val('signal', (U * phase).real, units='m/s**2')
    p.set_val('filter_x', (X * phase).real, units='m/s**2')
    p.run_model()
    np.testing.assert_allclose(p.get_val('filter_x_dot'), (jw * X * phase).real, atol=1e-12)
    W = np.array([w.response(f) for w in bank.weightings])
    np.testing.assert_allclose(p.get_val('weighted'), (W * U * phase).real, atol=1e-12)
    units = {m['prom_name']: m['units'] for m in comp.get_io_metadata(('output',)).values()}
    assert units == {'filter_x_dot': 'm/s**3', 'weighted': 'm/s**2'}


SINE_HZ, HORIZON = 5.0, 3.0


def _collocate(w: iso.Weighting, segments: int) -> tuple[np.ndarray, ...]:
    """The filter states of ``w`` as one Dymos state vector (rate_source
    ``filter_x_dot``) and J = ∫ a_w² dt, driven by a unit 5 Hz sine from rest, solved
    by Radau collocation of order 5 (solve_segments, Newton): time, a_w, J at the nodes."""
    import dymos as dm

    weightings = (w,)
    n_states = iso.filter_bank(weightings).n_states

    class ODE(om.Group):
        def initialize(self):
            self.options.declare('num_nodes', types=int)

        def setup(self):
            nn = self.options['num_nodes']
            sine = om.ExecComp(
                f'u = sin({2 * np.pi * SINE_HZ} * time)',
                u={'shape': (nn, 1), 'units': 'm/s**2'},
                time={'shape': (nn, 1), 'units': 's'},
                has_diag_partials=True,
            )
            self.add_subsystem('sine', sine, promotes_inputs=['time'])
            self.add_subsystem(
                'comfort',
                WeightingFilterComp(num_nodes=nn, weightings=weightings),
                promotes_outputs=['filter_x_dot', 'weighted'],
                promotes_inputs=['filter_x'],
            )
            self.connect('sine.u', 'comfort.signal')
            square = om.ExecComp(
                'a2 = weighted**2',
                a2={'shape': (nn, 1), 'units': 'm**2/s**4'},
                weighted={'shape': (nn, 1), 'units': 'm/s**2'},
                has_diag_partials=True,
            )
            self.add_subsystem('square', square, promotes=['*'])

    p = om.Problem(reports=False)
    tx = dm.Radau(num_segments=segments, order=5, solve_segments='forward')
    phase = dm.Phase(ode_class=ODE, transcription=tx)
    p.model.add_subsystem('phase', phase)
    phase.set_time_options(fix_initial=True, fix_duration=True, units='s', targets=['time'])
    phase.add_state(
        'x_w',
        shape=(n_states,),
        rate_source='filter_x_dot',
        targets=['filter_x'],
        units='m/s**2',
        fix_initial=True,
    )
    phase.add_state('J', rate_source='a2', units='m**2/s**3', fix_initial=True)
    phase.add_timeseries_output('weighted')
    phase.nonlinear_solver = om.NewtonSolver(solve_subsystems=True, maxiter=10, iprint=-1)
    phase.nonlinear_solver.options['err_on_non_converge'] = True
    phase.linear_solver = om.DirectSolver()
    p.setup()
    phase.set_time_val(initial=0.0, duration=HORIZON)
    phase.set_state_val('x_w', 0.0)
    phase.set_state_val('J', 0.0)
    p.run_model()
    return tuple(p.get_val(f'phase.timeseries.{k}')[:, 0] for k in ('time', 'weighted', 'J'))


@pytest.mark.parametrize(
    'low_pass, segments, tol',
    [(True, 100, 5e-3), (False, 30, 1e-2)],
    ids=['Wk', 'Wk without low pass'],
)
def test_filter_states_in_dymos_radau_collocation(low_pass, segments, tol):
    """a_w from Radau collocation equals the exact solution C (x_ss(t) + e^{At}(x0 -
    x_ss(0))) of the same linear ODE at the nodes (to ``tol`` of its peak, the largest
    error in the first segments' fast transient), and ∫ a_w² dt over the last second
    gives the steady r.m.s. |W(5 Hz)|/√2. ``f2=None`` drops the 100 Hz low pass."""
    w = iso.WK if low_pass else dataclasses.replace(iso.WK, f2=None)
    t, a_w, J = _collocate(w, segments)
    ss, jw = w.state_space, 2j * np.pi * SINE_HZ
    X = np.linalg.solve(jw * np.eye(ss.n_states) - ss.A, -1j * ss.B[:, 0])  # sin = Re(-j e^jωt)
    x_ss = (X[None, :] * np.exp(jw * t)[:, None]).real
    x = x_ss - np.array([expm(ss.A * ti) @ x_ss[0] for ti in t])
    exact = x @ ss.C[0]
    err = np.max(np.abs(a_w - exact)) / np.max(np.abs(exact))
    assert err < tol, err
    rms = np.sqrt(J[-1] - np.interp(HORIZON - 1.0, t, J))
    assert rms == pytest.approx(w.magnitude(SINE_HZ) / np.sqrt(2.0), rel=1e-3)


def test_the_low_pass_needs_short_radau_segments():
    """Dymos' Radau collocates at each segment's left end; its stability function grows
    without bound for stiff modes (|R(z)| > 1 beyond |z| ≈ 23 at order 5 and damping
    1/√2). The 100 Hz band-limiting low pass (|λ| = 628 rad/s) therefore diverges on
    0.05 s segments (|z| = 31) where the 0.03 s segments above are stable."""
    with pytest.raises(AnalysisError):
        _collocate(iso.WK, 60)
