"""A measured road (:class:`suspopt.road.CSVRoad`): the not-a-knot cubic spline through
its samples (MATLAB's ``spline``, the co-design benchmark's road), and the option that
takes its heights relative to the start, where the vehicle stands."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from suspopt.errors import ConfigError
from suspopt.road import CSVRoad, make_road
from suspopt.spec import config_from_dict

ROOT = Path(__file__).resolve().parents[2]
IRI = ROOT / 'examples' / 'data' / 'iri_737b.csv'


@pytest.fixture
def rough(tmp_path) -> Path:
    """A few unevenly spaced samples: the end conditions show over the whole profile."""
    s = np.array([-1.0, 0.0, 0.7, 1.5, 2.0, 3.1, 4.0])
    h = np.array([0.01, 0.02, -0.01, 0.03, 0.0, 0.015, -0.02])
    path = tmp_path / 'road.csv'
    path.write_text('distance,height\n' + ''.join(f'{a},{b}\n' for a, b in zip(s, h)))
    return path


def test_the_spline_is_not_a_knot(rough):
    """Its third derivative is continuous at the second and the second-to-last samples
    (the not-a-knot conditions, de Boor, A Practical Guide to Splines, ch. IV), which a
    natural or clamped spline's is not."""
    road = CSVRoad(file=str(rough))
    s, h = np.loadtxt(rough, delimiter=',', skiprows=1).T
    x = np.linspace(-0.5, 3.9, 57)
    np.testing.assert_allclose(
        road.r(x), CubicSpline(s, h, bc_type='not-a-knot')(x), rtol=0, atol=1e-15
    )
    sp = road._spline
    for knot in (1, len(s) - 2):
        jump = sp(s[knot] + 1e-9, 3) - sp(s[knot] - 1e-9, 3)
        assert abs(jump) < 1e-6 * np.abs(sp.c[0]).max()
    natural = CubicSpline(s, h, bc_type='natural')
    assert np.max(np.abs(natural(x) - road.r(x))) > 1e-4  # the end conditions matter here


def test_relative_to_start_puts_the_start_at_zero(rough):
    plain = CSVRoad(file=str(rough))
    level = make_road({'profile': 'csv', 'file': str(rough), 'relative_to_start': True})
    x = np.linspace(-3.0, 4.0, 71)  # before the first sample too (the rear wheel)
    assert level.r(0.0) == pytest.approx(0.0, abs=1e-15)
    np.testing.assert_allclose(level.r(x), plain.r(x) - plain.r(0.0), atol=1e-15)
    np.testing.assert_allclose(level.dr_ds(x), plain.dr_ds(x), atol=1e-15)


def test_the_benchmark_road_starts_on_the_road():
    road = make_road({'profile': 'csv', 'file': str(IRI), 'relative_to_start': True})
    assert road.r(0.0) == 0.0
    assert CSVRoad(file=str(IRI)).r(0.0) == pytest.approx(3.886190778e-4, rel=1e-9)


def test_the_option_is_a_study_file_key():
    road = {'profile': 'csv', 'file': str(IRI)}
    cfg = config_from_dict({'road': {**road, 'relative_to_start': True}})
    assert cfg.road['relative_to_start'] is True
    assert config_from_dict({'road': road}).road['relative_to_start'] is False
    with pytest.raises(ConfigError, match='road.relative_to_start: must be true or false'):
        config_from_dict({'road': {**road, 'relative_to_start': 1}})
