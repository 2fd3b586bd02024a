"""The fault matrix: every command that writes a directory, under every fault a user's
machine can throw at it, ends with the documented exit code (``docs/commands.md``), one
error line and no traceback, and loses nothing that had finished.

Faults are hooked to the named stages of a run (:func:`suspopt.interrupts.stage`)
deterministically, never by sleeping: the first run of a command records its stages;
each fault then reruns it and strikes at one of them —

* SIGINT or SIGTERM (alternately) at each stage: exit 130; every solve that returned
  converged before the signal (the stage ``solve:returned``) is in the directory's
  record, the signal after IPOPT's last iteration included;
* a full disk (ENOSPC) at each atomic write, and at the SQLite case recorder's write:
  exit 4, one line naming the file, no partial or temporary file left;
* an output directory that cannot be created, and a second run on a directory another
  run holds (exit 4, exit 2: refused before any work, nothing changed).

The problems are tiny (the paper's half car over one bump for 0.4 s). ``optimize`` gets
a signal at every stage and a full disk at the first write of every kind of file; the
studies get the faults that reach their own saving code (the first and second converged
solves, their record's first write, their recorder), which come early in each run, and
with ``SUSPOPT_FAULT_MATRIX=full`` every stage as ``optimize`` (minutes).
"""

from __future__ import annotations

import contextlib
import errno
import io
import json
import os
import signal
import sqlite3
from pathlib import Path

import pytest

from suspopt import interrupts
from suspopt.cli.main import main
from suspopt.output.rundir import LOCK, RunDirectory

BUG = 'this is a bug in suspopt'
TINY = """\
[maneuver]
speed = 10.0
horizon = 0.4
[road]
profile = "bump"
height = 0.02
length = 1.0
start = 0.5
[transcription]
segments = "auto"
[objective]
normalization = "{normalization}"
"""
SCENARIOS = '[[scenario]]\nname = "a"\n[[scenario]]\nname = "b"\nspeed = 8.0\n'


class Strike:
    """The fault to strike at the ``nth`` occurrence of stage ``at``: ``'SIGINT'``,
    ``'SIGTERM'`` or ``'ENOSPC'``; records every stage and every solve that returned."""

    def __init__(self, at: str | None = None, nth: int = 1, fault: str = 'SIGINT'):
        self.at, self.nth, self.fault = at, nth, fault
        self.seen: list[str] = []
        self.converged: list[dict[str, float]] = []  # designs of converged solves
        self.struck = False

    def __call__(self, name: str, **info) -> None:
        self.seen.append(name)
        if name == 'solve:returned' and info.get('success'):
            self.converged.append(dict(info['design']))
        if self.at is None or self.struck or name != self.at:
            return
        if self.seen.count(name) < self.nth:
            return
        self.struck = True
        if self.fault == 'ENOSPC':
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        os.kill(os.getpid(), getattr(signal, self.fault))


def _run(argv: list[str], strike: Strike) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    interrupts.OBSERVERS.append(strike)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main([str(a) for a in argv])
    finally:
        interrupts.OBSERVERS.remove(strike)
    return code, out.getvalue(), err.getvalue()


def _clean(stderr: str) -> list[str]:
    assert 'Traceback' not in stderr and BUG not in stderr, stderr
    return [ln for ln in stderr.strip().splitlines() if ln.startswith('suspopt: error: ')]


def _records(directory: Path) -> list[dict]:
    """Every solve record of the directory's record file (found by its keys)."""
    manifest = directory / 'manifest.json'
    if not manifest.exists():
        return []
    data = json.loads((directory / json.loads(manifest.read_text())['record']).read_text())
    found: list[dict] = []

    def walk(node) -> None:
        if isinstance(node, dict):
            if 'design' in node and node.get('success') is True:
                found.append(node)
            for v in node.values():
                walk(v)
        elif isinstance(node, list):
            for v in node:
                walk(v)

    walk(data)
    return found


def _same(a: dict[str, float], b: dict[str, float]) -> bool:
    return set(a) == set(b) and all(abs(a[k] - b[k]) <= 1e-9 * max(1.0, abs(a[k])) for k in a)


def _assert_whole(directory: Path) -> None:
    """No temporary file, no lock left; every JSON file whole."""
    if not directory.exists():
        return
    left = [p.name for p in directory.rglob('*') if p.suffix == '.tmp' or p.name == LOCK]
    assert not left, left
    for p in directory.glob('*.json'):
        json.loads(p.read_text())


@pytest.fixture()
def study_files(tmp_path: Path) -> dict[str, Path]:
    files = {}
    for name, normalization, extra in (
        ('reference', 'reference', ''),
        ('paper', 'paper', ''),
        ('robust', 'paper', SCENARIOS),
        ('codesign', 'reference', '[control]\nkind = "active"\n'),
    ):
        files[name] = tmp_path / f'{name}.toml'
        files[name].write_text(TINY.format(normalization=normalization) + extra)
    return files


