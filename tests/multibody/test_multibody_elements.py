"""Every joint and force type of ``suspopt.multibody.elements``, checked against finite
differences of its own equations and against Newton–Euler of each body.

Small rigs (two bodies A, B with non-zero reference angles, and the ground) hold one joint
type each, plus one of every force type. At random, not necessarily consistent states:

* ``C_q`` equals central differences of ``C(q)`` (h = 1e-6: error ~1e-10), so one wrong
  Jacobian entry fails;
* ``γ = -(C_q q̇)_q q̇`` equals minus a central difference of ``C_q(q + h q̇) q̇``;
* along a quadratic path ``q(t) = q + q̇ t + ½ q̈ t²`` with a quadratic prescribed motion,
  the first and second differences of ``C(q(t), t)`` equal ``Ċ = C_q q̇ - ν`` and
  ``C_q q̈ - γ`` (this covers the rheonomic ``ν = -C_t`` and ``-C_tt``).

At consistent, moving, loaded states from ``dynamics`` every body obeys ``m a = ΣF``,
``I φ̈ = ΣM`` with the joint reactions of :meth:`PlanarMultibodySolver.reactions` and
applied forces computed here from the rig's numbers; each joint between two bodies obeys
action = reaction, a pin transmits no couple, a slider no force along its axis.

Then each new joint type is broken on purpose (one sign or term), the same checks must
fail, and after the repair they pass again.
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from mechanisms import with_suspension_load  # noqa: E402 (tests/ is on the path)

from suspopt.errors import ConfigError
from suspopt.multibody.elements import PrescribedMotion
from suspopt.multibody.elements.fixed import FixedGroup
from suspopt.multibody.elements.prescribed import PrescribedGroup
from suspopt.multibody.elements.prismatic import PrismaticGroup
from suspopt.multibody.mechanism import mechanism_from_dict
from suspopt.multibody.solver import PlanarMultibodySolver

BODIES = [
    {'name': 'A', 'mass': 2.0, 'inertia': 0.05, 'position': [0.3, 0.1], 'angle': 0.4},
    {'name': 'B', 'mass': 3.0, 'inertia': 0.08, 'position': [0.7, -0.2], 'angle': -0.3},
]
MARKERS = [
    {'name': 'mA', 'body': 'A', 'point': [0.35, 0.3]},
    {'name': 'mB', 'body': 'B', 'point': [0.8, -0.1]},
    {'name': 'mG', 'body': 'ground', 'point': [0.0, 0.5]},
]
_AB = np.subtract([0.8, -0.1], [0.35, 0.3])
FORCES = [
    {'name': 'pA', 'type': 'point_load', 'marker': 'mA', 'direction': [0.6, 0.8]},
    {
        'name': 'sd',
        'type': 'spring_damper',
        'markers': ['mG', 'mB'],
        'stiffness': 500.0,
        'damping': 20.0,
        'free_length': 0.9,
    },
    {
        'name': 'ls',
        'type': 'linear_spring_damper',
        'markers': ['mA', 'mB'],
        'axis': (_AB / np.hypot(*_AB) + [0.1, 0.2]).tolist(),
        'stiffness': 800.0,
        'damping': 15.0,
    },
]
PIN_A = {'name': 'A-G', 'bodies': ['A', 'ground'], 'point': [0.1, 0.2]}
RIGS = {
    'revolute': (
        [PIN_A, {'name': 'X', 'bodies': ['A', 'B'], 'point': [0.55, -0.05]}],
        [('A', 'phi'), ('B', 'phi')],
        {},
    ),
    'prismatic': (
        [
            PIN_A,
            {
                'name': 'X',
                'type': 'prismatic',
                'bodies': ['A', 'B'],
                'point': [0.55, -0.05],
                'axis': [0.6, -0.8],
            },
        ],
        [('A', 'phi'), ('B', 'x')],
        {},
    ),
    'prismatic on the ground': (
        [
            PIN_A,
            {
                'name': 'X',
                'type': 'prismatic',
                'bodies': ['ground', 'B'],
                'point': [0.7, -0.2],
                'axis': [0.8, 0.6],
            },
        ],
        [('A', 'phi'), ('B', 'x')],
        {},
    ),
    'fixed': (
        [PIN_A, {'name': 'X', 'type': 'fixed', 'bodies': ['A', 'B'], 'point': [0.5, 0.0]}],
        [('A', 'phi')],
        {},
    ),
    'fixed flag': (
        [{'name': 'X', 'bodies': ['A', 'B'], 'point': [0.55, -0.05]}],
        [('A', 'phi')],
        {'B': True},
    ),
    'prescribed': (
        [
            {'name': 'X', 'type': 'prescribed', 'body': 'A'},
            {'name': 'A-B', 'bodies': ['A', 'B'], 'point': [0.55, -0.05]},
        ],
        [('B', 'phi')],
        {},
    ),
}


def rig_data(kind: str) -> dict:
    joints, ind, fixed = RIGS[kind]
    bodies = [dict(b, fixed=True) if b['name'] in fixed else dict(b) for b in BODIES]
    return {
        'name': kind,
        'bodies': bodies,
        'joints': copy.deepcopy(joints),
        'markers': copy.deepcopy(MARKERS),
        'forces': copy.deepcopy(FORCES),
        'independent': [{'body': b, 'coordinate': c} for b, c in ind],
    }


def rig(kind: str) -> PlanarMultibodySolver:
    return PlanarMultibodySolver(mechanism_from_dict(rig_data(kind)))


def motion_at(s: PlanarMultibodySolver, t: float, rng_seed: int = 7, N: int = 4):
    """A quadratic prescribed motion of every prescribed joint, at time t."""
    rng = np.random.default_rng(rng_seed)
    out = {}
    for name in s.prescribed:
        d0, v, a = (rng.uniform(-1, 1, (N, 3)) * sc for sc in (0.05, 0.5, 3.0))
        out[name] = PrescribedMotion(d0 + v * t + 0.5 * a * t * t, v + a * t, a)
    return out


def random_state(s: PlanarMultibodySolver, N: int = 4, seed: int = 0):
    rng = np.random.default_rng(seed)
    return (
        s.q0 + 0.1 * rng.standard_normal((N, s.n)),
        rng.standard_normal((N, s.n)),
        3.0 * rng.standard_normal((N, s.n)),
    )


def joint_errors(s: PlanarMultibodySolver) -> dict[str, float]:
    """Largest deviation of C_q, γ (with and without motion) and Ċ from differences."""
    q, qd, qdd = random_state(s)
    motion = motion_at(s, 0.0)
    h = 1e-6
    Cq = s.constraint_jacobian(q)
    fd = np.stack(
        [
            (s.constraints(q + h * e, motion) - s.constraints(q - h * e, motion)) / (2 * h)
            for e in np.eye(s.n)
        ],
        -1,
    )
    err = {'jacobian': float(np.max(np.abs(fd - Cq)))}
    Cq_qd = [np.einsum('nij,nj->ni', s.constraint_jacobian(q + sg * h * qd), qd) for sg in (1, -1)]
    err['gamma'] = float(np.max(np.abs(-(Cq_qd[0] - Cq_qd[1]) / (2 * h) - s.gamma(q, qd))))

    def C(t):
        return s.constraints(q + qd * t + 0.5 * qdd * t * t, motion_at(s, t))

    h1, h2 = 1e-5, 1e-4
    err['rate'] = float(
        np.max(np.abs((C(h1) - C(-h1)) / (2 * h1) - s.constraint_rate(q, qd, motion)))
    )
    second = (C(h2) - 2 * C(0.0) + C(-h2)) / h2**2
    err['gamma along a path'] = float(
        np.max(np.abs(second - (np.einsum('nij,nj->ni', Cq, qdd) - s.gamma(q, qd, motion))))
    )
    return err


TOL = {'jacobian': 1e-8, 'gamma': 1e-7, 'rate': 1e-7, 'gamma along a path': 1e-5}


@pytest.mark.parametrize('kind', list(RIGS))
def test_joint_equations_match_finite_differences(kind):
    err = joint_errors(rig(kind))
    print(f'\n{kind}: ' + ', '.join(f'{k} {v:.1e}' for k, v in err.items()))
    for k, v in err.items():
        assert v < TOL[k], (kind, k, v)


# ------------------------------------------------------------------ deliberately broken
def wrong_entry(slot, coordinate):
    def breaker(original):
        def jacobian(self, qe):
            J = original(self, qe)
            J[:, :, slot, 0, coordinate] += 0.3  # one entry of ∂C_1/∂q_b off
            return J

        return jacobian

    return breaker


def wrong_velocity_term(original):
    def gamma(self, qe, qde, drive=None):  # a missing (or wrong) ω_a² term
        return original(self, qe, qde, drive) + 0.5 * qde[:, self.bodies[:, :1], 2] ** 2

    return gamma


def no_angle_equation(original):
    def residual(self, qe, drive=None):
        C = original(self, qe, drive)
        C[..., 2] = 0.0  # the weld no longer holds the angle
        return C

    return residual


def no_velocity_term(original):
    return lambda self, drive: 0.0 * original(self, drive)  # ν = -C_t forgotten


def no_acceleration_term(original):
    return lambda self, qe, qde, drive=None: 0.0 * original(self, qe, qde, drive)  # -C_tt


@pytest.mark.parametrize(
    'kind, cls, method, breaker, check',
    [
        ('prismatic', PrismaticGroup, 'jacobian', wrong_entry(0, 2), 'jacobian'),
        ('prismatic on the ground', PrismaticGroup, 'jacobian', wrong_entry(1, 0), 'jacobian'),
        ('prismatic', PrismaticGroup, 'gamma', wrong_velocity_term, 'gamma'),
        ('fixed', FixedGroup, 'residual', no_angle_equation, 'jacobian'),
        ('prescribed', PrescribedGroup, 'velocity_term', no_velocity_term, 'rate'),
        ('prescribed', PrescribedGroup, 'gamma', no_acceleration_term, 'gamma along a path'),
    ],
)
def test_broken_joint_equations_are_caught(monkeypatch, kind, cls, method, breaker, check):
    """Each check above fails when one equation of a new joint type is broken, and passes
    again when it is restored (so the passing checks are not vacuous)."""
    monkeypatch.setattr(cls, method, breaker(getattr(cls, method)))
    bad = joint_errors(rig(kind))[check]
    assert bad > 1e3 * TOL[check], (kind, method, bad)
    monkeypatch.undo()
    assert joint_errors(rig(kind))[check] < TOL[check]


# ------------------------------------------------------------------ Newton-Euler
def rot(phi, u):
    c, s_ = np.cos(phi), np.sin(phi)
    return np.stack([c * u[..., 0] - s_ * u[..., 1], s_ * u[..., 0] + c * u[..., 1]], -1)


def cross(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def local(body: str, point) -> np.ndarray:
    b = next(x for x in BODIES if x['name'] == body)
    return rot(np.array(-b['angle']), np.subtract(point, b['position']))


def applied_forces(s, q, qd, mag):
    """Force and moment about the CG on A and B from the rig's forces, computed from the
    rig's numbers (not from the solver's force elements): {body: (F (N, 2), M (N,))}."""
    N = q.shape[0]
    out = {b: [np.zeros((N, 2)), np.zeros(N)] for b in ('A', 'B', 'ground')}
    iA, iB = s.body_names.index('A'), s.body_names.index('B')
    r = {'A': q[:, 3 * iA : 3 * iA + 2], 'B': q[:, 3 * iB : 3 * iB + 2], 'ground': np.zeros((N, 2))}
    phi = {'A': q[:, 3 * iA + 2], 'B': q[:, 3 * iB + 2], 'ground': np.zeros(N)}
    v = {
        'A': qd[:, 3 * iA : 3 * iA + 2],
        'B': qd[:, 3 * iB : 3 * iB + 2],
        'ground': np.zeros((N, 2)),
    }
    w = {'A': qd[:, 3 * iA + 2], 'B': qd[:, 3 * iB + 2], 'ground': np.zeros(N)}
    mk = {m['name']: (m['body'], m['point']) for m in MARKERS}

    def point(name):
        b, p = mk[name]
        if b == 'ground':
            return b, np.broadcast_to(np.array(p, float), (N, 2)), np.zeros((N, 2))
        arm = rot(phi[b], local(b, p))
        return b, r[b] + arm, v[b] + np.stack([-arm[:, 1], arm[:, 0]], -1) * w[b][:, None]

    def apply(b, p, F, line_point=None):
        out[b][0] += F
        out[b][1] += cross((p if line_point is None else line_point) - r[b], F)

    bA, pA, _ = point('mA')
    apply(bA, pA, mag[:, None] * np.array([0.6, 0.8]))
    # point-to-point spring-damper mG -> mB
    b0, p0, v0 = point('mG')
    b1, p1, v1 = point('mB')
    d = p1 - p0
    L = np.hypot(d[:, 0], d[:, 1])
    e = d / L[:, None]
    f = 500.0 * (L - 0.9) + 20.0 * np.sum(e * (v1 - v0), -1)
    apply(b0, p0, f[:, None] * e)
    apply(b1, p1, -f[:, None] * e)
    # linear spring-damper mA -> mB along an axis fixed in A
    b0, p0, v0 = point('mA')
    b1, p1, v1 = point('mB')
    ax = np.array(FORCES[2]['axis']) / np.hypot(*FORCES[2]['axis'])
    n = rot(phi['A'], local('A', ax + BODIES[0]['position']))
    ell0 = float(ax @ _AB)
    ell = np.sum(n * (p1 - p0), -1)
    ell_d = np.sum(np.stack([-n[:, 1], n[:, 0]], -1) * w['A'][:, None] * (p1 - p0), -1) + np.sum(
        n * (v1 - v0), -1
    )
    f = 800.0 * (ell - ell0) + 15.0 * ell_d
    apply(b1, p1, -f[:, None] * n)
    apply(b0, p0, f[:, None] * n, line_point=p1)  # on body 0 along the line through p1
    return out


@pytest.mark.parametrize('kind', list(RIGS))
def test_reactions_obey_newton_euler(kind):
    s = rig(kind)
    rng = np.random.default_rng(4)
    N = 6
    q_ind = s.q0[s.ind] + rng.uniform(-0.1, 0.1, (N, s.dof))
    qd_ind = rng.uniform(-1, 1, (N, s.dof))
    mag = rng.uniform(-50, 50, N)
    motion = motion_at(s, 0.0, N=N)
    st = s.dynamics(q_ind, qd_ind, mag[:, None], motion=motion)
    assert np.max(np.abs(s.constraints(st.q, motion))) < 1e-10
    assert np.max(np.abs(s.constraint_rate(st.q, st.qd, motion))) < 1e-10
    R = s.reactions(st.q, st.lam)
    applied = applied_forces(s, st.q, st.qd, mag)
    data = rig_data(kind)
    for b in ('A', 'B'):
        i = s.body_names.index(b)
        F, M = applied[b][0].copy(), applied[b][1].copy()
        for k, bodies in enumerate(s.joint_bodies):
            for slot, name in enumerate(bodies):
                if name == b:
                    F += R[:, k, slot, :2]
                    M += R[:, k, slot, 2]
        body = data['bodies'][i]
        res = np.concatenate(
            [
                body['mass'] * st.qdd[:, 3 * i : 3 * i + 2] - F,
                (body['inertia'] * st.qdd[:, 3 * i + 2] - M)[:, None],
            ],
            1,
        )
        assert np.max(np.abs(res)) < 1e-9 * max(1.0, np.max(np.abs(F))), (kind, b)
    # each joint between two bodies: action = reaction, moments balance about a point
    P = np.array([0.2, -0.4])
    for k, bodies in enumerate(s.joint_bodies):
        if len(bodies) < 2 or 'ground' in bodies:
            continue
        ia, ib = (s.body_names.index(x) for x in bodies)
        ra, rb = st.q[:, 3 * ia : 3 * ia + 2], st.q[:, 3 * ib : 3 * ib + 2]
        Fa, Fb = R[:, k, 0, :2], R[:, k, 1, :2]
        np.testing.assert_allclose(Fa + Fb, 0.0, atol=1e-10 * np.max(np.abs(Fa)))
        Ma = R[:, k, 0, 2] + cross(ra - P, Fa)
        Mb = R[:, k, 1, 2] + cross(rb - P, Fb)
        np.testing.assert_allclose(Ma + Mb, 0.0, atol=1e-10 * np.max(np.abs(Ma)))
    X = s.joint_names.index('X')
    joint = next(j for j in data['joints'] if j['name'] == 'X')
    if 'revolute' in kind or 'fixed flag' in kind:  # a pin transmits no couple
        for slot, b in enumerate(s.joint_bodies[X]):
            if b == 'ground':
                continue
            i = s.body_names.index(b)
            arm = rot(st.q[:, 3 * i + 2], local(b, joint['point']))
            np.testing.assert_allclose(
                R[:, X, slot, 2],
                cross(arm, R[:, X, slot, :2]),
                atol=1e-10 * np.max(np.abs(R[:, X])),
            )
    if 'prismatic' in kind:  # no force along the sliding axis
        first = joint['bodies'][0]
        ax = np.array(joint['axis']) / np.hypot(*joint['axis'])
        phi_a = 0.0 if first == 'ground' else st.q[:, 3 * s.body_names.index(first) + 2]
        ang0 = 0.0 if first == 'ground' else BODIES[0]['angle']
        t = rot(np.asarray(phi_a - ang0), ax)
        along = np.sum(R[:, X, 1, :2] * t, -1)
        assert np.max(np.abs(R[:, X, 1, :2])) > 1.0
        np.testing.assert_allclose(along, 0.0, atol=1e-10 * np.max(np.abs(R[:, X])))


def test_body_reaction_sums_the_joints_on_a_body():
    """``body_reaction`` = the sum of :meth:`reactions` on that body, torque shifted to a
    point; on the ground it balances the ground joints' forces on the bodies."""
    s = rig('prismatic on the ground')
    st = s.dynamics(s.q0[s.ind] + [[0.05, 0.02]], [[0.3, -0.4]], [[20.0]])
    R = s.reactions(st.q, st.lam)
    P = np.array([0.4, 0.9])
    iB = s.body_names.index('B')
    F, M = s.body_reaction('B', st.q, st.lam, point=P)
    rB = st.q[:, 3 * iB : 3 * iB + 2]
    np.testing.assert_allclose(F, R[:, s.joint_names.index('X'), 1, :2], rtol=1e-14)
    np.testing.assert_allclose(
        M, R[:, s.joint_names.index('X'), 1, 2] + cross(rB - P, F), rtol=1e-12
    )
    Fg, Mg = s.body_reaction('ground', st.q, st.lam)
    on_bodies = [s.body_reaction(b, st.q, st.lam, point=[0.0, 0.0]) for b in ('A', 'B')]
    np.testing.assert_allclose(Fg, -(on_bodies[0][0] + on_bodies[1][0]), atol=1e-10)
    np.testing.assert_allclose(Mg, -(on_bodies[0][1] + on_bodies[1][1]), atol=1e-10)
    Fa, _ = s.body_reaction('A', st.q, st.lam, joints=['A-G'])
    np.testing.assert_allclose(Fa, R[:, s.joint_names.index('A-G'), 0, :2], rtol=1e-14)
    with pytest.raises(ValueError, match='unknown joints'):
        s.body_reaction('A', st.q, st.lam, joints=['nope'])


