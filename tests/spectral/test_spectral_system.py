"""The affine system and the road: construction, evaluation, bad input."""

from __future__ import annotations

import numpy as np
import pytest
from spectral_vehicles import quarter_car

from suspopt.errors import ConfigError
from suspopt.spectral import RandomRoad, RoadCorner, StationaryModel, affine_system


def test_matrices_are_affine_in_the_design():
    s = quarter_car()
    A, B, C, D = s.matrices(np.array([2.0, 3.0]))
    np.testing.assert_array_equal(A, s.A0 + 2.0 * s.dA[0] + 3.0 * s.dA[1])
    np.testing.assert_array_equal(C, s.C0 + 2.0 * s.dC[0] + 3.0 * s.dC[1])
    np.testing.assert_array_equal(B, s.B0)
    np.testing.assert_array_equal(D, s.D0)
    model = StationaryModel(s, RandomRoad())
    by_name = model.response({'k': 2e4, 'c': 1.5e3})
    np.testing.assert_array_equal(by_name.variance, model.variances(np.array([2e4, 1.5e3])))
    assert set(by_name.rms_by_name()) == {'acc', 'travel', 'tyre'}


@pytest.mark.parametrize(
    'kwargs, key',
    [
        (dict(base={'A': np.eye(2), 'B': np.ones((3, 1))}), 'B0'),
        (dict(terms={'k': {'C': np.ones((2, 2))}}), 'terms.k.C'),
        (dict(terms={'k': {'E': np.ones((2, 2))}}), 'terms.k.E'),
        (dict(outputs=('y', 'y')), 'outputs'),
        (dict(corners=(RoadCorner(track=2),)), 'corners[0].track'),
        (dict(corners=(RoadCorner(offset=-1.0),)), 'corners[0].offset'),
        (dict(base={'A': np.full((2, 2), np.nan), 'B': np.ones((2, 1))}), 'A0'),
    ],
)
def test_bad_system_names_the_key(kwargs, key):
    args = dict(
        base={'A': -np.eye(2), 'B': np.ones((2, 1))},
        terms={'k': {'A': np.eye(2)}},
        outputs=('y',),
        corners=(RoadCorner(),),
    )
    args.update(kwargs)
    with pytest.raises(ConfigError, match=key.replace('[', r'\[').replace(']', r'\]')):
        affine_system(**args)


@pytest.mark.parametrize(
    'kwargs, key',
    [
        (dict(road_class='J'), 'road.road_class'),
        (dict(speed=0.0), 'road.speed'),
        (dict(tracks='coherent'), 'road.tracks'),
        (dict(tracks='isotropic'), 'road.separation'),
        (dict(gd_n0=-1.0), 'road.gd_n0'),
    ],
)
def test_bad_road_names_the_key(kwargs, key):
    with pytest.raises(ConfigError, match=key):
        RandomRoad(**kwargs)


def test_unstable_design_is_a_model_error():
    from suspopt.errors import ModelError

    s = quarter_car()
    with pytest.raises(ModelError, match='not stable'):
        StationaryModel(s, RandomRoad()).variances(np.array([2e4, -100.0]))


def test_corner_delay_is_offset_over_speed():
    assert RoadCorner(0, 2.7).delay(20.0) == pytest.approx(0.135)
    assert RandomRoad('A', 10.0).displacement_psd_n0 == pytest.approx(16e-6)
    assert RandomRoad(gd_n0=5e-5).displacement_psd_n0 == 5e-5