def _signal_strike(argv: list[str], out: Path, at: str, nth: int, fault: str) -> Strike:
    """Run ``argv`` with a signal at stage ``at``: exit 130, nothing converged lost."""
    strike = Strike(at, nth, fault)
    code, _, err = _run([*argv, '--out', out, '--overwrite'], strike)
    assert strike.struck, (at, strike.seen)
    assert code == 130, (at, code, err)
    _clean(err)
    assert 'interrupted' in err
    _assert_whole(out)
    kept = _records(out)
    lost = [d for d in strike.converged if not any(_same(d, r['design']) for r in kept)]
    assert not lost, (at, fault, lost)
    return strike


def _disk_full(argv: list[str], out: Path, at: str, overwrite: bool = True) -> None:
    """Run ``argv`` with a full disk at the write ``at``: exit 4, one line naming it."""
    strike = Strike(at, 1, 'ENOSPC')
    code, _, err = _run([*argv, '--out', out] + ['--overwrite'] * overwrite, strike)
    assert strike.struck, (at, strike.seen)
    (line,) = _clean(err)
    assert code == 4 and os.strerror(errno.ENOSPC) in line, (at, code, err)
    assert at.removeprefix('write:') in line, (at, line)
    _assert_whole(out)


def _recorder_full(argv: list[str], out: Path, monkeypatch) -> None:
    """The SQLite case recorder's disk fills up: exit 4 naming a case recorder."""
    from openmdao.recorders.sqlite_recorder import SqliteRecorder

    def full(self, *args, **kwargs):
        raise sqlite3.OperationalError('database or disk is full')

    with monkeypatch.context() as m:
        m.setattr(SqliteRecorder, 'record_iteration_problem', full)
        code, _, err = _run([*argv, '--out', out, '--overwrite'], Strike())
    (line,) = _clean(err)
    assert code == 4 and 'case recorder' in line and 'disk is full' in line, (code, err)
    _assert_whole(out)


def _refused_before_work(argv: list[str], tmp_path: Path, overwrite: bool = True) -> None:
    """An output directory that cannot be created (exit 4), and one another run holds
    (exit 2): refused at once, nothing in it changed."""
    blocker = tmp_path / 'a-file'
    blocker.write_text('not a directory')
    code, _, err = _run([*argv, '--out', blocker / 'out'], Strike())
    (line,) = _clean(err)
    assert code == 4 and 'cannot create' in line, err
    held = tmp_path / 'held'
    held.mkdir()
    (held / 'notes.txt').write_text('mine')
    with RunDirectory(held, fresh=False):
        strike = Strike()
        code, _, err = _run([*argv, '--out', held] + ['--overwrite'] * overwrite, strike)
    (line,) = _clean(err)
    assert code == 2 and 'in use by another suspopt run' in line, err
    assert not strike.seen and sorted(p.name for p in held.iterdir()) == ['notes.txt']


# ------------------------------------------------------------------ every stage
def _every_stage(argv: list[str], tmp_path: Path, monkeypatch) -> list[str]:
    """A first run records the stages; then a signal (SIGINT and SIGTERM alternately) at
    every stage, and a full disk at the first write of every kind of file. Returns the
    stages."""
    out = tmp_path / 'out'
    # a coloring cache of this test's own, emptied before each run: coloring is a stage
    monkeypatch.setenv('SUSPOPT_CACHE_DIR', str(tmp_path / 'cache-0'))
    first = Strike()
    code, _, err = _run([*argv, '--out', out], first)
    assert code == 0, err
    stages = list(dict.fromkeys(first.seen))
    # the first write of each kind of file: the record's, the manifest, an input copy, the
    # table, a figure (every write goes through the one atomic writer)
    kinds = {'write:manifest.json': 'manifest'}
    kinds.update({s: 'record' for s in stages if s.endswith(('result.json', 'study.json'))})
    writes = list(
        {
            kinds.get(s, Path(s).suffix): s for s in reversed(stages) if s.startswith('write:')
        }.values()
    )
    for i, stage in enumerate(s for s in stages if not s.startswith('write:')):
        monkeypatch.setenv('SUSPOPT_CACHE_DIR', str(tmp_path / f'cache-{i + 1}'))
        _signal_strike(argv, out, stage, 1, ('SIGINT', 'SIGTERM')[i % 2])
    for stage in writes:
        _disk_full(argv, out, stage)
    return stages