def test_prescribed_drive_reaction_is_the_force_that_moves_the_linkage():
    """The double wishbone with its frame prescribed instead of fixed: the frame heaves
    and rolls with given accelerations. The whole linkage obeys Σ m a = drive + tyre
    load (the only external forces), i.e. the prescribed joint's reaction on the frame is
    the force (and torque) that drives it."""
    data = _dw_data()
    f = next(b for b in data['bodies'] if b['name'] == 'F')
    del f['fixed']
    data['joints'].append({'name': 'mount', 'type': 'prescribed', 'body': 'F'})
    s = PlanarMultibodySolver(mechanism_from_dict(data))
    N = 5
    rng = np.random.default_rng(2)
    motion = {
        'mount': PrescribedMotion(
            rng.uniform(-0.03, 0.03, (N, 3)),
            rng.uniform(-0.5, 0.5, (N, 3)),
            rng.uniform(-5, 5, (N, 3)),
        )
    }
    F_T = rng.uniform(-2000, 2000, N)
    st = s.dynamics(
        s.q0[s.ind] + rng.uniform(-0.05, 0.05, (N, 1)),
        rng.uniform(-0.5, 0.5, (N, 1)),
        F_T[:, None],
        motion=motion,
    )
    iF = s.body_names.index('F')
    np.testing.assert_allclose(
        st.q[:, 3 * iF : 3 * iF + 3] - s.q0[3 * iF : 3 * iF + 3], motion['mount'].offset, atol=1e-12
    )
    np.testing.assert_allclose(st.qd[:, 3 * iF : 3 * iF + 3], motion['mount'].velocity, atol=1e-12)
    np.testing.assert_allclose(
        st.qdd[:, 3 * iF : 3 * iF + 3], motion['mount'].acceleration, atol=1e-9
    )
    drive, drive_M = s.body_reaction('F', st.q, st.lam, point=[0.0, 0.0], joints=['mount'])
    m = s.mass_diag.reshape(-1, 3)[:, 0]
    a = st.qdd.reshape(N, -1, 3)
    momentum_rate = np.sum(m[:, None] * a[:, :, :2], axis=1)
    np.testing.assert_allclose(
        momentum_rate, drive + np.stack([0 * F_T, F_T], 1), atol=1e-9 * np.max(np.abs(F_T))
    )
    # angular momentum about the origin: Σ (I φ̈ + r × m a) = drive torque + r_cp × F_T
    r = st.q.reshape(N, -1, 3)[:, :, :2]
    I = s.mass_diag.reshape(-1, 3)[:, 2]
    L_rate = np.sum(I * a[:, :, 2] + cross(r, m[:, None] * a[:, :, :2]), axis=1)
    cp = s.marker_positions(st.q)[:, s.marker_names.index('contact_patch')]
    np.testing.assert_allclose(
        L_rate, drive_M + cross(cp, np.stack([0 * F_T, F_T], 1)), atol=1e-9 * np.max(np.abs(F_T))
    )


