"""Mixed-fidelity model (issue 4): half-car chassis + two black-box multibody modules."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from suspopt.studies.run import evaluate, optimize
from suspopt.transcription.problem import VehicleProblem
from suspopt.verification.timemarching import simulate
from suspopt.verification.verify import objective_value

pytestmark = pytest.mark.slow


@pytest.fixture(scope='module')
def low_design(cfg, scales):
    res = optimize(cfg, 'low', scales=scales)
    assert res.success
    return res.design


@pytest.fixture(scope='module')
def mixed_problem(cfg, scales):
    with VehicleProblem(cfg, 'mixed', scales) as vp:
        yield vp


@pytest.fixture(scope='module')
def mixed_optimum(cfg, scales, low_design, mixed_problem):
    return optimize(cfg, 'mixed', start=low_design, scales=scales, problem=mixed_problem)


@pytest.mark.parametrize('where', ['initial', 'low_optimum'])
def test_collocation_matches_time_marching(cfg, scales, low_design, mixed_problem, where):
    """Each J_k within 0.5 % (issue 4); the multibody constraints hold along the solution."""
    design = cfg.design.initial() if where == 'initial' else low_design
    res = evaluate(cfg, 'mixed', design, scales=scales, problem=mixed_problem)
    v = res.verification.comparison
    assert res.verified and v.max_rel_diff < 5e-3
    assert res.max_constraint_residual_m < 1e-10
    assert v.scenarios[0].max_constraint_residual_m < 1e-10


def test_mixed_optimum_improves_in_the_mixed_model(cfg, scales, low_design, mixed_optimum):
    assert mixed_optimum.success
    at_low = evaluate(cfg, 'mixed', low_design, scales=scales, method='time-marching')
    at_mixed = evaluate(cfg, 'mixed', mixed_optimum.design, scales=scales, method='time-marching')
    assert at_mixed.objective < at_low.objective
    assert abs(at_mixed.objective / mixed_optimum.objective - 1.0) < 5e-3
    calls = mixed_optimum.multibody_calls  # the black box really ran
    assert calls['augmented'] > 0 and calls['positions'] > 0


def test_mixed_optimum_is_local_optimum_of_time_marching(cfg, scales, mixed_optimum):
    """Independent of collocation and of derivatives: the time-marching objective (SciPy
    DOP853, rtol 1e-6: its noise, ~1e-6 of f, is far below the changes of ~1e-4 that the
    checks below resolve) around the mixed-fidelity optimum x*, with h = 2 % of each range.

    1. Along each design axis, the parabola through x* - h, x*, x* + h curves upwards,
       its minimum lies within h/4 (0.5 % of the range) of x*, and it predicts less than
       1e-5 relative decrease: x* is the 1-D time-marching optimum on every axis.
    2. A poll along four orthogonal diagonals at the same step finds no point lower than
       f(x*) (1 - 1e-5) (issue 4 asks for 0.1 %). One sign per diagonal suffices: with the
       gradient shown to vanish by 1., f(x* + d) - f(x*) and f(x* - d) - f(x*) share the
       second-order term dᵀHd/2 and differ by 2 g·d only, and a saddle shows as a
       negative dᵀHd along some diagonal."""
    names = cfg.design_names()
    lo = np.array([cfg.design[n].lower for n in names])
    hi = np.array([cfg.design[n].upper for n in names])

    def f(x):
        tr = simulate(
            cfg, 'mixed', dict(zip(names, x)), t_eval=np.array([0.0, 5.0]), rtol=1e-6, atol=1e-9
        )
        return objective_value(cfg, dict(zip(cfg.terms(), tr.J)), scales[0])

    x = np.array([mixed_optimum.design[n] for n in names])
    assert np.all((x - 0.02 * (hi - lo) >= lo) & (x + 0.02 * (hi - lo) <= hi))  # interior
    h = 0.02 * (hi - lo)
    f0 = f(x)
    for j in range(4):
        e = np.zeros(4)
        e[j] = h[j]
        fp, fm = f(x + e), f(x - e)
        curvature = fp - 2.0 * f0 + fm
        assert curvature > 0.0, names[j]
        offset = -0.5 * (fp - fm) / curvature  # parabola's minimum, in units of h
        assert abs(offset) < 0.25, (names[j], offset)
        assert (fp - fm) ** 2 / (8.0 * curvature) < 1e-5 * f0, names[j]
    diagonals = np.array([[1, 1, 1, 1], [1, -1, 1, -1], [1, 1, -1, -1], [1, -1, -1, 1]]) / 2.0
    for d in diagonals:
        trial = x + d * h
        assert f(trial) > f0 * (1.0 - 1e-5), trial


def _reduced_gradient(vp: VehicleProblem) -> np.ndarray:
    """df/dx = f_x - f_s (c_s)^-1 c_x from the NLP's total Jacobian at a converged point."""
    lay = vp.driver.layout()
    of = [lay.objective.name] + [c.name for c in lay.constraints]
    wrt = [v.name for v in lay.design_vars]
    J = vp.problem.compute_totals(of=of, wrt=wrt, return_format='array', driver_scaling=False)
    cols, start = {}, 0
    for v in lay.design_vars:
        cols[v.name] = np.arange(start, start + v.size)
        start += v.size
    x_cols = np.concatenate([cols[vp.design_var(n)] for n in vp.design_names])
    s_cols = np.setdiff1d(np.arange(J.shape[1]), x_cols)
    f_x, f_s = J[0, x_cols], J[0, s_cols]
    c_x, c_s = J[1:][:, x_cols], J[1:][:, s_cols]
    return f_x - np.linalg.solve(c_s.T, f_s) @ c_x


