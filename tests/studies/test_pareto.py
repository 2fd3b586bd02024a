"""The comfort/road-holding Pareto front (suspopt.studies.pareto): one problem, reweighted."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from suspopt.cli.main import main
from suspopt.studies.pareto import comfort_and_road_holding, comfort_share_weights, run_pareto
from suspopt.studies.run import optimize

pytestmark = pytest.mark.slow
POINTS = 5


@pytest.fixture(scope='module')
def coarse(cfg):
    """A grid coarse enough to be quick and fine enough to verify (0.5 %) on this road."""
    return cfg.replace(transcription=dataclasses.replace(cfg.transcription, segments=60))


@pytest.fixture(scope='module')
def front(coarse, tmp_path_factory):
    out = tmp_path_factory.mktemp('pareto')
    return out, run_pareto(coarse, out, fidelity='low', points=POINTS)


def test_front_is_a_front(front, coarse, scales):
    """Weighted sums: as the comfort share grows, comfort C never gets worse and road
    holding R never gets better; no computed point dominates another; every f_α is the
    weighted sum of its own J_k."""
    _, data = front
    pts = data.points
    assert data.complete and len(pts) == POINTS and all(p.success for p in pts)
    assert all(p.result.verified for p in pts)
    assert [p.alpha for p in pts] == pytest.approx(np.linspace(0.0, 1.0, POINTS))
    C = np.array([p.comfort for p in pts])
    R = np.array([p.road_holding for p in pts])
    assert np.all(np.diff(C) < 1e-9) and np.all(np.diff(R) > -1e-9)
    assert C[0] - C[-1] > 0.5 and R[-1] - R[0] > 0.5  # a real trade-off, not a point
    for i in range(POINTS):
        for j in range(POINTS):
            assert not (C[j] < C[i] - 1e-9 and R[j] < R[i] - 1e-9), (i, j)
    # the initial design, evaluated in the same model, is beaten in both goals at once
    init = data.initial
    assert any(c < init.comfort and r < init.road_holding for c, r in zip(C, R))
    s = scales[0]
    for p in pts:
        f = sum(p.weights[t] * p.result.terms[t] / s[t] for t in s)
        assert p.result.objective == pytest.approx(f, rel=1e-12)
        assert (p.comfort, p.road_holding) == pytest.approx(
            comfort_and_road_holding(coarse, p.result.terms, s), rel=1e-12
        )


@pytest.mark.parametrize('index', [1, 2])  # alpha = 0.25 and the paper's equal weights
def test_reweighted_problem_equals_a_fresh_optimization(front, coarse, scales, index):
    """Reusing one problem with new weights (inputs, no new setup) gives what a fresh
    problem built with those weights gives from the initial design."""
    _, data = front
    p = data.points[index]
    assert p.weights == comfort_share_weights(coarse, p.alpha)
    assert p.result.weights == p.weights  # the record says what it minimized
    fresh = optimize(coarse.with_weights(p.weights), 'low', scales=scales, verify=False)
    assert fresh.success
    for n in coarse.design_names():
        assert p.result.design[n] == pytest.approx(fresh.design[n], rel=1e-4), n
    assert p.result.objective == pytest.approx(fresh.objective, rel=1e-7)


def test_report_rerenders_the_front(front, capsys):
    out, _ = front
    table = (out / 'table.md').read_text()
    assert (out / 'figures' / 'pareto.png').stat().st_size > 20_000
    (out / 'table.md').unlink()
    assert main(['report', str(out)]) == 0
    assert (out / 'table.md').read_text() == table
    assert table.count('| Solve_Succeeded |') == POINTS and table.count('| verified |') == POINTS
    assert json.loads((out / 'pareto.json').read_text())['complete']


def test_cli_refuses_a_front_of_one_point(tmp_path, capsys):
    assert main(['pareto', '--points', '1', '--out', str(tmp_path / 'p')]) == 2
    assert '--points: need at least 2' in capsys.readouterr().err
    assert not (tmp_path / 'p').exists()
