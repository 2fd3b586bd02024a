"""Kinematic curves (``suspopt.multibody.kinematics``) and the ``suspopt kinematics`` command.

* Double wishbone (a parallelogram, docs/model.md): motion ratio 0.15 / 0.33 at every travel,
  no camber, the track change of the arms' arc ``LA (cos θ - 1)``, ``sin θ = w / LA``, and
  the wheel rate ``k MR²``.
* All three linkages: the wheel rate is the solver's static force per travel. A vertical
  force F at the wheel centre holds the wheel at rest at travel w against the spring k
  (found from the augmented solve, which is affine in F); by virtual work F = dV/dw =
  k s s_w, and the wheel rate is dF/dw (central difference over ±0.1 mm: error ~1e-8).
  For the double wishbone the file's own tyre load at the contact patch gives the same.
The MacPherson's motion ratio, camber and track change against closed-form geometry are
in ``test_multibody_macpherson.py``.
"""

from __future__ import annotations

import numpy as np
import pytest

from suspopt.cli.main import main
from suspopt.multibody.kinematics import COLUMNS, curves_table, kinematic_curves, plot_curves
from suspopt.multibody.mechanism import load_mechanism, mechanism_path
from suspopt.multibody.solver import PlanarMultibodySolver

LA, A_CG = 0.45 - 0.12, 0.27 - 0.12
LINKAGES = ['double_wishbone', 'sla_double_wishbone', 'macpherson']


def test_double_wishbone_curves_are_the_parallelogram_s():
    c = kinematic_curves('double_wishbone', (-0.12, 0.12), k=25000.0, points=13)
    w = c['travel']
    np.testing.assert_allclose(w, np.linspace(-0.12, 0.12, 13), atol=1e-13)
    np.testing.assert_allclose(c['motion_ratio'], A_CG / LA, rtol=0, atol=1e-10)
    assert A_CG / LA == pytest.approx(0.4545, abs=1e-4)
    np.testing.assert_allclose(c['camber'], 0.0, atol=1e-10)
    np.testing.assert_allclose(
        c['track_change'], LA * (np.cos(np.arcsin(w / LA)) - 1.0), atol=1e-12
    )
    np.testing.assert_allclose(c['spring_deflection'], -A_CG / LA * w, atol=1e-12)
    np.testing.assert_allclose(c['wheel_rate'], 25000.0 * (A_CG / LA) ** 2, rtol=1e-10)


def static_hold(
    s: PlanarMultibodySolver, q: np.ndarray, k: float, spring: str, marker: str
) -> np.ndarray:
    """The vertical force at ``marker`` that holds states ``q`` at rest against the spring."""
    i = s.marker_names.index(marker)
    body, u = int(s.mk_body[i]), s.mk_u[i]
    N = q.shape[0]
    Q0 = s.generalized_forces(q, None, np.zeros_like(q), {spring: {'stiffness': k}})
    acc = []
    for F in (0.0, 1000.0):
        Q = Q0 + s.point_force(q, body, u, np.stack([np.zeros(N), np.full(N, F)], 1))
        qdd, _ = s.solve_augmented(q, np.zeros_like(q), Q)
        acc.append(qdd[:, s.ind[0]])
    return -acc[0] * 1000.0 / (acc[1] - acc[0])


