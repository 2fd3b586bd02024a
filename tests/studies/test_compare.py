"""The topology study (``suspopt compare``, issue 12) and mixed topologies on one car.

* end to end on a short drive (one bump, 0.6 s, 12 × 5 grid): two topologies, every design
  in every model verified by time marching, each model's own optimum the best design in
  it, the report re-rendered identically from the directory;
* the orchestration with the solves replaced by stand-ins (fast): a failed topology keeps
  the others (exit 1), a cell not verified (exit 3), an interrupt (exit 130, the partial
  ``compare.json`` and its report), bad ``--mechanisms`` refused before any work (exit 2);
* the full car with a MacPherson front and a double-wishbone rear axle, verified.
"""

from __future__ import annotations

import dataclasses
import shutil

import numpy as np
import pytest

import suspopt.output.compare_report as compare_report
import suspopt.studies.compare as compare
from suspopt.cli.main import main
from suspopt.errors import ModelError
from suspopt.output.compare_report import compare_markdown
from suspopt.output.rundir import read_json, read_record
from suspopt.records.compare import CompareStudy
from suspopt.records.solve import ScenarioResult, SolveRecord, SolveTimes
from suspopt.records.verification import Comparison, ScenarioComparison, Verification

TINY = """
[maneuver]
horizon = 0.6
[road]
profile = "bump"
start = 0.3
[transcription]
segments = 12
"""


@pytest.fixture()
def tiny(tmp_path):
    path = tmp_path / 'tiny.toml'
    path.write_text(TINY)
    return str(path)


@pytest.mark.slow
def test_compare_end_to_end(tiny, tmp_path, capsys):
    out = tmp_path / 'cmp'
    rc = main(
        [
            'compare',
            '--mechanisms',
            'double_wishbone,macpherson',
            '--config',
            tiny,
            '--out',
            str(out),
            '--quiet',
        ]
    )
    assert rc == 0, capsys.readouterr().err
    data = read_record(out, CompareStudy)
    assert isinstance(data, CompareStudy)
    assert data.complete and data.verified is True and not data.failures
    models = ('low', 'mixed:double_wishbone', 'mixed:macpherson')
    designs = ['initial', 'low_optimum', 'optimum:double_wishbone', 'optimum:macpherson']
    assert data.models == models and list(data.designs) == designs
    f = {}
    for d in designs:
        for m in models:
            c = data.cell(d, m)
            assert c is not None and c.success and c.verified is True, (d, m)
            assert c.verification.comparison.max_rel_diff < data.tolerance
            f[d, m] = c.objective
    # each model's own optimum is the best design in it (its optimization worked) ...
    own = {
        'low': 'low_optimum',
        'mixed:double_wishbone': 'optimum:double_wishbone',
        'mixed:macpherson': 'optimum:macpherson',
    }
    for m, d_own in own.items():
        assert all(f[d_own, m] <= f[d, m] * (1 + 1e-6) for d in designs), m
        assert data.best[m].best == d_own
    # ... and the two linkages want different settings (the point of the comparison)
    dw, mp = data.designs['optimum:double_wishbone'], data.designs['optimum:macpherson']
    assert abs(dw['c_S1'] - mp['c_S1']) > 0.1 * 4000.0
    assert data.best['mixed:double_wishbone'].excess['optimum:macpherson'] > 0.01
    # the kinematics of the linkages (paper Table 2: spring at 0.15 of the 0.33 m arm)
    kin = data.kinematics.curves
    assert kin['double_wishbone'].at_reference['motion_ratio'] == pytest.approx(
        0.15 / 0.33, rel=1e-6
    )
    assert 0.9 < kin['macpherson'].at_reference['motion_ratio'] < 1.0
    # the file holds what the record says (a round trip through compare.json)
    assert read_json(out / 'compare.json') == data.to_json()
    table = (out / 'table.md').read_text()
    assert 'Cross table' in table
    # the legend, the 3 optima, the 12 cells
    assert table.count('✓') == 1 + 3 + 12 and table.count('✗') == 1
    for name in ('road', 'kinematics', 'cross', 'trajectories'):
        assert (out / 'figures' / f'{name}.png').stat().st_size > 10_000, name
    # the report re-renders the same table from the directory alone
    (out / 'table.md').unlink()
    shutil.rmtree(out / 'figures')
    assert main(['report', str(out)]) == 0
    assert (out / 'table.md').read_text() == table
    assert (out / 'figures' / 'trajectories.png').exists()
    # a cell that time marching does not confirm: exit 3, marked in the table
    key = 'optimum:macpherson|mixed:double_wishbone'
    cell = data.cells[key]
    off = dataclasses.replace(cell.verification.comparison, max_rel_diff=0.02)
    data.cells[key] = cell.with_verification(Verification.of(off))
    compare.finish(data)
    assert data.verified is False and compare.exit_code(data) == 3
    text = compare_markdown(data)
    assert text.count('✗') == 2 and 'not verified: 1 of 12 cells' in text


