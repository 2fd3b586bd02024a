"""Validation of the planar multibody solver (``suspopt.multibody``) on the double wishbone.

The suspension of docs/model.md is a parallelogram four-bar: the frame F (fixed) is the ground
link, U and L are the two arms (pivot-to-outer-joint length ``LA = 0.45 - 0.12 = 0.33`` m,
centre of gravity ``a = 0.27 - 0.12 = 0.15`` m from the pivot) and the wheel W is the
coupler. Hence, exactly and for any travel,

* W translates without rotating, on a circle of radius ``LA``: with the arm angle ``θ``,
  ``z_W = LA sin θ`` and ``x_W - 0.54 = LA (cos θ - 1)``;
* the spring point on U (its centre of gravity) rises by ``a sin θ``: motion ratio
  ``r = a / LA``;
* the kinetic energy is ``½ J θ̇²`` with the constant ``J = m_W LA² + 2 (m_A a² + I_A)``, so
  free motion is a uniform rotation and the effective mass at the wheel for small motion is
  ``J / LA²``.

These closed forms are derived here from the body data (not from the solver) and are what
the solver is checked against.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib

import numpy as np
import pytest
from mechanisms import with_suspension_load  # noqa: E402 (tests/ is on the path)

from suspopt.errors import ConfigError, MultibodyError
from suspopt.multibody.mechanism import mechanism_from_dict, mechanism_path
from suspopt.multibody.simulate import simulate_mechanism
from suspopt.multibody.solver import PlanarMultibodySolver
from suspopt.multibody.suspension import SuspensionModule

# ------------------------------------------------------------------ closed-form reference
PIVOT_U, PIVOT_L = np.array([0.12, 0.2]), np.array([0.12, -0.2])
LA = 0.45 - 0.12  # arm length pivot -> wheel joint
A_CG = 0.27 - 0.12  # pivot -> arm CG = spring point
RATIO = (0.27 - 0.12) / (0.45 - 0.12)
M_W, M_ARM, I_ARM = 80.0, 20.0, 0.15
J_THETA = M_W * LA**2 + 2.0 * (M_ARM * A_CG**2 + I_ARM)  # inertia about the arm angle
M_EFF = M_W + 2.0 * (M_ARM * A_CG**2 + I_ARM) / LA**2  # = J_THETA / LA**2

# indices of the body coordinates (bodies W, U, L, F in file order; q = (x, z, phi))
W, U, L, F = 0, 1, 2, 3


def xi(body: int, c: int) -> int:
    return 3 * body + c


@pytest.fixture(scope='module')
def mech():
    return with_suspension_load('double_wishbone')


@pytest.fixture(scope='module')
def solver(mech):
    return PlanarMultibodySolver(mech)


def raw_data() -> dict:
    with mechanism_path('double_wishbone').open('rb') as fh:
        return tomllib.load(fh)


def spring_z(q: np.ndarray) -> np.ndarray:
    """Vertical displacement of the spring point (= U's centre of gravity) from t = 0."""
    return q[..., xi(U, 1)] - 0.2


# ================================================================== energy / constraints
@pytest.mark.parametrize('method', ['partitioned', 'baumgarte'])
def test_free_motion_conserves_energy_and_constraints(solver, method):
    """No applied force, wheel rate 0.015 m/s: 5 s of motion (travel 0 → 75 mm)."""
    t = np.linspace(0.0, 5.0, 101)
    tr = simulate_mechanism(solver, (0.0, 5.0), [0.0], [0.015], method=method, t_eval=t)
    T = solver.kinetic_energy(tr.qd)
    drift = np.max(np.abs(T / T[0] - 1.0))
    residual = np.max(np.abs(solver.constraints(tr.q)))
    print(
        f'\n{method}: kinetic energy drift {drift:.1e} over 5 s, constraint residual '
        f'{residual:.1e} m'
    )
    assert np.max(np.abs(tr.q[:, xi(W, 1)])) < 0.1  # stayed in the intended range
    assert tr.q[-1, xi(W, 1)] > 0.07  # and really moved
    assert drift < 1e-6, f'{method}: kinetic energy drift {drift:.2e}'
    assert residual < 1e-9, f'{method}: constraint residual {residual:.2e} m'
    # exact solution: uniform rotation of the arms, the wheel does not rotate
    theta = tr.q[:, xi(U, 2)]
    omega0 = 0.015 / LA
    np.testing.assert_allclose(theta, omega0 * t, rtol=0, atol=1e-8)
    assert np.max(np.abs(tr.q[:, xi(W, 2)])) < 1e-9


@pytest.mark.parametrize('direction', [1.0, -1.0])
@pytest.mark.parametrize('method', ['partitioned', 'baumgarte'])
def test_large_rotation_of_the_parallelogram(mech, method, direction):
    """The arms swing freely through a large angle, 0 → ±85°, at the exact uniform rate.

    With the wheel's z as independent coordinate the partitioning is singular when an arm
    is vertical (near it z_W barely changes), so these runs use a mechanism built in Python
    whose independent coordinate is the upper arm's angle. The change points of the
    parallelogram (arms vertical, all four links collinear, θ = ±90°) are a bifurcation
    where C_q loses rank; neither method can pass them (the step size collapses), so a
    full revolution is not attempted. The runs start at the reference pose because
    ``simulate_mechanism`` builds its initial state by Newton from the reference pose: from
    θ = -80° directly it converges to the crossed (anti-parallelogram) assembly.
    """
    m_phi = dataclasses.replace(mech, independent=(('U', 'phi'),))
    s = PlanarMultibodySolver(m_phi)
    omega = direction * 1.0
    T_end = math.radians(85.0)
    t = np.linspace(0.0, T_end, 81)
    # max_step: the exact motion has zero acceleration, so the error estimate is ~0 and
    # DOP853 would grow its step until one stage asks Newton (warm-started from the last
    # evaluation) for a pose tens of degrees away, which does not converge
    tr = simulate_mechanism(s, (0.0, T_end), [0.0], [omega], method=method, t_eval=t, max_step=0.05)
    theta = tr.q[:, xi(U, 2)]
    np.testing.assert_allclose(theta, omega * t, rtol=0, atol=1e-8)
    np.testing.assert_allclose(tr.q[:, xi(L, 2)], theta, rtol=0, atol=1e-8)
    assert np.max(np.abs(tr.q[:, xi(W, 2)])) < 1e-9  # no wheel rotation
    np.testing.assert_allclose(tr.q[:, xi(W, 1)], LA * np.sin(theta), atol=1e-9)
    np.testing.assert_allclose(tr.q[:, xi(W, 0)], 0.54 + LA * (np.cos(theta) - 1), atol=1e-9)
    T = s.kinetic_energy(tr.qd)
    np.testing.assert_allclose(T, 0.5 * J_THETA * omega**2, rtol=1e-9)
    assert np.max(np.abs(s.constraints(tr.q))) < 1e-9


@pytest.mark.parametrize('method', ['partitioned', 'baumgarte'])
def test_gravity_energy_conserved(mech, method):
    """Gravity on, plus a linear spring k between ground and the spring point (so that the
    mechanism oscillates about z_eq ≈ -47 mm instead of falling onto a change point):
    kinetic + gravity potential + spring energy is conserved over 5 s."""
    mg = dataclasses.replace(mech, gravity=(0.0, -9.81))
    s = PlanarMultibodySolver(mg)
    k = 1.0e5

    def loads(t, q, qd):  # 'suspension' load points down and carries +F_S = k z_U
        return np.array([k * spring_z(q), 0.0])

    t = np.linspace(0.0, 5.0, 201)
    tr = simulate_mechanism(s, (0.0, 5.0), [0.0], [0.0], loads=loads, method=method, t_eval=t)
    E = s.kinetic_energy(tr.qd) + s.potential_energy(tr.q) + 0.5 * k * spring_z(tr.q) ** 2
    z = tr.q[:, xi(W, 1)]
    assert -0.1 < z.min() < -0.08 and z.max() < 1e-9  # it really oscillated
    T_max = np.max(s.kinetic_energy(tr.qd))
    assert np.max(np.abs(E - E[0])) < 1e-6 * T_max
    assert np.max(np.abs(s.constraints(tr.q))) < 1e-9
    # gravity potential is -Σ m g·r, independently
    pot = 9.81 * (
        M_W * tr.q[:, xi(W, 1)]
        + M_ARM * tr.q[:, xi(U, 1)]
        + M_ARM * tr.q[:, xi(L, 1)]
        + 10.0 * tr.q[:, xi(F, 1)]
    )
    np.testing.assert_allclose(s.potential_energy(tr.q), pot, rtol=1e-12, atol=1e-12)


# ================================================================== kinematics
@pytest.mark.parametrize('z', [1e-4, -1e-4, 0.05, -0.05, 0.02])
def test_motion_ratio_and_wheel_path(z):
    mod = SuspensionModule('double_wishbone')
    kin = mod.kinematics(np.array([z]), np.array([0.3]))
    q = kin.state.q[0]
    s = mod.solver
    i = s.marker_names.index('spring_point')
    q_U = s.marker_positions(kin.state.q)[0, i, 1] - s.marker_reference()[i, 1]
    qd_U = s.marker_velocities(kin.state.q, kin.state.qd)[0, i, 1]
    # motion ratio of displacements and of velocities
    assert q_U / kin.q_W[0] == pytest.approx(RATIO, rel=1e-10)
    assert qd_U / kin.qd_W[0] == pytest.approx(RATIO, rel=1e-10)
    assert kin.q_W[0] == pytest.approx(z, rel=1e-12)
    # the coupler does not rotate; its lateral shift follows the arc of the arms
    assert abs(q[xi(W, 2)]) < 1e-12
    assert q[xi(W, 0)] - 0.54 == pytest.approx(
        LA * (math.cos(math.asin(z / LA)) - 1.0), rel=1e-9, abs=1e-15
    )
    assert q[xi(U, 2)] == pytest.approx(math.asin(z / LA), rel=1e-10)
    assert q[xi(L, 2)] == pytest.approx(math.asin(z / LA), rel=1e-10)


# ================================================================== effective wheel rate
def test_wheel_rate_static(solver):
    """A vertical spring k on the spring point: the tyre load that holds the wheel at rest
    at travel z (zero acceleration) is k·r²·z (virtual work: F_T δz_W = k z_U δz_U)."""
    k = 3.0e4
    for z in [1e-3, -1e-3, 0.03]:
        st = solver.consistent_state(np.array([[z]]), np.array([[0.0]]))
        zU = spring_z(st.q[0])
        acc = []
        for FT in (0.0, 1000.0):  # acceleration is affine in F_T: find its root
            qdd, _ = solver.solve_augmented(
                st.q, st.qd, solver.generalized_forces(st.q, np.array([[k * zU, FT]]))
            )
            acc.append(qdd[0, xi(W, 1)])
        FT_hold = -acc[0] * 1000.0 / (acc[1] - acc[0])
        assert FT_hold == pytest.approx(k * RATIO**2 * z, rel=1e-9)
        # and 1/(d zdd / d F_T) is the effective mass at the wheel (at rest: exactly J/LA²cos²)
        m_eff_z = J_THETA / (LA * math.cos(math.asin(z / LA))) ** 2
        assert 1000.0 / (acc[1] - acc[0]) == pytest.approx(m_eff_z, rel=1e-9)


def test_wheel_rate_natural_frequency(solver):
    """Small free oscillation (1 mm) with the spring k on the spring point: angular
    frequency sqrt(k r² / m_eff), m_eff = 80 + 2 (20·0.15² + 0.15) / 0.33² ≈ 91.02 kg."""
    k = 3.0e4
    omega_ref = math.sqrt(k * RATIO**2 / M_EFF)
    period = 2 * math.pi / omega_ref
    t = np.linspace(0.0, 3 * period, 3001)
    tr = simulate_mechanism(
        solver,
        (0.0, t[-1]),
        [1e-3],
        [0.0],
        t_eval=t,
        loads=lambda t, q, qd: np.array([k * spring_z(q), 0.0]),
    )
    z = tr.q[:, xi(W, 1)]
    # downward zero crossings, linearly interpolated (dense output every 1e-3 period)
    i = np.nonzero((z[:-1] > 0) & (z[1:] <= 0))[0]
    tc = t[i] - z[i] * (t[i + 1] - t[i]) / (z[i + 1] - z[i])
    assert len(tc) == 3
    measured = 2 * math.pi / np.mean(np.diff(tc))
    print(
        f'\nwheel hop on the linkage: {measured:.6f} rad/s, closed form {omega_ref:.6f} '
        f'(m_eff {M_EFF:.4f} kg, wheel rate k r² = {RATIO**2:.4f} k): relative error '
        f'{abs(measured / omega_ref - 1):.1e}'
    )
    assert measured == pytest.approx(omega_ref, rel=2e-5)
    assert np.max(np.abs(z)) == pytest.approx(1e-3, rel=1e-6)  # no spurious damping


# ================================================================== reactions
def _joint_geometry(mech):
    """Per joint: (i, j, u_i, u_j) with u the joint point in body axes (from the data)."""
    names = [b.name for b in mech.bodies]
    out = []
    for jt in mech.joints:
        ids, us = [], []
        for bn in jt.bodies:
            if bn == 'ground':
                ids.append(None)
                us.append(None)
                continue
            b = mech.bodies[names.index(bn)]
            c, s_ = math.cos(-b.angle), math.sin(-b.angle)
            d = np.subtract(jt.point, b.position)
            ids.append(names.index(bn))
            us.append(np.array([c * d[0] - s_ * d[1], s_ * d[0] + c * d[1]]))
        out.append((ids[0], ids[1], us[0], us[1]))
    return out


def _newton_euler_residual(mech, solver, q, qd, qdd, lam, F_S, F_T):
    """Per moving body: m a - ΣF and I φ̈ - ΣM_cg, with the joint forces from λ."""
    R = solver.joint_reactions(lam[None])[0]  # on each joint's first body
    forces = {b: np.zeros(2) for b in range(len(mech.bodies))}
    moments = {b: 0.0 for b in range(len(mech.bodies))}

    def rot(phi, u):
        c, s_ = math.cos(phi), math.sin(phi)
        return np.array([c * u[0] - s_ * u[1], s_ * u[0] + c * u[1]])

    def apply(b, u, f):
        arm = rot(q[xi(b, 2)], u)
        forces[b] += f
        moments[b] += arm[0] * f[1] - arm[1] * f[0]

    for k, (i, j, ui, uj) in enumerate(_joint_geometry(mech)):
        apply(i, ui, R[k])
        if j is not None:
            apply(j, uj, -R[k])
    # applied loads: -F_S vertical at the spring point (U's CG), +F_T at the contact patch
    apply(U, np.zeros(2), np.array([0.0, -F_S]))
    apply(W, np.array([0.0, -0.38]), np.array([0.0, F_T]))
    res = []
    for b, body in enumerate(mech.bodies):
        if body.fixed:
            continue
        res.append(
            np.r_[
                body.mass * qdd[xi(b, 0)] - forces[b][0],
                body.mass * qdd[xi(b, 1)] - forces[b][1],
                body.inertia * qdd[xi(b, 2)] - moments[b],
            ]
        )
    return np.array(res), forces, moments


def test_reactions_balance_loads_in_static_equilibrium(mech, solver):
    k, z = 3.0e4, 0.03
    st = solver.consistent_state(np.array([[z]]), np.array([[0.0]]))
    F_S = k * spring_z(st.q[0])
    F_T = k * RATIO**2 * z  # holds the wheel (see above)
    qdd, lam = solver.solve_augmented(
        st.q, st.qd, solver.generalized_forces(st.q, np.array([[F_S, F_T]]))
    )
    assert np.max(np.abs(qdd)) < 1e-9  # static equilibrium
    res, forces, moments = _newton_euler_residual(
        mech, solver, st.q[0], st.qd[0], qdd[0], lam[0], F_S, F_T
    )
    for b in (W, U, L):
        assert np.max(np.abs(forces[b])) < 1e-9 * F_T, mech.bodies[b].name
        assert abs(moments[b]) < 1e-9 * F_T, mech.bodies[b].name
    # the reactions are not trivially zero: the wheel joints carry the tyre load
    R = solver.joint_reactions(lam)[0]
    assert abs(R[0, 1] + R[1, 1]) == pytest.approx(F_T, rel=1e-9)  # W-U + W-L on W


def test_reactions_newton_euler_in_motion(mech, solver):
    """At a moving, loaded state every moving body obeys m a = ΣF and I φ̈ = ΣM."""
    rng = np.random.default_rng(3)
    for _ in range(5):
        z, v = rng.uniform(-0.05, 0.05), rng.uniform(-0.5, 0.5)
        F_S, F_T = rng.uniform(-3000, 3000, 2)
        st = solver.dynamics(np.array([[z]]), np.array([[v]]), np.array([[F_S, F_T]]))
        res, _, _ = _newton_euler_residual(
            mech, solver, st.q[0], st.qd[0], st.qdd[0], st.lam[0], F_S, F_T
        )
        assert np.max(np.abs(res)) < 1e-9 * 3000.0


@pytest.mark.parametrize('mechanism', ['double_wishbone', 'macpherson', 'sla_double_wishbone'])
def test_eliminations_of_eq_11_equal_the_assembled_augmented_solve(mechanism):
    """The default solve of eq. 11 (coordinate partitioning: the tangent's null space of
    C_q, then λ from the dependent rows) and the Schur complement of the diagonal M must
    give the same q̈ and λ as an LU factorization of the assembled augmented matrix, with
    and without Baumgarte terms, at many moving, loaded states."""
    from suspopt.multibody.suspension import SuspensionModule

    solver = SuspensionModule(mechanism).solver
    rng = np.random.default_rng(11)
    N = 64
    st = solver.consistent_state(rng.uniform(-0.05, 0.05, (N, 1)), rng.uniform(-1, 1, (N, 1)))
    Q = rng.uniform(-3000, 3000, (N, solver.n))
    for stab in (None, (10.0, 10.0)):
        qdd_d, lam_d = solver.solve_augmented(st.q, st.qd, Q, baumgarte=stab, method='dense')
        for method in ('partitioned', 'schur'):
            qdd, lam = solver.solve_augmented(st.q, st.qd, Q, baumgarte=stab, method=method)
            np.testing.assert_allclose(qdd, qdd_d, rtol=0.0, atol=1e-10 * np.max(np.abs(qdd_d)))
            np.testing.assert_allclose(lam, lam_d, rtol=0.0, atol=1e-10 * np.max(np.abs(lam_d)))
        default = solver.solve_augmented(st.q, st.qd, Q, baumgarte=stab)
        part = solver.solve_augmented(st.q, st.qd, Q, baumgarte=stab, method='partitioned')
        assert all(np.array_equal(a, b) for a, b in zip(default, part))
    with pytest.raises(ValueError, match='partitioned'):
        solver.solve_augmented(st.q, st.qd, Q, method='qr')


# ================================================================== error handling
def _bad(mutate):
    data = raw_data()
    mutate(data)
    return data


@pytest.mark.parametrize(
    'mutate, words',
    [
        (
            lambda d: d['joints'][0].__setitem__('bodies', ['W', 'Wheel']),
            ['joints[0].bodies', "unknown body 'Wheel'"],
        ),
        (lambda d: d['bodies'][1].__setitem__('mass', 0.0), ['bodies[1].mass', 'must be > 0']),
        (lambda d: d['bodies'][2].__setitem__('mass', -20.0), ['bodies[2].mass', 'must be > 0']),
        (
            lambda d: d['bodies'][0].__setitem__('inertia', 0.0),
            ['bodies[0].inertia', 'must be > 0'],
        ),
        (
            lambda d: d['bodies'][0].__setitem__('inertia', float('nan')),
            ['bodies[0].inertia', 'finite'],
        ),
        (
            lambda d: d['markers'][0].__setitem__('body', 'X'),
            ['markers[0].body', "unknown body 'X'"],
        ),
        (
            lambda d: d['independent'][0].__setitem__('coordinate', 'y'),
            ['independent[0].coordinate', "'y'"],
        ),
    ],
)
def test_invalid_mechanism_data_is_a_config_error(mutate, words):
    with pytest.raises(ConfigError) as err:
        mechanism_from_dict(_bad(mutate), suspension=True)
    for w in words:
        assert w in str(err.value)


def test_locked_mechanism_is_a_config_error():
    """A diagonal brace D from the U-F pivot to the W-L joint makes the parallelogram a
    truss: 0 degrees of freedom, but the file names one independent coordinate."""

    def brace(d):
        d['bodies'].append({'name': 'D', 'mass': 1.0, 'inertia': 0.01, 'position': [0.285, 0.0]})
        d['joints'] += [
            {'name': 'D-F', 'bodies': ['D', 'F'], 'point': [0.12, 0.2]},
            {'name': 'D-W', 'bodies': ['D', 'W'], 'point': [0.45, -0.2]},
        ]

    with pytest.raises(ConfigError) as err:
        PlanarMultibodySolver(mechanism_from_dict(_bad(brace), suspension=True))
    msg = str(err.value)
    assert '0 degrees of freedom' in msg and '1 independent coordinates' in msg


def test_redundant_mechanism_is_a_config_error():
    """A third parallel arm M (pivot (0.12, 0), joint on W at (0.45, 0)) is a redundant
    constraint: the equation count says 0 DOF while the linkage still moves. Naming the
    wheel travel is a count error; naming nothing leaves a singular C_q."""

    def third_arm(d):
        d['bodies'].append({'name': 'M', 'mass': 20.0, 'inertia': 0.15, 'position': [0.27, 0.0]})
        d['joints'] += [
            {'name': 'M-F', 'bodies': ['M', 'F'], 'point': [0.12, 0.0]},
            {'name': 'M-W', 'bodies': ['M', 'W'], 'point': [0.45, 0.0]},
        ]

    with pytest.raises(ConfigError, match='0 degrees of freedom'):
        PlanarMultibodySolver(mechanism_from_dict(_bad(third_arm), suspension=True))

    def third_arm_no_ind(d):
        third_arm(d)
        d['independent'] = []

    with pytest.raises(ConfigError, match='singular constraint Jacobian.*redundant'):
        PlanarMultibodySolver(mechanism_from_dict(_bad(third_arm_no_ind)))


def test_wrong_number_of_independent_coordinates_is_a_config_error():
    def two(d):
        d['independent'].append({'body': 'U', 'coordinate': 'phi'})

    with pytest.raises(ConfigError, match='exactly one independent coordinate'):
        mechanism_from_dict(_bad(two), suspension=True)
    with pytest.raises(ConfigError) as err:  # generic mechanism
        PlanarMultibodySolver(mechanism_from_dict(_bad(two)))
    assert '1 degrees of freedom' in str(err.value) and '2 independent' in str(err.value)


def test_independent_coordinate_that_cannot_drive_is_a_config_error(mech):
    """The wheel of a parallelogram never rotates: its φ cannot drive the mechanism."""
    with pytest.raises(ConfigError, match='singular constraint Jacobian'):
        PlanarMultibodySolver(dataclasses.replace(mech, independent=(('W', 'phi'),)))


def test_toggle_position_is_the_edge_of_the_range():
    """The parallelogram's arms (0.33 m) stand vertical at 0.33 m of wheel travel: there
    the arm angle rate per wheel rate, 1/(0.33 cos φ), is unbounded and the dynamics
    singular. The module refuses states where the linkage moves over 100 times faster
    than at its reference pose (cos φ < 1/100) and accepts everything short of that."""
    mod = SuspensionModule('double_wishbone')
    for z in (0.32, 0.3299, -0.3299):  # cos φ = 0.246, 0.0246: 4 and 41 times
        kin = mod.kinematics(np.array([z]), np.array([0.1]))
        assert abs(kin.q_W[0] - z) < 1e-12
    for z in (0.32999, 0.33, -0.32999):  # cos φ = 0.0078: 128 times
        with pytest.raises(MultibodyError, match='toggle'):
            mod.kinematics(np.array([0.0, z]), np.array([0.0, 0.0]))


def test_nan_and_out_of_range_inputs_are_multibody_errors(solver):
    with pytest.raises(MultibodyError, match='non-finite independent coordinate'):
        solver.positions(np.array([[np.nan]]))
    with pytest.raises(MultibodyError, match='non-finite independent coordinate'):
        solver.consistent_state(np.array([[0.0], [np.inf]]), np.array([[0.0], [0.0]]))
    with pytest.raises(MultibodyError, match='did not converge.*out of the mechanism'):
        solver.positions(np.array([[0.34]]))  # beyond the arm length 0.33 m
    with pytest.raises(MultibodyError, match='non-finite value in the augmented system'):
        solver.dynamics(np.array([[0.0]]), np.array([[0.0]]), np.array([[np.nan, 0.0]]))
    with pytest.raises(MultibodyError, match='non-finite value in the velocity analysis'):
        solver.dynamics(np.array([[0.0]]), np.array([[np.nan]]), np.array([[0.0, 0.0]]))


# ================================================================== batching
def test_batched_dynamics_equals_single_state_calls(solver):
    """N states in one call give the same result as N single calls.

    Copies of one state give bitwise the same result as the single call (no cross-talk in
    the vectorized indexing). For distinct states the agreement is only at the level of
    the Newton tolerance (newton_tol = 1e-12: measured differences up to 1.8e-12 m in q),
    not bitwise: the batched Newton loop in ``positions`` stops when the worst state has
    converged, so a state that alone would have stopped one iteration earlier (with
    |C| just below the tolerance) gets one more update in the batch.
    """
    z = np.full((5, 1), 0.0123)
    v = np.full((5, 1), 0.3)
    loads = np.tile([[1000.0, -500.0]], (5, 1))
    batch = solver.dynamics(z, v, loads)
    one = solver.dynamics(z[:1], v[:1], loads[:1])
    for name in ('q', 'qd', 'qdd', 'lam'):
        for j in range(5):
            assert np.array_equal(getattr(one, name)[0], getattr(batch, name)[j]), name

    rng = np.random.default_rng(1)
    N = 16
    z = rng.uniform(-0.05, 0.05, (N, 1))
    v = rng.uniform(-0.5, 0.5, (N, 1))
    loads = rng.uniform(-3000, 3000, (N, 2))
    batch = solver.dynamics(z, v, loads)
    tol = solver.newton_tol
    for i in range(N):
        one = solver.dynamics(z[i : i + 1], v[i : i + 1], loads[i : i + 1])
        # position error ≲ 10 newton_tol; it propagates to q̇, q̈, λ through O(1..1e3) factors
        np.testing.assert_allclose(one.q, batch.q[i : i + 1], rtol=0, atol=10 * tol)
        np.testing.assert_allclose(one.qd, batch.qd[i : i + 1], rtol=0, atol=10 * tol)
        np.testing.assert_allclose(one.qdd, batch.qdd[i : i + 1], rtol=0, atol=1e3 * tol)
        np.testing.assert_allclose(one.lam, batch.lam[i : i + 1], rtol=0, atol=1e5 * tol)