# ------------------------------------------------------------------ force elements
@pytest.mark.parametrize('name', ['sd', 'ls'])
def test_spring_force_is_minus_the_gradient_of_its_potential(name):
    s = rig('revolute')
    q, qd, _ = random_state(s)
    only = {n: {'stiffness': 0.0, 'damping': 0.0} for n in ('sd', 'ls') if n != name}
    only[name] = {'damping': 0.0}
    Q = s.generalized_forces(q, np.zeros((q.shape[0], 1)), qd, only)
    h = 1e-6
    grad = np.stack(
        [
            (s.potential_energy(q + h * e, only) - s.potential_energy(q - h * e, only)) / (2 * h)
            for e in np.eye(s.n)
        ],
        -1,
    )
    assert np.max(np.abs(Q)) > 10.0
    np.testing.assert_allclose(Q, -grad, atol=1e-7 * np.max(np.abs(Q)))


@pytest.mark.parametrize('name', ['sd', 'ls'])
def test_spring_queries(name):
    """Length, rate and ℓ̈ against differences along a path; tension = k (ℓ - ℓ0) + c ℓ̇;
    the end forces are the spring's generalized forces on the end bodies."""
    s = rig('prismatic')
    q, qd, qdd = random_state(s)
    k, c = {'sd': (500.0, 20.0), 'ls': (800.0, 15.0)}[name]
    sp = s.spring(name, q, qd, qdd=qdd)

    def length(t):
        return s.spring(name, q + qd * t + 0.5 * qdd * t * t, qd).length

    h = 1e-4
    np.testing.assert_allclose(sp.rate, (length(h) - length(-h)) / (2 * h), atol=1e-7)
    np.testing.assert_allclose(
        sp.acceleration, (length(h) - 2 * length(0.0) + length(-h)) / h**2, atol=1e-5
    )
    free = sp.length - sp.deflection
    np.testing.assert_allclose(sp.force, k * sp.deflection + c * sp.rate, rtol=1e-13)
    np.testing.assert_allclose(np.hypot(*np.moveaxis(sp.direction, -1, 0)), 1.0, rtol=1e-14)
    assert free[0] == (
        0.9
        if name == 'sd'
        else pytest.approx(np.dot(_AB, np.array(FORCES[2]['axis']) / np.hypot(*FORCES[2]['axis'])))
    )
    others = {n: {'stiffness': 0.0, 'damping': 0.0} for n in ('sd', 'ls') if n != name}
    Q = s.generalized_forces(q, np.zeros((q.shape[0], 1)), qd, others).reshape(len(q), -1, 3)
    for end, body in enumerate(sp.bodies):
        if body != 'ground':
            np.testing.assert_allclose(
                Q[:, s.body_names.index(body), :2], sp.end_forces[:, end], rtol=1e-12
            )
    # per-call stiffness and damping, one value per state
    kk = np.linspace(100.0, 900.0, q.shape[0])
    sp2 = s.spring(name, q, qd, params={name: {'stiffness': kk, 'damping': 0.0}})
    np.testing.assert_allclose(sp2.force, kk * sp.deflection, rtol=1e-13)