# ------------------------------------------------------------------ orchestration
def _stand_in(
    monkeypatch,
    fail: str | None = None,
    unverified: str | None = None,
    interrupt: str | None = None,
):
    """Replace the solves of :mod:`suspopt.studies.compare` by records of a made-up objective
    (a quadratic bowl per model); ``fail``/``interrupt``: the topology whose optimization
    raises a ModelError / KeyboardInterrupt; ``unverified``: a cell ``design|model`` whose
    verification fails."""
    centre = {'low': 0.3, 'double_wishbone': 0.6, 'macpherson': 0.8}

    def model_of(cfg, fid):
        return 'low' if fid == 'low' else cfg.vehicle.front.mechanism

    def key_of(cfg, fid):
        v = cfg.vehicle
        if fid == 'low':
            return 'low'
        return 'mixed:' + (
            v.front.mechanism
            if v.front.mechanism == v.rear.mechanism
            else f'{v.front.mechanism}+{v.rear.mechanism}'
        )

    def f_of(cfg, fid, design):
        c = centre[model_of(cfg, fid)]
        b = cfg.design.bounds()
        return 1.0 + sum(((design[n] - lo) / (hi - lo) - c) ** 2 for n, (lo, hi) in b.items())

    def record(cfg, fid, design, mode, label):
        f = f_of(cfg, fid, design)
        key = f'{label}|{key_of(cfg, fid)}'
        ok = key != unverified
        terms = dict.fromkeys(cfg.terms(), f)
        comparison = Comparison(
            method='stand-in',
            tolerance=5e-3,
            scenarios=(ScenarioComparison('s', terms, f, 1e-4 if ok else 0.02, 'heave', 0.0),),
            objective=f,
            max_rel_diff=1e-4 if ok else 0.02,
            time_s=0.0,
        )
        return SolveRecord(
            fidelity=fid,
            mode=mode,
            method='collocation',
            start=design,
            design=design,
            success=True,
            status='Solve_Succeeded',
            objective=f,
            scenarios=(ScenarioResult('s', 1.0, dict.fromkeys(cfg.terms(), 1.0), f, terms),),
            iterations=3,
            times=SolveTimes(0.0, 0.0),
            verification=Verification.of(comparison),
        )

    def evaluate(cfg, fid, design, *, label=None, **kw):
        return record(cfg, fid, design, 'evaluate', label)

    def optimize(cfg, fid, *, start, label=None, **kw):
        mech = model_of(cfg, fid)
        if mech == fail:
            raise ModelError(f'{mech}: the linkage reached its toggle position')
        if mech == interrupt:
            raise KeyboardInterrupt
        b = cfg.design.bounds()
        design = {n: lo + centre[mech] * (hi - lo) for n, (lo, hi) in b.items()}
        return record(cfg, fid, design, 'optimize', label)

    class Problem:  # what run_compare asks of a built problem, without building one
        scenarios = (None,)

        def __init__(self, *args, **kw):
            pass

        def timeseries(self, i=0):
            return None

        def stats(self):
            nlp = {'variables': 0, 'constraints': 0, 'jacobian_nonzeros': 0, 'colors': 0}
            return {
                'setup_s': 0.0,
                'coloring_s': 0.0,
                'coloring_from_cache': False,
                'nlp': nlp,
                'multibody_calls_total': {},
            }

        def cleanup(self):
            pass

    monkeypatch.setattr(compare, 'evaluate', evaluate)
    monkeypatch.setattr(compare, 'optimize', optimize)
    monkeypatch.setattr(compare, 'VehicleProblem', Problem)
    for name in ('_kinematics_figure', '_cross_figure'):  # the tables are the point here
        monkeypatch.setattr(compare_report, name, lambda path, data: path)
    monkeypatch.setattr(compare_report, 'road_figure', lambda path, setting: path)


