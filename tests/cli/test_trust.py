"""Trust (issue 15): a result is verified or flagged, interruptions and failures lose
nothing, and bad input never reaches "a bug in suspopt".

Every test here states one promise to the user and checks it as the user sees it: the
exit code, the one-line message naming the key, the files left behind. Signals are sent
to real processes. Grids are coarse and verification is skipped wherever the promise is
not about verification.
"""

from __future__ import annotations

import codecs
import contextlib
import dataclasses
import errno
import io
import json
import math
import multiprocessing
import os
import re
import signal
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import pytest

from suspopt.cli.main import main
from suspopt.multibody.mechanism import mechanism_path
from suspopt.output.rundir import write_record
from suspopt.records.codec import FORMAT
from suspopt.records.manifest import DOCUMENTS
from suspopt.records.solve import ScenarioResult, SolveRecord
from suspopt.records.twostep import TwoStepStudy
from suspopt.records.verification import Verification
from suspopt.road import read_road_csv
from suspopt.spec.load import config_from_dict
from suspopt.spec.template import toml_value

ROOT = Path(__file__).resolve().parents[2]
SUSPOPT = [sys.executable, '-m', 'suspopt.cli']
#: the paper's grid (16 x 5): the coarsest the default car accepts, quick to solve
GRID = ['--segments', '16']
#: the measured road of :func:`_road_csv` has content up to 8.6 Hz at 10 m/s
CSV_GRID = ['--segments', '20']
BUG = 'this is a bug in suspopt'


def _run(args, capsys):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


def _errors(stderr: str) -> list[str]:
    """The error lines; every line of stderr is one (no traceback, no bug line)."""
    assert 'Traceback' not in stderr and BUG not in stderr, stderr
    lines = stderr.strip().splitlines()
    assert lines and all(ln.startswith('suspopt: error: ') for ln in lines), stderr
    return lines


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def _env(**extra: str) -> dict[str, str]:
    return {**os.environ, 'PYTHONUNBUFFERED': '1', **extra}


def _road_csv(path: Path) -> Path:
    """A measured-road stand-in: a 3 cm, 2 m long 1-cos bump at 8 m; 60 m of data."""

    def h(s: float) -> float:
        return 0.015 * (1.0 - math.cos(math.pi * (s - 8.0))) if 8.0 <= s <= 10.0 else 0.0

    rows = ['distance,height'] + [f'{s:g},{h(s):.6f}' for s in (i * 0.25 for i in range(241))]
    return _write(path, '\n'.join(rows) + '\n')


# ------------------------------------------------------------------ silently wrong results
@pytest.mark.parametrize(
    'toml, args, cause',
    [
        ('', ['--segments', '1'], 'of the wheel hop'),  # converged to f = 0.000000 before
        ('[maneuver]\nspeed = 100.0\n', [], 'bumps of 2 m at 100 m/s'),  # km/h typed as m/s
    ],
    ids=['one segment', 'speed 100'],
)
def test_a_grid_that_cannot_resolve_the_motion_is_refused(tmp_path, capsys, toml, args, cause):
    study = _write(tmp_path / 'study.toml', toml)
    for command in (
        ['evaluate', '--fidelity', 'low'],
        ['optimize', '--fidelity', 'low', '--out', tmp_path / 'out'],
    ):
        code, _, err = _run([*command, '--config', study, *args], capsys)
        (line,) = _errors(err)
        assert code == 2 and 'transcription.segments' in line and cause in line, line
        assert 'too coarse' in line and '"auto" gives' in line
    assert not (tmp_path / 'out').exists()  # before any work
    # segments = "auto" sizes the grid instead
    from suspopt.spec.resolve import grid_problems

    data = {**tomllib.loads(toml), 'transcription': {'segments': 'auto'}}
    cfg = config_from_dict(data)
    (sc,) = cfg.scenarios()
    assert grid_problems(cfg, sc, 'transcription.segments') == [] and sc.segments >= 90


def test_a_grid_too_coarse_for_the_horizon_is_flagged_not_verified(tmp_path, capsys):
    """The paper's car and bumps over 20 s on the default 80 segments: enough nodes per
    wheel-hop period to be accepted, too few to agree with time marching: exit 3."""
    study = _write(
        tmp_path / 'study.toml',
        '[maneuver]\nhorizon = 20.0\n[objective]\nnormalization = "paper"\n',
    )
    code, out, err = _run(['evaluate', '--fidelity', 'low', '--config', study], capsys)
    res = json.loads(out)
    assert code == 3 and res['verified'] is False and res['success'] is True
    c = res['verification']['comparison']
    assert res['verification']['state'] == 'not_verified' and c['max_rel_diff'] > c['tolerance']
    (line,) = _errors(err)
    assert 'NOT verified' in line and '"auto"' in line