def _dw_data() -> dict:
    import tomllib

    from suspopt.multibody.mechanism import mechanism_path

    with mechanism_path('double_wishbone').open('rb') as fh:
        return tomllib.load(fh)


@pytest.mark.parametrize('name', ['double_wishbone', 'sla_double_wishbone'])
def test_spring_element_reproduces_the_suspension_point_load(name):
    """The shipped vertical spring element with k, c supplied per call gives the same q̈
    and joint multipliers as today's point load -F_S with F_S = k q^z_U + c q̇^z_U on the
    spring point (docs/model.md, chassis at rest); only the frame's weld multipliers differ, by
    the spring's force and moment on the frame."""
    s = PlanarMultibodySolver(with_suspension_load(name))
    rng = np.random.default_rng(8)
    N = 12
    z, v = rng.uniform(-0.08, 0.08, (N, 1)), rng.uniform(-0.6, 0.6, (N, 1))
    k, c, F_T = rng.uniform(1e4, 5e4, N), rng.uniform(1e3, 5e3, N), rng.uniform(-3e3, 3e3, N)
    st = s.consistent_state(s.q0[s.ind] + z, v)
    spring = s.marker_names.index('spring_point')
    q_U = s.marker_positions(st.q)[:, spring, 1] - s.marker_reference()[spring, 1]
    qd_U = s.marker_velocities(st.q, st.qd)[:, spring, 1]
    F_S = k * q_U + c * qd_U
    old = s.solve_augmented(st.q, st.qd, s.generalized_forces(st.q, np.stack([F_S, F_T], 1)))
    new = s.solve_augmented(
        st.q,
        st.qd,
        s.generalized_forces(
            st.q, np.stack([0 * F_S, F_T], 1), st.qd, {'spring': {'stiffness': k, 'damping': c}}
        ),
    )
    np.testing.assert_allclose(new[0], old[0], rtol=0, atol=1e-10 * np.max(np.abs(old[0])))
    nj = 2 * s.nj  # the revolute joints' multipliers; the frame's weld comes last
    np.testing.assert_allclose(
        new[1][:, :nj], old[1][:, :nj], rtol=0, atol=1e-10 * np.max(np.abs(old[1]))
    )
    sp = s.spring('spring', st.q, st.qd, {'spring': {'stiffness': k, 'damping': c}})
    np.testing.assert_allclose(sp.force, -F_S, rtol=1e-12)  # tension = -F_S
    np.testing.assert_allclose(sp.end_forces[:, 1], np.stack([0 * F_S, -F_S], 1), atol=1e-9)
    F_new, _ = s.body_reaction('F', st.q, new[1])
    F_old, _ = s.body_reaction('F', st.q, old[1])
    np.testing.assert_allclose(F_new - F_old, -sp.end_forces[:, 0], atol=1e-8)
    # and the frame still does not move
    assert np.max(np.abs(new[0].reshape(N, -1, 3)[:, s.body_names.index('F')])) < 1e-12


