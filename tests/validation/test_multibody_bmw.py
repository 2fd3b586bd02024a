"""The BMW E90's own corners, ``data/bmw_e90_front.toml`` and ``data/bmw_e90_rear.toml``
(the default full car's mechanisms), against their source, against Chrono's 3D linkages
and against Exudyn.

Source numbers typed in from Chrono::Vehicle (github.com/projectchrono/chrono at
7689fbc02d12c5419fa6acad8791100fd89979dd, ``src/chrono_models/vehicle/bmw/``):
``BMW_E90_MacPhersonStrut.cpp`` and ``BMW_E90_DoubleWishbone.cpp`` (left-side hardpoints:
X forward, Y left, Z up; masses; inertias), ``BMW_E90_FrontWheel.cpp``,
``BMW_E90_RearWheel.cpp`` and ``BMW_E90_TMsimpleTireFront.cpp`` (the 11.2 kg tyre that
``suspopt/vehicles.py`` takes for both axles).

* Masses: each moving body carries terms of the full car's unsprung mass (spindle +
  upright + wheel + tyre + half of the arms), so the moving mass is the low-fidelity
  wheel mass; the halved arms keep Chrono's radii of gyration.
* Front view: the front corner is ``macpherson.toml``'s geometry (closed-form checks in
  ``test_multibody_macpherson.py``); the rear's arms are projected along their bushing
  axes onto their ball joints' transverse planes (the file's header).
* 3D: an independent solution of Chrono's 3D linkages (rigid upright; each ball joint on
  its circle about the arm's bushing axis; the tie rod a fixed distance; the MacPherson's
  strut line through the top mount), Newton on six pose coordinates per travel: the
  planar curves (motion ratio, camber, track change) follow it over ±80 mm; the rear's
  plain front-view projection (X dropped, pivots nearest the ball joints) would not.
* Exudyn: each corner built from its numbers typed in here, spring-damper along the
  file's spring line, the tyre pulse of ``test_multibody_exudyn.py``; the wheel's
  trajectory, the spring tension and the pins' reactions agree to 1e-5 of their
  amplitudes.
* The default full car with these corners: mixed fidelity by collocation, verified by
  time marching (slow).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from test_multibody_exudyn import (
    T_PULSE,
    LoadForceVector,
    MarkerBodyPosition,
    MarkerBodyRigid,
    NodeRigidBody2D,
    ObjectGround,
    PrismaticJoint2D,
    RevoluteJoint2D,
    RigidBody2D,
    SensorNode,
    SensorObject,
    SpringDamper,
    exu,
    solve_exudyn,  # noqa: E402
)

from suspopt.multibody.kinematics import kinematic_curves, reference_wheel_rate
from suspopt.multibody.mechanism import Marker, load_mechanism
from suspopt.multibody.simulate import simulate_mechanism
from suspopt.multibody.solver import PlanarMultibodySolver
from suspopt.spec.load import full_car_defaults

TYRE_RADIUS = 0.3186  # BMW_E90_TMsimpleTire*.cpp: unloaded radius
TYRE = (11.2, 0.495988)  # BMW_E90_TMsimpleTireFront.cpp: mass, diametral inertia

FRONT = {  # BMW_E90_MacPhersonStrut.cpp, getLocation(), left side
    'SPINDLE': (0.0, 0.750062, 0.0),
    'UPRIGHT': (0.0, 0.650062, 0.0),
    'LCA_F': (0.27051, 0.34544, -0.05969),
    'LCA_B': (-0.04318, 0.37338, -0.12573),
    'LCA_U': (0.02794, 0.66294, -0.10414),
    'LCA_CM': (0.0708025, 0.511175, -0.098425),
    'SPRING_C': (-0.08382, 0.54102, 0.46863),
    'SPRING_U': (-0.00508, 0.61976, -0.00127),
    'TIEROD_C': (-0.2, 0.2, -0.05),
    'TIEROD_U': (-0.2, 0.574803759, -0.00127),
}
#: part: (mass, inertia about X); the LCA's principal moments in its own frame
FRONT_PARTS = {
    'spindle': (9.962477554, 0.000478),
    'upright': (13.51, 0.0138),
    'wheel': (18.0, 0.767875),
    'tire': TYRE,
    'LCA': (2.72, (0.0151, 0.0207, 0.0355)),
    'strut': (13.5, 0.000478),
}

REAR = {  # BMW_E90_DoubleWishbone.cpp, getLocation(), left side
    'SPINDLE': (0.0, 0.7493, 0.0),
    'UPRIGHT': (0.0, 0.6493, 0.0),
    'UCA_F': (0.14986, 0.4572, 0.0635),
    'UCA_B': (-0.0508, 0.40132, 0.11684),
    'UCA_U': (0.01397, 0.65024, 0.08636),
    'UCA_CM': (0.037676667, 0.50292, 0.0889),
    'LCA_F': (0.22352, 0.41148, -0.07874),
    'LCA_B': (-0.1778, 0.25908, -0.12446),
    'LCA_U': (-0.01778, 0.64389, -0.127),
    'LCA_CM': (0.009313333, 0.43815, -0.110066667),
    'SHOCK_C': (-0.09906, 0.508, 0.36576),
    'SHOCK_A': (-0.08382, 0.56388, -0.127),
    'SPRING_C': (-0.12446, 0.44704, 0.09906),
    'SPRING_A': (-0.11176, 0.46736, -0.17526),
    'TIEROD_C': (-0.2235, 0.25781, -0.04064),
    'TIEROD_U': (-0.1524, 0.65786, -0.04572),
}
REAR_PARTS = {
    'spindle': (14.705, 0.04117),
    'upright': (19.45, 0.1656),
    'wheel': (15.4, 0.673602),
    'tire': TYRE,
    'UCA': (5.813, (0.03, 0.03, 0.06276)),
    'LCA': (23.965, (0.4, 0.4, 0.8938)),
}
FRONT = {k: np.array(v) for k, v in FRONT.items()}
REAR = {k: np.array(v) for k, v in REAR.items()}
WHEEL_X = 0.54  # the wheel centre's front-view x in every file


def front_view(P: dict, p) -> np.ndarray:
    """x = Y - (Y_spindle - 0.54), z = Z."""
    return np.array([p[1] - P['SPINDLE'][1] + WHEEL_X, p[2]])


def bushing_axis(P: dict, arm: str) -> tuple[np.ndarray, np.ndarray]:
    """The arm's bushing axis (B -> F) as (the point nearest its ball joint, unit vector)."""
    B, F, U = P[f'{arm}_B'], P[f'{arm}_F'], P[f'{arm}_U']
    a = (F - B) / np.linalg.norm(F - B)
    return B + np.dot(U - B, a) * a, a