@pytest.mark.parametrize(
    'toml, key',
    [
        ('[vehicle.front]\nwheel_mass = 1.2\n', 'vehicle.front.wheel_mass'),  # typo for 120
        ('[vehicle.rear]\ntyre_stiffness = 2e9\n', 'vehicle.rear.tyre_stiffness'),
        ('[maneuver]\nspeed = 1000.0\n', 'maneuver.speed'),
        ('[maneuver]\nhorizon = 1e6\n', 'maneuver.horizon'),
        ('[transcription]\nsegments = 100000\n', 'transcription.segments'),
        (
            '[transcription]\nsegments = "auto"\n[maneuver]\nhorizon = 500.0\n',
            'transcription.segments',
        ),  # auto-sized beyond what can be built
        ('[design.c_S1]\nupper = 5e9\n', 'design.c_S1.upper'),
        ('[road]\nprofile = "bump"\nheight = 5.0\n', 'road.height'),  # 5 cm typed as 5 m
    ],
    ids=[
        'wheel 1.2 kg',
        'tyre',
        'speed',
        'horizon 1e6 s',
        'segments 100000',
        'auto 500 s',
        'damping',
        'bump 5 m',
    ],
)
def test_absurd_magnitudes_are_refused_at_once(tmp_path, capsys, toml, key):
    study = _write(tmp_path / 'study.toml', toml)
    t0 = time.perf_counter()
    code, _, err = _run(
        ['evaluate', '--fidelity', 'low', '--method', 'time-marching', '--config', study], capsys
    )
    (line,) = _errors(err)  # one line: the cause, not its consequences
    assert code == 2 and f'{study}: {key}: ' in line, line
    assert time.perf_counter() - t0 < 10.0  # no minutes-long hang


# ------------------------------------------------------------------ mechanism files
def _mechanism(tmp_path: Path, name: str, *replacements: tuple[str, str]) -> Path:
    text = mechanism_path('double_wishbone').read_text()
    for old, new in replacements:
        assert old in text
        text = text.replace(old, new)
    return _write(tmp_path / f'{name}.toml', text)


def test_a_tyre_load_pointing_down_or_an_unstable_linkage_is_refused(tmp_path, capsys):
    down = _mechanism(tmp_path, 'down', ('direction = [0.0, 1.0]', 'direction = [0.0, -1.0]'))
    # the spring mount level with the spring point: the spring does not deflect with the
    # wheel travel at the reference pose, zero wheel rate
    flat = _mechanism(
        tmp_path,
        'flat',
        ('point = [0.27, 0.5]', 'point = [0.0, 0.2]'),
        ('type = "linear_spring_damper"', 'type = "spring_damper"'),
        (
            'axis = [0.0, -1.0]     # fixed in the frame, from the mount down to '
            'the spring point\n',
            '',
        ),
    )
    for mech, axle, words in (
        (down, 'rear', ['loads[0].direction', 'points down', "(load 'tyre'"]),
        (
            flat,
            'front',
            ['suspension.spring', 'wheel rate 0 N/m', 'statically unstable', "(force 'spring')"],
        ),
    ):
        study = _write(
            tmp_path / f'{mech.stem}.study.toml', f'[vehicle.{axle}]\nmechanism = "{mech.name}"\n'
        )
        code, _, err = _run(
            ['evaluate', '--fidelity', 'low', '--method', 'time-marching', '--config', study],
            capsys,
        )
        (line,) = _errors(err)
        assert code == 2 and f'vehicle.{axle}.mechanism: {mech}' in line
        assert all(w in line for w in words), line
    code, _, err = _run(['kinematics', down, '--out', tmp_path / 'kin'], capsys)
    assert code == 2 and 'points down' in _errors(err)[0]


# ------------------------------------------------------------------ IPOPT options
@pytest.mark.parametrize(
    'option, words',
    [
        ('hessian_approximation = "exact"', 'set optimizer.hessian instead'),
        ('linear_solver = "ma27"', "IPOPT cannot run with 'ma27'"),  # not in the bundled IPOPT
        ('output_file = "no-such-dir/ipopt.out"', 'directory no-such-dir does not exist'),
        ('max_iter = 3', 'set optimizer.max_iter instead'),
    ],
    ids=['exact Hessian', 'linear solver', 'output file', 'driver option'],
)
def test_ipopt_options_that_would_fail_later_are_refused_up_front(tmp_path, capsys, option, words):
    study = _write(tmp_path / 'study.toml', f'[optimizer.options]\n{option}\n')
    code, _, err = _run(
        ['optimize', '--fidelity', 'low', '--config', study, '--out', tmp_path / 'out'], capsys
    )
    (line,) = _errors(err)
    assert code == 2 and f'optimizer.options.{option.split()[0]}: ' in line and words in line
    assert not (tmp_path / 'out').exists()


