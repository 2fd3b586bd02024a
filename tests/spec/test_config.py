"""Study-file validation (issue 6): every bad input gives one line naming the key, exit 2."""

from __future__ import annotations

import math
import subprocess
import sys
import tomllib

import numpy as np
import pytest

from suspopt.cli.main import main
from suspopt.errors import ConfigError
from suspopt.spec.load import config_from_dict, load_config
from suspopt.spec.schema import StudyConfig
from suspopt.spec.template import default_config_toml


def _write(tmp_path, text: str, name: str = 'study.toml'):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_defaults_reproduce_spec():
    c = StudyConfig()
    v = c.vehicle
    assert (v.front.axle_position, v.rear.axle_position) == (1.271, -1.713)
    assert (v.chassis_mass, v.chassis_pitch_inertia) == (1414.0, 2782.0)
    assert (v.front.wheel_mass, v.front.tyre_stiffness) == (120.0, 200000.0)
    assert math.isclose(v.wheelbase, 2.984)
    assert c.design.initial() == {'k_S1': 30000.0, 'k_S2': 30000.0, 'c_S1': 3000.0, 'c_S2': 3000.0}
    assert c.design.bounds()['k_S2'] == (10000.0, 50000.0)
    assert c.design.bounds()['c_S1'] == (1000.0, 5000.0)
    assert (c.maneuver.speed, c.maneuver.horizon) == (10.0, 5.0)
    assert c.road == {'profile': 'two_bumps', 'height': 0.05, 'length': 2.0, 'starts': [5.0, 10.0]}
    weighted = {t: w for t, w in c.objective.weights.items() if w}
    assert weighted == {'heave': 0.25, 'pitch': 0.25, 'wheel_1': 0.25, 'wheel_2': 0.25}
    assert c.objective.normalization == 'reference'
    assert c.transcription.order == 5


def test_init_file_round_trips_to_defaults(tmp_path):
    assert main(['init', str(tmp_path / 'case.toml')]) == 0
    assert load_config(tmp_path / 'case.toml') == StudyConfig()
    assert config_from_dict(tomllib.loads(default_config_toml())) == StudyConfig()
    assert config_from_dict(StudyConfig().to_dict()) == StudyConfig()
    # init refuses to overwrite
    assert main(['init', str(tmp_path / 'case.toml')]) == 2


BAD_INPUTS = [
    # (TOML snippet, key expected in the message, words expected in the message)
    ('[vehicle]\nchasis_mass = 1400.0', 'vehicle.chasis_mass', "did you mean 'chassis_mass'"),
    ('[vehicle]\nchassis_mass = "heavy"', 'vehicle.chassis_mass', 'must be a number'),
    ('[vehicle]\nchassis_mass = -1.0', 'vehicle.chassis_mass', 'must be > 0'),
    ('[vehicle]\nchassis_pitch_inertia = 0.0', 'vehicle.chassis_pitch_inertia', 'must be > 0'),
    ('[vehicle.front]\nwheel_mass = -120.0', 'vehicle.front.wheel_mass', 'must be > 0'),
    ('[vehicle.rear]\ntyre_stiffness = 0', 'vehicle.rear.tyre_stiffness', 'must be > 0'),
    ('[vehicle.front]\naxle_position = nan', 'vehicle.front.axle_position', 'finite'),
    ('[vehicle.front]\naxle_position = -3.0', 'vehicle.front.axle_position', 'ahead of'),
    ('[maneuver]\nspeed = inf', 'maneuver.speed', 'finite'),
    ('[design.k_S1]\nlower = 60000.0', 'design.k_S1.lower', 'above upper bound'),
    ('[design.c_S2]\ninitial = 9000.0', 'design.c_S2.initial', 'outside the bounds'),
    ('[design.k_S2]\nlower = -5.0', 'design.k_S2.lower', 'must be > 0'),
    ('[design.k_S3]\ninitial = 1.0', 'design.k_S3', 'unknown key'),
    (
        '[objective]\nnormalization = "refrence"',
        'objective.normalization',
        "did you mean 'reference'",
    ),
    ('[objective]\nweights = [1.0, 1.0]', 'objective.weights', 'needs 4 values'),
    ('[transcription]\nsegments = 0', 'transcription.segments', 'must be > 0'),
    ('[transcription]\nsegments = 12.5', 'transcription.segments', 'must be an integer'),
    ('[road]\nprofile = "twobumps"', 'road.profile', "did you mean 'two_bumps'"),
    ('[road]\nprofile = "step"\nramp_length = 0.0', 'road.ramp_length', 'must be > 0'),
    ('[road]\nprofile = "iso8608"\nroad_class = "Z"', 'road.road_class', 'must be one of'),
    ('[road]\nprofile = "bump"\nhieght = 0.1', 'road.hieght', "did you mean 'height'"),
    ('[road]\nprofile = "csv"', 'road.file', 'missing value'),
    ('[road]\nprofile = "csv"\nfile = "no_such_road.csv"', 'road.file', 'road CSV not found'),
    (
        '[vehicle.front]\nmechanism = "no_such_mechanism.toml"',
        'vehicle.front.mechanism',
        'not found',
    ),
    ('[multibody]\nfd_form = "backward"', 'multibody.fd_form', "'forward' or 'central'"),
    ('speling = 1', 'speling', 'unknown key'),
    ('[transcription]\norder = 1', 'transcription.order', 'must be >= 2'),
    (
        '[transcription]\ninitial_guess = "warm"',
        'transcription.initial_guess',
        "'auto', 'simulate' or 'zero'",
    ),
    ('[optimizer]\nprint_level = 99', 'optimizer.print_level', 'must be 0..12'),
    ('[optimizer]\nmax_iter = 0', 'optimizer.max_iter', 'must be > 0'),
    (
        '[optimizer.options]\nno_such_option = 3',
        'optimizer.options.no_such_option',
        'not a valid option',
    ),
    (
        '[optimizer.options]\nmu_strategy = "bogus"',
        'optimizer.options.mu_strategy',
        'valid: monotone, adaptive',
    ),
    ('[optimizer.options]\nmax_cpu_time = -1.0', 'optimizer.options.max_cpu_time', 'range: 0 <'),
]