def along_axis(P: dict, arm: str, p) -> np.ndarray:
    """Front view of ``p`` moved along the arm's bushing axis to the ball joint's X."""
    _, a = bushing_axis(P, arm)
    return front_view(P, p + (P[f'{arm}_U'][0] - p[0]) / a[0] * a)


def arm_inertia_x(P: dict, arm: str, moments) -> float:
    """Inertia about X of principal ``moments`` in Chrono's arm frame (u along the bushing
    axis, w normal to the arm's plane, ChDoubleWishbone / ChMacPhersonStrut)."""
    F, B, U = P[f'{arm}_F'], P[f'{arm}_B'], P[f'{arm}_U']
    w = np.cross(B - U, F - U)
    w /= np.linalg.norm(w)
    u = (F - B) / np.linalg.norm(F - B)
    R = np.column_stack([u, np.cross(w, u), w])
    return float((R @ np.diag(moments) @ R.T)[0, 0])


def wheel_body(P: dict, parts: dict) -> tuple[float, float, np.ndarray]:
    """Upright + spindle + wheel + tyre: mass, inertia about X at the CG, CG."""
    m_hub = sum(parts[k][0] for k in ('spindle', 'wheel', 'tire'))
    m_up = parts['upright'][0]
    hub, up = front_view(P, P['SPINDLE']), front_view(P, P['UPRIGHT'])
    cg = (m_hub * hub + m_up * up) / (m_hub + m_up)
    inertia = (
        sum(parts[k][1] for k in ('spindle', 'upright', 'wheel', 'tire'))
        + m_hub * np.sum((hub - cg) ** 2)
        + m_up * np.sum((up - cg) ** 2)
    )
    return m_hub + m_up, inertia, cg


@pytest.fixture(scope='module')
def front():
    return load_mechanism('bmw_e90_front', suspension=True)


@pytest.fixture(scope='module')
def rear():
    return load_mechanism('bmw_e90_rear', suspension=True)


# ------------------------------------------------------------------ the data
def test_both_load_with_one_degree_of_freedom(front, rear):
    for mech, spring in ((front, 'strut_spring'), (rear, 'spring')):
        s = PlanarMultibodySolver(mech)  # refuses a linkage locking in ±0.1 m
        assert (s.n, s.m, s.dof) == (12, 11, 1)
        assert mech.independent == (('W', 'z'),) and mech.roles['spring'] == spring
        assert mech.travel == (-0.1, 0.1)


def test_the_front_is_the_shipped_strut_with_the_bmws_masses(front):
    """Geometry: every joint, marker and force of ``macpherson.toml``; masses: Chrono's
    parts with the 11.2 kg tyre, the arm and the strut halved (their radii of gyration
    kept)."""
    mp = load_mechanism('macpherson', suspension=True)
    assert front.joints == mp.joints and front.markers == mp.markers
    assert front.forces == mp.forces and front.loads == mp.loads
    assert [b.position for b in front.bodies if b.name != 'W'] == [
        b.position for b in mp.bodies if b.name != 'W'
    ]
    bodies = {b.name: b for b in front.bodies}
    m_W, I_W, cg = wheel_body(FRONT, FRONT_PARTS)
    assert bodies['W'].mass == pytest.approx(m_W, abs=1e-6)
    assert bodies['W'].inertia == pytest.approx(I_W, abs=1e-6)
    np.testing.assert_allclose(bodies['W'].position, cg, rtol=0, atol=1e-6)
    m_L, I_L = FRONT_PARTS['LCA'][0] / 2, arm_inertia_x(FRONT, 'LCA', FRONT_PARTS['LCA'][1]) / 2
    assert bodies['L'].mass == pytest.approx(m_L, abs=1e-9)
    assert bodies['L'].inertia == pytest.approx(I_L, abs=1e-6)
    assert bodies['R'].mass == pytest.approx(FRONT_PARTS['strut'][0] / 2, abs=1e-9)
    assert bodies['R'].inertia == pytest.approx(FRONT_PARTS['strut'][1] / 2, abs=1e-6)
    # the arm's radius of gyration is the one of macpherson.toml (Chrono's, any scale);
    # both files round inertias to 1e-6 kg m^2 (0.0080087 -> 0.008009 here: 6e-5 relative)
    mp_L = next(b for b in mp.bodies if b.name == 'L')
    assert bodies['L'].inertia / bodies['L'].mass == pytest.approx(
        mp_L.inertia / mp_L.mass, rel=1.5e-4
    )