# ------------------------------------------------------------------ bad mechanism data
def _err(data) -> str:
    with pytest.raises(ConfigError) as err:
        mechanism_from_dict(data, suspension='suspension' in data)
    return str(err.value)


@pytest.mark.parametrize(
    'change, words',
    [
        (
            lambda d: d['joints'][1].update(axis=[0.0, 0.0]),
            ['joints[1].axis: must be a non-zero finite vector', "(joint 'X')"],
        ),
        (
            lambda d: d['joints'][1].update(axis=[float('nan'), 1.0]),
            ['joints[1].axis: must be a non-zero finite vector', "(joint 'X')"],
        ),
        (
            lambda d: d['joints'][1].update(type='slider'),
            [
                "joints[1].type: unknown joint type 'slider'",
                'fixed, prescribed, prismatic, revolute',
                "(joint 'X')",
            ],
        ),
        (lambda d: d['joints'][1].update(type='prismatc'), ["did you mean 'prismatic'"]),
        (lambda d: d['joints'][1].update(normal=[1, 0]), ['joints[1].normal: unknown key']),
        (
            lambda d: d['forces'][1].update(free_length=0.0),
            ['forces[1].free_length: must be > 0', "(force 'sd')"],
        ),
        (lambda d: d['forces'][1].update(free_length=-0.2), ['forces[1].free_length: must be > 0']),
        (lambda d: d['forces'][1].update(stiffness=-1.0), ['forces[1].stiffness: must be >= 0']),
        (
            lambda d: d['forces'][1].update(markers=['mB', 'mB']),
            ["forces[1].markers: both ends are on body 'B'", "(force 'sd')"],
        ),
        (
            lambda d: (
                d['markers'].append({'name': 'mB2', 'body': 'B', 'point': [0.7, 0.0]})
                or d['forces'][2].update(markers=['mB', 'mB2'])
            ),
            ['forces[2].markers: both ends'],
        ),
        (
            lambda d: d['forces'][2].update(axis=[0.0, 0.0]),
            ['forces[2].axis: must be a non-zero finite vector', "(force 'ls')"],
        ),
        (
            lambda d: d['forces'][2].update(axis=(-_AB).tolist()),
            ["forces[2].axis: must point from marker 'mA' towards marker 'mB'"],
        ),
        (lambda d: d['forces'][1].pop('type'), ['forces[1].type: missing value']),
        (lambda d: d['forces'][1].update(type='damper'), ["unknown force type 'damper'"]),
        (lambda d: d['forces'][1].update(markers=['mG', 'mX']), ["unknown marker 'mX'"]),
        (lambda d: d['forces'][0].update(name='sd'), ["forces[1].name: duplicate name 'sd'"]),
        (
            lambda d: (
                d['markers'].append({'name': 'mC', 'body': 'A', 'point': [0.8, -0.1]})
                or d['forces'][1].update(markers=['mB', 'mC'], free_length=None)
                or d['forces'][1].pop('free_length')
            ),
            ['forces[1].free_length: the default'],
        ),
    ],
)
def test_bad_element_data_is_refused_naming_the_element(change, words):
    data = rig_data('prismatic')
    change(data)
    msg = _err(data)
    for w in words:
        assert w in msg, msg


