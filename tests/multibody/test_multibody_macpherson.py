"""The shipped MacPherson strut (``data/macpherson.toml``) against its source and against
closed-form geometry.

Source numbers typed in from Chrono::Vehicle's ``BMW_E90_MacPhersonStrut.cpp`` (left
side: X forward, Y left, Z up), ``BMW_E90_FrontWheel.cpp`` and
``BMW_E90_TMeasyTireFront.cpp``; the file's front view is ``x = Y - 0.210062``, ``z = Z``
with masses and inertias times 120 / 95.29.

Closed-form front-view kinematics, independent of the solver: the ball joint B moves on
a circle of radius r about the arm's pivot P, ``B = P + r (cos θ, sin θ)``. The upright
slides on the strut, whose axis always passes through the top mount T, and B keeps its
signed distance ``d = e × (B - T)`` from that axis (both are fixed in the upright), so
with β the angle of ``B - T`` (pointing down, against the axis direction e)
``sin(β - α) = d / |B - T|`` gives the axis angle ``α = β - π + asin(d / |B - T|)``, the
upright turns by ``α - α0``, and every upright point follows. Derivatives along θ by
central differences (h = 1e-6: error ~1e-10).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq

from suspopt.multibody.kinematics import kinematic_curves
from suspopt.multibody.mechanism import load_mechanism
from suspopt.multibody.simulate import simulate_mechanism
from suspopt.multibody.solver import PlanarMultibodySolver

CHRONO = {  # getLocation(), left side
    'SPINDLE': (0.0, 0.750062, 0.0),
    'UPRIGHT': (0.0, 0.650062, 0.0),
    'LCA_F': (0.27051, 0.34544, -0.05969),
    'LCA_B': (-0.04318, 0.37338, -0.12573),
    'LCA_U': (0.02794, 0.66294, -0.10414),
    'LCA_CM': (0.0708025, 0.511175, -0.098425),
    'SPRING_C': (-0.08382, 0.54102, 0.46863),
    'SPRING_U': (-0.00508, 0.61976, -0.00127),
}
MASS = {
    'spindle': 9.962477554,
    'upright': 13.51,
    'LCA': 2.72,
    'strut': 13.5,
    'wheel': 18.0,
    'tire': 37.6,
}
TYRE_RADIUS = 0.3186
SCALE = 120.0 / sum(MASS.values())


def front(name: str) -> np.ndarray:
    X, Y, Z = CHRONO[name]
    return np.array([Y - 0.210062, Z])


def pivot() -> np.ndarray:
    """The point of the arm's bushing axis nearest the ball joint, in the front view."""
    B, F, U = (np.array(CHRONO[k]) for k in ('LCA_B', 'LCA_F', 'LCA_U'))
    a = (F - B) / np.linalg.norm(F - B)
    c = B + np.dot(U - B, a) * a
    return np.array([c[1] - 0.210062, c[2]])


@pytest.fixture(scope='module')
def mech():
    return load_mechanism('macpherson', suspension=True)