def test_the_rear_is_chronos_double_a_arm_projected_along_the_bushing_axes(rear):
    joints = {j.name: j.point for j in rear.joints}
    markers = {m.name: m.point for m in rear.markers}
    bodies = {b.name: b for b in rear.bodies}
    close = dict(rtol=0, atol=1e-6)
    for arm, body in (('UCA', 'U'), ('LCA', 'L')):
        c, _ = bushing_axis(REAR, arm)
        np.testing.assert_allclose(joints[f'{body}-F'], along_axis(REAR, arm, c), **close)
        np.testing.assert_allclose(joints[f'W-{body}'], front_view(REAR, REAR[f'{arm}_U']), **close)
        np.testing.assert_allclose(
            bodies[body].position, along_axis(REAR, arm, REAR[f'{arm}_CM']), **close
        )
    seat = along_axis(REAR, 'LCA', REAR['SPRING_A'])
    np.testing.assert_allclose(markers['spring_seat'], seat, **close)
    shift = seat - front_view(REAR, REAR['SPRING_A'])
    np.testing.assert_allclose(
        markers['spring_mount'], front_view(REAR, REAR['SPRING_C']) + shift, **close
    )
    np.testing.assert_allclose(markers['wheel_centre'], [WHEEL_X, 0.0], **close)
    np.testing.assert_allclose(markers['contact_patch'], [WHEEL_X, -TYRE_RADIUS], **close)
    assert {m.name: m.body for m in rear.markers}['spring_seat'] == 'L'
    # masses: Chrono's parts with the 11.2 kg tyre, the arms halved
    m_W, I_W, cg = wheel_body(REAR, REAR_PARTS)
    assert bodies['W'].mass == pytest.approx(m_W, abs=1e-9)
    assert bodies['W'].inertia == pytest.approx(I_W, abs=1e-6)
    np.testing.assert_allclose(bodies['W'].position, cg, **close)
    for arm, body in (('UCA', 'U'), ('LCA', 'L')):
        m, moments = REAR_PARTS[arm]
        assert bodies[body].mass == pytest.approx(m / 2, abs=1e-9)
        assert bodies[body].inertia == pytest.approx(
            arm_inertia_x(REAR, arm, moments) / 2, abs=1e-6
        )


def moving_mass(mech) -> float:
    return sum(b.mass for b in mech.bodies if not b.fixed)


def corner_mass_mismatches(vehicle) -> list[tuple[str, float, float]]:
    """Axles whose low-fidelity wheel mass is not their mechanism's moving mass (to the
    0.1 kg the wheel masses are given to): (axle, wheel_mass, moving mass)."""
    out = []
    for axle in ('front', 'rear'):
        a = getattr(vehicle, axle)
        m = moving_mass(load_mechanism(a.mechanism, suspension=True))
        if abs(m - a.wheel_mass) > 0.05:
            out.append((axle, a.wheel_mass, m))
    return out


def test_moving_mass_is_the_full_cars_unsprung_mass(front, rear):
    """Spindle + upright + wheel + tyre + half of the arms (and of the strut), the sum
    ``suspopt/vehicles.py`` derives: the low-fidelity wheel mass up to its rounding."""
    full = full_car_defaults().vehicle
    assert (full.front.mechanism, full.rear.mechanism) == ('bmw_e90_front', 'bmw_e90_rear')
    for mech, parts, arms, axle, want in (
        (front, FRONT_PARTS, ('LCA', 'strut'), full.front, 60.782478),
        (rear, REAR_PARTS, ('UCA', 'LCA'), full.rear, 75.644),
    ):
        total = (
            sum(parts[k][0] for k in ('spindle', 'upright', 'wheel', 'tire'))
            + sum(parts[k][0] for k in arms) / 2
        )
        assert total == pytest.approx(want, abs=1e-6)  # the sum the headers document
        assert moving_mass(mech) == pytest.approx(want, abs=1e-6)
        assert axle.wheel_mass == round(want, 1), (mech.name, want, axle.wheel_mass)
    assert corner_mass_mismatches(full) == []


