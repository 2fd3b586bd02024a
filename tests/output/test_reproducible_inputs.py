"""Reproducible inputs (suspopt.output.roads, the CLI's report): every results directory
holds its road as used — the samples at the collocation grid, and an ISO 8608 road's
profile and cosines, from which another tool rebuilds it; ``optimize`` writes its table
and figures as every directory-writing command does; ``report`` renders any results
directory (a quarter car's, a sweep's through the sweep's own renderer)."""

from __future__ import annotations

import contextlib
import csv
import io
import json
from pathlib import Path

import numpy as np
import pytest

from suspopt.cli.main import main
from suspopt.road import road_tracks
from suspopt.spec.load import _merge, config_from_dict, full_car_defaults


def _run(argv) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in argv])
    return code, out.getvalue(), err.getvalue()


def _read(path: Path) -> tuple[list[str], np.ndarray]:
    rows = list(csv.reader(path.open()))
    return rows[0], np.array(rows[1:], dtype=float)


def test_an_iso_road_is_kept_as_used_and_rebuilt_from_its_cosines(tmp_path):
    """The full car's ISO 8608 road: the heights under every wheel at the nodes, and per
    track the profile on its synthesis grid and its cosines. The profile is rebuilt here
    from the cosines and the fade-in of docs/roads.md alone (a sum of cosines, not the
    FFT and spline suspopt uses)."""
    from suspopt.output.roads import write_roads

    cfg = config_from_dict(_merge(full_car_defaults().to_dict(), {'maneuver': {'horizon': 1.0}}))
    files = {p.name for p in write_roads(tmp_path, cfg)}
    assert files == {
        'road_0_main.csv',
        'road_0_main_left_profile.csv',
        'road_0_main_left_lines.csv',
        'road_0_main_right_profile.csv',
        'road_0_main_right_lines.csv',
    }
    road = cfg.road
    for side in ('left', 'right'):
        _, prof = _read(tmp_path / 'inputs' / f'road_0_main_{side}_profile.csv')
        _, lines = _read(tmp_path / 'inputs' / f'road_0_main_{side}_lines.csv')
        s = prof[:, 0]
        n, a, phi = lines.T
        h = np.cos(2 * np.pi * np.outer(s, n) + phi) @ a
        h *= 0.5 * (1.0 - np.cos(np.pi * np.clip(s / road['fade_in'], 0.0, 1.0)))
        np.testing.assert_allclose(prof[:, 1], h, atol=1e-12 * np.abs(a).sum())
        assert s[-1] >= cfg.maneuver.speed * cfg.maneuver.horizon
    header, grid = _read(tmp_path / 'inputs' / 'road_0_main.csv')
    assert header[:3] == ['t [s]', 's_1L [m]', 'r_1L [m]'] and len(header) == 9
    sc = cfg.scenarios()[0]
    assert len(grid) == sc.segments * sc.order + 1  # every distinct node of the grid
    assert grid[0, 0] == 0.0 and grid[-1, 0] == pytest.approx(sc.horizon)
    tracks = road_tracks(road, 2, cfg.layout().track_separation())
    np.testing.assert_allclose(grid[:, 2], tracks[0].r(grid[:, 1]), rtol=1e-15)
    np.testing.assert_allclose(grid[:, 4], tracks[1].r(grid[:, 3]), rtol=1e-15)


def test_optimize_writes_its_table_figures_and_road_and_report_renders_a_quarter_car(tmp_path):
    """Found: optimize wrote no table.md or figures; a quarter car's directory could not
    be rendered (its description has no rear axle)."""
    study = tmp_path / 'qc.toml'
    study.write_text(
        '[vehicle]\nmodel = "quarter_car"\n[maneuver]\nhorizon = 0.4\n'
        '[road]\nprofile = "bump"\nheight = 0.02\nlength = 1.0\nstart = 0.5\n'
        '[transcription]\nsegments = "auto"\n'
    )
    out = tmp_path / 'run'
    code, stdout, err = _run(
        ['optimize', '--fidelity', 'low', '--config', study, '--out', out, '--quiet']
    )
    assert code == 0, err
    assert (out / 'table.md').exists() and (out / 'figures' / 'trajectories.png').exists()
    assert (out / 'inputs' / 'road_0_main.csv').exists()
    code, _, err = _run(['report', out])
    assert code == 0, err


def test_report_of_a_sweep_directory_that_never_started_is_one_line(tmp_path):
    """A sweep's directory goes to the sweep's renderer; one with only its manifest
    (killed before its first write) is refused in one line, exit 2."""
    d = tmp_path / 'sweep'
    d.mkdir()
    (d / 'manifest.json').write_text(json.dumps({'kind': 'sweep', 'format': 1}))
    code, _, err = _run(['report', d])
    assert code == 2 and 'sweep.json' in err and 'Traceback' not in err