def _run(tiny, out, capsys, extra=()):
    rc = main(
        [
            'compare',
            '--mechanisms',
            'double_wishbone,macpherson',
            '--config',
            tiny,
            '--out',
            str(out),
            '--quiet',
            *extra,
        ]
    )
    return rc, capsys.readouterr()


def test_compare_failed_topology_keeps_the_others(tiny, tmp_path, capsys, monkeypatch):
    _stand_in(monkeypatch, fail='macpherson')
    rc, io = _run(tiny, tmp_path / 'cmp', capsys)
    assert rc == 1
    assert 'optimization failed in mixed:macpherson: Model_Error' in io.err
    data = read_record(tmp_path / 'cmp', CompareStudy)
    assert data.complete and data.failures[0].model == 'mixed:macpherson'
    assert 'optimum:macpherson' not in data.designs
    assert data.steps['mixed:macpherson'].success is False
    # every design that exists, in every model (the failed topology's model included)
    assert sorted(data.cells) == sorted(
        f'{d}|{m}'
        for d in ('initial', 'low_optimum', 'optimum:double_wishbone')
        for m in data.models
    )
    assert data.best['mixed:double_wishbone'].best == 'optimum:double_wishbone'
    assert data.best['mixed:macpherson'].f_own is None
    table = (tmp_path / 'cmp' / 'table.md').read_text()
    assert '**Failed:** optimization in mixed:macpherson' in table


def test_compare_not_verified_exits_3(tiny, tmp_path, capsys, monkeypatch):
    _stand_in(monkeypatch, unverified='low_optimum|mixed:macpherson')
    rc, io = _run(tiny, tmp_path / 'cmp', capsys)
    assert rc == 3
    assert 'not verified: 1 of 12 cells; worst low_optimum|mixed:macpherson' in io.err
    data = read_record(tmp_path / 'cmp', CompareStudy)
    assert data.complete and data.verified is False and not data.failures


def test_compare_interrupt_keeps_what_finished(tiny, tmp_path, capsys, monkeypatch):
    _stand_in(monkeypatch, interrupt='macpherson')
    out = tmp_path / 'cmp'
    rc, _ = _run(tiny, out, capsys)
    assert rc == 130
    data = read_record(out, CompareStudy)
    assert data.interrupted and not data.complete
    assert set(data.steps) == {'low', 'mixed:double_wishbone'}
    assert main(['report', str(out)]) == 0  # a partial study renders
    assert '**Incomplete:** the study was interrupted' in (out / 'table.md').read_text()


@pytest.mark.parametrize(
    'mechanisms, message',
    [
        ('double_wishbone,no_such_linkage', 'no_such_linkage'),
        ('macpherson,macpherson', 'listed twice'),
        ('macpherson+double_wishbone+macpherson', 'one mechanism, or FRONT+REAR'),
        ('double_wishbone,', 'comma-separated list'),
    ],
)
def test_compare_refuses_bad_mechanisms_before_any_work(tmp_path, capsys, mechanisms, message):
    out = tmp_path / 'cmp'
    assert main(['compare', '--mechanisms', mechanisms, '--out', str(out)]) == 2
    err = capsys.readouterr().err
    assert '--mechanisms' in err and message in err
    assert not out.exists()