# ------------------------------------------------------------------ road CSV
def test_a_road_csv_with_a_byte_order_mark_keeps_its_first_row(tmp_path, capsys):
    rows = '0,0\n5,0\n5.5,0.02\n6,0\n60,0\n'
    path = tmp_path / 'road.csv'
    path.write_bytes(codecs.BOM_UTF8 + rows.encode())  # as a spreadsheet saves it
    s, h = read_road_csv(path)
    assert s[0] == 0.0 and len(s) == 5  # the first row is data, not a header
    path.write_bytes(codecs.BOM_UTF8 + b'distance,height\n' + rows.encode())
    assert len(read_road_csv(path)[0]) == 5  # a header with a mark is still a header
    study = _write(
        tmp_path / 'study.toml',
        '[road]\nprofile = "csv"\nfile = "road.csv"\n[objective]\nnormalization = "paper"\n',
    )
    code, out, err = _run(
        ['evaluate', '--fidelity', 'low', '--method', 'time-marching', '--config', study], capsys
    )
    assert code == 0 and json.loads(out)['success'], err
    _write(path, '0,0,x\n1\n2,0\n3,0\n60,0\n')  # a number in the first row: it is data
    code, _, err = _run(['evaluate', '--fidelity', 'low', '--config', study], capsys)
    assert code == 2 and 'road.file' in _errors(err)[0] and 'row 2 is not two numbers' in err


# ------------------------------------------------------------------ results directories
def _fake_record(ok: bool = True) -> SolveRecord:
    """A converged evaluation of the default car at its initial design (made-up values)."""
    cfg = config_from_dict({})
    terms = dict.fromkeys(cfg.terms(), 1.0)
    x = cfg.design.initial()
    return SolveRecord(
        fidelity='low',
        mode='evaluate',
        method='collocation',
        start=x,
        design=x,
        success=ok,
        status='Solve_Succeeded',
        objective=1.0,
        scenarios=(ScenarioResult('default', 1.0, dict(terms), 1.0, terms),),
        verification=Verification.skipped(),
    )


def _fake_study(out: Path, evaluations: dict | None = None, **changes) -> TwoStepStudy:
    """A minimal study directory as a run writes it (manifest and study.json)."""
    cfg = config_from_dict({})
    out.mkdir(parents=True, exist_ok=True)
    study = TwoStepStudy(
        config=cfg.to_dict(),
        scales=(dict.fromkeys(cfg.terms(), 1.0),),
        terms=cfg.terms(),
        design_names=cfg.design_names(),
        normalization='reference',
        weights=dict(cfg.objective.weights),
        evaluations=evaluations or {},
        complete=True,
    )
    study = dataclasses.replace(study, **changes)
    write_record(out, study)
    return study


#: a manifest of each kind of run
MANIFESTS = {
    kind: json.dumps({'kind': kind, 'format': FORMAT, 'record': file})
    for kind, (_, file) in DOCUMENTS.items()
}


