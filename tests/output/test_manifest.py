"""The run directory's manifest (suspopt.output.rundir) and ``report``'s dispatch on it."""

from __future__ import annotations

import json

import pytest
import record_samples as samples  # tests/ is on the path (conftest.py)

import suspopt.output.report as report
from suspopt.errors import ConfigError
from suspopt.output.rundir import RUN_OUTPUTS, RunDirectory, read_manifest, write_record
from suspopt.records.codec import FORMAT
from suspopt.records.manifest import DOCUMENTS, MANIFEST

#: the renderer of each kind: (module, function)
RENDERERS = {
    'solve': ('suspopt.output.solve_report', 'render_run'),
    'study': ('suspopt.output.study_report', 'render_study'),
    'pareto': ('suspopt.output.pareto_report', 'render_pareto'),
    'robust': ('suspopt.output.robust_report', 'render_robust'),
    'compare': ('suspopt.output.compare_report', 'render_compare'),
    'coupling': ('suspopt.output.coupling_report', 'render_coupling'),
    'spectral': ('suspopt.output.spectral_report', 'render_spectral'),
    'codesign': ('suspopt.output.codesign_report', 'render_codesign'),
}


def test_write_record_writes_the_manifest_naming_kind_format_and_file(tmp_path):
    write_record(tmp_path, samples.pareto())
    manifest = json.loads((tmp_path / MANIFEST).read_text())
    assert manifest['kind'] == 'pareto' and manifest['format'] == FORMAT
    assert manifest['record'] == 'pareto.json' and (tmp_path / 'pareto.json').exists()
    assert read_manifest(tmp_path).record_type is type(samples.pareto())
    write_record(tmp_path, samples.solve())  # another kind in the same place: the manifest follows
    assert read_manifest(tmp_path).kind == 'solve'
    assert MANIFEST in RUN_OUTPUTS and all(f in RUN_OUTPUTS for _, f in DOCUMENTS.values())


@pytest.mark.parametrize('kind', list(DOCUMENTS))
def test_report_dispatches_on_the_manifest_not_on_the_files(tmp_path, monkeypatch, kind):
    """Every kind's record beside decoys of every other kind: the manifest decides."""
    import importlib

    for other, make in samples.DOCUMENT_SAMPLES.items():
        if other != kind:
            write_record(tmp_path, make())
    write_record(tmp_path, samples.DOCUMENT_SAMPLES[kind]())
    called = []
    for k, (module, name) in RENDERERS.items():
        monkeypatch.setattr(
            importlib.import_module(module),
            name,
            lambda out, record, *rest, k=k: called.append((k, record)) or [],
        )
    report.render(tmp_path)
    ((k, record),) = called
    assert k == kind and record == samples.DOCUMENT_SAMPLES[kind]()


def test_a_directory_without_a_manifest_is_refused_in_one_line(tmp_path):
    """A directory from before the manifest (or not a run's) is refused, not guessed at."""
    (tmp_path / 'study.json').write_text('{}')
    with pytest.raises(ConfigError, match=r'no manifest.json: .*older suspopt') as err:
        report.render(tmp_path)
    assert len(err.value.problems) == 1


def test_overwrite_clears_the_manifest(tmp_path):
    write_record(tmp_path, samples.solve())
    with RunDirectory(tmp_path, overwrite=True):
        assert not (tmp_path / MANIFEST).exists() and not (tmp_path / 'result.json').exists()