def test_a_corner_mass_mismatch_is_caught():
    """The full car as before this branch (the paper's 120 kg double wishbone on both
    axles, the BMW's 60.8 / 75.6 kg wheels in the low-fidelity model): both axles caught;
    the BMW's corners swapped between the axles: both caught too."""
    import dataclasses

    full = full_car_defaults().vehicle
    paper = dataclasses.replace(
        full,
        front=dataclasses.replace(full.front, mechanism='double_wishbone'),
        rear=dataclasses.replace(full.rear, mechanism='double_wishbone'),
    )
    assert [(a, m) for a, _, m in corner_mass_mismatches(paper)] == [
        ('front', 120.0),
        ('rear', 120.0),
    ]
    swapped = dataclasses.replace(
        full,
        front=dataclasses.replace(full.front, mechanism='bmw_e90_rear'),
        rear=dataclasses.replace(full.rear, mechanism='bmw_e90_front'),
    )
    assert [a for a, _, _ in corner_mass_mismatches(swapped)] == ['front', 'rear']


# ------------------------------------------------------------------ travel and statics
@pytest.mark.parametrize('name', ['bmw_e90_front', 'bmw_e90_rear'])
def test_the_design_travel_is_free_of_toggle(name):
    """Over the file's whole travel range (±0.1 m, 41 poses; the mixed model's trust
    region): every pose assembles, the dependent block of the constraint Jacobian keeps at
    least a third of its reference smallest singular value, no coordinate moves more than
    5 times faster per unit wheel travel than at the reference pose (the solver's own
    travel check refuses 100), the wheel centre follows the independent coordinate and
    the spring's motion ratio keeps its sign, away from 0."""
    mech = load_mechanism(name, suspension=True)
    s = PlanarMultibodySolver(mech)
    c = kinematic_curves(mech, mech.travel, points=41)
    np.testing.assert_allclose(c['travel'], np.linspace(*mech.travel, 41), rtol=0, atol=1e-12)
    q = s.positions((c['independent'] + s.q0[s.ind[0]])[:, None])
    assert np.max(np.abs(s.constraints(q))) < 1e-10
    sigma = np.linalg.svd(s.constraint_jacobian(q)[:, :, s.dep], compute_uv=False)[:, -1]
    sigma0 = np.linalg.svd(s.constraint_jacobian(s.q0[None])[0][:, s.dep], compute_uv=False)[-1]
    qd = s.velocities(q, np.ones((41, 1)))
    qd0 = s.velocities(s.q0[None], np.ones((1, 1)))[0]
    speed = np.max(np.abs(qd), axis=1) / np.max(np.abs(qd0))
    wheel = s.marker_names.index(mech.roles['wheel_marker'])
    w_z = s.marker_velocities(q, qd)[:, wheel, 1]
    print(
        f'\n{name} over {mech.travel} m: smallest singular value of C_q,dep '
        f'{sigma.min() / sigma0:.3f} of the reference, speed up to {speed.max():.2f} times, '
        f'dw/dz {w_z.min():.4f}..{w_z.max():.4f}, motion ratio '
        f'{c["motion_ratio"].min():.4f}..{c["motion_ratio"].max():.4f}'
    )
    assert np.min(sigma) > sigma0 / 3.0
    assert np.max(speed) < 5.0
    assert np.all((w_z > 0.8) & (w_z < 1.25))
    assert np.all(c['motion_ratio'] > 0.3) and np.all(c['motion_ratio'] < 1.5)


def corner_loads() -> dict[str, float]:
    """The default full car's static sprung weight on one wheel of each axle [N]."""
    v = full_car_defaults().vehicle
    a1, a2, g = v.front.axle_position, v.rear.axle_position, 9.81
    return {
        'bmw_e90_front': v.chassis_mass * g * -a2 / (a1 - a2) / 2,
        'bmw_e90_rear': v.chassis_mass * g * a1 / (a1 - a2) / 2,
    }


