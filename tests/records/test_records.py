"""The typed records (suspopt.records): every one survives JSON, a damaged file is bad
input naming the file and the key (exit 2), and a bug in a renderer is not."""

from __future__ import annotations

import dataclasses
import importlib
import json
import pkgutil

import pytest
import record_samples as samples  # tests/ is on the path (conftest.py)

import suspopt.records
from suspopt.cli.main import main
from suspopt.errors import ConfigError
from suspopt.output.rundir import read_record, write_record
from suspopt.records.codec import FORMAT, Record
from suspopt.records.manifest import DOCUMENTS, Manifest
from suspopt.records.solve import SolveRecord
from suspopt.records.verification import Check, Verification


def _through_json(record: Record) -> Record:
    text = json.dumps(record.to_json())  # what write_json writes (NaN and inf included)
    return type(record).from_json(json.loads(text), 'sample.json')


def _record_types() -> set[type]:
    """Every record type defined in suspopt.records."""
    for info in pkgutil.iter_modules(suspopt.records.__path__):
        importlib.import_module(f'suspopt.records.{info.name}')

    def below(cls: type) -> set[type]:
        return {c for s in cls.__subclasses__() for c in {s} | below(s)}

    return {c for c in below(Record) if c.__module__.startswith('suspopt.records.')}


def _types_in(value: object) -> set[type]:
    """The record types inside a record (itself included)."""
    if isinstance(value, Record):
        found = {type(value)}
        for f in dataclasses.fields(value):  # type: ignore[arg-type]
            found |= _types_in(getattr(value, f.name))
        return found
    if isinstance(value, dict):
        return set().union(*map(_types_in, value.values())) if value else set()
    if isinstance(value, (list, tuple)):
        return set().union(*map(_types_in, value)) if value else set()
    return set()


@pytest.mark.parametrize('kind', list(samples.DOCUMENT_SAMPLES))
def test_every_document_survives_json(kind):
    record = samples.DOCUMENT_SAMPLES[kind]()
    assert record.KIND == kind and DOCUMENTS[kind][0] is type(record)
    back = _through_json(record)
    assert back == record
    assert back.to_json() == record.to_json()


def test_the_samples_hold_every_record_type_and_state():
    """A new record type (or verification state) without a sample fails here: its round
    trip is then tested by the test above."""
    makers = list(samples.DOCUMENT_SAMPLES.values())
    found = set().union(*(_types_in(make()) for make in makers))
    found.add(Manifest)
    assert _record_types() <= found, sorted(c.__name__ for c in _record_types() - found)
    twostep = samples.twostep()
    states = {
        e.verification.state for e in [*twostep.evaluations.values(), *twostep.steps.values()]
    }
    states |= {Check.NOT_APPLICABLE}
    assert states == set(Check), set(Check) - states
    na = Verification.not_applicable('the time marching itself')
    assert _through_json(samples.solve(verification=na)) == samples.solve(verification=na)


def test_a_failed_solve_has_no_objective_and_says_where_it_stopped():
    data = samples.solve(success=False).to_json()
    assert data['objective'] is None and data['terms'] is None and data['verified'] is None
    assert data['objective_at_stop'] == 3.6 and data['terms_at_stop']['heave'] == 1.3
    assert data['scenarios'][1]['objective'] is None
    assert data['formula'].startswith('f = 1 f_city + 3 f_highway; f_s = 0.25 J_heave/s_heave')
    data['objective'] = 3.6  # a failed solve given a value: damaged
    with pytest.raises(ConfigError, match=r'^x.json: objective: a failed solve has no objective'):
        SolveRecord.from_json(data, 'x.json')


# ------------------------------------------------------------------ damaged files
def _damage(data: dict, path: tuple, value: object) -> dict:
    data = json.loads(json.dumps(data))
    node = data
    for key in path[:-1]:
        node = node[key]
    if value is KeyError:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return data


