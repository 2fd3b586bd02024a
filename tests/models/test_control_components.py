"""The controlled suspension's components (:mod:`suspopt.models.control`): partials by
complex step, the declared sparsity against the true one, and their equations against
closed forms."""

from __future__ import annotations

import numpy as np
import pytest
from openmdao.utils.assert_utils import assert_check_partials
from test_components import _random_problem, sparsity_mismatches

from suspopt.models.control import (
    ActiveForceComp,
    LinearFeedbackComp,
    SkyGroundhookComp,
    StrutRateComp,
    VariableDamperComp,
    smooth_clip,
    smooth_clip_slope,
)
from suspopt.models.settings import SuspensionSettingsComp

NN = 6
#: a full car with actuators at three of its four corners (the scatter is not an identity)
SOME = dict(num_nodes=NN, corners=4, controlled=(0, 2, 3))

COMPONENTS = {
    'strut_rate': lambda: StrutRateComp(num_nodes=NN, corners=4),
    'active_force': lambda: ActiveForceComp(**SOME),
    'active_force_quarter': lambda: ActiveForceComp(num_nodes=NN, corners=1, controlled=(0,)),
    'variable_damper': lambda: VariableDamperComp(**SOME),
    # some of the random commands beyond the limits (saturated, slope 0), some within
    'active_force_saturated': lambda: ActiveForceComp(limits=(-1.2, 1.2), **SOME),
    'variable_damper_saturated': lambda: VariableDamperComp(limits=(-1.0, 1.4), **SOME),
    'linear_feedback': lambda: LinearFeedbackComp(**SOME),
    # the random inputs are O(1): a range, floor and width of that size put them on every
    # part of the clip (below, inside, above) and the quotient's peak
    'skyhook': lambda: SkyGroundhookComp(
        c_min=0.3, c_max=1.5, smoothing=0.2, velocity_floor=0.4, **SOME
    ),
    'settings_gains': lambda: SuspensionSettingsComp(
        design=('k_S1', 'k_S2', 'c_S1', 'c_S2', 'g_sky1', 'g_gnd2', 'g_tr1', 'g_rt2'),
        labels=('1L', '1R', '2L', '2R'),
    ),
}


@pytest.mark.parametrize('name', sorted(COMPONENTS))
def test_check_partials(name):
    p = _random_problem(COMPONENTS[name]())
    data = p.check_partials(method='cs', out_stream=None, compact_print=True)
    assert_check_partials(data, atol=1e-10, rtol=1e-10)


@pytest.mark.parametrize('name', sorted(COMPONENTS))
def test_declared_sparsity_is_the_true_sparsity(name):
    # a saturated command has zero partials where it is beyond the limits
    mismatches = sparsity_mismatches(COMPONENTS[name](), exact='saturated' not in name)
    assert not mismatches, mismatches


def test_sparsity_check_sees_a_damper_that_forgets_the_velocity():
    """Broken once: a variable damper declaring dF_A/dv_A at the first controlled corner
    only is caught by the sparsity check."""

    class Forgetful(VariableDamperComp):
        def setup(self):
            super().setup()
            nn, nc = self._shape
            rows = np.arange(nn) * nc + self._idx[0]
            self.declare_partials('F_A', 'v_A', rows=rows, cols=rows)

        def compute_partials(self, inputs, partials):
            super().compute_partials(inputs, partials)
            partials['F_A', 'c_A'] = self._picked(inputs['v_A']).ravel()
            partials['F_A', 'v_A'] = np.asarray(inputs['c_A'])[:, 0]

    mismatches = sparsity_mismatches(Forgetful(**SOME))
    assert any('dF_A/dv_A' in m and 'not declared' in m for m in mismatches), mismatches


def test_actuators_act_at_their_corners_only():
    rng = np.random.default_rng(1)
    v = rng.normal(size=(NN, 4))
    u = rng.normal(size=(NN, 3))
    out = ActiveForceComp(**SOME).evaluate({'u_A': u, 'v_A': v})
    assert np.array_equal(out['F_A'][:, [0, 2, 3]], u) and not out['F_A'][:, 1].any()
    np.testing.assert_allclose(out['P_A'], u * v[:, [0, 2, 3]])
    c = rng.uniform(100.0, 3000.0, size=(NN, 3))
    out = VariableDamperComp(**SOME).evaluate({'c_A': c, 'v_A': v})
    np.testing.assert_allclose(out['u_F'], c * v[:, [0, 2, 3]])
    assert np.all(out['P_A'] >= 0.0)  # a damper only dissipates
    assert not out['F_A'][:, 1].any()