@pytest.mark.parametrize('name, axle', [('bmw_e90_front', 0), ('bmw_e90_rear', 1)])
def test_static_equilibrium_under_the_corner_load(name, axle):
    """The corner under its static load F (the default full car's sprung weight per
    wheel, 3.56 / 3.52 kN) at the contact patch, its spring at the default design's k_S
    and preloaded by F / MR (the mixed model's convention: gravity ignored, the reference
    pose is the static one). Route 1, the solver: the augmented solve at rest gives zero
    acceleration at the reference pose, and Brent's method on the independent coordinate
    finds the equilibria under 0.75 F and 1.25 F. Route 2, virtual work on the kinematic
    curves: the vertical force at the contact patch holding the wheel is dV/dw / (dz_patch/dw),
    dV/dw = (k s + f_p) s_w = -(k s + f_p) MR, the patch turning with the camber. The two
    agree; the equilibria lie inside the travel range, on the right sides (stable), the
    pins' reactions stay within a few times the load (no toggle amplification)."""
    from scipy.optimize import brentq

    mech = load_mechanism(name, suspension=True)
    s = PlanarMultibodySolver(mech)
    cfg = full_car_defaults()
    k = cfg.design.initial()[f'k_S{axle + 1}']
    F = corner_loads()[name]
    _, _, mr0 = reference_wheel_rate(mech, s)
    spring = mech.roles['spring']
    fp = -F / mr0  # tension: the spring pushes
    params = {spring: {'stiffness': k, 'damping': 0.0, 'preload': fp}}
    wheel = s.marker_names.index(mech.roles['wheel_marker'])

    def at_rest(z, load):
        q = s.positions(np.array([[z]]))
        Q = s.generalized_forces(q, np.array([[load]]), np.zeros_like(q), params)
        qdd, lam = s.solve_augmented(q, np.zeros_like(q), Q)
        return q, qdd, lam

    q0, qdd0, lam0 = at_rest(s.q0[s.ind[0]], F)
    assert np.max(np.abs(qdd0)) < 1e-9 * F  # the reference pose is the static one
    reactions = np.max(np.abs(s.joint_reactions(lam0, q0)))
    assert reactions < 2.0 * F, reactions / F  # 0.36 F (front), 1.05 F (rear)
    lo, hi = (s.q0[s.ind[0]] + t for t in mech.travel)
    c = kinematic_curves(mech, mech.travel, k=k, points=801)
    # the load acts at the contact patch, TYRE_RADIUS below the wheel centre on the
    # cambering wheel: z_patch = w + r (1 - cos phi), phi = -camber
    phi = -np.radians(c['camber'])
    patch_rate = 1.0 + TYRE_RADIUS * np.sin(phi) * np.gradient(phi, c['travel'])
    hold = -(k * c['spring_deflection'] + fp) * c['motion_ratio'] / patch_rate
    assert np.all(np.diff(hold) > 0.0)  # rising with the travel: stable
    assert hold[400] == pytest.approx(F, rel=1e-12)
    for factor in (0.75, 1.25):
        z = brentq(
            lambda z, factor=factor: at_rest(z, factor * F)[1][0, s.ind[0]], lo, hi, xtol=1e-14
        )
        q = at_rest(z, factor * F)[0]
        w1 = s.marker_positions(q)[0, wheel, 1] - s.marker_reference()[wheel, 1]
        w2 = np.interp(factor * F, hold, c['travel'])
        print(
            f'\n{name}: {factor:g} x {F:.0f} N: wheel travel {w1 * 1e3:+.3f} mm '
            f'(solver), {w2 * 1e3:+.3f} mm (virtual work)'
        )
        assert w1 == pytest.approx(w2, abs=2e-6)
        assert mech.travel[0] < w1 < mech.travel[1]
        assert (w1 > 0.0) == (factor > 1.0)


# ------------------------------------------------------------------ Chrono's 3D linkages
class Linkage3D:
    """Chrono's corner in 3D: the upright's pose ``x`` (rotation vector, displacement of
    the spindle point) from its reference; each ball joint on its circle about the arm's
    bushing axis, the tie rod's length, the strut (MacPherson: the upright's strut line
    through the top mount), the spindle's vertical travel ``w``."""

    def __init__(self, P: dict, arms: tuple[str, ...], strut: bool):
        self.P, self.arms, self.strut = P, arms, strut
        self.circles = {}
        for arm in arms:
            c, a = bushing_axis(P, arm)
            self.circles[arm] = (c, a, np.linalg.norm(P[f'{arm}_U'] - c))
        self.tierod = np.linalg.norm(P['TIEROD_U'] - P['TIEROD_C'])

    def move(self, x, p):
        R = Rotation.from_rotvec(x[:3]).as_matrix()
        return self.P['SPINDLE'] + x[3:] + R @ (p - self.P['SPINDLE'])

    def residual(self, x, w):
        P, r = self.P, []
        for arm, (c, a, radius) in self.circles.items():
            u = self.move(x, P[f'{arm}_U']) - c
            r += [a @ u, np.linalg.norm(u) - radius]
        if self.strut:
            e = Rotation.from_rotvec(x[:3]).as_matrix() @ (P['SPRING_C'] - P['SPRING_U'])
            e /= np.linalg.norm(e)
            d = P['SPRING_C'] - self.move(x, P['SPRING_U'])
            n1 = np.cross(e, [1.0, 0.0, 0.0])
            n1 /= np.linalg.norm(n1)
            r += [n1 @ d, np.cross(e, n1) @ d]
        r.append(np.linalg.norm(self.move(x, P['TIEROD_U']) - P['TIEROD_C']) - self.tierod)
        r.append(x[5] - w)
        return np.array(r)

    def pose(self, w, x=None):
        x = np.zeros(6) if x is None else x.copy()
        for _ in range(30):
            r = self.residual(x, w)
            if np.max(np.abs(r)) < 1e-13:
                return x
            J = np.empty((6, 6))
            for k in range(6):
                dx = np.zeros(6)
                dx[k] = 1e-7
                J[:, k] = (self.residual(x + dx, w) - self.residual(x - dx, w)) / 2e-7
            x = x - np.linalg.solve(J, r)
        raise AssertionError(f'3D linkage: no pose at travel {w}')

    def spring_length(self, x):
        P = self.P
        if self.strut:
            return np.linalg.norm(P['SPRING_C'] - self.move(x, P['SPRING_U']))
        c, a, _ = self.circles['LCA']
        u0, u = P['LCA_U'] - c, self.move(x, P['LCA_U']) - c
        turn = Rotation.from_rotvec(np.arctan2(np.cross(u0, u) @ a, u0 @ u) * a).as_matrix()
        return np.linalg.norm(P['SPRING_C'] - (c + turn @ (P['SPRING_A'] - c)))

    def curves(self, travels, h=1e-5):
        out = {'motion_ratio': [], 'camber': [], 'track_change': []}
        x = np.zeros(6)
        patch = self.P['SPINDLE'] - [0.0, 0.0, TYRE_RADIUS]
        for w in travels:
            x = self.pose(w, x)
            up, down = self.pose(w + h, x), self.pose(w - h, x)
            out['motion_ratio'].append(
                -(self.spring_length(up) - self.spring_length(down)) / (2 * h)
            )
            spin = Rotation.from_rotvec(x[:3]).as_matrix() @ [0.0, 1.0, 0.0]
            out['camber'].append(-np.degrees(np.arcsin(spin[2])))  # + top outboard (left)
            out['track_change'].append((self.move(x, patch) - patch)[1])
        return {k: np.array(v) for k, v in out.items()}


