"""The propagated total derivatives (all colors at once through the data flow) against the
public path (one OpenMDAO linear solve per color) on every model kind, at a perturbed
point where no derivative is zero by accident; and the comparison fails when one edge of
the data flow is wrong."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from test_sparsity import _cases, _problem

from suspopt.driver import sparsity
from suspopt.driver.propagation import PropagatedTotals, make_totals
from suspopt.driver.totals import ColoredTotals
from suspopt.spec.load import config_from_dict

CASES = [
    'half car, low',
    'half car, mixed',
    'full car with bars, low',
    'half car, mixed, chassis mount',
    'full car with bars, mixed, chassis mount',
    'two scenarios, worst case, low',
]


def _config(cfg, case):
    if case == 'two scenarios, worst case, low':
        two = config_from_dict(
            {
                'objective': {'aggregate': 'max'},
                'scenario': [{'name': 'slow', 'speed': 8.0}, {'name': 'fast', 'speed': 14.0}],
            }
        )
        # a structure test: 5 segments (too coarse for results, refused in a file)
        return two.replace(transcription=dataclasses.replace(two.transcription, segments=5)), 'low'
    return _cases(cfg)[case]


def _perturb(vp, seed=0):
    """States and design moved off the zero start (where many partials vanish)."""
    p, rng = vp.problem, np.random.default_rng(seed)
    for name in p.model.get_io_metadata(iotypes='output', return_rel_names=False):
        if '.states:' in name or 'parameters:' in name:
            v = p.get_val(name)
            p.set_val(
                name,
                v * (1 + 0.1 * rng.standard_normal(v.shape)) + 1e-3 * rng.standard_normal(v.shape),
            )
    p.run_model()


def _both(vp):
    drv = vp.driver
    lay, coloring = drv.layout(), drv.total_coloring()
    fast = make_totals(vp.problem, lay, coloring, 'auto')
    public = make_totals(vp.problem, lay, coloring, 'solves')
    assert isinstance(fast, PropagatedTotals) and isinstance(public, ColoredTotals)
    return fast, public


@pytest.mark.parametrize('case', CASES)
def test_propagated_totals_equal_the_linear_solves(cfg, case, monkeypatch):
    monkeypatch.setattr(sparsity, 'DENSE_ROW_MIN', 20)  # the tiny grids' dense rows are short
    config, fidelity = _config(cfg, case)
    with _problem(config, fidelity) as vp:
        _perturb(vp)
        fast, public = _both(vp)
        g1, j1 = public.compute()
        g0, j0 = fast.compute()
    assert np.abs(g1).max() > 0 and np.abs(j1).max() > 0
    np.testing.assert_allclose(g0, g1, rtol=1e-10, atol=1e-12 * np.abs(g1).max())
    np.testing.assert_allclose(j0, j1, rtol=1e-10, atol=1e-12 * np.abs(j1).max())
    if case == 'two scenarios, worst case, low':  # the dense rows went the reverse way
        assert fast.coloring.reverse_rows.size == 2


def test_comparison_fails_on_a_wrong_edge(cfg):
    """One edge's unit factor off by 0.1 % (a wrong conversion): the derivatives differ."""
    config, fidelity = _config(cfg, 'half car, low')
    with _problem(config, fidelity) as vp:
        _perturb(vp)
        fast, public = _both(vp)
        g1, j1 = public.compute()
        products = [
            p
            for ps in fast._products.values()
            for p in ps
            if p.edge.of.endswith('rhs_all.dJ_dt') or 'collocation' in p.edge.of
        ]
        wrong = products[0]
        object.__setattr__(wrong.edge, 'factor', wrong.edge.factor * 1.001)
        g0, j0 = fast.compute()
    assert not (np.allclose(g0, g1, rtol=1e-6) and np.allclose(j0, j1, rtol=1e-6))
