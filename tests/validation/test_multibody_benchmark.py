"""Textbook benchmark: Andrews' squeezing mechanism (seven bodies, one closed-loop DOF).

Source of the problem data and of the reference solution:

* E. Hairer, G. Wanner, *Solving Ordinary Differential Equations II*, 2nd ed., Springer
  1996, Sect. VII.7 ("Andrews' squeezing mechanism"; from W. Schiehlen (ed.), *Multibody
  Systems Handbook*, Springer 1990, problem by Giles/Manning and Andrews).
* F. Mazzia, C. Magherini et al., *Test Set for IVP Solvers* (University of Bari),
  problem ``andrews`` (file ``andrews.f``, $Id: andrews.F,v 1.2 2006/10/02$, also
  distributed in the R package deTestSet as ``ex_andrews``; IFToMM benchmark A03 is the
  same mechanism). Its ``SOLN`` gives y(t = 0.03 s), computed with PSIDE at rtol = atol =
  1e-14 (Cray C90): the 7 angles y1..y7, their rates y8..y14, accelerations y15..y21 and
  the 6 loop-closure multipliers y22..y27 (16 digits each, copied below).

The published model uses 7 *relative* angles (β, Θ, γ, Φ, δ, Ω, ε) and 6 loop-closure
equations. Here it is rebuilt with *absolute* body coordinates and 10 revolute joints:

    body 1 crank (about O = 0, angle β), body 2 (angle β + Θ, pinned to 1 at R),
    body 3 (about B, angle γ), body 4 (angle Φ + δ), body 5 (about A, angle δ),
    body 6 (angle Ω + ε), body 7 (about A, angle ε); bodies 2, 3, 4 and 6 meet at E
    (three joints 2-3, 2-4, 2-6 at E); 4-5 at F = A + zt (cos δ, sin δ);
    6-7 at G = A + u (sin ε, -cos ε).

Centres of gravity are placed as the published mass matrix implies (body 1 at ra from O,
body 2 at da from R towards E, body 4 at ea from E, body 6 at fa from E; bodies 3, 5 and 7
rotate about fixed pivots, so only the distance of their CG matters:
sqrt(sa² + sb²), sqrt(ta² + tb²), sqrt(ua² + ub²)). The spring c0 (free length l0) between
D on body 3 and the fixed point C is a ``spring_damper`` element of the mechanism, between
a marker on body 3 and one on the ground; the driving torque mom on the crank is applied
through the ``forces`` callback of :func:`simulate_mechanism`.

The loop-closure equations g1..g6 of the test set are exactly ``p_E(2) - p_E(3)``,
``p_E(2) - p_E(4)``, ``p_E(2) - p_E(6)``, i.e. this file's joints E23, E24, E26 with body 2
first, so their multipliers are directly comparable with y22..y27.

Tolerances: the reference is accurate to ~1e-10 or better in the angles; the checks allow
1e-7 rad on the angles (measured ~1.5e-9 with the default rtol = 1e-10), 1e-7 relative on
the rates (measured ~4e-10), 1e-6 relative on accelerations and multipliers (measured
~1e-7: index-3 algebraic quantities, the least accurate part of the reference).
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from suspopt.multibody.mechanism import Body, Marker, Mechanism, RevoluteJoint, SpringDamper
from suspopt.multibody.simulate import simulate_mechanism
from suspopt.multibody.solver import PlanarMultibodySolver

# ----------------------------------------------------------------- published data (Bari)
M = [0.04325, 0.00365, 0.02373, 0.00706, 0.07050, 0.00706, 0.05498]
I = [2.194e-6, 4.410e-7, 5.255e-6, 5.667e-7, 1.169e-5, 5.667e-7, 1.912e-5]
XA, YA, XB, YB, XC, YC = -0.06934, -0.00227, -0.03635, 0.03273, 0.014, 0.072
C0, D, DA, E_, EA, RR, RA, L0 = 4530.0, 28e-3, 115e-4, 2e-2, 1421e-5, 7e-3, 92e-5, 7785e-5
SS, SA, SB, SC, SD, TA, TB = 35e-3, 1874e-5, 1043e-5, 18e-3, 2e-2, 2308e-5, 916e-5
U_, UA, UB, ZF, ZT, FA, MOM = 4e-2, 1228e-5, 449e-5, 2e-2, 4e-2, 1421e-5, 33e-3

#: consistent initial angles (β, Θ, γ, Φ, δ, Ω, ε) at t = 0, velocities zero
Q0 = [
    -0.0617138900142764496358948458001,
    0.0,
    0.455279819163070380255912382449,
    0.222668390165885884674473185609,
    0.487364979543842550225598953530,
    -0.222668390165885884674473185609,
    1.23054744454982119249735015568,
]
#: initial multipliers of g1, g2 (the others are 0), from the test set's INIT
LAM0 = [98.56687039624108960576549821700, -6.12268834425566265503114393122]

#: reference solution at t = 0.03 s (Test Set for IVP Solvers, andrews.f, SOLN)
REF_Q = np.array(
    [
        0.1581077119629904e2,
        -0.1575637105984298e2,
        0.4082224013073101e-1,
        -0.5347301163226948e0,
        0.5244099658805304e0,
        0.5347301163226948e0,
        0.1048080741042263e1,
    ]
)
REF_V = np.array(
    [
        0.1139920302151208e4,
        -0.1424379294994111e4,
        0.1103291221937134e2,
        0.1929337464421385e2,
        0.5735699284790808e0,
        -0.1929337464421385e2,
        0.3231791658026955e0,
    ]
)
REF_A = np.array(
    [
        -0.2463176316945196e5,
        0.5185037701610329e5,
        0.3241025686413781e6,
        0.5667493645176213e6,
        0.1674362929479361e5,
        -0.5667493645176222e6,
        0.9826520791458422e4,
    ]
)
REF_LAM = np.array(
    [
        0.1991753333731910e3,
        -0.2975531228015052e2,
        0.2306654119098399e2,
        0.3145271365475927e2,
        0.2264249232082739e2,
        0.1161740700019673e2,
    ]
)
T_END = 0.03


def _e(a):  # unit vector along angle a
    return np.array([math.cos(a), math.sin(a)])


def _p(a):  # the test set's (sin a, -cos a)
    return np.array([math.sin(a), -math.cos(a)])


def build_andrews():
    """Mechanism (absolute coordinates, the spring as an element) and its solver."""
    be, th, ga, ph, de, om, ep = Q0
    O, A, B = np.zeros(2), np.array([XA, YA]), np.array([XB, YB])
    R = RR * _e(be)
    E = R - D * _e(be + th)
    F = A + ZT * _e(de)
    G = A + U_ * _p(ep)
    # the published initial angles close all three loops at E
    assert np.allclose(E, B + SS * _p(ga), atol=1e-12)
    assert np.allclose(E, F + E_ * _p(ph + de), atol=1e-12)
    assert np.allclose(E, G + ZF * _e(om + ep), atol=1e-12)
    ang = [be, be + th, ga, ph + de, de, om + ep, ep]
    cg = [
        RA * _e(be),
        R - DA * _e(be + th),
        B + math.hypot(SA, SB) * _e(ga),
        F + (E_ - EA) * _p(ph + de),
        A + math.hypot(TA, TB) * _e(de),
        G + (ZF - FA) * _e(om + ep),
        A + math.hypot(UA, UB) * _e(ep),
    ]
    names = [f'K{i + 1}' for i in range(7)]
    bodies = tuple(
        Body(names[i], M[i], I[i], (float(cg[i][0]), float(cg[i][1])), ang[i]) for i in range(7)
    )

    def J(name, a, b, p):
        return RevoluteJoint(name, (a, b), (float(p[0]), float(p[1])))

    joints = (
        J('O', 'K1', 'ground', O),
        J('R', 'K1', 'K2', R),
        J('E23', 'K2', 'K3', E),
        J('E24', 'K2', 'K4', E),
        J('E26', 'K2', 'K6', E),
        J('B', 'K3', 'ground', B),
        J('A5', 'K5', 'ground', A),
        J('A7', 'K7', 'ground', A),
        J('F', 'K4', 'K5', F),
        J('G', 'K6', 'K7', G),
    )
    # spring point D = B + (sd cos γ + sc sin γ, sd sin γ - sc cos γ) on body 3; C fixed
    Dp = B + SD * _e(ga) + SC * _p(ga)
    markers = (Marker('D', 'K3', (float(Dp[0]), float(Dp[1]))), Marker('C', 'ground', (XC, YC)))
    spring = SpringDamper('c0', ('C', 'D'), stiffness=C0, free_length=L0)
    mech = Mechanism(
        'Andrews squeezing mechanism',
        bodies,
        joints,
        markers=markers,
        independent=(('K1', 'phi'),),
        forces=(spring,),
    )
    return mech, PlanarMultibodySolver(mech)


def make_forces(solver):
    def forces(t, q, qd):  # driving torque on the crank (body 1)
        Q = np.zeros(solver.n)
        Q[2] = MOM
        return Q

    return forces


def relative(a):
    """Absolute body angles -> the published relative angles (β, Θ, γ, Φ, δ, Ω, ε)."""
    phi = a[..., 2::3]
    return np.stack(
        [
            phi[..., 0],
            phi[..., 1] - phi[..., 0],
            phi[..., 2],
            phi[..., 3] - phi[..., 4],
            phi[..., 4],
            phi[..., 5] - phi[..., 6],
            phi[..., 6],
        ],
        -1,
    )


@pytest.fixture(scope='module')
def andrews():
    return build_andrews()


def test_initial_multipliers(andrews):
    """At t = 0 the loop force at E between bodies 2 and 3 is the published λ(0)."""
    mech, solver = andrews
    st = solver.consistent_state(np.array([[Q0[0]]]), np.array([[0.0]]))
    Q = (
        solver.generalized_forces(st.q, None, st.qd)
        + make_forces(solver)(0.0, st.q[0], st.qd[0])[None]
    )
    qdd, lam = solver.solve_augmented(st.q, st.qd, Q)
    np.testing.assert_allclose(lam[0, 4:6], LAM0, rtol=1e-10)
    np.testing.assert_allclose(lam[0, 6:10], 0.0, atol=1e-10)
    # published initial accelerations: w(0) = (14222.44..., -10666.83..., 0, ..., 0)
    np.testing.assert_allclose(
        relative(qdd[0]),
        [14222.4439199541138705911625887, -10666.8329399655854029433719415, 0, 0, 0, 0, 0],
        rtol=1e-10,
        atol=1e-8,
    )


@pytest.mark.parametrize('method', ['partitioned', 'baumgarte'])
def test_andrews_reference_solution_at_t_003(andrews, method):
    mech, solver = andrews
    t0 = time.perf_counter()
    tr = simulate_mechanism(
        solver,
        (0.0, T_END),
        [Q0[0]],
        [0.0],
        forces=make_forces(solver),
        method=method,
        t_eval=np.array([0.0, T_END]),
        rtol=1e-10,
        atol=1e-12,
    )
    elapsed = time.perf_counter() - t0
    q, v, a = relative(tr.q[-1]), relative(tr.qd[-1]), relative(tr.qdd[-1])
    err_q = np.abs(q - REF_Q)
    print(
        f'\n{method}: {elapsed:.2f} s, {tr.info["rhs_evaluations"]} rhs, '
        f'angle error {err_q.max():.2e} rad, rate error '
        f'{np.abs(v - REF_V).max() / np.abs(REF_V).max():.2e} rel, accel error '
        f'{np.abs(a - REF_A).max() / np.abs(REF_A).max():.2e} rel, multiplier error '
        f'{np.abs(tr.lam[-1, 4:10] - REF_LAM).max() / np.abs(REF_LAM).max():.2e} rel'
    )
    assert np.all(err_q < 1e-7), err_q
    np.testing.assert_allclose(v, REF_V, rtol=0, atol=1e-7 * np.abs(REF_V).max())
    np.testing.assert_allclose(a, REF_A, rtol=0, atol=1e-6 * np.abs(REF_A).max())
    np.testing.assert_allclose(tr.lam[-1, 4:10], REF_LAM, rtol=0, atol=1e-6 * np.abs(REF_LAM).max())
    assert tr.info['max_constraint_residual'] < 1e-9