def test_report_refuses_a_damaged_results_directory(tmp_path, capsys):
    """Every damaged file a user can hand to ``report`` is exit 2 with one line naming
    the file and the key (never the bug line)."""
    cases = {
        'not a directory': ('x', 'not a directory'),
        'empty': ('', 'no manifest.json'),
    }
    (tmp_path / 'x').write_text('')
    study = MANIFESTS['study']
    for name, manifest, text, words in (
        ('no manifest', None, '{}', 'no manifest.json'),
        ('garbage manifest', '{"kind": ', None, 'manifest.json: damaged results file'),
        ('unknown kind', '{"kind": "x", "format": 1, "record": "a"}', None, 'kind: not a kind'),
        ('newer format', study.replace(f'"format": {FORMAT}', '"format": 99'), '{}', 'format'),
        ('no record', study, None, 'no study.json'),
        ('garbage', study, '{"config": ', 'study.json: damaged results file'),
        ('incomplete', study, '{}', 'study.json: kind: missing'),
        ('another kind', study, '{"kind": "solve", "format": 1}', "kind: expected 'study'"),
        (
            'wrong types',
            study,
            json.dumps({'kind': 'study', 'format': FORMAT, 'config': 1, 'scales': 2}),
            'study.json: config: expected a JSON object, got 1',
        ),
    ):
        (tmp_path / name).mkdir()
        if manifest is not None:
            (tmp_path / name / 'manifest.json').write_text(manifest)
        if text is not None:
            (tmp_path / name / 'study.json').write_text(text)
        cases[name] = (name, words)
    (tmp_path / 'run').mkdir()
    (tmp_path / 'run' / 'manifest.json').write_text(MANIFESTS['solve'])
    (tmp_path / 'run' / 'result.json').write_text(
        json.dumps({'kind': 'solve', 'format': FORMAT, 'fidelity': 'low'})
    )
    cases['incomplete run'] = ('run', 'result.json: mode: missing')
    _fake_study(tmp_path / 'recorder', {'low/initial': _fake_record()})
    (tmp_path / 'recorder' / 'low.sql').write_bytes(b'not a database' * 100)
    cases['damaged recorder'] = ('recorder', 'damaged case recorder')
    _fake_study(tmp_path / 'no car', config={'road': {}})
    cases['damaged study description'] = ('no car', 'study.json: config.vehicle: missing')
    bad_value = _fake_record().to_json()
    bad_value['scenarios'][0]['terms']['heave'] = 'x'
    (tmp_path / 'value').mkdir()
    (tmp_path / 'value' / 'manifest.json').write_text(MANIFESTS['solve'])
    (tmp_path / 'value' / 'result.json').write_text(json.dumps(bad_value))
    cases['a term not a number'] = ('value', 'scenarios[0].terms.heave: expected a number')
    for name, (d, words) in cases.items():
        code, _, err = _run(['report', tmp_path / d], capsys)
        (line,) = _errors(err)
        assert code == 2, (name, err)
        assert words in line, (name, line)


def test_an_unwritable_or_full_out_is_exit_4(tmp_path, capsys, monkeypatch):
    (tmp_path / 'file').write_text('')
    code, _, err = _run(
        ['optimize', '--fidelity', 'low', '--out', tmp_path / 'file' / 'out'], capsys
    )
    (line,) = _errors(err)
    assert code == 4 and 'cannot create' in line

    import suspopt.output.rundir as results

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(results.json, 'dump', full)  # the disk fills up
    code, _, err = _run(
        ['study', *GRID, '--no-verify', '--quiet', '--out', tmp_path / 'full'], capsys
    )
    (line,) = _errors(err)
    assert code == 4 and os.strerror(errno.ENOSPC) in line
    assert re.search(r'cannot write \S*/full/(manifest|study)\.json', line), line


def test_overwrite_leaves_nothing_of_an_earlier_run_when_the_new_one_fails_early(tmp_path, capsys):
    out = tmp_path / 'study'
    _fake_study(out)
    for name in ('table.md', 'time_marching.npz', 'low.sql', 'study.json.x1y2.tmp'):
        (out / name).write_text('earlier run')
    (out / 'figures').mkdir()
    (out / 'figures' / 'road.png').write_text('earlier run')
    (out / 'notes.txt').write_text("the user's own file")
    # bumps the car never reaches: the reference normalization fails after --overwrite
    study = _write(
        tmp_path / 'study.toml', '[road]\nprofile = "two_bumps"\nstarts = [200.0, 205.0]\n'
    )
    code, _, err = _run(
        ['study', '--config', study, '--out', out, '--overwrite', '--quiet'], capsys
    )
    assert code == 2 and 'objective.normalization' in _errors(err)[0]
    assert sorted(p.name for p in out.iterdir()) == ['notes.txt']