@pytest.mark.parametrize('snippet,key,words', BAD_INPUTS, ids=[b[1] for b in BAD_INPUTS])
def test_bad_input_names_the_key_and_exits_2(tmp_path, capsys, snippet, key, words):
    path = _write(tmp_path, snippet)
    with pytest.raises(ConfigError) as err:
        load_config(path)
    lines = [p for p in err.value.problems if key in p]
    assert lines, err.value.problems
    assert any(words in line for line in lines), lines
    assert main(['evaluate', '--fidelity', 'low', '--config', str(path)]) == 2
    stderr = capsys.readouterr().err
    assert key in stderr and 'Traceback' not in stderr
    assert all(line.startswith('suspopt: error: ') for line in stderr.strip().splitlines())


@pytest.mark.parametrize(
    'rows,words',
    [
        ('0,0\n2,0\n1,0\n3,0\n80,0\n', 'strictly increasing'),
        ('0,0\n1,0\n2,0\n3,0\n', 'covers s = 0..3 m but the drive needs 0..50'),
        ('0,0\n1,x\n2,0\n3,0\n60,0\n', 'row 2 is not two numbers'),
        ('0,0\n', 'at least 4'),
    ],
)
def test_bad_road_csv(tmp_path, capsys, rows, words):
    _write(tmp_path, rows, 'road.csv')
    path = _write(tmp_path, '[road]\nprofile = "csv"\nfile = "road.csv"')
    with pytest.raises(ConfigError) as err:
        load_config(path)
    assert any('road.file' in p and words in p for p in err.value.problems), err.value.problems
    assert main(['evaluate', '--fidelity', 'low', '--config', str(path)]) == 2
    stderr = capsys.readouterr().err
    assert 'road.file' in stderr and words in stderr and 'Traceback' not in stderr


def test_road_csv_that_is_not_text(tmp_path, capsys):
    (tmp_path / 'road.csv').write_bytes(b'\xff\xfe\x00\x01' * 64)
    path = _write(tmp_path, '[road]\nprofile = "csv"\nfile = "road.csv"')
    assert main(['evaluate', '--fidelity', 'low', '--config', str(path)]) == 2
    stderr = capsys.readouterr().err
    assert 'road.file' in stderr and 'not valid CSV: not a text (UTF-8) file' in stderr


def test_unreadable_and_invalid_files(tmp_path, capsys):
    with pytest.raises(ConfigError, match='config file not found'):
        load_config(tmp_path / 'missing.toml')
    with pytest.raises(ConfigError, match='not valid TOML'):
        load_config(_write(tmp_path, '[vehicle\nchassis_mass = 1'))
    assert main(['study', '--config', str(tmp_path / 'missing.toml')]) == 2
    assert 'config file not found' in capsys.readouterr().err
    assert (
        main(
            [
                'evaluate',
                '--fidelity',
                'low',
                '--config',
                str(_write(tmp_path, '[vehicle\nchassis_mass = 1')),
            ]
        )
        == 2
    )
    assert 'not valid TOML' in capsys.readouterr().err
    binary = tmp_path / 'binary.toml'
    binary.write_bytes(b'\xff\xfe[vehicle]\x00')
    assert main(['evaluate', '--fidelity', 'low', '--config', str(binary)]) == 2
    stderr = capsys.readouterr().err
    assert 'binary.toml: not valid TOML' in stderr and 'Traceback' not in stderr
    # init into a directory that does not exist
    assert main(['init', str(tmp_path / 'no' / 'such' / 'dir' / 'case.toml')]) == 2
    assert 'does not exist' in capsys.readouterr().err


