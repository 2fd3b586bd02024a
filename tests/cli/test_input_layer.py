"""The one input layer (suspopt.inputs, suspopt.cli.inputs): every command-line value and
every input file, however malformed, ends in a documented exit code with one line per
problem naming the key or the file, never a traceback or "a bug in suspopt".

A property-based test mutates valid files (study TOML, mechanism TOML, road CSV) and
valid argument vectors (empty, whitespace, signs, huge numbers, non-UTF-8 bytes,
truncation). Commands that would start work stop where the work starts (the run
directory's lock): the input phase is what is tested, each example in milliseconds."""

from __future__ import annotations

import contextlib
import io
import os
import re
from pathlib import Path

import pytest

from suspopt.cli.inputs import ARGUMENTS, CHOICES_AND_FLAGS
from suspopt.cli.main import main
from suspopt.cli.parser import build_parser
from suspopt.multibody.mechanism import mechanism_path

BUG = 'this is a bug in suspopt'
#: a cheap car: the paper's half car on one bump for 0.4 s, the paper's scales
STUDY = """\
[maneuver]
speed = 10.0
horizon = 0.4
[road]
profile = "csv"
file = "road.csv"
[vehicle.front]
mechanism = "mechanism.toml"
[transcription]
segments = "auto"
[objective]
normalization = "paper"
"""
#: a 2 cm, 1 m long bump at 1 m, 10 m of data
ROAD = 'distance,height\n' + ''.join(
    f'{0.25 * i:g},{0.02 if 4 <= i <= 7 else 0.0:g}\n' for i in range(41)
)


class WorkStarts(BaseException):
    """Raised where a command would start its work: the input was accepted."""


def _run(argv: list[str]) -> tuple[int | str, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code: int | str = main(argv)
        except WorkStarts:
            code = 'accepted'
    return code, out.getvalue(), err.getvalue()


def _assert_clean(code: int | str, stderr: str, allowed: tuple) -> None:
    """A documented code; every line of stderr an error line; no traceback, no bug."""
    assert code in allowed, (code, stderr)
    assert 'Traceback' not in stderr and BUG not in stderr, stderr
    if code not in (0, 'accepted'):
        lines = stderr.strip().splitlines()
        assert lines and all(ln.startswith('suspopt: error: ') for ln in lines), stderr


@pytest.fixture()
def files(tmp_path: Path) -> Path:
    (tmp_path / 'study.toml').write_text(STUDY)
    (tmp_path / 'road.csv').write_text(ROAD)
    (tmp_path / 'mechanism.toml').write_text(mechanism_path('double_wishbone').read_text())
    return tmp_path


@pytest.fixture()
def no_work(monkeypatch):
    """Every command stops where its work would start (after its input is checked)."""
    import suspopt.output.rundir as rundir

    def stop(self):
        raise WorkStarts

    monkeypatch.setattr(rundir.RunDirectory, '__enter__', stop)
    import suspopt.sweep.runner as runner

    for name in ('DirectoryLock',):  # the sweep's own lock (until it takes RunDirectory's)
        if hasattr(runner, name):
            monkeypatch.setattr(getattr(runner, name), '__enter__', stop)


# ------------------------------------------------------------------ the command line
def test_every_command_line_value_passes_through_the_input_layer():
    """Each option of each command is either checked by the input layer's table or is a
    choice or flag argparse checks itself: a new option cannot slip past it."""
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == 'command')
    missing = []
    for name, p in sub.choices.items():
        for action in p._actions:
            if action.dest in ('help',) or action.dest in CHOICES_AND_FLAGS:
                continue
            if action.dest not in ARGUMENTS and action.dest != 'points':
                missing.append(f'{name} {action.dest}')
            if action.type is not None:  # values are text; the table parses them
                missing.append(f'{name} {action.dest} (type={action.type})')
    assert not missing, missing


