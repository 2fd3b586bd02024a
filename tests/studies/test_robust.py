"""Robust design over several scenarios in one NLP: reductions to the single-scenario
problem, stationarity of the sum against separately built problems, the worst case, and the
dense-row (reverse) derivatives of the epigraph form."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from suspopt.driver import sparsity
from suspopt.spec.load import config_from_dict
from suspopt.studies.run import evaluate, optimize
from suspopt.transcription.problem import VehicleProblem
from suspopt.verification.scales import resolve_scales
from suspopt.verification.verify import combine

SEGMENTS = 20


def _config(scenarios, aggregate='sum', segments=SEGMENTS):
    return config_from_dict(
        {
            'transcription': {'segments': segments},
            'objective': {'aggregate': aggregate},
            'scenario': scenarios,
        }
    )


TWO = [{'name': 'slow', 'speed': 8.0}, {'name': 'fast', 'speed': 14.0}]


@pytest.fixture(scope='module')
def sum_optimum():
    cfg = _config(TWO)
    scales = resolve_scales(cfg)
    return cfg, scales, optimize(cfg, 'low', scales=scales)


def test_two_identical_scenarios_reduce_to_the_single_problem():
    """The same scenario twice, weights 1 and 1: the design of the single-scenario
    optimum, twice its objective."""
    one = _config([{'name': 'a'}])
    two = _config([{'name': 'a'}, {'name': 'b'}])
    r1, r2 = optimize(one, 'low'), optimize(two, 'low')
    assert r1.success and r2.success
    for name, value in r1.design.items():
        assert r2.design[name] == pytest.approx(value, rel=1e-5), name
    assert r2.objective == pytest.approx(2.0 * r1.objective, rel=1e-7)


def test_ipopt_sees_the_weighted_mean_and_reports_the_weighted_sum():
    """The NLP's objective is scaled by 1/Σ w_s (one scenario's magnitude for IPOPT),
    while the result, the history and the progress report Σ w_s f_s."""
    cfg = _config([{'name': 'a', 'weight': 1.0}, {'name': 'b', 'weight': 3.0, 'speed': 14.0}])
    scales = resolve_scales(cfg)
    with VehicleProblem(cfg, 'low', scales) as vp:
        (meta,) = vp.problem.model.get_objectives().values()
    assert meta['total_scaler'] == pytest.approx(0.25)
    seen = []
    r = optimize(cfg, 'low', scales=scales, progress=seen.append)
    assert r.success
    assert r.objective == pytest.approx(combine(cfg, [s.objective for s in r.scenarios]), rel=1e-12)
    assert r.history[-1].objective == pytest.approx(r.objective, rel=1e-7)
    assert seen and seen[-1].objective == pytest.approx(r.objective, rel=1e-7)
    assert r.aggregate == 'sum' and r.formula().startswith('f = 1 f_a + 3 f_b; f_s = ')


@pytest.mark.slow
def test_sum_optimum_is_stationary_for_separately_built_problems(sum_optimum):
    """Each scenario's f_s evaluated in its own single-scenario problem (its own
    collocation solve at the design): their sum equals the robust NLP's objective at its
    optimum, and no step of 1 % of a variable's range (kept inside the box) lowers it by
    more than the collocation tolerance — so the coupling of the scenarios through the
    shared design is right, not just each scenario."""
    cfg, scales, res = sum_optimum
    assert res.success
    singles = [_config([sc]) for sc in TWO]

    def total(design):
        return sum(
            evaluate(c, 'low', design, scales=(s,), verify=False).objective
            for c, s in zip(singles, scales)
        )

    x = res.design
    f0 = total(x)
    assert f0 == pytest.approx(res.objective, rel=1e-6)
    for name in cfg.design_names():
        var = cfg.design[name]
        h = 0.01 * (var.upper - var.lower)
        for step in (h, -h):
            trial = min(max(x[name] + step, var.lower), var.upper)
            if trial == x[name]:
                continue  # at its bound: only the feasible direction counts
            f = total({**x, name: trial})
            assert f > f0 * (1.0 - 1e-6), (name, step, f, f0)


@pytest.mark.slow
def test_worst_case_bounds_every_scenario_and_beats_the_sum_optimum(sum_optimum):
    """max aggregate (epigraph): the optimum's t equals the largest f_s (the bound is
    active) and every f_s is below it; its worst case is no worse than that of the sum's
    optimum, which in turn has the smaller sum."""
    cfg, scales, res_sum = sum_optimum
    cfg_max = _config(TWO, aggregate='max')
    res_max = optimize(cfg_max, 'low', scales=scales)
    assert res_max.success and res_max.aggregate == 'max'
    f_max = [s.objective for s in res_max.scenarios]
    f_sum = [s.objective for s in res_sum.scenarios]
    assert res_max.objective == pytest.approx(max(f_max), rel=1e-6)
    assert max(f_max) <= max(f_sum) * (1.0 + 1e-6)
    assert sum(f_sum) <= sum(f_max) * (1.0 + 1e-6)
    assert combine(cfg_max, f_max) == pytest.approx(res_max.objective, rel=1e-6)


def test_a_short_scenarios_worst_case_row_goes_to_reverse_too():
    """Four worst-case rows f_s ≤ t of unequal length, the shortest (a coarse scenario)
    spanning under a fifth of the NLP's columns: all four are left to reverse solves, so
    the forward colors stay those of the sparse rows (kept forward, that row alone would
    need one color per state of its scenario: hundreds, and their dense seeds)."""
    cfg = config_from_dict(
        {
            'transcription': {'segments': 80},
            'objective': {'aggregate': 'max'},
            'scenario': [
                {'name': 'coarse', 'segments': 16},
                {'name': 'b', 'speed': 8.0},
                {'name': 'c', 'speed': 12.0},
                {'name': 'd', 'speed': 14.0},
            ],
        }
    )
    scales = tuple(dict.fromkeys(cfg.terms(), 1.0) for _ in cfg.scenarios())
    with VehicleProblem(cfg, 'low', scales, use_cache=False) as vp:
        vp.driver.prepare()
        coloring = vp.driver.total_coloring()
    m, n = coloring.shape
    nnz = np.bincount(coloring.rows, minlength=m)
    longest = np.sort(nnz)[::-1]
    assert longest[3] < 0.2 * n < longest[2]  # the shortest of the four is the case
    assert sorted(nnz[coloring.reverse_rows]) == sorted(longest[:4])
    assert coloring.n_colors <= 2 * max(longest[4:])


def test_dense_rows_by_reverse_solves_equal_openmdaos_totals(monkeypatch):
    """The worst-case bounds f_s ≤ t depend on every state of their scenario: the
    coloring leaves them to reverse solves. At a random point those rows, and all the
    others, equal OpenMDAO's uncolored driver-scaled totals; the coloring is a valid
    column coloring of the remaining rows."""
    monkeypatch.setattr(sparsity, 'DENSE_ROW_MIN', 20)  # the tiny grid's rows are short
    cfg = _config(TWO, aggregate='max')  # a structure test: 4 segments (refused in a file)
    cfg = cfg.replace(transcription=dataclasses.replace(cfg.transcription, segments=4))
    scales = tuple(dict.fromkeys(cfg.terms(), 1.0) for _ in cfg.scenarios())
    with VehicleProblem(cfg, 'low', scales, use_cache=False) as vp:
        drv = vp.driver
        drv.prepare()
        lay = drv.layout()
        coloring = drv.total_coloring()
        p = vp.problem
        rng = np.random.default_rng(2)
        for v in lay.design_vars:
            val = p.get_val(v.name)
            p.set_val(
                v.name, val + rng.uniform(-1, 1, val.shape) * np.maximum(np.abs(val), 0.01) * 0.5
            )
        p.run_model()
        x = drv.scaled_design()
        grad, jac = drv.gradient(x), drv.jacobian(x)
        J = p.compute_totals(
            of=[lay.objective.name] + [c.name for c in lay.constraints],
            wrt=[v.name for v in lay.design_vars],
            return_format='array',
            coloring_info=False,
            driver_scaling=True,
        )
    assert coloring.reverse_rows.size == len(cfg.scenarios())
    np.testing.assert_allclose(grad, J[0], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(jac, J[1 + coloring.rows, coloring.cols], rtol=1e-9, atol=1e-12)
    forward = ~np.isin(coloring.rows, coloring.reverse_rows)
    for c in range(coloring.n_colors):
        hit = coloring.rows[forward & (coloring.colors[coloring.cols] == c)]
        assert np.unique(hit).size == hit.size, f'color {c} columns share a row'


@pytest.mark.slow
def test_robust_command_shows_what_the_robust_design_buys(tmp_path, capsys):
    """``suspopt robust``: the robust optimum and each scenario's own, each on every
    scenario by time marching. Each scenario's own optimum is (to the collocation's
    tolerance) the best on that scenario, the robust optimum the best on the sum; the files
    are complete and the report renders them; one scenario is not a robust study."""
    from suspopt.cli.main import main
    from suspopt.output.rundir import read_json

    study = tmp_path / 'robust.toml'
    study.write_text(
        '[transcription]\nsegments = "auto"\n'
        + ''.join(f'[[scenario]]\nname = "{sc["name"]}"\nspeed = {sc["speed"]}\n' for sc in TWO)
    )
    out = tmp_path / 'run'
    assert main(['robust', '--config', str(study), '--out', str(out), '--quiet']) == 0
    data = read_json(out / 'robust.json')
    assert data['complete'] and data['verified'] is True
    assert set(data['optima']) == {'robust', 'slow', 'fast'}
    cross = data['cross']
    for name in ('slow', 'fast'):
        own = cross[name]['scenarios'][name]
        assert all(own <= c['scenarios'][name] * (1 + 2e-3) for c in cross.values()), name
    assert all(cross['robust']['aggregate'] <= c['aggregate'] * (1 + 2e-3) for c in cross.values())
    table = (out / 'table.md').read_text()
    assert '| robust |' in table and (out / 'figures' / 'robustness.png').stat().st_size > 0
    assert 'Every optimum on every scenario' in capsys.readouterr().out
    single = tmp_path / 'one.toml'
    single.write_text('[[scenario]]\nname = "only"\n')
    assert main(['robust', '--config', str(single), '--out', str(tmp_path / 'x')]) == 2
    assert 'scenario' in capsys.readouterr().err


def test_mixed_fidelity_scenarios_are_the_separate_problems():
    """Both fidelities: the mixed-fidelity model over two scenarios in one NLP (the design
    held) gives each scenario the f_s of its own single-scenario problem, and the sum."""
    cfg = _config(TWO, segments=24)
    scales = tuple(dict.fromkeys(cfg.terms(), 1.0) for _ in cfg.scenarios())
    design = cfg.design.initial()
    both = evaluate(cfg, 'mixed', design, scales=scales, verify=False)
    assert both.success
    alone = [
        evaluate(
            _config([sc], segments=24), 'mixed', design, scales=(scales[0],), verify=False
        ).objective
        for sc in TWO
    ]
    for rec, f in zip(both.scenarios, alone):
        assert rec.objective == pytest.approx(f, rel=1e-7), rec.name
    assert both.objective == pytest.approx(sum(alone), rel=1e-7)
