"""Engineering constraints solved end to end on the quarter car (short horizon): a travel
bound that binds is met and active at the optimum and holds by time marching; a bound no
design in the box meets ends as IPOPT's infeasibility, reported as such (exit 1, the run
directory written, the constraint and its smallest violation named)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from suspopt.cli.main import main
from suspopt.records.solve import SolveRecord
from suspopt.spec.load import config_from_dict
from suspopt.studies.run import optimize
from suspopt.verification.timemarching import simulate

QUARTER = {
    'vehicle': {'model': 'quarter_car'},
    'maneuver': {'horizon': 1.0},
    'transcription': {'segments': 20},
}
pytestmark = pytest.mark.slow

BOUND = 0.015  # m; the unconstrained optimum on this road travels about 0.023 m


@pytest.fixture(scope='module')
def travel_bound():
    cfg = config_from_dict(
        {**QUARTER, 'constraints': {'travel': {'bump': BOUND, 'rebound': BOUND}}}
    )
    return cfg, optimize(cfg, 'low')


def test_a_binding_travel_bound_is_met_and_active(travel_bound):
    cfg, rec = travel_bound
    assert rec.success and rec.verified is True
    rows = {v.name: (v, k) for v, k in rec.constraint_rows()}
    assert set(rows) == {'travel.bump', 'travel.rebound'}
    value, marched = rows['travel.bump']
    assert value.active and value.value == pytest.approx(BOUND, rel=1e-4)
    assert marched is not None and not marched.violated
    assert marched.value == pytest.approx(BOUND, rel=0.01)  # dense in time, between nodes too
    # it is the bound that holds the damper up: 10 % softer, the wheel travels past it
    lo, _ = cfg.design.bounds()['c_S1']
    assert lo < rec.design['c_S1']
    softer = {**rec.design, 'c_S1': 0.9 * rec.design['c_S1']}
    tr = simulate(cfg, 'low', softer, t_eval=np.linspace(0.0, 1.0, 2001))
    assert tr['travel'].max() > 1.02 * BOUND


def test_an_impossible_bound_is_reported_as_infeasible(tmp_path, capsys):
    study = tmp_path / 'qc.toml'
    study.write_text(
        '[vehicle]\nmodel = "quarter_car"\n[maneuver]\nhorizon = 0.5\n'
        '[transcription]\nsegments = 10\n[constraints.travel]\nbump = 1e-5\n'
    )
    out = tmp_path / 'run'
    args = ['optimize', '--fidelity', 'low', '--config', str(study), '--out', str(out)]
    assert main([*args, '--quiet']) == 1
    err = capsys.readouterr().err
    assert 'infeasible: constraints.travel.bump' in err
    rec = SolveRecord.from_json(json.loads((out / 'result.json').read_text()))
    assert not rec.success and rec.infeasibility is not None
    inf = rec.infeasibility
    assert inf.name == 'travel.bump' and inf.units == 'm'
    assert inf.violation == pytest.approx(inf.value - 1e-5) and inf.violation > 1e-3
    assert main(['report', str(out)]) == 0
    assert '**Infeasible:** constraints.travel.bump' in (out / 'table.md').read_text()