@pytest.mark.parametrize(
    'argv, words',
    [
        (['compare', '--mechanisms', ' '], '--mechanisms: empty value'),
        (['compare', '--mechanisms', 'double_wishbone,,macpherson'], 'an empty entry'),
        (['optimize', '--fidelity', 'low', '--start', ''], '--start: empty value'),
        (['evaluate', '--fidelity', 'low', '--design', '1,2,3,4,,'], 'an empty entry'),
        (['evaluate', '--fidelity', 'low', '--config', ''], '--config: empty value'),
        (['study', '--out', '  '], '--out: empty value'),
        (['report', ''], 'DIR: empty value'),
        (['init', ' '], 'FILE: empty value'),
        (['kinematics', 'double_wishbone', '--travel', ' '], '--travel: empty value'),
        (['kinematics', 'double_wishbone', '--points', '-3'], '--points: need at least 2'),
        (['kinematics', 'double_wishbone', '--points', '99999999999'], '--points: must be at most'),
        (['pareto', '--points', '1e3'], '--points: expected a whole number'),
        (['study', '--verify-jobs', '-1'], '--verify-jobs: must be >= 0'),
        (['optimize', '--fidelity', 'low', '--max-iter', '9' * 30], '--max-iter: must be at most'),
        (['optimize', '--fidelity', 'low', '--max-iter', '-5'], '--max-iter: must be >= 1'),
        (['evaluate', '--fidelity', 'low', '--order', '-1'], '--order: need at least 2'),
        (['evaluate', '--fidelity', 'low', '--segments', '-5'], '--segments: must be >= 1'),
        (['sweep', 'x.toml', '--out', 'o', '--workers', '-1'], '--workers: must be >= 1'),
        (
            ['sweep', 'x.toml', '--out', 'o', '--scheduler', 'http://localhost:8786'],
            "--scheduler: 'http' is not a scheme of a Dask scheduler",
        ),
        (
            ['kinematics', 'double_wishbone', '--k', '1e400'],
            '--k: the spring rate must be a finite number',
        ),
        (['evaluate', '--fidelity', 'lo'], "--fidelity: invalid choice: 'lo'"),
        (['evaluate'], 'the following arguments are required: --fidelity'),
        (['evaluate', '--fidelity', 'low', '--config', 'a\x00b'], '--config:'),
    ],
    ids=lambda v: ' '.join(v) if isinstance(v, list) else None,
)
def test_a_bad_command_line_value_is_one_line_naming_the_option(tmp_path, argv, words):
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        code, _, err = _run(argv)
    finally:
        os.chdir(cwd)
    _assert_clean(code, err, (2,))
    (line,) = err.strip().splitlines()
    assert words in line, line


def test_ipopt_option_errors_are_read_from_ipopts_own_documentation():
    """IPOPT's refusal of an option is one clean line: the type it expects, its valid
    settings or its range; an integer beyond a C int and a non-finite number are refused
    before IPOPT sees them (both raised or went through silently)."""
    from suspopt.driver import ipopt_option_problems

    (line,) = ipopt_option_problems({'linear_solver': 5})
    assert line.endswith('(valid: ma27, ma57, ma77, ma86, ma97, pardiso, mumps, custom)'), line
    assert 'expects a setting, got 5' in line
    (line,) = ipopt_option_problems({'acceptable_iter': 2**40})
    assert 'too large' in line
    (line,) = ipopt_option_problems({'bound_push': float('nan')})
    assert 'must be a finite number' in line
    (line,) = ipopt_option_problems({'mu_init': -1.0})
    assert line.startswith('mu_init: -1.0 is out of range (range: 0 < (0.1) <= +inf')
    (line,) = ipopt_option_problems({'': 'x'})
    assert line.startswith(": '' is not an option name")


# ------------------------------------------------------------------ input files
@pytest.mark.parametrize(
    'name, mangle, words',
    [
        ('mechanism.toml', lambda b: b.replace(b'#', b'# \xe9', 1), 'not a text (UTF-8) file'),
        ('study.toml', lambda b: b'# caf\xe9\n' + b, 'not a text (UTF-8) file'),
        ('road.csv', lambda b: b.replace(b'height', b'height \xb5m'), 'not a text (UTF-8)'),
        # cut inside a string (a cut between two tables is valid TOML with keys missing)
        ('mechanism.toml', lambda b: b[: b.index(b'"W-U"') + 3], 'not valid TOML'),
        ('road.csv', lambda b: b.replace(b'1.5,0.02', b'1.5,1e300'), 'beyond a road surface'),
        ('study.toml', lambda b: b'[road]\nprofile = "iso8608"\nseed = -1\n', 'road.seed'),
    ],
    ids=['mechanism latin-1', 'study latin-1', 'csv latin-1', 'mechanism cut', 'csv 1e300', 'seed'],
)
def test_a_bad_input_file_is_one_line_naming_the_file(files, name, mangle, words):
    path = files / name
    path.write_bytes(mangle(path.read_bytes()))
    code, _, err = _run(
        [
            'evaluate',
            '--fidelity',
            'low',
            '--method',
            'time-marching',
            '--config',
            str(files / 'study.toml'),
        ]
    )
    _assert_clean(code, err, (2,))
    (line,) = err.strip().splitlines()
    assert words in line and name in line, line


def test_a_quarter_car_reads_back_its_own_description():
    """A study's own description (what every record keeps) reads back: the quarter car's
    held keys it refuses (its rear axle and pitch inertia)."""
    from suspopt.spec.load import config_from_dict

    cfg = config_from_dict({'vehicle': {'model': 'quarter_car'}})
    assert config_from_dict(cfg.to_dict()) == cfg