def test_linear_feedback_in_closed_form():
    """u = -g_sky v_M + g_gnd v_W + g_tr (z_W - z_M) + g_rt (v_W - v_M), per corner."""
    g = {'g_sky': 1500.0, 'g_gnd': 300.0, 'g_tr': -2000.0, 'g_rt': 250.0}
    comp = LinearFeedbackComp(num_nodes=1, corners=2, controlled=(1,))
    values = {
        'z_M': np.array([[0.0, 0.01]]),
        'v_M': np.array([[0.0, 0.2]]),
        'wheel_z': np.array([[0.0, 0.03]]),
        'wheel_v': np.array([[0.0, -0.5]]),
        **{k: np.array([0.0, v]) for k, v in g.items()},
    }
    u = comp.evaluate(values)['u_A']
    expected = -1500.0 * 0.2 + 300.0 * -0.5 - 2000.0 * 0.02 + 250.0 * -0.7
    assert u.shape == (1, 1) and u[0, 0] == pytest.approx(expected, rel=1e-14)


def test_smooth_clip_stays_within_its_bounds_and_tends_to_the_clip():
    x = np.linspace(-5.0, 6.0, 2001)
    lo, hi, w = 0.3, 4.0, 0.05
    c = smooth_clip(x, lo, hi, w)
    assert np.all(c > lo) and np.all(c < hi)
    far = (np.abs(x - lo) > 1.0) & (np.abs(x - hi) > 1.0)
    # within w² / (4 d) of the clip at a distance d from both bounds
    assert np.max(np.abs(c - np.clip(x, lo, hi))[far]) <= w**2 / 4.0 * 2.0
    slope = smooth_clip_slope(x, lo, hi, w)
    np.testing.assert_allclose(slope[1:-1], np.gradient(c, x)[1:-1], atol=2e-3)
    assert np.all(slope > 0.0) and np.all(slope < 1.0)


def test_skyhook_realizes_the_demand_where_the_damper_can():
    """Where the demanded force and the damper's motion agree in sign and the demand is
    within [c_min, c_max] |v|, the damper gives the demand; against the motion, c_min;
    beyond it, c_max (the clipped skyhook law)."""
    comp = SkyGroundhookComp(
        num_nodes=3, corners=1, controlled=(0,), c_min=200.0, c_max=4000.0, velocity_floor=1e-4
    )
    v_A = np.array([[0.3], [0.3], [0.3]])
    # demand = -g_sky v_M: 600 N (c 2000: reachable), -600 N (a push: c_min), 3000 N (c_max)
    v_M = np.array([[-0.4], [0.4], [-2.0]])
    c = comp.evaluate(
        {
            'v_M': v_M,
            'wheel_v': np.zeros((3, 1)),
            'v_A': v_A,
            'g_sky': np.array([1500.0]),
            'g_gnd': np.array([0.0]),
        }
    )['c_A'][:, 0]
    assert c[0] == pytest.approx(2000.0, rel=1e-4)
    assert c[1] == pytest.approx(200.0, abs=1.0)
    assert c[2] == pytest.approx(4000.0, abs=1.0)


def test_saturation_is_the_hardwares_range():
    """Commands beyond the range give its limit (between the nodes, where a polynomial
    through bang-bang values overshoots); within it, the command itself."""
    c = np.array([[-500.0, 100.0, 2500.0, 9000.0]]).T
    v = np.full((4, 1), 0.2)
    out = VariableDamperComp(num_nodes=4, corners=1, controlled=(0,), limits=(200.0, 3000.0))
    F = out.evaluate({'c_A': c, 'v_A': v})['u_F'][:, 0]
    np.testing.assert_allclose(F, [40.0, 40.0, 500.0, 600.0])
    act = ActiveForceComp(num_nodes=4, corners=1, controlled=(0,), limits=(-800.0, 800.0))
    u = act.evaluate({'u_A': c, 'v_A': v})['u_F'][:, 0]
    np.testing.assert_allclose(u, [-500.0, 100.0, 800.0, 800.0])
