"""IpoptDriver on small problems with known answers (independent of Dymos)."""

from __future__ import annotations

import json

import numpy as np
import openmdao.api as om
import pytest

from suspopt.driver import IpoptDriver


class Paraboloid(om.ExplicitComponent):
    """f = (x-3)² + xy + (y+4)² - 3; optional NaN region to emulate a failing model."""

    def initialize(self):
        self.options.declare('nan_above', default=np.inf)

    def setup(self):
        self.add_input('x', 0.0)
        self.add_input('y', 0.0)
        self.add_output('f', 0.0)
        self.add_output('g', 0.0)
        self.declare_partials('*', '*')

    def compute(self, inputs, outputs):
        x, y = inputs['x'][0], inputs['y'][0]
        outputs['f'] = (x - 3.0) ** 2 + x * y + (y + 4.0) ** 2 - 3.0
        if x > self.options['nan_above']:
            outputs['f'] = np.nan
        outputs['g'] = x + y

    def compute_partials(self, inputs, J):
        x, y = inputs['x'][0], inputs['y'][0]
        J['f', 'x'] = 2.0 * (x - 3.0) + y
        J['f', 'y'] = x + 2.0 * (y + 4.0)
        J['g', 'x'] = 1.0
        J['g', 'y'] = 1.0


def _problem(con=None, nan_above=np.inf, x0=(0.0, 0.0), **opts):
    p = om.Problem(reports=False)
    p.model.add_subsystem('comp', Paraboloid(nan_above=nan_above), promotes=['*'])
    p.model.add_design_var('x', lower=-50.0, upper=50.0)
    p.model.add_design_var('y', lower=-50.0, upper=50.0)
    p.model.add_objective('f')
    if con:
        p.model.add_constraint('g', **con)
    opt_settings = opts.pop('opt_settings', {})
    p.driver = p.ipopt = IpoptDriver(**opts)
    p.driver.opt_settings.update(opt_settings)
    p.setup()
    p.set_val('x', x0[0])
    p.set_val('y', x0[1])
    p.final_setup()
    p.run = lambda: p.run_driver().success
    return p


def test_unconstrained_minimum():
    """Analytic minimum: x = 20/3, y = -22/3, f = -27.333..."""
    p = _problem()
    assert p.run()
    assert p.ipopt.status == 0
    np.testing.assert_allclose([p.get_val('x')[0], p.get_val('y')[0]], [20 / 3, -22 / 3], rtol=1e-6)
    np.testing.assert_allclose(p.get_val('f')[0], -82 / 3, rtol=1e-8)


def test_two_sided_constraint_and_progress():
    """x + y = 1 (equality): on y = 1 - x, f = x² - 15x + 31, minimum at x = 7.5, y = -6.5.
    With -15 <= x + y <= 0 the unconstrained optimum (x + y = -2/3) is feasible."""
    seen = []
    p = _problem(con={'equals': 1.0}, progress=seen.append)
    p.run()
    assert p.ipopt.status == 0
    np.testing.assert_allclose([p.get_val('x')[0], p.get_val('y')[0]], [7.5, -6.5], rtol=1e-6)
    assert seen and seen[-1].constraint_violation < 1e-8
    assert [s.iteration for s in seen] == list(range(len(seen)))
    p2 = _problem(con={'lower': -15.0, 'upper': 0.0})
    p2.run()
    np.testing.assert_allclose(p2.get_val('x')[0], 20 / 3, rtol=1e-6)


def test_iteration_limit_is_a_failure():
    p = _problem(max_iter=1)
    assert p.run() is False
    assert p.ipopt.status_message == 'Maximum_Iterations_Exceeded'


def test_nan_region_is_avoided_by_backtracking():
    """The model returns NaN for x > 8: IPOPT is told the evaluation failed, cuts the
    step and still converges to the minimum at x = 20/3."""
    p = _problem(nan_above=8.0, x0=(7.9, 0.0))
    p.run()
    assert p.ipopt.status == 0
    np.testing.assert_allclose(p.get_val('x')[0], 20 / 3, rtol=1e-6)


def test_nan_at_start_is_reported():
    p = _problem(nan_above=-1.0, x0=(0.0, 0.0))
    assert p.run() is False
    assert 'NaN' in (p.ipopt.last_error or '')


def test_pinned_variable_is_held():
    p = _problem(pinned=['x'], x0=(2.0, 0.0))
    p.run()
    assert p.get_val('x')[0] == 2.0
    np.testing.assert_allclose(p.get_val('y')[0], -5.0, rtol=1e-6)  # df/dy = 2 + 2(y+4) = 0


def test_write_json_is_atomic(tmp_path):
    """A failure while writing leaves the previous file intact and no temporary files."""
    from suspopt.output.rundir import write_json

    path = tmp_path / 'result.json'
    write_json(path, {'a': 1})
    with pytest.raises(TypeError):
        write_json(path, {'a': 2, 'b': object()})
    assert json.loads(path.read_text()) == {'a': 1}
    assert [p.name for p in tmp_path.iterdir()] == ['result.json']


@pytest.mark.parametrize(
    'given, used',
    [({}, 'extended'), ({'limited_memory_aug_solver': 'sherman-morrison'}, 'sherman-morrison')],
)
def test_limited_memory_update_in_the_augmented_system_unless_the_study_says(tmp_path, given, used):
    """IPOPT runs with the driver's ``limited_memory_aug_solver = extended`` (read back
    from IPOPT's own list of the options it was given); a study's option overrides it."""
    log = tmp_path / 'ipopt.out'
    p = _problem(
        opt_settings={
            'output_file': str(log),
            'file_print_level': 5,
            'print_user_options': 'yes',
            **given,
        }
    )
    assert p.run()
    lines = [ln.split() for ln in log.read_text().splitlines()]
    assert ['limited_memory_aug_solver', '=', used] in [ln[:3] for ln in lines]