# ------------------------------------------------------------------ random bad input
#: what a user can get wrong in a value
NASTY = [
    '',
    ' ',
    '\t',
    '-1',
    '-0',
    '+3',
    '0',
    '1e400',
    '-1e400',
    'nan',
    '9' * 25,
    '1_000',
    '\udcff',
    'a\udcffb',
    ',',
    '+',
    '=',
    '..',
]
#: valid argument vectors of every command (paths relative to the test's folder)
ARGVS = [
    ['evaluate', '--fidelity', 'low', '--method', 'time-marching', '--config', 'study.toml'],
    ['evaluate', '--fidelity', 'low', '--config', 'study.toml', '--design', '3e4,3e4,3e3,3e3'],
    ['optimize', '--fidelity', 'mixed', '--config', 'study.toml', '--start', 'k_S1=35000'],
    ['optimize', '--fidelity', 'low', '--segments', '20', '--order', '3', '--max-iter', '5'],
    ['study', '--config', 'study.toml', '--out', 'out', '--verify-jobs', '1'],
    ['pareto', '--points', '3', '--config', 'study.toml', '--out', 'out'],
    ['compare', '--mechanisms', 'double_wishbone,macpherson+double_wishbone', '--out', 'o'],
    ['robust', '--config', 'study.toml', '--out', 'out'],
    ['codesign', '--config', 'study.toml', '--fidelity', 'mixed', '--out', 'out'],
    ['kinematics', 'mechanism.toml', '--travel=-0.05,0.05', '--points', '5', '--k', '3e4'],
    ['init', 'new.toml', '--model', 'full_car'],
    ['report', 'out'],
    ['sweep', 'sweep.toml', '--out', 'out', '--workers', '2'],
    ['sweep', 'sweep.toml', '--out', 'out', '--scheduler', 'tcp://127.0.0.1:8786'],
]


def _mutate_argv(draw, st) -> list[str]:
    argv = list(draw(st.sampled_from(ARGVS)))
    for _ in range(draw(st.integers(1, 2))):
        i = draw(st.integers(1, len(argv) - 1))
        kind = draw(st.sampled_from(['replace', 'replace', 'truncate', 'append', 'drop']))
        if kind == 'replace':
            argv[i] = draw(st.sampled_from(NASTY))
        elif kind == 'truncate':
            argv[i] = argv[i][: draw(st.integers(0, max(0, len(argv[i]) - 1)))]
        elif kind == 'append':
            argv[i] = argv[i] + draw(st.sampled_from(NASTY))
        else:
            del argv[i]
    return argv


def _mutate_bytes(data: bytes, draw, st) -> bytes:
    kind = draw(st.sampled_from(['truncate', 'byte', 'number', 'line', 'blank']))
    if kind == 'truncate':
        return data[: draw(st.integers(0, len(data)))]
    if kind == 'byte':
        i = draw(st.integers(0, len(data)))
        return data[:i] + draw(st.sampled_from([b'\xff', b'\xe9', b'\x00', b'\xc3'])) + data[i:]
    if kind == 'blank':
        return data.replace(b'\n', b'\n \t', 1)
    numbers = [m.span() for m in re.finditer(rb'-?\d+(\.\d+)?(e-?\d+)?', data)]
    lines = [m.span() for m in re.finditer(rb'[^\n]*\n', data)]
    spans = numbers if kind == 'number' else lines
    if not spans:
        return data
    a, b = draw(st.sampled_from(spans))
    new = draw(st.sampled_from([b'', b'-1', b'1e300', b'nan', b'-0', b'99999999999999999999']))
    return data[:a] + (new if kind == 'number' else b'') + data[b:]


def test_random_bad_files_and_command_lines_end_in_a_documented_code(files, no_work):
    """Hypothesis mutates the valid files and argument vectors: every run ends in a
    documented exit code (or reaches the start of its work), with every stderr line an
    error line and never a traceback or the bug line."""
    from hypothesis import HealthCheck, given, settings
    from hypothesis import strategies as st

    (files / 'sweep.toml').write_text(
        'study = "study.toml"\ncommand = "optimize"\n[axes]\n"maneuver.speed" = [9.0, 10.0]\n'
    )
    originals = {n: (files / n).read_bytes() for n in ('study.toml', 'mechanism.toml', 'road.csv')}
    cwd = os.getcwd()
    os.chdir(files)
    try:
        for argv in ARGVS[:1]:  # the base files run
            code, _, err = _run(argv)
            assert code == 0, err

        @settings(
            max_examples=int(os.environ.get('SUSPOPT_HYPOTHESIS_EXAMPLES', 40)),
            deadline=None,
            derandomize=True,
            database=None,
            suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
        )
        @given(st.data())
        def check(data):
            for name, raw in originals.items():
                (files / name).write_bytes(raw)
            if data.draw(st.booleans()):
                argv = _mutate_argv(data.draw, st)
                allowed: tuple = (0, 1, 2, 3, 4, 'accepted')
            else:
                name = data.draw(st.sampled_from(sorted(originals)))
                (files / name).write_bytes(_mutate_bytes(originals[name], data.draw, st))
                argv = ARGVS[0]
                allowed = (0, 2)
            code, _, err = _run(argv)
            _assert_clean(code, err, allowed)

        check()
    finally:
        os.chdir(cwd)