def test_topology_labels_and_front_rear_pairs(tmp_path):
    from suspopt.multibody.mechanism import mechanism_path

    other = tmp_path / 'macpherson.toml'  # a file with a built-in's stem
    shutil.copyfile(mechanism_path('macpherson'), other)
    tops = compare.parse_topologies(f'macpherson, macpherson+double_wishbone,{other}')
    assert tops[:2] == [('macpherson', 'macpherson'), ('macpherson', 'double_wishbone')]
    assert tops[2] == (str(other), str(other))
    assert compare.topology_labels(tops) == [
        'macpherson',
        'macpherson+double_wishbone',
        'macpherson-2',
    ]


def test_compare_full_car_topologies_per_axle(tmp_path, capsys, monkeypatch):
    """The full car (six design variables, anti-roll bars) with a MacPherson front and
    double-wishbone rear against double wishbones all round (stand-in solves)."""
    from suspopt.spec.template import default_config_toml

    path = tmp_path / 'full.toml'
    text = default_config_toml('full_car')
    assert 'horizon = 5.0 ' in text
    path.write_text(text.replace('horizon = 5.0 ', 'horizon = 0.3 '))  # short: s_k cheap
    _stand_in(monkeypatch)
    out = tmp_path / 'cmp'
    rc = main(
        [
            'compare',
            '--mechanisms',
            'macpherson+double_wishbone,double_wishbone',
            '--config',
            str(path),
            '--out',
            str(out),
            '--quiet',
        ]
    )
    assert rc == 0, capsys.readouterr().err
    data = read_record(out, CompareStudy)
    assert data.models == ('low', 'mixed:macpherson+double_wishbone', 'mixed:double_wishbone')
    top = data.topologies[0]
    assert (top.front, top.rear) == ('macpherson', 'double_wishbone')
    assert set(data.kinematics.curves) == {'macpherson', 'double_wishbone'}
    assert len(data.cells) == 4 * 3
    table = (out / 'table.md').read_text()
    assert '| full car (low fidelity) |' in table and 'k_R1 [N·m/rad]' in table


# ------------------------------------------------------------------ the full car
@pytest.mark.slow
def test_full_car_macpherson_front_double_wishbone_rear_verifies():
    """Mixed fidelity with one mechanism per axle: the default full car (BMW E90 data),
    MacPherson front, the paper's double wishbone rear (both set here: the defaults are
    the BMW's own corners), on its ISO 8608 road (short drive, automatic grid), evaluated
    by collocation and verified by time marching."""
    from suspopt.spec.load import config_from_dict, full_car_defaults
    from suspopt.studies.run import evaluate
    from suspopt.transcription.vehicle import multibody_modules
    from suspopt.verification.scales import resolve_scales

    d = full_car_defaults().to_dict()
    d['vehicle']['front']['mechanism'] = 'macpherson'
    d['vehicle']['rear']['mechanism'] = 'double_wishbone'
    d['maneuver']['horizon'] = 0.3
    cfg = config_from_dict(d)
    assert list(multibody_modules(cfg)) == ['macpherson', 'double_wishbone']
    rec = evaluate(cfg, 'mixed', scales=resolve_scales(cfg))
    assert rec.success and rec.verified is True, rec.verification
    assert rec.max_constraint_residual_m < 1e-10
    J = rec.terms
    assert J['roll'] > 0.0 and np.isfinite(list(J.values())).all()
    # the axles differ: the same road under a MacPherson and a double wishbone
    assert J['wheel_1L'] != pytest.approx(J['wheel_2L'], rel=1e-2)