@pytest.mark.parametrize('name', LINKAGES)
def test_wheel_rate_is_the_static_force_per_travel(name):
    k = 32000.0
    c = kinematic_curves(name, k=k, points=9)
    mech = load_mechanism(name, suspension=True)
    s = PlanarMultibodySolver(mech)
    roles = mech.roles
    wheel = s.marker_names.index(roles['wheel_marker'])

    def hold(dz):
        q = s.positions((c['independent'] + dz + s.q0[s.ind[0]])[:, None])
        w = s.marker_positions(q)[:, wheel, 1] - s.marker_reference()[wheel, 1]
        return w, static_hold(s, q, k, roles['spring'], roles['wheel_marker'])

    w, F = hold(0.0)
    np.testing.assert_allclose(w, c['travel'], atol=1e-12)
    dVdw = -k * c['spring_deflection'] * c['motion_ratio']  # k s s_w
    np.testing.assert_allclose(F, dVdw, rtol=1e-9, atol=1e-9 * np.max(np.abs(F)))
    h = 1e-4
    (wp, Fp), (wm, Fm) = hold(h), hold(-h)
    rate = (Fp - Fm) / (wp - wm)
    err = np.max(np.abs(rate / c['wheel_rate'] - 1.0))
    print(
        f'\n{name}: wheel rate {c["wheel_rate"].min():.0f}..{c["wheel_rate"].max():.0f} N/m '
        f'(k = {k:g}); static force per travel differs by {err:.1e} (relative)'
    )
    assert err < 1e-6
    if name == 'double_wishbone':  # the file's tyre load at the contact patch: the same
        q = s.positions((c['independent'] + s.q0[s.ind[0]])[:, None])
        patch = mech.force(roles['tyre_load']).marker
        np.testing.assert_allclose(
            static_hold(s, q, k, roles['spring'], patch), F, rtol=1e-9, atol=1e-6
        )


def test_table_and_figure(tmp_path):
    c = kinematic_curves('sla_double_wishbone', points=5)
    text = curves_table(c)
    lines = text.strip().splitlines()
    assert lines[2] == '| ' + ' | '.join(h for _, h, _ in COLUMNS) + ' |'
    assert len(lines) == 4 + 5 + 2 and lines[-1].startswith('roll centre: ')
    assert '| 0.0000 | 0.0000 | 0.4967 |' in text  # the reference row
    path = plot_curves(c, tmp_path / 'k.png')
    assert path.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n' and path.stat().st_size > 10_000


def test_kinematics_command(tmp_path, capsys):
    assert (
        main(
            [
                'kinematics',
                'macpherson',
                '--travel=-0.05,0.05',
                '--k',
                '29770',
                '--points',
                '3',
                '--out',
                str(tmp_path),
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert 'spring rate 29770 N/m' in out and '| -50.0000 |' in out and '| 50.0000 |' in out
    assert (tmp_path / 'kinematics_macpherson.png').is_file()
    assert (tmp_path / 'kinematics_macpherson.md').read_text() in out


@pytest.mark.parametrize(
    'argv, words',
    [
        (['kinematics', 'no_such_linkage'], ['mechanism file not found: no_such_linkage']),
        (['kinematics', 'double_wishbone', '--travel', '0.1'], ['--travel: expected MIN,MAX']),
        (['kinematics', 'double_wishbone', '--travel=0.1,-0.1'], ['--travel: expected MIN,MAX']),
        (
            ['kinematics', 'double_wishbone', '--travel=-0.1,0.4'],
            [
                'travel: double wishbone (paper Table 2) cannot follow the wheel travel '
                '[-0.1, 0.4] m'
            ],
        ),
        (['kinematics', 'double_wishbone', '--k', '0'], ['--k: the spring rate must be']),
        (['kinematics', 'double_wishbone', '--k', 'nan'], ['--k: the spring rate must be']),
        (['kinematics', 'double_wishbone', '--points', '1'], ['--points: need at least 2']),
    ],
)
def test_kinematics_command_refuses_bad_input(tmp_path, capsys, argv, words):
    assert main(argv + ['--out', str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    for w in words:
        assert w in err[0], err


def test_kinematics_command_refuses_a_bad_mechanism_file(tmp_path, capsys):
    text = mechanism_path('macpherson').read_text()
    bad = tmp_path / 'bad.toml'
    bad.write_text(text.replace('axis = [-0.07874, 0.4699]', 'axis = [0.0, 0.0]'))
    assert main(['kinematics', str(bad), '--out', str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert (
        len(err) == 1
        and 'joints[3].axis: must be a non-zero finite vector' in err[0]
        and "(joint 'strut')" in err[0]
    ), err
