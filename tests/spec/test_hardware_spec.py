"""The suspension hardware in the study file (docs/nonlinear_hardware.md): each axle's
curve tables, their checks naming the keys (exit 2), the curve parameters as design
variables, and the default (no table) exactly today's linear spring and damper."""

from __future__ import annotations

import tomllib

import pytest

from suspopt.cli.main import main
from suspopt.curves import BumpStop, DamperCurve, SpringCurve
from suspopt.errors import ConfigError
from suspopt.spec.hardware import corner_units, study_units
from suspopt.spec.load import config_from_dict, full_car_defaults, load_config
from suspopt.spec.schema import StudyConfig
from suspopt.spec.template import default_config_toml

DIGRESSIVE = {
    'c_bump_low': 3000.0,
    'v_bump_knee': 0.08,
    'c_bump_high': 1200.0,
    'c_rebound_low': 7000.0,
    'v_rebound_knee': 0.12,
    'c_rebound_high': 2800.0,
}


def _full_car(front: dict, design: dict | None = None) -> StudyConfig:
    d = full_car_defaults().to_dict()
    d['vehicle']['front'].update(front)
    d['design'] = {'per_corner': False, **(design or {})}
    return config_from_dict(d)


def test_no_tables_is_todays_linear_car():
    """Every default car: no curves, the same design variables, the same description."""
    for cfg in (StudyConfig(), config_from_dict({}), full_car_defaults()):
        assert not any(study_units(cfg)) and not any(corner_units(cfg))
        assert all(not ax.has_curves for ax in cfg.vehicle.axles)
    assert config_from_dict({}).design_names() == ('k_S1', 'k_S2', 'c_S1', 'c_S2')
    assert full_car_defaults().design_names() == (
        'k_S1',
        'k_S2',
        'c_S1',
        'c_S2',
        'k_R1',
        'k_R2',
    )
    assert config_from_dict(tomllib.loads(default_config_toml())) == StudyConfig()


def test_tables_read_into_the_axles_hardware():
    cfg = config_from_dict(
        {
            'vehicle': {
                'front': {
                    'damper_curve': DIGRESSIVE,
                    'bump_stop': {'gap': 0.03, 'coefficients': [2.0e6, 3.0e8]},
                },
                'rear': {'spring_curve': {'coefficients': [35000.0, 0.0, 4.0e6]}},
            }
        }
    )
    front, rear = study_units(cfg)
    assert front.damper == DamperCurve(**DIGRESSIVE)
    assert front.bump_stop == BumpStop(0.03, (2.0e6, 3.0e8)) and front.rebound_stop is None
    assert front.spring == SpringCurve((30000.0,))  # the design's k_S1
    assert rear.spring == SpringCurve((35000.0, 0.0, 4.0e6))
    # c_S1 is replaced by the curve; k_S2's start is the polynomial's rate
    assert cfg.design_names() == ('k_S1', 'k_S2', 'c_S2')
    assert cfg.design['k_S2'].initial == 35000.0
    assert config_from_dict(cfg.to_dict()) == cfg


def test_curve_parameters_become_design_variables_when_named():
    cfg = _full_car(
        {'damper_curve': DIGRESSIVE, 'bump_stop': {'gap': 0.03, 'coefficients': [2.0e6]}},
        {'c_rebound_low_1': {'lower': 3000.0, 'upper': 9000.0}, 'bump_gap_1': {}},
    )
    names = cfg.design_names()
    assert names == ('k_S1', 'k_S2', 'c_S2', 'c_rebound_low_1', 'bump_gap_1', 'k_R1', 'k_R2')
    dv = cfg.design['c_rebound_low_1']
    assert (dv.initial, dv.lower, dv.upper) == (7000.0, 3000.0, 9000.0)
    # defaults: the hardware's value, from 0 to 4 times it within the bump travel (the
    # default full car's travel constraint, 0.05 m)
    gap = cfg.design['bump_gap_1']
    assert (gap.initial, gap.lower, gap.upper) == (0.03, 0.0, 0.05)
    per_corner = _full_car(
        {'damper_curve': DIGRESSIVE},
        {'per_corner': True, 'c_bump_low_1': {'upper': 5000.0}, 'v_bump_knee_1R': {}},
    )
    curve_vars = [n for n in per_corner.design_names() if n[0] in 'cv' and 'S' not in n]
    assert curve_vars == ['c_bump_low_1L', 'c_bump_low_1R', 'v_bump_knee_1R']
    assert per_corner.design['c_bump_low_1R'].upper == 5000.0


