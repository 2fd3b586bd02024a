"""The command line end to end: outputs, refusals, failures, interruption, report."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pytest

from suspopt.cli.main import main

pytestmark = pytest.mark.slow
KEYS = {
    'fidelity',
    'design',
    'objective',
    'terms',
    'scales',
    'success',
    'iterations',
    'wall_time_s',
}
#: a grid quick to solve that still verifies (0.5 %) on the default road
GRID = ['--segments', '60']


def _run(args, capsys):
    code = main(args)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_evaluate_prints_json(capsys):
    code, out, _ = _run(['evaluate', '--fidelity', 'low', '--method', 'time-marching'], capsys)
    assert code == 0
    res = json.loads(out)
    assert KEYS <= set(res) and res['method'] == 'time-marching'
    assert abs(res['objective'] - 1.0) < 1e-6  # reference normalization at the initial design
    # the mixed model's lightly damped wheel hop needs the default grid (60 x 5: 0.9 %)
    code, out, _ = _run(
        [
            'evaluate',
            '--fidelity',
            'mixed',
            '--design',
            '37500,28100,1500,1235',
            '--normalization',
            'paper',
        ],
        capsys,
    )
    assert code == 0
    res = json.loads(out)
    paper = {'heave': 0.1, 'pitch': 0.01, 'wheel_1': 1.0, 'wheel_2': 1.0}
    assert KEYS <= set(res) and {t: res['scales'][t] for t in paper} == paper
    assert res['verified'] is True
    assert res['design']['k_S1'] == 37500.0 and res['success']


def test_optimize_writes_results_and_refuses_to_overwrite(tmp_path, capsys):
    out = tmp_path / 'opt'
    code, stdout, stderr = _run(['optimize', '--fidelity', 'low', *GRID, '--out', str(out)], capsys)
    assert code == 0
    res = json.loads((out / 'result.json').read_text())
    assert KEYS <= set(res) and res['success'] and res['iterations'] > 0
    assert (out / 'cases.sql').exists()
    assert 'objective f =' in stdout and 'iter' in stderr and 'constr.viol' in stderr
    code, _, stderr = _run(['optimize', '--fidelity', 'low', *GRID, '--out', str(out)], capsys)
    assert code == 2 and 'already contains results' in stderr and '--overwrite' in stderr
    code, _, stderr = _run(
        ['optimize', '--fidelity', 'low', *GRID, '--out', str(out), '--overwrite', '--quiet'],
        capsys,
    )
    assert code == 0 and stderr == ''
    # report re-renders an optimize run from its records alone
    code, stdout, _ = _run(['report', str(out)], capsys)
    res = json.loads((out / 'result.json').read_text())
    assert code == 0 and 'Solve_Succeeded' in stdout
    assert f'| result | {res["design"]["k_S1"]:.0f} | {res["design"]["k_S2"]:.0f} |' in stdout
    assert f'{res["objective"]:.4f}' in stdout
    for name in ('road', 'trajectories', 'convergence'):
        assert (out / 'figures' / f'{name}.png').stat().st_size > 10_000
    assert (
        json.loads((out / 'result.json').read_text())['config']['transcription']['segments'] == 60
    )


def test_iteration_limit_exits_1_and_keeps_results(tmp_path, capsys):
    out = tmp_path / 'limited'
    code, _, stderr = _run(
        ['optimize', '--fidelity', 'low', *GRID, '--max-iter', '2', '--out', str(out), '--quiet'],
        capsys,
    )
    assert code == 1
    res = json.loads((out / 'result.json').read_text())
    assert res['success'] is False and res['status'] == 'Maximum_Iterations_Exceeded'
    assert 'Maximum_Iterations_Exceeded' in stderr and 'after 2 iterations' in stderr
    assert 'constraint violation' in stderr


def test_ctrl_c_stops_cleanly(tmp_path):
    """SIGINT ends IPOPT after the current iteration; results and recorder are kept."""
    out = tmp_path / 'interrupted'
    proc = subprocess.Popen(
        [
            sys.executable,
            '-m',
            'suspopt.cli',
            'optimize',
            '--fidelity',
            'mixed',
            *GRID,
            '--out',
            str(out),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, 'PYTHONUNBUFFERED': '1'},
    )
    lines = []
    for line in proc.stderr:
        lines.append(line)
        if line.strip().startswith('1 '):  # IPOPT iteration 1 done
            proc.send_signal(signal.SIGINT)
            break
    stdout, rest = proc.communicate(timeout=300)
    stderr = ''.join(lines) + rest
    assert proc.returncode == 130, stderr
    res = json.loads((out / 'result.json').read_text())
    assert res['success'] is False and res['status'] == 'User_Requested_Stop'
    assert res['interrupted'] is True and res['objective'] is None
    assert (out / 'cases.sql').exists()
    assert 'interrupted' in stderr and 'Traceback' not in stderr


def test_study_same_with_default_file_and_report_rerenders(tmp_path, capsys):
    """The study from `suspopt init`'s file equals the study with no file; `report`
    re-renders the same table from the recorded data alone."""
    assert main(['init', str(tmp_path / 'case.toml')]) == 0
    a, b = tmp_path / 'a', tmp_path / 'b'
    # 30 x 5 is too coarse for the default road (docs/model.md): the study says so, exit 3
    assert main(['study', '--segments', '30', '--out', str(a)]) == 3
    stderr = capsys.readouterr().err
    assert 'not verified: collocation and time marching differ by' in stderr
    assert (
        main(
            [
                'study',
                '--segments',
                '30',
                '--out',
                str(b),
                '--quiet',
                '--no-verify',
                '--config',
                str(tmp_path / 'case.toml'),
            ]
        )
        == 0
    )
    capsys.readouterr()
    sa = json.loads((a / 'study.json').read_text())
    sb = json.loads((b / 'study.json').read_text())
    assert sa['complete'] and sb['complete']
    assert sa['designs'] == sb['designs']
    for key, ev in sa['evaluations'].items():
        assert ev['objective'] == sb['evaluations'][key]['objective'], key
    assert set(sa['evaluations']) == {
        f'{m}/{d}' for m in ('low', 'mixed') for d in ('initial', 'low_optimum', 'mixed_optimum')
    }
    for key, ev in sa['evaluations'].items():  # the recorded comparison is consistent
        v, coll = ev['verification']['comparison'], ev['terms']
        tm = v['scenarios'][0]['terms']
        weighted = [k for k in tm if ev['weights'][k] > 0.0]  # the check's terms
        diff = max(abs(coll[k] / tm[k] - 1.0) for k in weighted)
        assert v['max_rel_diff'] == pytest.approx(diff, rel=1e-12)
        assert ev['verified'] is (diff <= v['tolerance'])
        assert ev['verification']['state'] == ('verified' if ev['verified'] else 'not_verified')
        assert sb['evaluations'][key]['verified'] is None  # not checked, and says so
        assert sb['evaluations'][key]['verification']['state'] == 'skipped'
    assert sa['verified'] is False and sb['verified'] is None
    table = (a / 'table.md').read_text()
    assert table.startswith('**Warning:** not verified: collocation and time marching differ')
    assert (
        'f = 0.25 J_heave/s_heave + 0.25 J_pitch/s_pitch + 0.25 J_wheel_1/s_wheel_1 + '
        '0.25 J_wheel_2/s_wheel_2.'
    ) in table
    assert '**Not checked:**' in (b / 'table.md').read_text()
    figures = sorted(p.name for p in (a / 'figures').iterdir())
    assert figures == [
        'convergence.png',
        'cross_evaluation.png',
        'initial_design.png',
        'optima.png',
        'road.png',
        'verification.png',
    ]
    (a / 'table.md').unlink()
    for p in (a / 'figures').iterdir():
        p.unlink()
    assert main(['report', str(a)]) == 0
    assert (a / 'table.md').read_text() == table
    assert sorted(p.name for p in (a / 'figures').iterdir()) == figures
    assert main(['report', str(tmp_path)]) == 2  # not a study directory


BIG_BUMP = '[road]\nprofile = "bump"\nheight = 0.6\n[objective]\nnormalization = "paper"\n'


def test_linkage_beyond_its_range_exits_1_naming_the_cause(tmp_path, capsys):
    """A 0.6 m bump drives the wheel to the wishbones' toggle position (0.33 m): time
    marching stops there at once with the multibody error (it used to creep for minutes),
    and an optimization from there ends with exit 1 and a result.json saying why."""
    cfg = tmp_path / 'big.toml'
    cfg.write_text(BIG_BUMP)
    t0 = time.perf_counter()
    code, _, err = _run(
        ['evaluate', '--fidelity', 'mixed', '--method', 'time-marching', '--config', str(cfg)],
        capsys,
    )
    assert code == 1 and time.perf_counter() - t0 < 30.0
    assert "mechanism's range" in err or 'edge of its range' in err, err
    assert 'Traceback' not in err
    out = tmp_path / 'opt'
    code, _, err = _run(
        [
            'optimize',
            '--fidelity',
            'mixed',
            '--config',
            str(cfg),
            *GRID,
            '--out',
            str(out),
            '--quiet',
        ],
        capsys,
    )
    assert code == 1 and 'model evaluation failed at the starting point' in err
    res = json.loads((out / 'result.json').read_text())
    assert res['success'] is False and res['status'] == 'Model_Error'
    assert 'double wishbone' in res['message']


def test_road_that_excites_nothing_is_bad_input(tmp_path, capsys):
    """The reference normalization divides by J_k at the initial design; a bump beyond
    the end of the drive makes them zero: exit 2 naming objective.normalization."""
    cfg = tmp_path / 'late.toml'
    cfg.write_text('[road]\nprofile = "bump"\nstart = 200.0\n')
    code, _, err = _run(['evaluate', '--fidelity', 'low', '--config', str(cfg)], capsys)
    assert code == 2 and 'objective.normalization' in err and 'custom' in err


def test_start_moves_ipopt_not_the_normalization(tmp_path, capsys):
    """`--start` only says where IPOPT starts: the reference scales stay the J_k of the
    study's initial design (docs/model.md), so every start minimizes the same f and finds the
    same optimum."""
    from suspopt.spec.schema import StudyConfig
    from suspopt.verification.scales import resolve_scales

    results = []
    for name, start in (('a', []), ('b', ['--start', '45000,15000,4000,1500'])):
        code, _, _ = _run(
            [
                'optimize',
                '--fidelity',
                'low',
                *GRID,
                '--quiet',
                '--out',
                str(tmp_path / name),
                *start,
            ],
            capsys,
        )
        assert code == 0
        results.append(json.loads((tmp_path / name / 'result.json').read_text()))
    (s,) = resolve_scales(StudyConfig())
    for res in results:
        assert res['scales'] == s
    assert results[1]['start'] == {'k_S1': 45000.0, 'k_S2': 15000.0, 'c_S1': 4000.0, 'c_S2': 1500.0}
    assert abs(results[0]['objective'] - results[1]['objective']) < 1e-7
