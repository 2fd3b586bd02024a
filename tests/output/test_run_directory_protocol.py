"""One run directory protocol (suspopt.output.rundir): one lock for every command that
writes into a directory (``report`` and ``kinematics`` too), ``--overwrite`` clears what
a run writes before it starts — its manifest first —, and a file of another run left in
the directory is never drawn as this run's."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

import numpy as np
import pytest

from suspopt.cli.main import main
from suspopt.errors import RunError
from suspopt.output.rundir import LOCK, RunDirectory


def _run(argv) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main([str(a) for a in argv])
    return code, err.getvalue()


@pytest.mark.parametrize(
    'argv',
    [['report', '{dir}'], ['kinematics', 'double_wishbone', '--points', '3', '--out', '{dir}']],
    ids=['report', 'kinematics'],
)
def test_every_command_on_a_directory_takes_its_lock(tmp_path, argv):
    """While a run holds the directory, report and kinematics are refused at once (before
    they used no lock: report rewrote table.md under a running study)."""
    d = tmp_path / 'run'
    d.mkdir()
    (d / 'manifest.json').write_text('{}')
    with RunDirectory(d, fresh=False):
        code, err = _run([a.format(dir=d) for a in argv])
    assert code == 2 and 'in use by another suspopt run' in err, err
    assert sorted(p.name for p in d.iterdir()) == ['manifest.json']


def test_overwrite_removes_the_manifest_first_and_everything_a_run_writes(tmp_path, monkeypatch):
    d = tmp_path / 'run'
    (d / 'figures').mkdir(parents=True)
    (d / 'inputs').mkdir()
    for name in ('manifest.json', 'study.json', 'time_marching.npz', 'low.sql', 'table.md'):
        (d / name).write_text('earlier run')
    (d / 'figures' / 'road.png').write_text('earlier run')
    (d / 'inputs' / 'road_0_main.csv').write_text('earlier run')
    (d / 'notes.txt').write_text("the user's own")
    removed: list[str] = []
    real = Path.unlink

    def unlink(self, *args, **kwargs):
        removed.append(self.name)
        if self.name == 'time_marching.npz':  # the disk fails in the middle of the clear
            raise PermissionError(13, 'Permission denied')
        return real(self, *args, **kwargs)

    monkeypatch.setattr(Path, 'unlink', unlink)
    with pytest.raises(RunError, match='cannot clear'):
        RunDirectory(d, overwrite=True).__enter__()
    assert removed[0] == 'manifest.json'  # never a run mixed of two: no manifest left
    monkeypatch.setattr(Path, 'unlink', real)
    assert not (d / 'manifest.json').exists() and not (d / LOCK).exists()
    with RunDirectory(d, overwrite=True):
        pass
    assert sorted(p.name for p in d.iterdir()) == ['notes.txt']


def test_another_runs_time_marching_is_never_drawn_as_this_studys(tmp_path):
    """``time_marching.npz`` carries the fingerprint of its study; a report draws it only
    with that study (found: an earlier run's file mixed into a new study's figure)."""
    from suspopt.output.study_report import FINGERPRINT, _marched, study_fingerprint
    from suspopt.records.twostep import TwoStepStudy

    def study(k: float) -> TwoStepStudy:
        return TwoStepStudy(
            config={'road': {}},
            scales=({},),
            terms=(),
            design_names=('k_S1',),
            normalization='paper',
            weights={},
            designs={'initial': {'k_S1': k}},
        )

    old, new = study(30000.0), study(35000.0)
    path = tmp_path / 'time_marching.npz'
    np.savez(path, **{'low/initial/t': np.arange(3.0), FINGERPRINT: study_fingerprint(old)})
    assert _marched(path, old) is not None
    assert _marched(path, new) is None
    np.savez(path, **{'low/initial/t': np.arange(3.0)})  # no fingerprint: not drawn
    assert _marched(path, new) is None


def test_init_and_kinematics_report_an_unwritable_output_as_the_environment(tmp_path):
    """Exit 4 (the environment), as the exit-code table says, not 2 (bad input)."""
    blocker = tmp_path / 'a-file'
    blocker.write_text('')
    code, err = _run(['kinematics', 'double_wishbone', '--points', '3', '--out', blocker / 'x'])
    assert code == 4 and 'cannot create' in err, err
    code, err = _run(['init', tmp_path])  # a directory where the file should go
    assert code == 2 and 'is a directory' in err, err
