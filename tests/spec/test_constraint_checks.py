"""Bad engineering-constraint input (``[constraints.*]``): one ConfigError naming the key."""

from __future__ import annotations

import pytest

from suspopt.errors import ConfigError
from suspopt.spec.load import config_from_dict

FULL = {'model': 'full_car'}

CASES = [
    ({}, {'travel': {'bump': -0.05}}, 'constraints.travel.bump'),
    ({}, {'travel': {'rebound': -0.05}}, 'constraints.travel.rebound'),
    ({}, {'travel': {}}, 'constraints.travel'),
    ({}, {'tyre_contact': {'margin': -0.1}}, 'constraints.tyre_contact.margin'),
    ({}, {'tyre_contact': {'margin': 1.0}}, 'constraints.tyre_contact.margin'),
    (FULL, {'roll_gradient': {'max': -3.0}}, 'constraints.roll_gradient.max'),
    (FULL, {'roll_gradient': {'min': 5.0, 'max': 3.0}}, 'constraints.roll_gradient.min'),
    (FULL, {'roll_gradient': {'front_share': [0.5, 1.2]}}, 'constraints.roll_gradient.front_share'),
    (FULL, {'roll_gradient': {'front_share': [0.7, 0.5]}}, 'constraints.roll_gradient.front_share'),
    (FULL, {'roll_gradient': {'front_share': [0.5]}}, 'constraints.roll_gradient.front_share'),
    ({}, {'roll_gradient': {'max': 4.0}}, 'constraints.roll_gradient'),
    (
        {'model': 'quarter_car'},
        {'ride_frequency': {'pitch': [1.0, 2.0]}},
        'constraints.ride_frequency.pitch',
    ),
    ({}, {'ride_frequency': {'heave': [1.5, 1.0]}}, 'constraints.ride_frequency.heave'),
    ({}, {'ride_frequency': {'heave': [-1.0, 1.0]}}, 'constraints.ride_frequency.heave'),
    ({**FULL, 'cg_height': 0.0}, {'roll_gradient': {'max': 4.0}}, 'vehicle.cg_height'),
    ({}, {'stability': {'margin': -1.0}}, 'constraints.stability.margin'),
]


@pytest.mark.parametrize(('vehicle', 'constraints', 'key'), CASES, ids=[c[2] for c in CASES])
def test_bad_constraint_names_its_key(vehicle, constraints, key):
    data = {'constraints': constraints, **({'vehicle': vehicle} if vehicle else {})}
    with pytest.raises(ConfigError) as err:
        config_from_dict(data)
    lines = str(err.value).splitlines()
    assert any(line.lstrip('- ').startswith(f'{key}:') for line in lines), str(err.value)


def test_a_negative_bound_is_one_problem():
    """A negative roll-gradient max is reported once, not also as 'min above max'."""
    with pytest.raises(ConfigError) as err:
        config_from_dict({'vehicle': FULL, 'constraints': {'roll_gradient': {'max': -3.0}}})
    assert 'constraints.roll_gradient.min' not in str(err.value)
