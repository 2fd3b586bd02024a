"""The roads of a run as used, written into its results directory (``inputs/``) so that
another tool can rebuild exactly what the models saw (``docs/roads.md``):

* ``road_<scenario>.csv`` — every wheel's distance along its track and the road height
  under it at every collocation node: ``t``, then ``s_<corner>``, ``r_<corner>`` per
  corner (``δ_c(t) = r(v t - offset_c)``, docs/roads.md);
* ``road_<scenario>_<track>_profile.csv`` — a generated profile (ISO 8608) on its
  synthesis grid (``distance,height``, the points its cubic spline passes through) over
  the distance driven, and ``road_<scenario>_<track>_lines.csv``, its cosines
  (``n [cycle/m], amplitude [m], phase [rad]`` of the left track; the right track's
  mixed coefficients, ``amplitude`` and ``phase`` of each line after the coherence
  model).

The file names use each scenario's index and a name-safe form of its name, so they are
unique whatever the names.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np

from suspopt.output.rundir import keep_inputs, write_text
from suspopt.road import ISO8608Road, road_tracks
from suspopt.road.profiles import track_coherence
from suspopt.spec import StudyConfig
from suspopt.transcription.grid import radau_grid

TRACK_NAMES = ('left', 'right')


def _safe(name: str) -> str:
    return re.sub(r'[^A-Za-z0-9_.-]+', '_', name).strip('._') or 'scenario'


def _csv(header: list[str], columns: list[np.ndarray]) -> str:
    rows = np.column_stack(columns)
    return (
        ','.join(header)
        + '\n'
        + '\n'.join(','.join(f'{x:.17g}' for x in row) for row in rows)
        + '\n'
    )


def _lines(road: ISO8608Road, track: int, separation: float) -> str:
    """The cosines of one track of an ISO 8608 road: frequency, amplitude, phase."""
    n, amp, phase = road.lines()
    if track:  # the right track: the left's lines mixed with independent ones
        gamma = track_coherence(road.coherence, n, separation)
        other = np.random.default_rng([road.seed, track]).uniform(0.0, 2.0 * np.pi, n.size)
        coef = gamma * np.exp(1j * phase) + np.sqrt(np.maximum(1.0 - gamma**2, 0.0)) * np.exp(
            1j * other
        )
        amp, phase = amp * np.abs(coef), np.angle(coef)
    return _csv(['n [cycle/m]', 'amplitude [m]', 'phase [rad]'], [n, amp, phase])


def write_roads(directory: str | Path, config: StudyConfig) -> list[Path]:
    """Write the roads of every scenario of ``config`` as used into
    ``directory/inputs`` (see the module docstring); returns the files written."""
    inputs = Path(directory) / 'inputs'
    layout = config.layout()
    offsets = np.asarray(layout.offsets())
    written = []
    for i, sc in enumerate(config.scenarios()):
        stem = f'road_{i}_{_safe(sc.name)}'
        tracks = road_tracks(sc.road, layout.n_tracks, layout.track_separation())
        nodes, _ = radau_grid(sc.segments, sc.order)
        t = np.unique(0.5 * (nodes + 1.0) * sc.horizon)
        header, columns = ['t [s]'], [t]
        for c, corner in enumerate(layout.corners):
            s = sc.speed * t - offsets[c]
            header += [f's_{corner.label} [m]', f'r_{corner.label} [m]']
            columns += [s, tracks[corner.track].r(s)]
        path = inputs / f'{stem}.csv'
        write_text(path, _csv(header, columns))
        written.append(path)
        for k, road in enumerate(tracks):
            if not isinstance(road, ISO8608Road):
                continue
            step = 1.0 / (ISO8608Road.samples_per_wavelength * road.n_max)
            end = min(road.length, sc.speed * sc.horizon + float(offsets.max()) + step)
            s = np.arange(0.0, end + step, step)
            name = f'{stem}_{TRACK_NAMES[k] if len(tracks) > 1 else "track"}'
            profile = inputs / f'{name}_profile.csv'
            write_text(profile, _csv(['distance [m]', 'height [m]'], [s, road.r(s)]))
            lines = inputs / f'{name}_lines.csv'
            write_text(lines, _lines(road, k, layout.track_separation()))
            written += [profile, lines]
    return written


def keep_study_inputs(directory: str | Path, config: StudyConfig) -> dict[str, Any]:
    """Everything a results directory keeps of its inputs: copies of the files the study
    reads (:func:`~suspopt.output.rundir.keep_inputs`) and its roads as used
    (:func:`write_roads`). Returns the study description pointing at the copies."""
    data = keep_inputs(directory, config.to_dict())
    write_roads(directory, config)
    return data