@pytest.mark.parametrize(
    'kind, path, value, message',
    [
        ('solve', ('iterations',), 'ten', "iterations: expected an integer, got 'ten'"),
        ('solve', ('design', 'k_S1'), None, 'design.k_S1: expected a number, got None'),
        ('solve', ('history', 1, 'objective'), KeyError, 'history[1].objective: missing'),
        ('solve', ('success',), 1, 'success: expected true or false, got 1'),
        ('solve', ('verification', 'state'), 'fine', 'verification.state: expected one of'),
        (
            'solve',
            ('verification', 'comparison', 'max_rel_diff'),
            0.5,
            "verification.state: 'verified' contradicts max_rel_diff 0.5",
        ),
        ('solve', ('verification', 'comparison'), None, 'verification.comparison: missing for'),
        ('solve', ('format',), FORMAT + 1, 'format: format 2 is not the format 1'),
        (
            'study',
            ('steps', 'low', 'scenarios', 0, 'grid'),
            [80, 5],
            'grid: expected a JSON object',
        ),
        (
            'study',
            ('evaluations', 'mid/initial'),
            samples.solve().to_json(),
            'evaluations.mid/initial: not an evaluation',
        ),
        (
            'study',
            ('problems', 'low', 'nlp', 'colors'),
            2.5,
            'problems.low.nlp.colors: expected an',
        ),
        ('pareto', ('points', 0, 'comfort'), None, 'points[0].comfort: given exactly when'),
        ('pareto', ('bounds', 'k_S1'), [1.0], 'bounds.k_S1: expected a list of 2'),
        ('robust', ('weights',), [1.0], 'weights: 1 weights for 2 scenarios'),
        ('compare', ('recorders', 'mixed:dw'), KeyError, 'recorders.mixed:dw: missing'),
        ('compare', ('kinematics', 'curves', 'dw', 'camber', 0), 'x', 'curves.dw.camber[0]:'),
        ('coupling', ('evaluations', 'wall'), {}, 'evaluations.wall: not a model'),
        ('spectral', ('scenarios', 0, 'road', 'speed'), 'fast', 'road.speed: expected a number'),
        ('spectral', ('mode',), 'both', "mode: expected 'evaluate' or 'optimize', got 'both'"),
        ('spectral', ('objective',), None, 'objective: missing for a converged result'),
    ],
)
def test_a_damaged_value_names_the_file_and_the_key(tmp_path, capsys, kind, path, value, message):
    record = samples.DOCUMENT_SAMPLES[kind]()
    write_record(tmp_path, record)
    file = tmp_path / DOCUMENTS[kind][1]
    file.write_text(json.dumps(_damage(record.to_json(), path, value)))
    with pytest.raises(ConfigError) as err:
        read_record(tmp_path)
    (line,) = err.value.problems
    assert line.startswith(f'{file}: ') and message in line, line
    assert main(['report', str(tmp_path)]) == 2  # the command line: bad input, one line
    (printed,) = capsys.readouterr().err.strip().splitlines()
    assert printed == f'suspopt: error: {line}'


def test_a_renderer_bug_is_a_bug_not_damaged_results(tmp_path, capsys, monkeypatch):
    """A KeyError inside the renderer of a valid directory is reported as a bug of
    suspopt (exit 1), not as a damaged directory (exit 2)."""
    import suspopt.output.solve_report as solve_report

    write_record(tmp_path, dataclasses.replace(samples.solve(), config=None))
    assert main(['report', str(tmp_path)]) == 0  # it renders
    capsys.readouterr()

    def broken(res):
        return {}['heave']  # a renderer's bug

    monkeypatch.setattr(solve_report, 'run_markdown', broken)
    assert main(['report', str(tmp_path)]) == 1
    err = capsys.readouterr().err
    assert 'this is a bug in suspopt' in err and 'KeyError' in err
    assert 'damaged' not in err