TRAVELS = np.linspace(-0.08, 0.08, 5)
#: how far the planar curves may stray from the 3D linkage's over ±80 mm (the front view
#: drops the caster, the upright's pitch and toe): motion ratio (relative), camber [deg],
#: track change [m]
AGREE = {'motion_ratio': 0.07, 'camber': 0.6, 'track_change': 2.5e-3}


def differences(planar: dict, spatial: dict) -> dict[str, float]:
    return {
        'motion_ratio': float(
            np.max(np.abs(planar['motion_ratio'] / spatial['motion_ratio'] - 1.0))
        ),
        'camber': float(np.max(np.abs(planar['camber'] - spatial['camber']))),
        'track_change': float(np.max(np.abs(planar['track_change'] - spatial['track_change']))),
    }


@pytest.mark.parametrize(
    'name, P, arms, strut',
    [('bmw_e90_front', FRONT, ('LCA',), True), ('bmw_e90_rear', REAR, ('UCA', 'LCA'), False)],
)
def test_planar_curves_follow_chronos_3d_linkage(name, P, arms, strut):
    spatial = Linkage3D(P, arms, strut).curves(TRAVELS)
    planar = kinematic_curves(name, (TRAVELS[0], TRAVELS[-1]), points=len(TRAVELS))
    np.testing.assert_allclose(planar['travel'], TRAVELS, rtol=0, atol=1e-12)
    err = differences(planar, spatial)
    print(
        f"\n{name} against Chrono's 3D linkage over ±80 mm: motion ratio "
        f'{err["motion_ratio"]:.1%}, camber {err["camber"]:.2f} deg, track change '
        f'{err["track_change"] * 1e3:.2f} mm'
    )
    for k, tol in AGREE.items():
        assert err[k] < tol, (k, err[k])


def test_the_plain_projection_would_miss_the_rears_3d_motion_ratio(rear):
    """The rear with ``macpherson.toml``'s projection (X dropped; the pivots at the points
    of the bushing axes nearest the ball joints): its spring's motion ratio is 40 % below
    Chrono's 3D linkage's and its camber curve of the wrong sign in rebound: why the rear
    file projects along the bushing axes."""
    import dataclasses

    plain_pivot = {
        f'{b}-F': front_view(REAR, bushing_axis(REAR, arm)[0])
        for arm, b in (('UCA', 'U'), ('LCA', 'L'))
    }
    joints = tuple(
        dataclasses.replace(j, point=tuple(plain_pivot[j.name])) if j.name in plain_pivot else j
        for j in rear.joints
    )
    ends = {'spring_mount': REAR['SPRING_C'], 'spring_seat': REAR['SPRING_A']}
    markers = tuple(
        Marker(m.name, m.body, tuple(front_view(REAR, ends[m.name]))) if m.name in ends else m
        for m in rear.markers
    )
    plain = dataclasses.replace(rear, joints=joints, markers=markers)
    spatial = Linkage3D(REAR, ('UCA', 'LCA'), False).curves(TRAVELS)
    c = kinematic_curves(plain, (TRAVELS[0], TRAVELS[-1]), points=len(TRAVELS))
    assert np.all(c['motion_ratio'] < 0.7 * spatial['motion_ratio'])
    assert c['camber'][0] > 1.0 > 0.0 > spatial['camber'][0]


