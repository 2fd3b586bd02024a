"""IpoptDriver as an OpenMDAO driver: run_driver, the driver's recorder, debug_print, the
failure flag and DriverResult, option checks (small problems with known answers)."""

from __future__ import annotations

import numpy as np
import openmdao.api as om
import pytest

from suspopt.driver import IpoptDriver


class Paraboloid(om.ExplicitComponent):
    """f = (x-3)² + xy + (y+4)² - 3, g = x + y (minimum of f at x = 20/3, y = -22/3)."""

    def setup(self):
        self.add_input('x', 0.0)
        self.add_input('y', 0.0)
        self.add_output('f', 0.0)
        self.add_output('g', 0.0)
        self.declare_partials('*', '*')

    def compute(self, inputs, outputs):
        x, y = inputs['x'][0], inputs['y'][0]
        outputs['f'] = (x - 3.0) ** 2 + x * y + (y + 4.0) ** 2 - 3.0
        outputs['g'] = x + y

    def compute_partials(self, inputs, J):
        x, y = inputs['x'][0], inputs['y'][0]
        J['f', 'x'] = 2.0 * (x - 3.0) + y
        J['f', 'y'] = x + 2.0 * (y + 4.0)
        J['g', 'x'] = 1.0
        J['g', 'y'] = 1.0


def _problem(x0=(0.0, 0.0), con=None, **opts) -> om.Problem:
    p = om.Problem(reports=False)
    p.model.add_subsystem('comp', Paraboloid(), promotes=['*'])
    p.model.add_design_var('x', lower=-50.0, upper=50.0)
    p.model.add_design_var('y', lower=-50.0, upper=50.0)
    p.model.add_objective('f')
    if con:
        p.model.add_constraint('g', **con)
    p.driver = IpoptDriver(**opts)
    p.setup()
    p.set_val('x', x0[0])
    p.set_val('y', x0[1])
    return p


def test_run_driver_solves_and_returns_openmdaos_driver_result():
    """x + y = 1: on y = 1 - x, f = x² - 15x + 31, minimum at x = 7.5."""
    p = _problem(con={'equals': 1.0})
    result = p.run_driver()
    assert result.success and result.exit_status == 'Solve_Succeeded'
    assert result.iter_count == p.driver.history[-1].iteration > 0
    assert result.model_evals == p.driver.n_function_evals > 0
    assert result.deriv_evals == p.driver.n_gradient_evals > 0
    np.testing.assert_allclose([p.get_val('x')[0], p.get_val('y')[0]], [7.5, -6.5], rtol=1e-6)
    assert p.driver.run() is False  # OpenMDAO's failure flag: False when converged


def test_failure_flag_and_result_when_ipopt_stops_early():
    p = _problem(max_iter=1)
    result = p.run_driver()
    assert not result.success and result.exit_status == 'Maximum_Iterations_Exceeded'
    assert p.driver.run() is True


def test_the_drivers_recorder_records_every_accepted_iteration(tmp_path):
    """One case per IPOPT iteration (0 … N), each at IPOPT's accepted iterate: its
    recorded objective is the one IPOPT reported for that iteration, and the last case is
    the optimum."""
    path = tmp_path / 'cases.sql'
    p = _problem(x0=(40.0, 40.0))
    p.driver.add_recorder(om.SqliteRecorder(str(path)))
    p.driver.recording_options['record_desvars'] = True
    p.driver.recording_options['record_objectives'] = True
    p.run_driver()
    p.cleanup()
    history = p.driver.history
    cases = om.CaseReader(str(path)).get_cases('driver', recurse=False)
    assert len(cases) == len(history) == history[-1].iteration + 1 > 3
    f = [float(c.get_objectives()['f'][0]) for c in cases]
    np.testing.assert_allclose(f, [h.objective for h in history], rtol=1e-12)
    assert [c.name.rsplit('|', 1)[-1] for c in cases] == [str(i) for i in range(len(cases))]
    np.testing.assert_allclose(
        [cases[-1].get_design_vars()['x'][0], cases[-1].get_design_vars()['y'][0]],
        [20 / 3, -22 / 3],
        rtol=1e-6,
    )


def test_openmdaos_debug_print_shows_each_iteration(capsys):
    p = _problem(x0=(1.0, 1.0))
    p.driver.options['debug_print'] = ['desvars', 'objs', 'totals']
    p.run_driver()
    out = capsys.readouterr().out
    n = len(p.driver.history)
    assert out.count('Design Vars') == n and out.count('Objectives') == n
    assert 'Driver total derivatives for iteration' in out


def test_pinned_option_holds_a_design_variable():
    p = _problem(x0=(2.0, 0.0), pinned=['x'])
    p.run_driver()
    assert p.get_val('x')[0] == 2.0
    np.testing.assert_allclose(p.get_val('y')[0], -5.0, rtol=1e-6)  # df/dy = 2 + 2(y+4) = 0


