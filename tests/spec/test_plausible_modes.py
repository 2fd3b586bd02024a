"""Plausibility and cost from the model's fastest mode (suspopt.spec.modes): a parameter
that makes the vehicle stiff is refused before any work, naming it; the default cars are
not. The modes are checked against a hand computation of the quarter car."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from suspopt.cli.main import main
from suspopt.errors import ConfigError
from suspopt.spec.load import _merge, config_from_dict, full_car_defaults
from suspopt.spec.modes import mode_problems, modes


def _full_car(**vehicle) -> dict:
    return _merge(full_car_defaults().to_dict(), {'vehicle': vehicle})


@pytest.mark.parametrize(
    'data, key, words',
    [
        # found: accepted, then hours in IPOPT at 100 % CPU (a roll inertia in the wrong unit)
        (_full_car(chassis_roll_inertia=0.5), 'vehicle.chassis_roll_inertia', 'a roll mode'),
        ({'vehicle': {'chassis_pitch_inertia': 10.0}}, 'vehicle.chassis_pitch_inertia', 'pitch'),
        (
            {
                'vehicle': {'front': {'wheel_mass': 10.0}},
                'design': {'c_S1': {'upper': 1e6}},
                'maneuver': {'horizon': 100.0},
                'transcription': {'segments': 2000},
            },
            'design.c_S1.upper',
            'too stiff to integrate',
        ),
    ],
    ids=['roll inertia 0.5', 'pitch inertia 10', 'damping bound on a light wheel'],
)
def test_a_stiff_vehicle_is_refused_at_once_naming_the_parameter(
    tmp_path, capsys, data, key, words
):
    with pytest.raises(ConfigError) as err:
        config_from_dict(data)
    (line,) = err.value.problems
    assert line.startswith(f'{key}: ') and words in line, line
    study = tmp_path / 'study.toml'
    from suspopt.spec.template import toml_value

    def toml(d: dict, prefix: str = '') -> list[str]:
        flat = [f'{k} = {toml_value(v)}' for k, v in d.items() if not isinstance(v, dict)]
        out = ([f'[{prefix}]'] if prefix and flat else []) + flat
        for k, v in d.items():
            if isinstance(v, dict):
                out += toml(v, f'{prefix}.{k}' if prefix else k)
        return out

    study.write_text('\n'.join(toml(data)) + '\n')
    t0 = time.perf_counter()
    code = main(['evaluate', '--fidelity', 'low', '--config', str(study)])
    stderr = capsys.readouterr().err
    assert code == 2 and f'{key}: ' in stderr and 'Traceback' not in stderr, stderr
    assert time.perf_counter() - t0 < 20.0  # refused, not solved


@pytest.mark.parametrize('model', ['quarter_car', 'half_car', 'full_car'])
def test_the_default_cars_are_plausible(model):
    cfg = (
        full_car_defaults()
        if model == 'full_car'
        else config_from_dict({'vehicle': {'model': model}})
    )
    assert mode_problems(cfg) == []


def test_the_modes_of_a_quarter_car_by_hand():
    """The quarter car's two modes at its initial design against the eigenvalues of its
    mass, damping and stiffness matrices written out here (chassis M on k_S, c_S; wheel m
    on k_S, c_S and the tyre k_T)."""
    cfg = config_from_dict({'vehicle': {'model': 'quarter_car'}})
    v, d = cfg.vehicle, cfg.design.initial()
    M, m, kT = v.chassis_mass, v.front.wheel_mass, v.front.tyre_stiffness
    k, c = d['k_S1'], d['c_S1']
    Minv = np.diag([1.0 / M, 1.0 / m])
    K = np.array([[k, -k], [-k, k + kT]])
    C = np.array([[c, -c], [-c, c]])
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-Minv @ K, -Minv @ C]])
    expected = sorted(np.abs(np.linalg.eigvals(A)), reverse=True)
    got = [mode.rate for mode in modes(cfg, d)]
    np.testing.assert_allclose(got, expected, rtol=1e-6)
    assert modes(cfg, d)[0].motion == 'wheel 1' and modes(cfg, d)[-1].motion == 'heave'
    assert math.isclose(got[0], max(expected))
