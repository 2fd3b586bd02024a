"""The ``[control]`` table (``docs/codesign.md``): what it adds to a study (the effort
terms, a feedback law's gains as design variables) and the bad input it refuses, each
problem one line naming its key (exit code 2 on the command line)."""

from __future__ import annotations

import pytest

from suspopt.cli.main import main
from suspopt.errors import ConfigError
from suspopt.spec import config_from_dict


def test_an_active_quarter_car_has_an_effort_term():
    cfg = config_from_dict({'vehicle': {'model': 'quarter_car'}, 'control': {'kind': 'active'}})
    assert cfg.terms()[-1] == 'control_1' and cfg.controlled() == ('1',)
    assert cfg.design_names() == ('k_S1', 'c_S1')  # open loop: no gains


def test_feedback_gains_are_design_variables_of_the_controlled_axles():
    cfg = config_from_dict(
        {
            'vehicle': {'model': 'full_car'},
            'control': {
                'kind': 'semi_active',
                'law': 'feedback',
                'corners': ['2L', '2R'],
                'c_min': 300.0,
                'c_max': 5000.0,
            },
            'design': {'g_sky2': {'initial': 2000.0, 'lower': 0.0, 'upper': 8000.0}},
        }
    )
    assert cfg.controlled() == ('2L', '2R')
    assert [t for t in cfg.terms() if t.startswith('control')] == ['control_2L', 'control_2R']
    assert cfg.design_names()[-2:] == ('g_sky2', 'g_gnd2')
    assert cfg.design['g_sky2'].upper == 8000.0
    active = config_from_dict({'control': {'kind': 'active', 'law': 'feedback'}})
    assert active.design_names()[4:] == (
        'g_sky1', 'g_sky2', 'g_gnd1', 'g_gnd2', 'g_tr1', 'g_tr2', 'g_rt1', 'g_rt2'
    )  # fmt: skip
    # effort weights by group, split among the controlled corners
    grouped = config_from_dict(
        {'control': {'kind': 'active'}, 'objective': {'weights': {'heave': 1.0, 'control': 0.5}}}
    )
    assert grouped.objective.weights['control_1'] == grouped.objective.weights['control_2'] == 0.25


BAD = [
    (
        {'kind': 'semi_active', 'c_min': 4000.0, 'c_max': 300.0},
        'control.c_min: 4000 N s/m is above control.c_max = 300 N s/m',
    ),
    (
        {'kind': 'active', 'corners': ['1L']},
        "control.corners: '1L': no such corner on a half car (its corners: 1, 2)",
    ),
    (
        {'kind': 'active', 'power_max': 2000.0},
        'control.power_max: an active force needs control.force_max too',
    ),
    ({'kind': 'activ'}, "control.kind: must be one of none, active, semi_active, got 'activ'"),
    ({'kind': 'active', 'law': 'lqr'}, 'control.law: must be one of open_loop, feedback'),
    ({'kind': 'semi_active'}, 'control.c_max: a semi-active damper needs c_max > 0'),
    ({'kind': 'active', 'c_max': 3000.0}, 'control.c_max: only for a semi-active damper'),
    ({'c_max': 3000.0}, "control.c_max: only with a control (control.kind = 'active'"),
    ({'kind': 'active', 'force_max': -5.0}, 'control.force_max: -5 N is implausible'),
]


@pytest.mark.parametrize('table, line', BAD, ids=[b[1].split(':')[0] + str(i) for i, b in
                                                  enumerate(BAD)])  # fmt: skip
def test_bad_control_input_names_its_key(table, line):
    with pytest.raises(ConfigError) as err:
        config_from_dict({'control': table})
    assert any(p.startswith(line) for p in err.value.problems), err.value.problems


def test_a_semi_active_power_bound_needs_no_force_bound():
    cfg = config_from_dict(
        {'control': {'kind': 'semi_active', 'c_min': 300.0, 'c_max': 4000.0, 'power_max': 800.0}}
    )
    assert cfg.control.power_max == 800.0


@pytest.mark.parametrize(
    'table, key',
    [
        ('kind = "semi_active"\nc_min = 4000.0\nc_max = 300.0', 'control.c_min'),
        ('kind = "active"\ncorners = ["2R"]', 'control.corners'),
        ('kind = "active"\npower_max = 1500.0', 'control.power_max'),
    ],
)
def test_bad_control_input_is_exit_code_2(tmp_path, capsys, table, key):
    path = tmp_path / 'study.toml'
    path.write_text(f'[vehicle]\nmodel = "quarter_car"\n\n[control]\n{table}\n')
    assert main(['optimize', '--config', str(path), '--fidelity', 'low']) == 2
    err = capsys.readouterr().err
    assert f'{path}: {key}:' in err