def test_the_file_is_chronos_strut_in_the_front_view(mech):
    joints = {j.name: j for j in mech.joints}
    markers = {m.name: m.point for m in mech.markers}
    bodies = {b.name: b for b in mech.bodies}
    close = dict(rtol=0, atol=1e-6)
    np.testing.assert_allclose(joints['L-F'].point, pivot(), **close)
    np.testing.assert_allclose(joints['L-W'].point, front('LCA_U'), **close)
    np.testing.assert_allclose(joints['R-F'].point, front('SPRING_C'), **close)
    np.testing.assert_allclose(markers['top_mount'], front('SPRING_C'), **close)
    np.testing.assert_allclose(joints['strut'].point, front('SPRING_U'), **close)
    np.testing.assert_allclose(markers['spring_seat'], front('SPRING_U'), **close)
    axis = front('SPRING_C') - front('SPRING_U')
    np.testing.assert_allclose(joints['strut'].axis, axis / np.hypot(*axis), rtol=1e-12)
    np.testing.assert_allclose(markers['wheel_centre'], [0.54, 0.0], **close)
    np.testing.assert_allclose(markers['contact_patch'], [0.54, -TYRE_RADIUS], **close)
    # masses: Chrono's, scaled to a moving mass of 120 kg
    m_W = MASS['spindle'] + MASS['upright'] + MASS['wheel'] + MASS['tire']
    assert bodies['W'].mass == pytest.approx(SCALE * m_W, abs=1e-6)
    assert bodies['L'].mass == pytest.approx(SCALE * MASS['LCA'], abs=1e-6)
    assert bodies['R'].mass == pytest.approx(SCALE * MASS['strut'], abs=1e-6)
    assert sum(b.mass for b in mech.bodies if not b.fixed) == pytest.approx(120.0, abs=1e-5)
    cg_W = (m_W * front('SPINDLE') + MASS['upright'] * (front('UPRIGHT') - front('SPINDLE'))) / m_W
    np.testing.assert_allclose(bodies['W'].position, cg_W, **close)
    np.testing.assert_allclose(
        bodies['R'].position, (front('SPRING_C') + front('SPRING_U')) / 2, **close
    )
    np.testing.assert_allclose(bodies['L'].position, front('LCA_CM'), **close)
    # W's inertia about the longitudinal axis: the parts' diametral inertias plus offsets
    I_W = (
        0.000478
        + 0.0138
        + 0.767875
        + 3.84
        + sum(
            m * np.sum((front(p) - cg_W) ** 2)
            for m, p in (
                (MASS['spindle'] + MASS['wheel'] + MASS['tire'], 'SPINDLE'),
                (MASS['upright'], 'UPRIGHT'),
            )
        )
    )
    assert bodies['W'].inertia == pytest.approx(SCALE * I_W, abs=1e-6)


def test_it_has_one_degree_of_freedom(mech):
    s = PlanarMultibodySolver(mech)
    assert (s.n, s.m, s.dof) == (12, 11, 1)  # Exudyn: 9 coordinates, 8 constraints
    assert mech.independent == (('W', 'z'),)


#: the file's front-view hardpoints (the projection above, rounded to 1e-6 m)
PIVOT, BALL, TOP, SEAT = (
    (0.159096, -0.115752),
    (0.452878, -0.10414),
    (0.330958, 0.46863),
    (0.409698, -0.00127),
)


class ClosedForm:
    """Front-view MacPherson kinematics from the hardpoints (see the module docstring)."""

    def __init__(self):
        self.P, self.B0, self.T, self.S0 = (np.array(p) for p in (PIVOT, BALL, TOP, SEAT))
        d = self.B0 - self.P
        self.r, self.theta0 = np.hypot(*d), np.arctan2(d[1], d[0])
        e = (self.T - self.S0) / np.hypot(*(self.T - self.S0))
        self.alpha0 = np.arctan2(e[1], e[0])
        v = self.B0 - self.T
        self.d = e[0] * v[1] - e[1] * v[0]

    def pose(self, theta):
        B = self.P + self.r * np.array([np.cos(theta), np.sin(theta)])
        v = B - self.T
        alpha = np.arctan2(v[1], v[0]) - np.pi + np.arcsin(self.d / np.hypot(*v))
        return B, np.angle(np.exp(1j * (alpha - self.alpha0)))

    def point(self, theta, X0):
        B, phi = self.pose(theta)
        c, s = np.cos(phi), np.sin(phi)
        u = X0 - self.B0
        return B + np.array([c * u[0] - s * u[1], s * u[0] + c * u[1]])

    def travel(self, theta):
        return self.point(theta, np.array([0.54, 0.0]))[1]

    def spring_length(self, theta):
        return np.hypot(*(self.point(theta, self.S0) - self.T))


def closed_form_errors(points: int = 11) -> dict[str, float]:
    """Largest differences of the solver's curves from the closed form over ±0.1 m."""
    g = ClosedForm()
    c = kinematic_curves('macpherson', (-0.1, 0.1), points=points)
    h = 1e-6
    L0 = g.spring_length(g.theta0)
    err = dict.fromkeys(['motion ratio', 'deflection', 'camber', 'track'], 0.0)
    for i, w in enumerate(c['travel']):
        th = brentq(lambda t, w=w: g.travel(t) - w, g.theta0 - 0.6, g.theta0 + 0.6, xtol=1e-15)
        mr = -(
            (g.spring_length(th + h) - g.spring_length(th - h))
            / (g.travel(th + h) - g.travel(th - h))
        )
        cp = g.point(th, np.array([0.54, -TYRE_RADIUS]))
        for key, got, want in (
            ('motion ratio', c['motion_ratio'][i], mr),
            ('deflection', c['spring_deflection'][i], g.spring_length(th) - L0),
            ('camber', c['camber'][i], -np.degrees(g.pose(th)[1])),
            ('track', c['track_change'][i], cp[0] - 0.54),
        ):
            err[key] = max(err[key], abs(got - want))
    return err, c