BAD = [
    # (vehicle.front tables, design, key in the message, words in the message)
    (
        {'damper_curve': {**DIGRESSIVE, 'c_bump_high': -5.0}},
        {},
        'vehicle.front.damper_curve.c_bump_high',
        'negative damping',
    ),
    (
        {'damper_curve': {'velocities': [-0.5, 0.3, 0.0, 0.6], 'forces': [-900, 300, 0, 500]}},
        {},
        'vehicle.front.damper_curve.velocities',
        'strictly increasing',
    ),
    (
        {'damper_curve': {'velocities': [-0.5, 0.0, 0.3, 0.6], 'forces': [-900, 0, 300, 250]}},
        {},
        'vehicle.front.damper_curve.forces',
        'must increase',
    ),
    (
        {'spring_curve': {'deflections': [-0.1, 0.0, 0.1], 'forces': [-3000, 20, 3000]}},
        {},
        'vehicle.front.spring_curve.forces',
        'pass through zero',
    ),
    (
        {'bump_stop': {'gap': 0.5, 'coefficients': [1.0e6]}},
        {},
        'vehicle.front.bump_stop.gap',
        'larger than the bump travel',
    ),
    (
        {'spring_curve': {'coefficients': [30000.0, -4.0e6]}},
        {},
        'vehicle.front.spring_curve.coefficients',
        'the rate dS/dx must be >= 0',
    ),
    ({'damper_curve': {'c_bump_low': 3000.0}}, {}, 'vehicle.front.damper_curve', 'missing'),
    (
        {'damper_curve': {**DIGRESSIVE, 'c_bump_mid': 1.0}},
        {},
        'vehicle.front.damper_curve.c_bump_mid',
        'unknown key',
    ),
    (
        {'damper_curve': DIGRESSIVE},
        {'v_bump_knee_1': {'lower': 0.005}},
        'design.v_bump_knee_1.lower',
        'the knee blend must not reach the zero blend',
    ),
    (
        {'bump_stop': {'gap': 0.03, 'coefficients': [1.0e6]}},
        {'bump_gap_1': {'upper': 0.2}},
        'design.bump_gap_1.upper',
        'larger than the bump travel',
    ),
    ({'damper_curve': DIGRESSIVE}, {'c_S1': {}}, 'design.c_S1', 'the damper of vehicle.front'),
    ({}, {'bump_gap_1': {}}, 'design.bump_gap_1', 'no curve parameter'),
]


@pytest.mark.parametrize('front,design,key,words', BAD, ids=[f'{b[2]}-{b[3]}' for b in BAD])
def test_bad_hardware_names_the_key_and_exits_2(tmp_path, capsys, front, design, key, words):
    """One line naming the key for each problem (the curve library's checks under the
    axle's key), exit code 2 from the command line."""
    data = {'vehicle': {'front': front}, 'design': design}
    with pytest.raises(ConfigError) as err:
        config_from_dict(data)
    lines = [p for p in err.value.problems if p.startswith(key)]
    assert any(words in line for line in lines), err.value.problems
    path = tmp_path / 'study.toml'
    path.write_text(_toml(data))
    with pytest.raises(ConfigError):
        load_config(path)
    assert main(['evaluate', '--fidelity', 'low', '--config', str(path)]) == 2
    assert key in capsys.readouterr().err


def test_a_stop_is_checked_against_the_travel_constraint():
    """The travel a stop's gap must be within: [constraints.travel] where given."""
    front = {'bump_stop': {'gap': 0.05, 'coefficients': [1.0e6]}}
    config_from_dict({'vehicle': {'front': front}})  # the mechanism's travel: 0.1 m
    with pytest.raises(ConfigError, match='larger than the bump travel 0.04 m'):
        config_from_dict(
            {
                'vehicle': {'front': front},
                'constraints': {'travel': {'bump': 0.04, 'rebound': 0.06}},
            }
        )


def _toml(data: dict, prefix: str = '') -> str:
    """A small TOML writer for the tests' nested tables of numbers and lists."""
    lines, tables = [], []
    for k, v in data.items():
        if isinstance(v, dict):
            tables.append((k, v))
        else:
            lines.append(f'{k} = {v!r}'.replace("'", '"'))
    out = ([f'[{prefix}]'] if prefix and (lines or not tables) else []) + lines
    for k, v in tables:
        out.append(_toml(v, f'{prefix}.{k}' if prefix else k))
    return '\n'.join(out)


def test_the_templates_commented_hardware_reads_when_uncommented():
    """``suspopt init``'s example of the hardware tables is a valid study file."""
    lines = default_config_toml().splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith('# nonlinear hardware'))
    end = next(i for i in range(start, len(lines)) if not lines[i].startswith('#'))
    body = '\n'.join(
        line[2:]
        for line in lines[start:end]
        if line.startswith(('# [', '# c_', '# v_', '# gap', '# coefficients'))
    )
    cfg = config_from_dict(tomllib.loads(body))
    assert study_units(cfg)[0].bump_stop == BumpStop(0.03, (2.0e6, 5.0e7))
    assert 'c_S1' not in cfg.design_names()


def test_per_corner_curves_a_spring_table_and_the_automatic_grid():
    """Per corner, a front polynomial's cubic coefficient (``k_S3_1L``: not the rear rate),
    a rear spring table (no ``k_S2``: the automatic grid takes the table's rate at static)
    and a rear rebound stop's gap; the description round-trips."""
    from suspopt.spec.resolve import wheel_hop_frequency

    d = full_car_defaults().to_dict()
    f_linear = wheel_hop_frequency(config_from_dict(d))
    d['vehicle']['front']['spring_curve'] = {'coefficients': [29770.0, 0.0, 1.0e7]}
    d['vehicle']['rear']['spring_curve'] = {
        'deflections': [-0.1, 0.0, 0.1],
        'forces': [-3000.0, 0.0, 4000.0],
    }
    d['vehicle']['rear']['rebound_stop'] = {'gap': 0.05, 'coefficients': [1.0e6]}
    d['design'] = {'per_corner': True, 'k_S3_1': {}, 'rebound_gap_2R': {}}
    cfg = config_from_dict(d)
    names = cfg.design_names()
    assert {'k_S1L', 'k_S1R', 'k_S3_1L', 'k_S3_1R', 'rebound_gap_2R'} <= set(names)
    assert not {'k_S2L', 'k_S2R', 'rebound_gap_2L'} & set(names)
    assert cfg.design['k_S3_1L'].initial == 1.0e7
    # the rear's wheel hop from the table (35 kN/m at static) is below the front's
    assert wheel_hop_frequency(cfg) == pytest.approx(f_linear)
    assert cfg.scenarios()[0].segments > 0
    assert config_from_dict(cfg.to_dict()) == cfg