def test_bad_options_are_refused():
    with pytest.raises(ValueError, match='hessian'):
        IpoptDriver(hessian='newton')
    with pytest.raises(TypeError, match='progress'):
        IpoptDriver(progress=3)
    p = _problem(pinned=['z'])
    with pytest.raises(ValueError, match=r"pinned \['z'\]"):
        p.run_driver()


@pytest.mark.parametrize('behavior', ['warn', 'raise'])
def test_an_initial_design_outside_its_bounds_follows_invalid_desvar_behavior(behavior):
    p = _problem(x0=(60.0, 0.0), invalid_desvar_behavior=behavior)
    if behavior == 'raise':
        with pytest.raises(ValueError, match='x are out of their bounds'):
            p.run_driver()
    else:
        with pytest.warns(om.DriverWarning, match='x are out of their bounds'):
            assert p.run_driver().success


def test_exact_hessian_of_a_quadratic_and_the_recorder_at_ipopts_iterates(tmp_path):
    """f's Hessian is [[2, 1], [1, 2]] (IPOPT's lower triangle, driver scaling = 1); with it
    IPOPT needs fewer iterations than with L-BFGS. Its finite differences move the model
    off IPOPT's iterate, and each recorded case is still IPOPT's iterate."""
    path = tmp_path / 'cases.sql'
    p = _problem(x0=(40.0, 40.0), hessian='exact')
    p.driver.add_recorder(om.SqliteRecorder(str(path)))
    p.final_setup()
    p.driver.prepare()
    rows, cols = p.driver.hessianstructure()
    H = np.zeros((2, 2))
    H[rows, cols] = p.driver.hessian(np.array([1.0, 2.0]), np.zeros(0), 1.0)
    np.testing.assert_allclose(H, [[2.0, 0.0], [1.0, 2.0]], rtol=1e-6, atol=1e-7)
    assert p.run_driver().success
    p.cleanup()
    history = p.driver.history
    lbfgs = _problem(x0=(40.0, 40.0))
    lbfgs.run_driver()
    assert p.driver.n_hessian_evals > 0
    assert history[-1].iteration < lbfgs.driver.history[-1].iteration
    cases = om.CaseReader(str(path)).get_cases('driver', recurse=False)
    f = [float(c.get_objectives()['f'][0]) for c in cases]
    np.testing.assert_allclose(f, [h.objective for h in history], rtol=1e-12)
    np.testing.assert_allclose([p.get_val('x')[0], p.get_val('y')[0]], [20 / 3, -22 / 3])


class Implicit(om.ImplicitComponent):
    """r = y - x² = 0 (an implicit component: no propagated totals, no exact Hessian)."""

    def setup(self):
        self.add_input('x', 1.0)
        self.add_output('y', 1.0)
        self.declare_partials('y', ['x', 'y'])

    def apply_nonlinear(self, inputs, outputs, residuals):
        residuals['y'] = outputs['y'] - inputs['x'] ** 2

    def solve_nonlinear(self, inputs, outputs):
        outputs['y'] = inputs['x'] ** 2

    def linearize(self, inputs, outputs, J):
        J['y', 'x'] = -2.0 * inputs['x']
        J['y', 'y'] = 1.0


def test_exact_hessian_falls_back_to_lbfgs_where_the_data_flow_is_not_read():
    p = om.Problem(reports=False)
    p.model.add_subsystem('c', Implicit(), promotes=['*'])
    p.model.add_subsystem('f', om.ExecComp('f = (y - 2)**2'), promotes=['*'])
    p.model.linear_solver = om.DirectSolver()
    p.model.add_design_var('x', lower=0.0, upper=3.0)
    p.model.add_objective('f')
    p.driver = IpoptDriver(hessian='exact')
    p.setup()
    with pytest.warns(om.DriverWarning, match='using limited-memory'):
        assert p.run_driver().success
    assert p.driver.n_hessian_evals == 0
    np.testing.assert_allclose(p.get_val('x')[0], np.sqrt(2.0), rtol=1e-6)


def test_a_case_is_recorded_at_ipopts_iterate_even_if_the_model_was_run_elsewhere(tmp_path):
    """IPOPT may have evaluated other points after accepting its iterate (a watchdog step,
    the Hessian's differences): the driver runs the model at the iterate to record it."""

    class Iterate:  # what cyipopt tells during a solve
        def get_current_iterate(self, scaled):
            return {'x': np.array([1.0, 2.0])}

    path = tmp_path / 'cases.sql'
    p = _problem()
    p.driver.add_recorder(om.SqliteRecorder(str(path)))
    p.final_setup()
    drv = p.driver
    drv.prepare()
    drv.objective(np.array([5.0, -3.0]))  # the model elsewhere
    drv._nlp = Iterate()
    drv.intermediate(0, 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0)
    p.cleanup()
    (case,) = om.CaseReader(str(path)).get_cases('driver', recurse=False)
    # f(1, 2) = 4 + 2 + 36 - 3
    assert float(case.get_objectives()['f'][0]) == 39.0