TOL = {'motion ratio': 1e-8, 'deflection': 1e-12, 'camber': 1e-9, 'track': 1e-12}


def test_curves_match_the_closed_form_geometry():
    err, c = closed_form_errors()
    print(
        '\nMacPherson curves against the closed form: '
        + ', '.join(f'{k} {v:.1e}' for k, v in err.items())
    )
    for k, v in err.items():
        assert v < TOL[k], (k, v)
    # a real MacPherson: the motion ratio below 1 in rebound and above in bump, the
    # camber positive in rebound
    assert c['motion_ratio'][0] < 0.9 < c['motion_ratio'][5] < 1.0 < c['motion_ratio'][-1]
    assert c['camber'][0] > 2.0


def test_a_wrong_strut_angle_is_caught(monkeypatch):
    """The same comparison fails when the prismatic joint's rotation equation is off by
    0.02 rad (and passes again after the repair)."""
    from suspopt.multibody.elements.prismatic import PrismaticGroup

    init = PrismaticGroup.__init__

    def wrong(self, specs, layout):
        init(self, specs, layout)
        self.angle = self.angle + 0.02

    monkeypatch.setattr(PrismaticGroup, '__init__', wrong)
    err, _ = closed_form_errors(3)
    assert err['camber'] > 0.5 and err['motion ratio'] > 1e-3, err
    monkeypatch.undo()
    err, _ = closed_form_errors(3)
    assert all(v < TOL[k] for k, v in err.items()), err


@pytest.mark.parametrize('method', ['partitioned', 'baumgarte'])
def test_free_oscillation_conserves_energy(mech, method):
    """Spring 30 kN/m along the strut, no damping, released at 40 mm of bump: kinetic plus
    spring energy stays constant over 1 s (about 2.5 periods) and the constraints hold."""
    s = PlanarMultibodySolver(mech)
    params = {'strut_spring': {'stiffness': 3.0e4, 'damping': 0.0}}
    t = np.linspace(0.0, 1.0, 201)
    tr = simulate_mechanism(
        s, (0.0, 1.0), [s.q0[1] + 0.04], [0.0], params=params, method=method, t_eval=t
    )
    E = s.kinetic_energy(tr.qd) + s.potential_energy(tr.q, params)
    z = tr.q[:, 1] - s.q0[1]
    assert z.min() < -0.035 and z.max() > 0.035  # it swung through
    crossings = np.count_nonzero(np.diff(np.sign(z)))
    assert crossings >= 4
    drift = np.max(np.abs(E / E[0] - 1.0))
    print(
        f'\nMacPherson free oscillation ({method}): {crossings / 2:g} periods, energy '
        f'drift {drift:.1e}, constraint residual {tr.info["max_constraint_residual"]:.1e}'
    )
    assert drift < 1e-7
    assert tr.info['max_constraint_residual'] < 1e-9


def test_a_strut_that_jams_within_the_travel_is_refused(mech):
    """The top mount moved to (0.5, 0.05): the strut lies almost flat and the upright,
    sliding on it, cannot follow the arm 10 mm into the bump."""
    import dataclasses

    from suspopt.errors import ConfigError
    from suspopt.multibody.mechanism import Marker

    top = (0.5, 0.05)
    joints = tuple(
        dataclasses.replace(j, point=top)
        if j.name == 'R-F'
        else dataclasses.replace(
            j, axis=tuple(np.subtract(top, SEAT) / np.hypot(*np.subtract(top, SEAT)))
        )
        if j.name == 'strut'
        else j
        for j in mech.joints
    )
    markers = tuple(
        Marker('top_mount', 'F', top) if m.name == 'top_mount' else m for m in mech.markers
    )
    jammed = dataclasses.replace(mech, joints=joints, markers=markers)
    with pytest.raises(ConfigError) as err:
        PlanarMultibodySolver(jammed)
    msg = str(err.value)
    assert 'suspension.travel: the linkage locks between wheel travel +0 and +0.01 m' in msg, msg
    assert "'strut'" in msg and 'inside its travel range [-0.1, 0.1] m' in msg