def test_held_variables_failed_solves_and_kept_inputs(tmp_path, capsys):
    """``--start`` cannot move a variable with ``optimize = false``; a failed solve is
    never reported as a score (result.json, summary, table, CLI line); ``report`` renders
    from the run's own copy of the road CSV after the original is gone."""
    road = _road_csv(tmp_path / 'road.csv')
    study = _write(
        tmp_path / 'study.toml',
        f'[road]\nprofile = "csv"\nfile = "{road.name}"\n'
        '[design.k_S1]\noptimize = false\n[objective]\nnormalization = "paper"\n',
    )
    out = tmp_path / 'run'
    code, _, err = _run(
        [
            'optimize',
            '--fidelity',
            'low',
            '--config',
            study,
            *CSV_GRID,
            '--start',
            'k_S1=35000',
            '--out',
            out,
        ],
        capsys,
    )
    (line,) = _errors(err)
    assert code == 2 and '--start: k_S1' in line and 'optimize = false' in line
    assert not out.exists()
    code, stdout, err = _run(
        [
            'optimize',
            '--fidelity',
            'low',
            '--config',
            study,
            *CSV_GRID,
            '--start',
            'c_S1=2000',
            '--max-iter',
            '2',
            '--no-verify',
            '--quiet',
            '--out',
            out,
        ],
        capsys,
    )
    (line,) = _errors(err)
    assert code == 1 and 'did not converge' in line
    res = json.loads((out / 'result.json').read_text())
    assert res['success'] is False and res['objective'] is None and res['terms'] is None
    assert math.isfinite(res['objective_at_stop']) and res['terms_at_stop']
    assert all(s['objective'] is None and s['terms'] is None for s in res['scenarios'])
    assert res['start']['c_S1'] == 2000.0
    assert res['design']['k_S1'] == pytest.approx(30000.0, rel=1e-12)  # held
    assert 'objective f: none (not converged' in stdout and 'objective f =' not in stdout
    moved = tmp_path / 'moved'
    out.rename(moved)  # the copies travel with the directory
    out = moved
    road.unlink()  # report reads the run's copy, never the original
    code, stdout, err = _run(['report', out], capsys)
    assert code == 0, err
    table = (out / 'table.md').read_text()
    assert 'NOT converged' in table and 'not a result' in table
    row = next(ln for ln in table.splitlines() if ln.startswith('| stopped at'))
    assert row.endswith('| — |')  # no f where IPOPT stopped
    assert (out / 'figures' / 'road.png').stat().st_size > 10_000


def test_a_failed_pareto_point_is_not_a_point_of_the_front():
    from suspopt.output.pareto_report import pareto_markdown
    from suspopt.records.pareto import ParetoFront, ParetoPoint

    failed = dataclasses.replace(
        _fake_record(),
        success=False,
        status='Maximum_Iterations_Exceeded',
        objective=None,
        objective_at_stop=0.0,
        iterations=3,
        design={'k_S1': 2e4},
    )
    front = ParetoFront(
        config={},
        fidelity='low',
        scales=({},),
        terms=(),
        design_names=('k_S1',),
        bounds={'k_S1': (1e4, 5e4)},
        normalization='reference',
        points=[ParetoPoint(0.5, {}, failed, None, None, 0.0, 0.0)],
    )
    row = pareto_markdown(front).splitlines()[4]
    assert row.startswith('| 0.500 | 20000 | — | — | — |') and 'NOT converged' in row


# ------------------------------------------------------------------ interruptions
def test_an_interrupt_just_after_ipopts_last_iteration_keeps_the_result(
    tmp_path, capsys, monkeypatch
):
    import cyipopt

    import suspopt.driver.ipopt

    class LateInterrupt(cyipopt.Problem):
        def solve(self, x):
            result = super().solve(x)
            os.kill(os.getpid(), signal.SIGINT)  # Ctrl-C as IPOPT returns
            return result

    monkeypatch.setattr(suspopt.driver.ipopt.cyipopt, 'Problem', LateInterrupt)
    out = tmp_path / 'run'
    code, _, err = _run(
        [
            'optimize',
            '--fidelity',
            'low',
            *GRID,
            '--normalization',
            'paper',
            '--quiet',
            '--out',
            out,
        ],
        capsys,
    )
    assert code == 130 and 'interrupted' in err and BUG not in err
    res = json.loads((out / 'result.json').read_text())
    assert res['success'] is True and res['interrupted'] is True
    assert math.isfinite(res['objective']) and res['terms']
    assert res['verified'] is None and res['verification']['state'] == 'interrupted'
    assert 'interrupted' in res['verification']['note']


def test_a_study_interrupted_after_a_step_converged_keeps_that_step(tmp_path, capsys, monkeypatch):
    """Ctrl-C as IPOPT returns from the low-fidelity optimization (the study's second
    solve): the converged step is kept, marked not checked; the study is not complete."""
    import cyipopt

    import suspopt.driver.ipopt

    solves = []

    class LateInterrupt(cyipopt.Problem):
        def solve(self, x):
            result = super().solve(x)
            solves.append(result[1]['status'])
            if len(solves) == 2:
                os.kill(os.getpid(), signal.SIGINT)
            return result

    monkeypatch.setattr(suspopt.driver.ipopt.cyipopt, 'Problem', LateInterrupt)
    out = tmp_path / 'study'
    code, _, err = _run(
        ['study', *GRID, '--normalization', 'paper', '--quiet', '--out', out], capsys
    )
    assert code == 130 and BUG not in err and solves == [0, 0]
    data = json.loads((out / 'study.json').read_text())
    assert data['complete'] is False and list(data['evaluations']) == ['low/initial']
    step = data['steps']['low']
    assert step['success'] and step['interrupted'] and step['verified'] is None
    assert step['verification']['state'] == 'interrupted'
    assert 'interrupted' in step['verification']['note']
    # the first evaluation's verification ran in the background: either it came in (a
    # real comparison: at this coarse grid the initial design is *not* verified, pitch
    # differs by ~90 %), or it is said to be cut off
    first = data['evaluations']['low/initial']
    v = first['verification']
    if v['state'] == 'interrupted':
        assert first['verified'] is None and v['comparison'] is None
    else:
        c = v['comparison']
        assert first['verified'] is (c['max_rel_diff'] <= c['tolerance'])
        assert math.isfinite(c['objective']) and c['scenarios'][0]['terms']
    assert not multiprocessing.active_children()  # no background process left