def test_total_derivatives_match_fd_of_converged_model(cfg, scales):
    """df/dx through the whole coupled model (analytic partials + FD partials of the
    black box, assembled by OpenMDAO) against central differences of the converged
    collocation solution (solved to 1e-13): within 1e-5 with forward (default) and with
    central FD in the black box (measured 2e-6 and 1.5e-6)."""
    x0 = {'k_S1': 32000.0, 'k_S2': 21000.0, 'c_S1': 2600.0, 'c_S2': 2200.0}
    base = cfg.replace(
        transcription=dataclasses.replace(cfg.transcription, segments=30),
        optimizer=dataclasses.replace(cfg.optimizer, tol=1e-13, options={'constr_viol_tol': 1e-14}),
    )
    guess = simulate(base, 'low', x0, rtol=1e-7, atol=1e-10)  # a start; solved to 1e-13
    grads = {}
    for form in ('central', 'forward'):
        c = base.replace(multibody=dataclasses.replace(base.multibody, fd_form=form))
        with VehicleProblem(c, 'mixed', scales, optimize_design=False) as vp:
            vp.set_design(x0)
            vp.set_initial_guess(guess)
            assert vp.solve(optimize=False).success
            grads[form] = _reduced_gradient(vp)
            if form == 'central':
                fd = []
                for name in vp.design_names:
                    h = 1e-4 * x0[name]
                    vals = []
                    for sign in (1.0, -1.0):
                        vp.set_design({**x0, name: x0[name] + sign * h})
                        assert vp.solve(optimize=False).success
                        vals.append(vp.objective())
                    fd.append((vals[0] - vals[1]) / (2 * h))
    for form, g in grads.items():
        print(
            f'reduced gradient, {form} FD in the black box: largest relative difference '
            f'to central differences of the converged model {np.max(np.abs(g / fd - 1)):.1e}'
        )
    np.testing.assert_allclose(grads['central'], fd, rtol=1e-5)
    np.testing.assert_allclose(grads['forward'], fd, rtol=1e-5)