@pytest.mark.slow
def test_optimize_under_every_fault_at_every_stage(tmp_path, study_files, monkeypatch):
    argv = ['optimize', '--fidelity', 'low', '--config', study_files['paper'], '--quiet']
    stages = _every_stage(argv, tmp_path, monkeypatch)
    assert {'scales', 'build', 'coloring', 'ipopt:iteration', 'solve:returned', 'verify'} <= set(
        stages
    ), stages
    assert {'render', 'write:result.json', 'write:table.md', 'write:road.png'} <= set(stages)
    out = tmp_path / 'out'
    strike = _signal_strike(argv, out, 'ipopt:end', 1, 'SIGTERM')  # after the last iteration
    data = json.loads((out / 'result.json').read_text())  # converged: kept as a result
    assert data['success'] and data['interrupted'] and strike.converged
    assert data['verification']['state'] == 'interrupted'
    _recorder_full(argv, out, monkeypatch)
    _refused_before_work(argv, tmp_path)


@pytest.mark.slow
def test_a_signal_after_ipopts_last_iteration_of_a_mixed_optimize_keeps_the_result(
    tmp_path, study_files
):
    """The interval found losing the converged result (exit 130, no result.json): from
    IPOPT's return to the record's write, every point of it."""
    argv = ['optimize', '--fidelity', 'mixed', '--config', study_files['paper'], '--quiet']
    out = tmp_path / 'out'
    for i, stage in enumerate(('ipopt:end', 'solve:returned', 'record:mixed_optimum')):
        _signal_strike(argv, out, stage, 1, ('SIGINT', 'SIGTERM')[i % 2])
        data = json.loads((out / 'result.json').read_text())
        assert data['success'] and data['interrupted'] and data['objective'] is not None


# ------------------------------------------------------------------ the studies
#: command line, study file, record file, whether it keeps a case recorder
STUDIES = {
    'study': (['study', '--verify-jobs', '0'], 'paper', 'study.json', True),
    'pareto': (['pareto', '--points', '2'], 'paper', 'pareto.json', True),
    'robust': (['robust'], 'robust', 'robust.json', False),
    'compare': (['compare', '--mechanisms', 'macpherson'], 'paper', 'compare.json', True),
    'coupling': (['coupling'], 'paper', 'coupling.json', False),
    'codesign': (['codesign'], 'codesign', 'codesign.json', False),
}


@pytest.mark.slow
@pytest.mark.parametrize('command', list(STUDIES))
def test_every_study_under_the_faults_that_reach_its_own_saving(
    command, tmp_path, study_files, monkeypatch
):
    head, config, record, recorder = STUDIES[command]
    argv = [*head, '--config', study_files[config], '--quiet']
    out = tmp_path / 'out'
    if os.environ.get('SUSPOPT_FAULT_MATRIX') == 'full':  # every stage, as optimize
        _every_stage(argv, tmp_path, monkeypatch)
    # a signal just after the first converged solve returned, and as the second did
    _signal_strike(argv, out, 'solve:returned', 1, 'SIGINT')
    assert _records(out), 'the converged solve is kept'
    _signal_strike(argv, out, 'solve:returned', 2, 'SIGTERM')
    _disk_full(argv, out, f'write:{record}')
    if recorder:
        _recorder_full(argv, out, monkeypatch)
    _refused_before_work(argv, tmp_path)


# ------------------------------------------------------------------ the other writers
def test_kinematics_report_and_init_under_a_full_disk_and_a_held_directory(tmp_path, study_files):
    kin = ['kinematics', 'double_wishbone', '--points', '3']
    _disk_full(kin, tmp_path / 'kin', 'write:kinematics_double_wishbone.md', overwrite=False)
    _refused_before_work(kin, tmp_path, overwrite=False)
    run = tmp_path / 'run'
    code, _, err = _run(
        [
            'optimize',
            '--fidelity',
            'low',
            '--config',
            study_files['paper'],
            '--quiet',
            '--no-verify',
            '--out',
            run,
        ],
        Strike(),
    )
    assert code == 0, err
    strike = Strike('write:table.md', 1, 'ENOSPC')
    code, _, err = _run(['report', run], strike)
    (line,) = _clean(err)
    assert code == 4 and 'table.md' in line
    with RunDirectory(run, fresh=False):  # a run writing into it: report waits for nothing
        code, _, err = _run(['report', run], Strike())
    assert code == 2 and 'in use by another suspopt run' in _clean(err)[0]
    code, _, err = _run(['report', run], Strike('render', 1, 'SIGTERM'))
    assert code == 130 and not _clean(err)
    _assert_whole(run)
    strike = Strike('write:new.toml', 1, 'ENOSPC')
    code, _, err = _run(['init', tmp_path / 'new.toml'], strike)
    (line,) = _clean(err)
    assert code == 4 and 'new.toml' in line and not (tmp_path / 'new.toml').exists()