def _wait_for(proc: subprocess.Popen, lines: list[str], *patterns: str) -> None:
    """Read the process's stderr until each pattern has been seen, in order."""
    for pattern in patterns:
        for line in proc.stderr:
            lines.append(line)
            if re.search(pattern, line):
                break
        else:
            raise AssertionError(f'{pattern!r} never came: {"".join(lines)}')


def test_ctrl_c_during_a_study_evaluation_and_a_second_run_on_its_out(tmp_path, capsys):
    """A second run (this test's process) on the same --out is refused at once (the
    lock), even with --overwrite, and clears nothing; Ctrl-C during the study's evaluation
    of the mixed-fidelity model stops it (exit 130) with ``complete`` false and nothing
    unconverged kept."""
    out = tmp_path / 'study'
    study = subprocess.Popen(
        SUSPOPT
        + [
            'study',
            '--segments',
            '24',
            '--no-verify',
            '--normalization',
            'paper',
            '--out',
            str(out),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=_env(),
    )
    lines: list[str] = []
    try:
        _wait_for(study, lines, 'results in')
        study.send_signal(signal.SIGSTOP)  # it holds the lock while the second one tries
        t0 = time.perf_counter()
        second = _run(['optimize', '--fidelity', 'low', '--overwrite', '--out', out], capsys)
        assert time.perf_counter() - t0 < 5.0  # at once
        assert (out / '.suspopt.lock').exists()  # its lock untouched
        study.send_signal(signal.SIGCONT)
        # the mixed-fidelity evaluation's first IPOPT iteration
        _wait_for(study, lines, r'step 2/2', r'^\s+0 ')
        study.send_signal(signal.SIGINT)
        _, rest = study.communicate(timeout=120)
    finally:
        study.kill()
    stderr = ''.join(lines) + rest
    assert study.returncode == 130, stderr
    assert 'interrupted' in stderr and 'Traceback' not in stderr and BUG not in stderr
    assert second[0] == 2 and 'in use by another suspopt run' in _errors(second[2])[0]
    data = json.loads((out / 'study.json').read_text())
    assert data['complete'] is False and 'low/low_optimum' in data['evaluations']
    assert 'mixed/mixed_optimum' not in data['evaluations']
    assert all(e['success'] for e in data['evaluations'].values())
    assert all(s['success'] for s in data['steps'].values())
    assert not (out / 'table.md').exists()


def test_sigterm_during_pareto_leaves_no_scratch_and_report_uses_the_copies(tmp_path, capsys):
    scratch = tmp_path / 'tmp'
    scratch.mkdir()
    road = _road_csv(tmp_path / 'road.csv')
    study = _write(
        tmp_path / 'study.toml',
        f'[road]\nprofile = "csv"\nfile = "{road}"\n[objective]\nnormalization = "paper"\n',
    )
    out = tmp_path / 'pareto'
    proc = subprocess.Popen(
        SUSPOPT
        + [
            'pareto',
            '--points',
            '3',
            *CSV_GRID,
            '--no-verify',
            '--config',
            str(study),
            '--out',
            str(out),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=_env(TMPDIR=str(scratch)),
    )
    lines: list[str] = []
    try:
        _wait_for(proc, lines, r'comfort share 0\.000', r'^\s+1 ')
        proc.send_signal(signal.SIGTERM)
        _, rest = proc.communicate(timeout=120)
    finally:
        proc.kill()
    stderr = ''.join(lines) + rest
    assert proc.returncode == 130 and 'Traceback' not in stderr and BUG not in stderr, stderr
    assert not list(scratch.glob('suspopt-om-*'))
    front = json.loads((out / 'pareto.json').read_text())
    assert front['complete'] is False and all(p['result']['success'] for p in front['points'])
    road.unlink()
    code, _, err = _run(['report', out], capsys)
    assert code == 0, err
    assert (out / 'figures' / 'pareto.png').exists()


# ------------------------------------------------------------------ random bad input
BASE_STUDY = {
    'vehicle': {
        'front': {'wheel_mass': 120.0, 'tyre_stiffness': 200000.0, 'mechanism': 'mechanism.toml'},
        'rear': {'axle_position': -1.713, 'mechanism': 'double_wishbone'},
    },
    'maneuver': {'speed': 10.0, 'horizon': 1.0},
    'road': {'profile': 'bump', 'height': 0.05, 'length': 2.0, 'start': 1.0},
    'design': {
        'k_S1': {'initial': 30000.0, 'lower': 10000.0, 'upper': 50000.0},
        'c_S2': {'initial': 3000.0, 'lower': 1000.0, 'upper': 5000.0, 'optimize': True},
    },
    'objective': {'normalization': 'paper', 'weights': {'heave': 0.25, 'pitch': 0.25}},
    'transcription': {'segments': 'auto', 'order': 5},
    'optimizer': {'max_iter': 50, 'options': {'mu_strategy': 'adaptive'}},
    'multibody': {'fd_step': 1e-6},
}
BAD_VALUES = [
    'text',
    '',
    -1.0,
    0.0,
    -7,
    0,
    math.nan,
    math.inf,
    -math.inf,
    1e300,
    1e-300,
    True,
    [1.0, 2.0],
    [],
    {'x': 1.0},
    {},
]
#: an error line: "[<file>: ]<key>: ...", the key a dotted path with indices
KEY = re.compile(r'^[A-Za-z_][\w-]*(\[\d+\])?(\.[\w-]+(\[\d+\])?)*( \([^)]*\))?: ')


def _toml(data: dict) -> str:
    """A TOML file of ``data``: its tables as [sections], everything below them inline."""
    top = [f'{_key(k)} = {toml_value(v)}' for k, v in data.items() if not isinstance(v, dict)]
    for k, v in data.items():
        if isinstance(v, dict):
            top += [f'[{_key(k)}]'] + [f'{_key(a)} = {toml_value(b)}' for a, b in v.items()]
    return '\n'.join(top) + '\n'


def _key(k: str) -> str:
    return k if re.fullmatch(r'[A-Za-z0-9_-]+', k) else json.dumps(k)


def _paths(node, prefix=()):
    """Every place in a nested structure: (path, value)."""
    yield prefix, node
    items = (
        node.items()
        if isinstance(node, dict)
        else enumerate(node)
        if isinstance(node, list)
        else ()
    )
    for k, v in items:
        yield from _paths(v, prefix + (k,))


def _mutate(data, draw, st):
    """One random edit: a wrong value, a missing or renamed key, or swapped sections."""
    import copy

    data = copy.deepcopy(data)
    places = [p for p, _ in _paths(data) if p]
    path = draw(st.sampled_from(places))
    parent = data
    for k in path[:-1]:
        parent = parent[k]
    kind = draw(st.sampled_from(['value', 'value', 'value', 'delete', 'rename', 'swap']))
    last = path[-1]
    if kind == 'value' or not isinstance(parent, dict):
        parent[last] = draw(st.sampled_from(BAD_VALUES))
    elif kind == 'delete':
        del parent[last]
    elif kind == 'rename':
        parent[last[:-1] + last[-1].upper() if len(last) > 1 else last + 'x'] = parent.pop(last)
    else:
        other = draw(st.sampled_from(sorted(parent)))
        parent[last], parent[other] = parent[other], parent[last]
    return data


def _check_evaluate(tmp: Path, study: dict, mechanism: dict) -> None:
    (tmp / 'mechanism.toml').write_text(_toml(mechanism))
    path = tmp / 'study.toml'
    path.write_text(_toml(study))
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(
            ['evaluate', '--fidelity', 'low', '--method', 'time-marching', '--config', str(path)]
        )
    stderr = err.getvalue()
    assert code in (0, 2), (code, stderr, _toml(study), _toml(mechanism))
    if code == 0:
        assert math.isfinite(json.loads(out.getvalue())['objective'])
        return
    for line in _errors(stderr):
        rest = line.removeprefix('suspopt: error: ').removeprefix(f'{path}: ')
        assert KEY.match(rest), (line, _toml(study), _toml(mechanism))
        inner = rest.removeprefix('vehicle.front.mechanism: ')
        if inner.startswith(f'{tmp / "mechanism.toml"}: '):  # and the mechanism file's key
            assert KEY.match(inner.removeprefix(f'{tmp / "mechanism.toml"}: ')), line


def test_random_bad_study_and_mechanism_files_never_reach_a_bug(tmp_path):
    """Hypothesis edits valid files at random; every run either succeeds or is refused
    with lines that each name a key (never a traceback or the bug line)."""
    from hypothesis import HealthCheck, given, settings
    from hypothesis import strategies as st

    mechanism = tomllib.loads(mechanism_path('double_wishbone').read_text())
    _check_evaluate(tmp_path, BASE_STUDY, mechanism)  # the base files run

    @settings(
        max_examples=int(os.environ.get('SUSPOPT_HYPOTHESIS_EXAMPLES', 20)),
        deadline=None,
        derandomize=True,
        database=None,
        suppress_health_check=[HealthCheck.too_slow],
    )
    @given(st.data())
    def check(data):
        study, mech = BASE_STUDY, mechanism
        for _ in range(data.draw(st.integers(1, 2))):
            if data.draw(st.booleans()):
                study = _mutate(study, data.draw, st)
            else:
                mech = _mutate(mech, data.draw, st)
        _check_evaluate(tmp_path, study, mech)

    check()


# ------------------------------------------------------------------ house-keeping
README_BEGIN, README_END = '<!-- python-api -->', '<!-- /python-api -->'


def test_the_readme_python_api_example_runs(tmp_path, monkeypatch):
    """README.md's "Python API" example (a ```python block between the markers) runs as
    printed."""
    text = (ROOT / 'README.md').read_text()
    assert README_BEGIN in text and README_END in text, (
        f'README.md has no Python API example between {README_BEGIN} and {README_END}'
    )
    block = text.split(README_BEGIN, 1)[1].split(README_END, 1)[0]
    assert '```python' in block, 'the Python API example is a ```python block'
    code = block.split('```python', 1)[1].split('```', 1)[0]
    monkeypatch.chdir(tmp_path)
    exec(compile(code, 'README.md (Python API)', 'exec'), {'__name__': '__readme__'})


def test_nothing_a_user_receives_points_into_the_projects_shared_folder():
    files = [p for p in (ROOT / 'suspopt').rglob('*') if p.suffix in ('.py', '.toml')]
    files += [
        p
        for d in ('docs', 'examples')
        for p in (ROOT / d).rglob('*')
        if p.suffix in ('.md', '.toml', '.py', '.txt')
    ]
    files += [ROOT / 'README.md', ROOT / 'pyproject.toml']
    bad = [str(p.relative_to(ROOT)) for p in files if '../shared' in p.read_text()]
    assert not bad, f'"../shared" paths in {bad}'


def test_a_figure_is_written_whole_or_not_at_all(tmp_path):
    """Figures are saved atomically: a write that fails after the image file was opened
    (here PIL's encoder, given a bad compression level; Matplotlib's own ``savefig``
    leaves a 124-byte partial PNG in place of the old file) leaves the previous file as
    it was and no temporary file; a good one replaces it with a whole PNG."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    from suspopt.output.figures import save_figure

    path = tmp_path / 'figure.png'
    path.write_bytes(b'the previous figure')
    fig, ax = plt.subplots()
    ax.plot([0.0, 1.0])
    with pytest.raises(TypeError):
        save_figure(fig, path, pil_kwargs={'compress_level': 'not a number'})
    assert path.read_bytes() == b'the previous figure' and os.listdir(tmp_path) == [path.name]
    save_figure(fig, path)
    plt.close(fig)
    assert path.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n' and os.listdir(tmp_path) == [path.name]


def test_results_are_written_atomically_with_the_usual_permissions(tmp_path):
    """Every results file (JSON, tables, figures) gets the permissions a new file gets
    here (0o666 less the umask: readable by the group on a shared cluster folder, not the
    owner-only 0o600 of a temporary file), and a write that fails leaves the old file as
    it was and no temporary file."""
    import stat

    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    from suspopt.output.figures import save_figure
    from suspopt.output.rundir import NEW_FILE_MODE, write_json, write_text

    mask = os.umask(0o022)
    os.umask(mask)
    assert NEW_FILE_MODE == 0o666 & ~mask
    fig, ax = plt.subplots()
    ax.plot([0.0, 1.0])
    paths = [tmp_path / 'a.json', tmp_path / 'b.md', tmp_path / 'c.png']
    write_json(paths[0], {'x': 1})
    write_text(paths[1], 'table')
    save_figure(fig, paths[2])
    plt.close(fig)
    assert [stat.S_IMODE(p.stat().st_mode) for p in paths] == [NEW_FILE_MODE] * 3
    with pytest.raises(TypeError):
        write_text(paths[1], b'not text')
    assert paths[1].read_text() == 'table'
    assert sorted(p.name for p in tmp_path.iterdir()) == ['a.json', 'b.md', 'c.png']