def test_bad_mechanism_file(tmp_path):
    mech = tmp_path / 'mech.toml'
    from suspopt.multibody.mechanism import mechanism_path

    text = mechanism_path('double_wishbone').read_text()
    mech.write_text(
        text.replace('bodies = ["W", "U"]', 'bodies = ["W", "UU"]')
        .replace('mass = 20.0', 'mass = -20.0', 1)
        .replace('inertia = 0.15', 'inertia = 0.0', 1)
    )
    path = _write(tmp_path, f'[vehicle.front]\nmechanism = "{mech.name}"')
    with pytest.raises(ConfigError) as err:
        load_config(path)
    text = '\n'.join(err.value.problems)
    assert "joints[0].bodies: unknown body 'UU'" in text and "did you mean 'U'" in text
    assert 'bodies[1].mass: must be > 0' in text
    assert 'bodies[1].inertia: must be > 0' in text


def test_a_mechanism_file_edited_between_loads_is_checked_anew(tmp_path):
    """The mechanism checks are remembered by the file's content (a sweep validates one
    mechanism per task), never by its name alone."""
    from suspopt.multibody.mechanism import mechanism_path

    text = mechanism_path('double_wishbone').read_text()
    mech = tmp_path / 'mech.toml'
    mech.write_text(text)
    path = _write(tmp_path, f'[vehicle.front]\nmechanism = "{mech.name}"')
    load_config(path)
    mech.write_text(text.replace('mass = 20.0', 'mass = -20.0', 1))
    with pytest.raises(ConfigError) as err:
        load_config(path)
    assert 'bodies[1].mass: must be > 0' in '\n'.join(err.value.problems)
    mech.write_text(text)
    load_config(path)


def test_bad_command_line_values(capsys):
    assert main(['evaluate', '--fidelity', 'low', '--design', '1,2,3']) == 2
    assert '--design' in capsys.readouterr().err
    assert main(['evaluate', '--fidelity', 'low', '--design', 'nan,3e4,3e3,3e3']) == 2
    assert '--design: design values must be finite and >= 0' in capsys.readouterr().err
    assert main(['evaluate', '--fidelity', 'low', '--design', '3e4,3e4,-1,3e3']) == 2
    assert 'c_S1 = -1' in capsys.readouterr().err
    assert main(['optimize', '--fidelity', 'low', '--start', '1e4,1e4,1e3']) == 2
    assert main(['optimize', '--fidelity', 'low', '--start', '6e4,1e4,1e3,1e3']) == 2
    assert '--start: k_S1 = 60000 is outside [10000, 50000]' in capsys.readouterr().err
    assert main(['evaluate', '--fidelity', 'low', '--segments', '0']) == 2
    assert '--segments: must be >= 1' in capsys.readouterr().err


def test_csv_road_reproduces_two_bumps(tmp_path):
    """A measured-road CSV sampled from the built-in two bumps gives the same objective."""
    from suspopt.studies.run import evaluate

    road = StudyConfig().road_profile()
    s = np.linspace(0.0, 60.0, 60001)
    (tmp_path / 'road.csv').write_text(
        'distance_m,height_m\n' + '\n'.join(f'{a:.6f},{b:.17g}' for a, b in zip(s, road.r(s)))
    )
    cfg = load_config(_write(tmp_path, '[road]\nprofile = "csv"\nfile = "road.csv"'))
    base = StudyConfig()
    design = base.design.initial()
    scales = (dict.fromkeys(base.terms(), 1.0),)
    a = evaluate(base, 'low', design, method='time-marching', scales=scales)
    b = evaluate(cfg, 'low', design, method='time-marching', scales=scales)
    assert abs(b.objective / a.objective - 1.0) < 1e-6


def test_a_bad_study_file_is_refused_before_the_heavy_imports(tmp_path):
    """A wrong value is refused (exit 2, naming the key) by the study file's own checks,
    before OpenMDAO, Dymos, IPOPT, Matplotlib or Dask are imported, by every command that
    reads a study file: the user waits for none of them (fails if the configuration
    imports a component or the driver, or a command imports its work first)."""
    bad = tmp_path / 'bad.toml'
    bad.write_text('[vehicle]\nchassis_mass = -3\n')
    commands = [
        ['optimize', '--fidelity', 'low'],
        ['evaluate', '--fidelity', 'low'],
        ['study'],
        ['coupling'],
        ['pareto', '--fidelity', 'low'],
        ['compare'],
        ['robust', '--fidelity', 'low'],
    ]
    script = (
        'import sys\nfrom suspopt.cli import main\n'
        "heavy = ('openmdao.api', 'openmdao.core', 'dymos', 'cyipopt', 'matplotlib', "
        "'distributed')\n"
        f'for cmd in {commands!r}:\n'
        f"    code = main(cmd + ['--config', {str(bad)!r}])\n"
        '    print(cmd[0], code, *[m for m in heavy if m in sys.modules])\n'
    )
    out = subprocess.run(
        [sys.executable, '-c', script], capture_output=True, text=True, timeout=120
    )
    lines = out.stdout.split('\n')[:-1]
    assert lines == [f'{c[0]} 2' for c in commands], out.stdout + out.stderr
    assert out.stderr.count('vehicle.chassis_mass') == len(commands)