def test_kinematic_curves_are_sane_over_80_mm(front, rear):
    """Motion ratio, wheel rate (at Chrono's own springs), camber and track change at
    -80 ... 80 mm: a strut whose motion ratio rises through 1 with bump; a rear whose
    spring's stays near its reference value; both wheels' rates positive, camber within
    2 deg, the tyre's lateral scrub within 16 mm; the rear spring within Chrono's
    ±0.05 m of travel between its stops."""
    table = {}
    for mech, k in ((front, 29770.0), (rear, 37130.0)):
        c = kinematic_curves(mech, (-0.08, 0.08), k=k, points=5)
        table[mech.name] = c
        print(f'\n{mech.name} (spring {k:g} N/m):')
        for i in range(5):
            print(
                f'  {c["travel"][i] * 1e3:+5.0f} mm: motion ratio {c["motion_ratio"][i]:.4f}, '
                f'wheel rate {c["wheel_rate"][i] * 1e-3:.3f} N/mm, camber '
                f'{c["camber"][i]:+.3f} deg, track {c["track_change"][i] * 1e3:+.2f} mm'
            )
        assert np.all(c['wheel_rate'] > 0.0)
        assert np.max(np.abs(c['camber'])) < 2.0
        assert np.max(np.abs(c['track_change'])) < 0.016
        assert np.all(np.diff(c['spring_deflection']) < 0.0)  # bump compresses it
    f, r = table[front.name], table[rear.name]
    assert 0.85 < f['motion_ratio'][0] < f['motion_ratio'][2] < 1.0 < f['motion_ratio'][-1] < 1.15
    assert np.all(np.abs(r['motion_ratio'] / r['motion_ratio'][2] - 1.0) < 0.05)
    assert np.max(np.abs(r['spring_deflection'])) < 0.05
    # the wheel rate at the reference pose: the spring's rate times the motion ratio squared
    for mech in (front, rear):
        a, b, mr = reference_wheel_rate(mech)
        assert a == pytest.approx(mr**2, rel=1e-12) and b == 0.0


# ------------------------------------------------------------------ Exudyn
#: the corners typed in from their files' numbers: body -> (mass, inertia, CG); pins
#: (body, body or 'ground', point); the strut (prismatic R-W: point, top mount) or None;
#: the spring (chassis end on the ground, linkage end and its body); contact patch;
#: spring rate, damping, tyre pulse peak
EX_FRONT = {
    'bodies': {
        'W': (52.672478, 1.378589, (0.514351, 0.0)),
        'L': (1.36, 0.008009, (0.301113, -0.098425)),
        'R': (6.75, 0.000239, (0.370328, 0.23368)),
    },
    'pins': [
        ('L', 'ground', (0.159096, -0.115752)),
        ('L', 'W', (0.452878, -0.10414)),
        ('R', 'ground', (0.330958, 0.46863)),
    ],
    'strut': ((0.409698, -0.00127), (0.330958, 0.46863)),
    'spring': ((0.330958, 0.46863), 'W', (0.409698, -0.00127)),
    'name': 'strut_spring',
    'k': 29770.0,
    'c': 1500.0,
    'peak': 1500.0,
}
EX_REAR = {
    'bodies': {
        'W': (60.755, 1.508593, (0.507986, 0.0)),
        'U': (2.9065, 0.015959, (0.287018, 0.095202)),
        'L': (11.9825, 0.204613, (0.218561, -0.113153)),
    },
    'pins': [
        ('W', 'U', (0.44094, 0.08636)),
        ('W', 'L', (0.43459, -0.127)),
        ('U', 'ground', (0.210057, 0.099623)),
        ('L', 'ground', (0.110547, -0.10623)),
    ],
    'strut': None,
    'spring': ((0.273429, 0.109767), 'L', (0.293749, -0.164553)),
    'name': 'spring',
    'k': 37130.0,
    'c': 1500.0,
    'peak': 800.0,
}
EX_T_END = 0.3


def pulse(peak: float):
    return lambda t: peak * math.sin(math.pi * t / T_PULSE) ** 2 if t < T_PULSE else 0.0


def run_exudyn_corner(corner: dict) -> dict:
    """Exudyn (as ``test_multibody_exudyn.run_exudyn_macpherson``): ObjectRigidBody2D
    bodies, ObjectJointRevolute2D pins, an ObjectJointPrismatic2D strut,
    ObjectConnectorSpringDamper from the ground to the linkage (reference length the
    reference distance), the tyre pulse on W at the contact patch; implicit trapezoidal
    rule (index 2), step 1e-4 s."""
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddObject(ObjectGround())
    nodes, objs, cg = {}, {'ground': ground}, {ground: (0.0, 0.0)}
    for name, (m, J, pos) in corner['bodies'].items():
        nodes[name] = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[pos[0], pos[1], 0.0]))
        objs[name] = mbs.AddObject(RigidBody2D(nodeNumber=nodes[name], mass=m, inertia=J))
        cg[objs[name]] = pos

    def marker(name, p, rigid=False):
        b = objs[name]
        kind = MarkerBodyRigid if rigid else MarkerBodyPosition
        return mbs.AddMarker(
            kind(bodyNumber=b, localPosition=[p[0] - cg[b][0], p[1] - cg[b][1], 0.0])
        )

    pins = [
        mbs.AddObject(RevoluteJoint2D(markerNumbers=[marker(a, p), marker(b, p)]))
        for a, b, p in corner['pins']
    ]
    if corner['strut']:
        seat, top = corner['strut']
        axis = np.subtract(top, seat) / np.hypot(*np.subtract(top, seat))
        mbs.AddObject(
            PrismaticJoint2D(
                markerNumbers=[marker('R', seat, True), marker('W', seat, True)],
                axisMarker0=[axis[0], axis[1], 0.0],
                normalMarker1=[-axis[1], axis[0], 0.0],
                constrainRotation=True,
            )
        )
    chassis_end, body, linkage_end = corner['spring']
    spring = mbs.AddObject(
        SpringDamper(
            markerNumbers=[marker('ground', chassis_end), marker(body, linkage_end)],
            referenceLength=float(np.hypot(*np.subtract(linkage_end, chassis_end))),
            stiffness=corner['k'],
            damping=corner['c'],
        )
    )
    force = pulse(corner['peak'])
    mbs.AddLoad(
        LoadForceVector(
            markerNumber=marker('W', (0.54, -0.3186)),
            loadVector=[0, 1, 0],
            loadVectorUserFunction=lambda mbs, t, lv: [0.0, force(t), 0.0],
        )
    )
    out = exu.OutputVariableType
    sensors = {
        'W': mbs.AddSensor(
            SensorNode(
                nodeNumber=nodes['W'], storeInternal=True, outputVariableType=out.Displacement
            )
        ),
        'W_phi': mbs.AddSensor(
            SensorNode(nodeNumber=nodes['W'], storeInternal=True, outputVariableType=out.Rotation)
        ),
        'spring': mbs.AddSensor(
            SensorObject(objectNumber=spring, storeInternal=True, outputVariableType=out.ForceLocal)
        ),
    }
    for k, j in enumerate(pins):
        sensors[k] = mbs.AddSensor(
            SensorObject(objectNumber=j, storeInternal=True, outputVariableType=out.Force)
        )
    return solve_exudyn(mbs, sensors, EX_T_END)