def test_check_totals_of_the_nlp(cfg, scales):
    """OpenMDAO's check_totals on the NLP functions (objective and defects) w.r.t. the
    design, at a non-converged point: MAUD assembly of analytic and FD partials."""
    small = cfg.replace(transcription=dataclasses.replace(cfg.transcription, segments=8))
    with VehicleProblem(small, 'mixed', scales) as vp:
        x0 = {'k_S1': 32000.0, 'k_S2': 21000.0, 'c_S1': 2600.0, 'c_S2': 2200.0}
        vp.set_design(x0)
        vp.set_initial_guess(simulate(small, 'low', x0, rtol=1e-7, atol=1e-10))
        p = vp.problem
        p.run_model()
        wrt = [vp.design_var(n) for n in vp.design_names]
        of = ['objective.f'] + [c.name for c in vp.driver.layout().constraints]
        data = p.check_totals(
            of=of,
            wrt=wrt,
            method='fd',
            form='central',
            step=1e-3,
            step_calc='rel',
            out_stream=None,
            driver_scaling=False,
        )
    worst = 0.0
    for _, d in data.items():
        J_fd, J_an = np.asarray(d['J_fd']), np.asarray(d['J_fwd'])
        scale = max(np.max(np.abs(J_fd)), 1e-30)
        worst = max(worst, np.max(np.abs(J_an - J_fd)) / scale)
    print(f"check_totals: largest difference {worst:.1e} of each block's largest entry")
    assert worst < 1e-4


def test_another_linkage_in_the_vehicle(cfg, scales):
    """Another suspension type is a data file: the short-long-arm double wishbone (its
    upright rotates with travel; spring on the lower arm) front and rear, with no code
    change. The coupled model still agrees with its time marching within 0.5 % on every
    J_k, and it is a different car from the parallelogram one."""
    import dataclasses as dc

    v = cfg.vehicle
    sla = cfg.replace(
        vehicle=dc.replace(
            v,
            front=dc.replace(v.front, mechanism='sla_double_wishbone'),
            rear=dc.replace(v.rear, mechanism='sla_double_wishbone'),
        )
    )
    design = cfg.design.initial()
    res = evaluate(sla, 'mixed', design, scales=scales)
    v = res.verification.comparison
    tm = np.array([v.scenarios[0].terms[t] for t in cfg.terms()])
    print(f'\nSLA car: J = {tm}, collocation vs time marching {v.max_rel_diff:.1e}')
    assert res.verified and v.max_rel_diff < 5e-3
    assert res.max_constraint_residual_m < 1e-10
    parallelogram = simulate(cfg, 'mixed', design, t_eval=np.array([0.0, 5.0])).J
    assert np.max(np.abs(tm / parallelogram - 1.0)) > 0.05


def test_the_recorder_keeps_no_multibody_module_in_its_metadata(cfg, scales, tmp_path):
    """The case recorder's system metadata holds no VehicleSpec, multibody module or
    phase ODE arguments (megabytes per system and per setup, with the modules' kept poses
    and tables; nothing reads them back), and the recorded trajectory is still there."""
    import openmdao.api as om

    from suspopt.output.rundir import read_trajectory

    small = cfg.replace(transcription=dataclasses.replace(cfg.transcription, segments=8))
    path = tmp_path / 'mixed.sql'
    with VehicleProblem(small, 'mixed', scales, recorder=path) as vp:
        vp.problem.run_model()
        vp.problem.record('check')
    reader = om.CaseReader(str(path))
    options = {name: set(opts) for name, opts in reader.list_model_options(out_stream=None).items()}
    assert 'traj.phases.s0.rhs_all.kinematics' in options  # the black boxes were recorded
    holding = sorted(n for n, o in options.items() if {'spec', 'modules', 'ode_init_kwargs'} & o)
    assert not holding, holding
    assert read_trajectory(reader, 'check') is not None
    assert path.stat().st_size < 5e6
