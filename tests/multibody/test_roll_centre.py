"""Kinematic roll centre and wheel-rate curves of suspopt.multibody.kinematics against
constructions that share no code with the multibody solver.

* The paper's double wishbone, a parallelogram of arm length ``L``: the upright
  translates on the arms' arc, so the contact patch moves along ``(-sin α, cos α)``
  (``sin α = w / L``) and its normal through the patch meets the centre line at the
  height ``-(x_P - x_c) tan α`` above the ground: at ground level at the reference pose
  (arms level), above it in droop, below in bump.
* The short-long-arm double wishbone: positions by intersecting circles (each arm's tip
  on its circle, the upright rigid between the tips), the instant centre as the
  intersection of the two arm lines, the roll centre as the intersection of the line from
  the contact patch through it with the centre line.
* The MacPherson strut, by the classic construction: the instant centre is the
  intersection of the lower arm's line with the line through the top mount perpendicular
  to the strut; positions from the lower arm's angle and the upright's rotation that puts
  the top mount on the strut axis (scalar root finding).
* The wheel rate and wheel force of the double wishbone with a bump stop, against the
  closed form ``K = F'(m w) m²``, ``F_w = F(m w) m`` (``m`` the constant motion ratio).

The linkages' numbers are typed in here from their files (docs/model.md, the files' headers).
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from mechanisms import raw
from scipy.optimize import brentq

from suspopt.errors import ConfigError
from suspopt.multibody.kinematics import kinematic_curves
from suspopt.multibody.mechanism import mechanism_from_dict

TRAVEL = np.linspace(-0.09, 0.09, 7)


def rot(psi: float, v) -> np.ndarray:
    c, s = math.cos(psi), math.sin(psi)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def line_intersection(p1, d1, p2, d2) -> np.ndarray:
    """Where ``p1 + s d1`` meets ``p2 + t d2``."""
    s, _ = np.linalg.solve(np.column_stack([d1, -np.asarray(d2)]), np.subtract(p2, p1))
    return np.asarray(p1) + s * np.asarray(d1)


def roll_centre_height(patch, ic, x_c: float) -> float:
    """The line from the contact patch through the instant centre at ``x = x_c``, above
    the patch."""
    d = np.subtract(ic, patch)
    return d[1] * (x_c - patch[0]) / d[0]


# ---------------------------------------------------------------- parallelogram
def test_parallel_equal_arms_roll_centre_closed_form():
    L, x_p = 0.45 - 0.12, 0.54
    c = kinematic_curves('double_wishbone', (-0.09, 0.09), points=7)
    alpha = np.arcsin(c['travel'] / L)
    P_x = x_p + L * (np.cos(alpha) - 1.0)
    np.testing.assert_allclose(c['roll_centre_height'], -(P_x - 0.0) * np.tan(alpha), atol=1e-12)
    assert abs(c['roll_centre_height'][3]) < 1e-15  # ground level at the reference pose
    assert c['centre_line'] == 0.0 and np.all(np.isinf(c['instant_centre']))
    # the centre line moves the height in proportion to the half track
    c2 = kinematic_curves('double_wishbone', (-0.09, 0.09), points=7, centre_line=-0.2)
    np.testing.assert_allclose(c2['roll_centre_height'], -(P_x + 0.2) * np.tan(alpha), atol=1e-12)


# ---------------------------------------------------------------- SLA double wishbone
SLA = {
    'upper': ((0.22, 0.18), (0.45, 0.2)),  # chassis pivot, ball joint on the upright
    'lower': ((0.10, -0.22), (0.45, -0.2)),
    'centre': (0.54, 0.0),
    'patch': (0.54, -0.38),
}


def circle_intersection(c1, r1, c2, r2, near) -> np.ndarray:
    d = np.subtract(c2, c1)
    dist = math.hypot(*d)
    a = (r1**2 - r2**2 + dist**2) / (2 * dist)
    h = math.sqrt(r1**2 - a**2)
    base = np.asarray(c1) + a * d / dist
    perp = np.array([-d[1], d[0]]) / dist
    cands = [base + h * perp, base - h * perp]
    return min(cands, key=lambda p: math.hypot(*(p - np.asarray(near))))


def sla_pose(theta: float):
    """The upright's pose at the lower arm's rotation ``theta`` from the reference:
    (its rotation, a function mapping reference points of the upright to current ones,
    the ball joints)."""
    (AU, BU0), (AL, BL0) = SLA['upper'], SLA['lower']
    BL = np.asarray(AL) + rot(theta, np.subtract(BL0, AL))
    BU = circle_intersection(
        AU, math.dist(AU, BU0), BL, math.dist(BU0, BL0), near=np.add(BU0, BL - BL0)
    )
    u0, u = np.subtract(BU0, BL0), BU - BL
    psi = math.atan2(u[1], u[0]) - math.atan2(u0[1], u0[0])
    return psi, (lambda p: BL + rot(psi, np.subtract(p, BL0))), (BU, BL)


def sla_at_travel(w: float):
    def miss(theta):
        return sla_pose(theta)[1](SLA['centre'])[1] - SLA['centre'][1] - w

    theta = brentq(miss, -0.6, 0.6, xtol=1e-15)
    return sla_pose(theta)


def test_sla_roll_centre_from_the_arm_lines():
    c = kinematic_curves('sla_double_wishbone', (-0.09, 0.09), points=7)
    (AU, _), (AL, _) = SLA['upper'], SLA['lower']
    heights, ics = [], []
    for w in c['travel']:
        _, move, (BU, BL) = sla_at_travel(w)
        ic = line_intersection(AU, BU - AU, AL, BL - AL)
        patch = move(SLA['patch'])
        heights.append(roll_centre_height(patch, ic, 0.0))
        ics.append(ic)
    np.testing.assert_allclose(c['instant_centre'], ics, rtol=1e-9)
    np.testing.assert_allclose(c['roll_centre_height'], heights, atol=1e-10)
    assert np.ptp(heights) > 0.1  # it migrates


# ---------------------------------------------------------------- MacPherson
MP = {
    'pivot': (0.159096, -0.115752),
    'ball': (0.452878, -0.10414),
    'top': (0.330958, 0.46863),
    'seat': (0.409698, -0.00127),
    'centre': (0.54, 0.0),
    'patch': (0.54, -0.3186),
    'centre_line': -0.210062,  # the file's projection: x = Y - 0.210062 (Chrono's Y = 0)
}


def mp_pose(theta: float):
    """The lower arm turned by ``theta``; the upright (ball joint on the arm, the strut
    axis fixed in it through the seat) turned by the ψ that puts the top mount on the
    strut axis: (ψ, a map of the upright's reference points, the ball joint, the axis)."""
    P, B0, T, S0 = (np.asarray(MP[k]) for k in ('pivot', 'ball', 'top', 'seat'))
    a0 = (T - S0) / np.linalg.norm(T - S0)
    B = P + rot(theta, B0 - P)

    def off_axis(psi):
        S, a = B + rot(psi, S0 - B0), rot(psi, a0)
        return a[0] * (T - S)[1] - a[1] * (T - S)[0]

    psi = brentq(off_axis, -0.5, 0.5, xtol=1e-15)
    return psi, (lambda p: B + rot(psi, np.subtract(p, B0))), B, rot(psi, a0)


def test_macpherson_roll_centre_by_the_classic_construction():
    c = kinematic_curves('macpherson', (-0.09, 0.09), points=7)
    assert c['centre_line'] == MP['centre_line']
    heights, ics = [], []
    for w in c['travel']:

        def miss(theta, w=w):
            return mp_pose(theta)[1](MP['centre'])[1] - MP['centre'][1] - w

        _, move, B, axis = mp_pose(brentq(miss, -0.8, 0.8, xtol=1e-15))
        top = np.asarray(MP['top'])
        ic = line_intersection(MP['pivot'], B - MP['pivot'], top, [-axis[1], axis[0]])
        heights.append(roll_centre_height(move(MP['patch']), ic, MP['centre_line']))
        ics.append(ic)
    np.testing.assert_allclose(c['instant_centre'], ics, rtol=1e-9)
    np.testing.assert_allclose(c['roll_centre_height'], heights, atol=1e-10)
    # a low roll centre at ride height that drops fast in bump (a strut's)
    assert abs(heights[3]) < 0.02 and heights[0] > 0.2 and heights[-1] < -0.3


def test_centre_line_must_be_inboard_of_the_patch():
    data = raw('double_wishbone')
    data['suspension']['centre_line'] = 0.6
    with pytest.raises(ConfigError, match=r'suspension\.centre_line: the centre line must be'):
        mechanism_from_dict(data, suspension=True)


# ---------------------------------------------------------------- wheel rate, bump stop
def test_wheel_rate_with_a_bump_stop_is_the_closed_form():
    """The parallelogram's spring compression is ``m w`` exactly (``m = 0.15/0.33``), so
    the wheel force is ``m F(m w)`` and the wheel rate ``m² F'(m w)``; the rate rises
    smoothly (C¹ force) from the stop's contact at ``w = gap / m``."""
    k, k3, gap, b2, b3 = 30000.0, 2.0e6, 0.02, 4.0e6, 6.0e7
    data = copy.deepcopy(raw('double_wishbone'))
    for f in data['forces']:
        if f['name'] == 'spring':
            del f['stiffness']
            f['spring_curve'] = {'coefficients': [k, 0.0, k3]}
            f['bump_stop'] = {'gap': gap, 'coefficients': [b2, b3]}
    c = kinematic_curves(mechanism_from_dict(data, suspension=True), (-0.09, 0.09), points=37)
    m = 0.15 / 0.33
    x = m * c['travel']
    d = np.maximum(x - gap, 0.0)
    F = k * x + k3 * x**3 + b2 * d**2 + b3 * d**3
    dF = k + 3 * k3 * x**2 + 2 * b2 * d + 3 * b3 * d**2
    np.testing.assert_allclose(c['wheel_force'], m * F, rtol=1e-10, atol=1e-9)
    np.testing.assert_allclose(c['wheel_rate'], m**2 * dF, rtol=1e-10)
    assert c['spring_rate'] == k
    contact = c['travel'] > gap / m
    assert contact.any() and (~contact).any()
    assert np.all(np.diff(c['wheel_rate'][contact]) > 0)
    # k given: replaces the curve's k_S
    c2 = kinematic_curves(mechanism_from_dict(data, suspension=True), (-0.05, 0.0), k=20000.0)
    assert c2['spring_rate'] == 20000.0