@pytest.mark.parametrize('name, corner', [('bmw_e90_front', EX_FRONT), ('bmw_e90_rear', EX_REAR)])
def test_corner_matches_exudyn(name, corner):
    ex = run_exudyn_corner(corner)
    s = PlanarMultibodySolver(load_mechanism(name, suspension=True))
    params = {corner['name']: {'stiffness': corner['k'], 'damping': corner['c']}}
    force = pulse(corner['peak'])
    tr = simulate_mechanism(
        s,
        (0.0, EX_T_END),
        [s.q0[1]],
        [0.0],
        t_eval=ex['W'][:, 0],
        max_step=0.02,
        rtol=1e-8,
        atol=1e-10,
        loads=lambda t, q, qd: np.array([force(t)]),
        params=params,
    )
    np.testing.assert_allclose(tr.t, ex['W'][:, 0], atol=1e-9)
    x0 = corner['bodies']['W'][2][0]
    z, phi = tr.q[:, 1], tr.q[:, 2]
    amp, phi_amp = np.max(np.abs(z)), np.max(np.abs(phi))
    assert 0.02 < amp < 0.06 and phi_amp > 1e-3  # it moved, and turned
    err = {
        'z': np.max(np.abs(z - ex['W'][:, 2])) / amp,
        'x': np.max(np.abs(tr.q[:, 0] - x0 - ex['W'][:, 1])) / amp,
        'phi': np.max(np.abs(phi - ex['W_phi'][:, -1])) / phi_amp,
    }
    f = s.spring(corner['name'], tr.q, tr.qd, params).force
    err['spring tension'] = np.max(np.abs(f - ex['spring'][:, 1])) / np.max(np.abs(f))
    R = s.joint_reactions(tr.lam, tr.q)
    names = [j.name for j in s.mechanism.joints]
    scale = np.max(np.abs(R))
    for k, (a, b, _) in enumerate(corner['pins']):
        j = names.index(f'{a}-{"F" if b == "ground" else b}')
        err[names[j]] = np.max(np.abs(R[:, j] - ex[k][:, 1:3])) / scale
    print(
        f'\n{name} against Exudyn: wheel z amplitude {amp * 1e3:.2f} mm, upright rotation '
        f'{phi_amp:.2e} rad, reactions up to {scale:.0f} N; max differences (of each '
        'amplitude): ' + ', '.join(f'{k} {v:.1e}' for k, v in err.items())
    )
    for k, v in err.items():
        assert v < 1e-5, (k, v)


# ------------------------------------------------------------------ the full car
@pytest.mark.slow
def test_default_full_car_with_the_bmw_corners_verifies():
    """The default full car (BMW E90, its own corners, anti-roll bars) in the mixed model
    over 1 s of its ISO 8608 road on the automatic grid: collocation, verified by time
    marching."""
    import time

    from suspopt.spec.load import config_from_dict
    from suspopt.studies.run import evaluate
    from suspopt.transcription.vehicle import multibody_modules

    d = full_car_defaults().to_dict()
    d['maneuver']['horizon'] = 1.0
    cfg = config_from_dict(d)
    assert cfg.transcription.segments == 'auto'
    assert list(multibody_modules(cfg)) == ['bmw_e90_front', 'bmw_e90_rear']
    t0 = time.perf_counter()
    rec = evaluate(cfg, 'mixed', verify=True)
    wall = time.perf_counter() - t0
    v = rec.verification
    print(
        f'\nfull car, BMW corners, 1 s: f = {rec.objective:.6g} by collocation, '
        f'verification {v}, wall time {wall:.1f} s'
    )
    assert rec.success and rec.verified is True, v
    assert rec.max_constraint_residual_m < 1e-10
    J = rec.terms
    assert J['roll'] > 0.0 and np.isfinite(list(J.values())).all()