def test_every_problem_is_reported_at_once():
    data = rig_data('prismatic')
    data['joints'][1]['axis'] = [0, 0]
    data['forces'][1]['free_length'] = -1.0
    data['forces'][2]['markers'] = ['mA', 'mA']
    with pytest.raises(ConfigError) as err:
        mechanism_from_dict(data)
    assert len(err.value.problems) == 3, err.value.problems


def test_suspension_without_a_spring_is_refused():
    data = _dw_data()
    data['forces'] = []
    del data['suspension']['spring']
    msg = _err(data)
    assert 'suspension.spring: missing value' in msg and 'has none' in msg
    data = _dw_data()
    data['suspension']['spring'] = 'tyre'
    msg = _err(data)
    assert "suspension.spring: 'tyre' is not a spring force element (springs: spring)" in msg


def test_suspension_travel_range_is_validated():
    data = _dw_data()
    data['suspension']['travel'] = [0.05, 0.1]
    assert 'suspension.travel: must be [min, max] with min < 0 < max' in _err(data)
    data['suspension']['travel'] = [-0.1, 0.35]  # past the arms' toggle at 0.33 m
    with pytest.raises(ConfigError) as err:
        PlanarMultibodySolver(mechanism_from_dict(data, suspension=True))
    msg = str(err.value)
    assert 'suspension.travel: the linkage locks between wheel travel +0.315 and +0.35 m' in msg, (
        msg
    )
    assert 'inside its travel range [-0.1, 0.35] m' in msg and 'range' in msg
    assert "(joints ['W-U', 'W-L', 'U-F', 'L-F', 'fixed F']): position analysis" in msg, msg


def test_motion_and_params_name_existing_elements():
    s = rig('prescribed')
    q = s.q0[None]
    with pytest.raises(ValueError, match='not prescribed joints'):
        s.constraints(q, {'A-B': PrescribedMotion([0, 0, 0])})
    with pytest.raises(ValueError, match='not a force element'):
        s.generalized_forces(q, params={'nope': {'stiffness': 1.0}})
    with pytest.raises(ValueError, match="has no parameter 'stiffnes'"):
        s.generalized_forces(q, params={'sd': {'stiffnes': 1.0}})
    with pytest.raises(ValueError, match='have damping'):
        s.generalized_forces(q)  # damping in the file: the velocities are needed
    with pytest.raises(ValueError, match='not a spring element'):
        s.spring('pA', q)
    s2 = rig('prismatic')
    with pytest.raises(ValueError, match='depend on the pose: pass q'):
        s2.joint_reactions(np.zeros((1, s2.m)))
    assert math.isfinite(float(s2.joint_reactions(np.ones((1, s2.m)), s2.q0[None]).sum()))
