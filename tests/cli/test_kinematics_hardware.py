"""``suspopt kinematics`` with a study's hardware: the wheel rate with the study's bump
stop on the axle's spring, the roll centre's migration and the centre line
(docs/nonlinear_hardware.md, "Kinematic roll centre")."""

from __future__ import annotations

import numpy as np
import pytest

from suspopt.cli.main import main
from suspopt.multibody.kinematics import kinematic_curves
from suspopt.multibody.mechanism import load_mechanism
from suspopt.spec.hardware import study_units
from suspopt.spec.load import load_config
from suspopt.transcription.vehicle import with_hardware

STUDY = """
[vehicle.front.bump_stop]
gap = 0.02
coefficients = [4.0e6, 6.0e7]

[vehicle.front.damper_curve]
c_bump_low = 3000.0
v_bump_knee = 0.08
c_bump_high = 1200.0
c_rebound_low = 7000.0
v_rebound_knee = 0.12
c_rebound_high = 2800.0
"""


def test_wheel_rate_with_the_studys_bump_stop(tmp_path, capsys):
    """The paper's double wishbone compresses its spring by ``m w`` (``m = 0.15/0.33``):
    with the study's stop on it, the wheel rate is ``m² (k + 2 b₂ δ + 3 b₃ δ²)``, ``δ =
    max(m w - gap, 0)``, the stop engaging at ``w = gap / m``; the command prints it."""
    study = tmp_path / 'hw.toml'
    study.write_text(STUDY)
    assert main(['kinematics', '--study', str(study), '--points', '9', '--out', str(tmp_path)]) == 0
    out = capsys.readouterr().out
    table = (tmp_path / 'kinematics_double_wishbone_hw_front.md').read_text()
    assert table in out and (tmp_path / 'kinematics_double_wishbone_hw_front.png').is_file()
    assert 'roll centre migration [mm]' in table and 'roll centre: 0.0 mm' in table
    unit = study_units(load_config(study))[0]
    mech = with_hardware(load_mechanism('double_wishbone', suspension=True), unit)
    c = kinematic_curves(mech, points=9)
    m, k, gap, b2, b3 = 0.15 / 0.33, 30000.0, 0.02, 4.0e6, 6.0e7
    d = np.maximum(m * c['travel'] - gap, 0.0)
    np.testing.assert_allclose(c['wheel_rate'], m**2 * (k + 2 * b2 * d + 3 * b3 * d**2), rtol=1e-10)
    rows = [line for line in table.splitlines() if line.startswith('| ') and 'mm' not in line]
    printed = np.array([float(r.split('|')[4]) for r in rows])  # wheel rate [N/mm]
    np.testing.assert_allclose(printed, c['wheel_rate'] / 1e3, atol=1e-4)
    assert printed[-1] > 10 * printed[0]  # the stop engaged at full bump


def test_roll_centre_migration_and_centre_line(tmp_path, capsys):
    """The migration is the height less the reference pose's (computed with the travels,
    also when the range excludes zero); ``--centre-line`` moves the centre line: the
    height is ``(x_P - x_c) dx_P/dz_P``, affine in ``x_c``."""
    base = kinematic_curves('sla_double_wishbone', (-0.05, 0.05), points=5)
    np.testing.assert_array_equal(base['travel'][2], 0.0)
    np.testing.assert_allclose(
        base['roll_centre_migration'], base['roll_centre_height'] - base['roll_centre_height'][2]
    )
    shifted = kinematic_curves('sla_double_wishbone', (0.01, 0.05), points=3)
    ref = kinematic_curves('sla_double_wishbone', (-0.05, 0.05), points=3)['roll_centre_height'][1]
    np.testing.assert_allclose(
        shifted['roll_centre_migration'], shifted['roll_centre_height'] - ref, atol=1e-12
    )
    moved = kinematic_curves('sla_double_wishbone', (-0.05, 0.05), points=5, centre_line=-0.3)
    slope = base['roll_centre_height'] - moved['roll_centre_height']
    x_c = load_mechanism('sla_double_wishbone', suspension=True).centre_line
    assert not np.allclose(slope, 0.0)
    third = kinematic_curves('sla_double_wishbone', (-0.05, 0.05), points=5, centre_line=-0.6)
    np.testing.assert_allclose(
        moved['roll_centre_height'] - third['roll_centre_height'],
        slope * 0.3 / (x_c + 0.3),
        rtol=1e-9,
    )
    argv = ['kinematics', 'sla_double_wishbone', '--centre-line', '-0.3', '--points', '3']
    assert main(argv + ['--out', str(tmp_path)]) == 0
    assert 'centre line x = -0.3 m' in capsys.readouterr().out


@pytest.mark.parametrize(
    'argv, words',
    [
        (['kinematics'], 'give a MECHANISM, or --study FILE'),
        (['kinematics', 'double_wishbone', '--centre-line', 'nan'], '--centre-line: must be'),
        (['kinematics', '--study', 'QUARTER', '--axle', 'rear'], 'a quarter car has one corner'),
        (['kinematics', '--study', 'BAD'], 'vehicle.front.bump_stop.gap'),
    ],
)
def test_kinematics_refuses_bad_input(tmp_path, capsys, argv, words):
    (tmp_path / 'q.toml').write_text('[vehicle]\nmodel = "quarter_car"\n')
    (tmp_path / 'b.toml').write_text(
        '[vehicle.front.bump_stop]\ngap = -0.01\ncoefficients = [1e6]\n'
    )
    files = {'QUARTER': str(tmp_path / 'q.toml'), 'BAD': str(tmp_path / 'b.toml')}
    argv = [files.get(a, a) for a in argv]
    assert main(argv + ['--out', str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert words in err, err
