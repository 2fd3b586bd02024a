"""The chassis-mounted multibody module (``multibody.mount = "chassis"``, issue 16).

Checks that can fail: the force on the chassis is the tyre force minus the linkage's
``Σ m_i a_i`` at every node; the chassis equations hold with the reactions queried at the
solved mount accelerations (the loop is closed); small-amplitude frequencies and damping
ratios equal a linear model derived by hand (Lagrange's equations), for both mounts;
partials, declared sparsity and the exact total sparsity; check_totals of the coupled
model; collocation against time marching.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import openmdao.api as om
import pytest

from suspopt.models import equations as eq
from suspopt.multibody.suspension import SuspensionModule
from suspopt.spec.load import config_from_dict, full_car_defaults
from suspopt.verification.timemarching import VehicleRHS

#: double wishbone of docs/model.md / paper Table 2, by hand: arm length (pivot to pivot), the
#: arm CG's and the spring point's distance from the frame pivot
ARM, ARM_CG = 0.45 - 0.12, 0.27 - 0.12
M_W, M_ARM, I_ARM = 80.0, 20.0, 0.15


def with_mount(cfg, mount: str, **kw):
    return cfg.replace(multibody=dataclasses.replace(cfg.multibody, mount=mount, **kw))


def random_kinematics(mod: SuspensionModule, n: int, seed: int, roll: bool):
    rng = np.random.default_rng(seed)
    z, v = rng.uniform(-0.05, 0.05, n), rng.uniform(-0.5, 0.5, n)
    pose = (
        rng.uniform(-0.02, 0.02, n),
        rng.uniform(-0.3, 0.3, n),
        rng.uniform(-0.03, 0.03, n) if roll else np.zeros(n),
        rng.uniform(-0.4, 0.4, n) if roll else np.zeros(n),
    )
    kin = mod.kinematics(z + pose[0], v + pose[1], pose=pose)
    k, c = rng.uniform(1e4, 5e4, n), rng.uniform(1e3, 5e3, n)
    return kin, k, c, rng.uniform(-3000.0, 3000.0, n), rng


def linkage_balance(mod: SuspensionModule, kin, k, c, F_T, acc):
    """Σ m_i a_i of the linkage's bodies (the frame excluded) and the tyre force's and
    their moments about P, from the solver's accelerations at mount accelerations
    ``acc`` (N, 2): what the linkage must apply on the chassis by Newton-Euler."""
    s = mod.solver
    N = k.size
    loads = np.zeros((N, len(s.load_names)))
    loads[:, mod.tyre_load] = F_T
    Q = s.generalized_forces(
        kin.state.q, loads, kin.state.qd, {mod.spring_name: {'stiffness': k, 'damping': c}}
    )
    fr = mod.frame_accelerations(kin.pose)
    a_F = fr[0] + acc[:, :1] * fr[1] + acc[:, 1:] * fr[2]
    qdd, _ = s.solve_augmented(
        kin.state.q, kin.state.qd, Q, Cq=kin.state.Cq, motion=mod.mount_motion(kin.pose, a_F)
    )
    m = s.mass_diag.reshape(-1, 3)
    q3, a3 = kin.state.q.reshape(N, -1, 3), qdd.reshape(N, -1, 3)
    P = np.stack([np.full(N, mod.mount_point[0]), mod.mount_point[1] + kin.pose[0]], -1)
    patch = s.marker_names.index('contact_patch')
    r_T = s.marker_positions(kin.state.q)[:, patch] - P
    F = np.stack([np.zeros(N), F_T], -1)
    M = r_T[:, 0] * F_T
    for i, name in enumerate(s.body_names):
        if name == mod.frame:
            continue
        ma = m[i, 0] * a3[:, i, :2]
        F = F - ma
        r = q3[:, i, :2] - P
        M = M - (m[i, 2] * a3[:, i, 2] + r[:, 0] * ma[:, 1] - r[:, 1] * ma[:, 0])
    return F, M


# ------------------------------------------------------------------ the module itself
@pytest.mark.parametrize('mechanism', ['double_wishbone', 'sla_double_wishbone', 'macpherson'])
@pytest.mark.parametrize('roll', [False, True])
def test_force_on_chassis_is_tyre_force_minus_linkage_inertia(mechanism, roll):
    """At random states, mount poses and mount accelerations: the force (x, z) and the
    moment about P the module reports on the chassis equal F_T minus Σ m_i a_i of the
    linkage's bodies (and their moments), to 1e-9 of the tyre force; the response at an
    acceleration is the affine combination of the reported blocks."""
    mod = SuspensionModule(mechanism, mount='chassis')
    kin, k, c, F_T, rng = random_kinematics(mod, 40, 1, roll)
    acc = np.stack([rng.uniform(-5, 5, 40), rng.uniform(-3, 3, 40) if roll else np.zeros(40)], -1)
    blocks, _ = mod.mount_response(kin, k, c, F_T, rotation=True)
    at, _ = mod.mount_response(kin, k, c, F_T, acceleration=acc)
    affine = eq.mount_response(blocks[:, None], acc[:, None])[:, 0]
    scale = np.max(np.abs(F_T))
    assert np.max(np.abs(at[:, 0] - affine)) < 1e-9 * np.max(np.abs(at[:, 0]))
    F, M = linkage_balance(mod, kin, k, c, F_T, acc)
    err_z = np.max(np.abs(at[:, 0, 1] - F[:, 1])) / scale
    err_x = np.max(np.abs(at[:, 0, 3] - F[:, 0])) / scale
    err_m = np.max(np.abs(at[:, 0, 2] - M)) / scale
    print(
        f'\n{mechanism}, roll {roll}: |F_z - (F_T - Σ m a_z)| = {err_z:.1e} F_T, '
        f'x {err_x:.1e}, moment about P {err_m:.1e} F_T·m'
    )
    assert max(err_z, err_x, err_m) < 1e-9


def test_chassis_side_reactions_add_up_to_the_force_on_the_chassis():
    """The force on the chassis is the sum of the chassis-side joints' reactions (the
    reported reactions on each joint's first body, reversed) and the spring's force on
    its chassis end (F_S); the frame's own mass changes nothing."""
    mod = SuspensionModule('double_wishbone', mount='chassis')
    kin, k, c, F_T, rng = random_kinematics(mod, 30, 2, False)
    acc = np.stack([rng.uniform(-5, 5, 30), np.zeros(30)], -1)
    R, F_S = mod.mount_response(kin, k, c, F_T, acceleration=acc)
    joints = R[:, 0, 4:].reshape(30, -1, 2)
    on_frame = [i for i, b in enumerate(mod.solver.joint_bodies[: mod.n_joints]) if b[1] == 'F']
    assert [mod.solver.joint_names[i] for i in on_frame] == ['U-F', 'L-F']
    F_z = -joints[:, on_frame, 1].sum(axis=1) + F_S
    np.testing.assert_allclose(R[:, 0, 1], F_z, rtol=0, atol=1e-9 * np.max(np.abs(F_T)))
    heavy = dataclasses.replace(
        mod.mechanism,
        bodies=tuple(
            dataclasses.replace(b, mass=50.0 * b.mass, inertia=9.0) if b.name == 'F' else b
            for b in mod.mechanism.bodies
        ),
    )
    other = SuspensionModule(
        dataclasses.replace(
            heavy,
            joints=heavy.joints[:-1],
            bodies=tuple(
                dataclasses.replace(b, fixed=True) if b.name == 'F' else b for b in heavy.bodies
            ),
        ),
        mount='chassis',
    )
    kin2 = other.kinematics(kin.q_W, kin.qd_W, pose=kin.pose)
    R2, _ = other.mount_response(kin2, k, c, F_T, acceleration=acc)
    np.testing.assert_allclose(R2, R, rtol=0, atol=1e-9 * np.max(np.abs(R)))


# ------------------------------------------------------------------ small amplitude
def hand_linear_model(cfg, design: dict[str, float], mount: str):
    """Mass, damping and stiffness matrices of the half car with the double wishbone at
    both axles, small amplitude, by Lagrange's equations in (z_C, θ_C, s_1, s_2), ``s``
    the wheel's travel relative to the frame (= its absolute travel with the frame fixed).

    The linkage is a parallelogram: at the reference pose the wheel translates
    vertically, each arm turns at ṡ/ARM and its CG (and the spring point, the upper arm's
    CG) rises at r ṡ, r = ARM_CG / ARM. Per axle: T = ½ m_e ṡ² + (chassis mount) the
    linkage carried by the mount, ½ m_L ż_M² + c_m ż_M ṡ, with m_e = m_W + 2 (m_arm r² +
    I_arm / ARM²), c_m = m_W + 2 m_arm r, m_L = m_W + 2 m_arm. V and the dissipation:
    chassis mount ½ k (r s)² + ½ k_T (z_M + s)², ½ c (r ṡ)²; ground mount (eq. 12)
    ½ k (r s - z_M)² + ½ k_T s², ½ c (r ṡ - ż_M)²."""
    v = cfg.vehicle
    r = ARM_CG / ARM
    m_e = M_W + 2 * (M_ARM * r**2 + I_ARM / ARM**2)
    c_m, m_L = M_W + 2 * M_ARM * r, M_W + 2 * M_ARM
    Mm = np.diag([v.chassis_mass, v.chassis_pitch_inertia, 0.0, 0.0])
    K, C = np.zeros((4, 4)), np.zeros((4, 4))
    for i, (ax, k, c) in enumerate(
        zip(v.axles, (design['k_S1'], design['k_S2']), (design['c_S1'], design['c_S2']))
    ):
        e = np.array([1.0, -ax.axle_position, 0.0, 0.0])  # z_M
        f = np.zeros(4)
        f[2 + i] = 1.0  # s_i
        Mm += m_e * np.outer(f, f)
        if mount == 'chassis':
            Mm += m_L * np.outer(e, e) + c_m * (np.outer(e, f) + np.outer(f, e))
            K += k * r**2 * np.outer(f, f) + ax.tyre_stiffness * np.outer(e + f, e + f)
            C += c * r**2 * np.outer(f, f)
        else:
            K += k * np.outer(r * f - e, r * f - e) + ax.tyre_stiffness * np.outer(f, f)
            C += c * np.outer(r * f - e, r * f - e)
    return Mm, C, K, m_e


def modes(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Natural frequencies [Hz] and damping ratios of the first-order system matrix A."""
    lam = np.linalg.eigvals(A)
    lam = lam[lam.imag > 0]
    lam = lam[np.argsort(np.abs(lam))]
    return np.abs(lam) / (2 * np.pi), -lam.real / np.abs(lam)


def linearized_rhs(cfg, design, h: float = 1e-5) -> np.ndarray:
    """The time-marching right-hand side of the multibody model at rest, by central
    differences over its 8 motion states (road flat at t = 0)."""
    rhs = VehicleRHS(cfg, 'mixed', design, cfg.scenarios()[0])
    n = 8
    A = np.zeros((n, n))
    y0 = np.zeros(n + len(cfg.terms()))
    for j in range(n):
        yp, ym = y0.copy(), y0.copy()
        yp[j], ym[j] = h, -h
        A[:, j] = (rhs(0.0, yp)[:n] - rhs(0.0, ym)[:n]) / (2 * h)
    return A


@pytest.mark.parametrize('mount', ['chassis', 'ground'])
def test_small_amplitude_modes_equal_the_hand_derived_linear_model(cfg, mount):
    """Natural frequencies and damping ratios of the multibody half car at rest (its
    time-marching right-hand side linearized by central differences) equal those of the
    linear model derived by hand, to 1e-6 relative; with the frame fixed the wheel's
    effective mass is 91.0 kg."""
    design = {'k_S1': 35000.0, 'k_S2': 22000.0, 'c_S1': 2800.0, 'c_S2': 1900.0}
    Mm, C, K, m_e = hand_linear_model(cfg, design, mount)
    assert m_e == pytest.approx(91.0, abs=0.05)
    Minv = np.linalg.inv(Mm)
    A_hand = np.block([[np.zeros((4, 4)), np.eye(4)], [-Minv @ K, -Minv @ C]])
    f_hand, zeta_hand = modes(A_hand)
    f_mb, zeta_mb = modes(linearized_rhs(with_mount(cfg, mount), design))
    df, dz = np.max(np.abs(f_mb / f_hand - 1)), np.max(np.abs(zeta_mb / zeta_hand - 1))
    print(
        f'\n{mount} mount: f [Hz] {np.round(f_mb, 4)}, zeta {np.round(zeta_mb, 4)}; '
        f'largest relative difference to the hand model: f {df:.1e}, zeta {dz:.1e}'
    )
    np.testing.assert_allclose(f_mb, f_hand, rtol=1e-6)
    np.testing.assert_allclose(zeta_mb, zeta_hand, rtol=1e-6)


# ------------------------------------------------------------------ the black boxes
POSE = {'z_M': 0.02, 'v_M': 0.3, 'psi_M': 0.03, 'w_M': 0.4}


def blackbox_problem(Comp, nn: int, roll: bool, seed: int = 0):
    from suspopt.multibody.components import ChassisMountDynamicsComp

    mod = SuspensionModule('double_wishbone', mount='chassis')
    p = om.Problem(reports=False)
    opts = {} if Comp is ChassisMountDynamicsComp else {'mount': 'chassis'}
    comp = p.model.add_subsystem(
        'c', Comp(num_nodes=nn, corners=1, modules=(mod,), roll=roll, **opts), promotes=['*']
    )
    p.setup()
    rng = np.random.default_rng(seed)
    ins = list(comp.list_inputs(out_stream=None, prom_name=False, return_format='dict'))
    x = {}
    for name in ins:
        lo, hi = {'k_S': (1e4, 5e4), 'c_S': (1e3, 5e3)}.get(name, (None, None))
        if lo is not None:
            x[name] = rng.uniform(lo, hi, 1)
        else:
            r = {'z_W': 0.05, 'v_W': 0.5, 'F_T': 3000.0, **POSE}[name]
            x[name] = rng.uniform(-r, r, (nn, 1))
    for name, val in x.items():
        p.set_val(name, val)
    p.run_model()
    outs = list(comp.list_outputs(out_stream=None, prom_name=False, return_format='dict'))
    return p, comp, x, ins, outs


def reference_jacobian(comp, x, ins, outs, h=1e-5):
    """Central differences of the component's own evaluate(), one entry at a time."""
    J = {}
    for w in ins:
        hw = h * max(1.0, float(np.max(np.abs(x[w])))) if w in ('k_S', 'c_S') else h
        for j in range(x[w].size):
            xp = {k: np.array(v, dtype=float) for k, v in x.items()}
            xm = {k: np.array(v, dtype=float) for k, v in x.items()}
            xp[w].flat[j] += hw
            xm[w].flat[j] -= hw
            fp, fm = comp.evaluate(xp), comp.evaluate(xm)
            for o in outs:
                J.setdefault((o, w), []).append((fp[o] - fm[o]).ravel() / (2 * hw))
    return {k: np.stack(v, axis=-1) for k, v in J.items()}


@pytest.mark.parametrize('roll', [False, True])
@pytest.mark.parametrize('kind', ['kinematics', 'dynamics'])
def test_chassis_mounted_black_boxes_fd_and_sparsity(kind, roll):
    """The chassis-mounted black boxes: their FD partials (forward, inside
    compute_partials) equal independent central differences (1e-4 of each block), the
    true Jacobian is node-diagonal, and one Jacobian costs one black-box call per input."""
    from suspopt.multibody.components import ChassisMountDynamicsComp, SuspensionKinematicsComp

    Comp = SuspensionKinematicsComp if kind == 'kinematics' else ChassisMountDynamicsComp
    nn = 6
    p, comp, x, ins, outs = blackbox_problem(Comp, nn, roll)
    assert set(POSE if roll else ('z_M', 'v_M')) <= set(ins)
    calls = [0]
    evaluate = comp.evaluate

    def counting(values):
        calls[0] += 1
        return evaluate(values)

    comp.evaluate = counting
    solver = comp.options['modules'][0].solver
    before = dict(solver.calls)
    J = p.compute_totals(of=outs, wrt=ins, return_format='dict')
    assert calls[0] == len(ins)
    # one factorization per pose the differences visit (wheel travel, mount height and
    # rotation moved), none again at the base pose between them
    new = {k: solver.calls[k] - before[k] for k in ('positions', 'factorizations')}
    assert new['factorizations'] == new['positions'] == (3 if roll else 2), new
    comp.evaluate = evaluate
    ref = reference_jacobian(comp, x, ins, outs)
    for (o, w), R in ref.items():
        A = np.asarray(J[o][w])
        scale = max(np.max(np.abs(R)), 1e-6 * max(np.max(np.abs(ref[o, v])) for v in ins))
        assert np.max(np.abs(A - R)) <= 1e-4 * scale, (o, w, np.max(np.abs(A - R)) / scale)
        if w not in ('k_S', 'c_S'):  # node-wise: off-diagonal node blocks exactly zero
            mask = np.zeros((nn, R.shape[0] // nn, nn), dtype=bool)
            mask[np.arange(nn), :, np.arange(nn)] = True
            assert np.all(R[~mask.reshape(R.shape)] == 0.0), (o, w)


# ------------------------------------------------------------------ in the vehicle model
X0 = {'k_S1': 32000.0, 'k_S2': 21000.0, 'c_S1': 2600.0, 'c_S2': 2200.0}


@pytest.fixture(scope='module')
def chassis_problem(cfg, scales):
    """The half car with chassis-mounted modules on a 4 × 3 grid, run at the half
    car's time-marching trajectory (a non-converged point: every node differs)."""
    from suspopt.transcription.problem import VehicleProblem
    from suspopt.verification.timemarching import simulate

    small = with_mount(
        cfg.replace(transcription=dataclasses.replace(cfg.transcription, segments=4, order=3)),
        'chassis',
    )
    with VehicleProblem(small, 'mixed', scales) as vp:
        vp.set_design(X0)
        vp.set_initial_guess(simulate(small, 'low', X0, rtol=1e-6, atol=1e-9))
        vp.problem.run_model()
        yield vp


def test_force_balance_and_closed_loop_at_every_node(chassis_problem):
    """At every node of the collocation model: the vertical force on the chassis F_M
    equals the tyre force minus the linkage's Σ m a_z, computed from the module queried
    at the mount acceleration the chassis equations produced (1e-9 of the tyre force); and
    the chassis equations hold with those forces (the loop is closed: 1e-9)."""
    vp = chassis_problem
    p, cfg = vp.problem, vp.config
    get = lambda name: np.asarray(p.get_val(f'traj.s0.rhs_all.{name}'))  # noqa: E731
    mod = vp.modules['double_wishbone']
    lay = cfg.layout()
    zdd_C, thdd_C = get('zdd_C'), get('thdd_C')
    F_M, F_T = get('F_M'), get('F_T')
    k, c = get('k_S'), get('c_S')
    nn = zdd_C.size
    worst = 0.0
    for i, corner in enumerate(lay.corners):
        pose = (get('z_M')[:, i], get('v_M')[:, i], np.zeros(nn), np.zeros(nn))
        kin = mod.kinematics(get('z_W')[:, i], get('v_W')[:, i], pose=pose)
        acc = np.stack([zdd_C - corner.a * thdd_C, np.zeros(nn)], -1)
        F, _ = linkage_balance(mod, kin, np.full(nn, k[i]), np.full(nn, c[i]), F_T[:, i], acc)
        worst = max(worst, np.max(np.abs(F_M[:, i] - F[:, 1])) / np.max(np.abs(F_T)))
    v = cfg.vehicle
    heave = np.max(np.abs(v.chassis_mass * zdd_C - F_M.sum(1))) / np.max(np.abs(F_M))
    pitch = np.max(np.abs(v.chassis_pitch_inertia * thdd_C + F_M @ lay.a)) / np.max(
        np.abs(F_M @ lay.a)
    )
    print(
        f'\n{nn} nodes: |F_M - (F_T - Σ m a_z)| <= {worst:.1e} F_T; chassis equations '
        f'with those forces: heave {heave:.1e}, pitch {pitch:.1e}'
    )
    assert np.max(np.abs(F_T)) > 100.0 and np.max(np.abs(zdd_C)) > 0.1
    assert worst < 1e-9 and heave < 1e-9 and pitch < 1e-9


def test_check_totals_of_the_coupled_nlp(chassis_problem):
    """OpenMDAO's check_totals on the NLP functions (objective and defects) w.r.t. the
    design and the states, at the non-converged point: the MAUD assembly of the analytic
    partials (the closed loop included) and the black boxes' FD partials."""
    vp = chassis_problem
    lay = vp.driver.layout()
    of = ['objective.f'] + [c.name for c in lay.constraints]
    wrt = [v.name for v in lay.design_vars]
    data = vp.problem.check_totals(
        of=of,
        wrt=wrt,
        method='fd',
        form='central',
        step=1e-4,
        step_calc='rel_avg',
        out_stream=None,
        driver_scaling=False,
    )
    worst = {}
    for (_o, w), d in data.items():
        J_fd, J_an = np.asarray(d['J_fd']), np.asarray(d.get('J_fwd', d.get('J_rev')))
        scale = np.max(np.abs(J_fd))
        if scale > 0.0:
            kind = 'design' if 'parameters' in w else 'states'
            worst[kind] = max(worst.get(kind, 0.0), np.max(np.abs(J_an - J_fd)) / scale)
    print(f"\ncheck_totals: largest difference of each block's largest entry {worst}")
    assert set(worst) == {'design', 'states'}
    assert max(worst.values()) < 1e-4


def test_frame_follows_the_chassis_on_both_sides_of_a_rolling_car():
    """Mirroring of the planar model (x outboard): on a full car in heave, pitch and roll,
    every frame point of a left and of a right corner's module moves vertically with the
    chassis point at its lateral position, y = y_c + side (x - x_P), z_C - a θ + y φ
    (small angles: to first order in φ)."""
    from suspopt.models.forces import MountMotionComp
    from suspopt.models.mount import MountRotationComp

    full = full_car_defaults()
    lay = full.layout()
    mod = SuspensionModule('double_wishbone', mount='chassis')
    s = mod.solver
    phi = 1e-4
    values = {
        'z_C': np.array([0.01]),
        'theta_C': np.array([0.002]),
        'phi_C': np.array([phi]),
        'v_C': np.zeros(1),
        'omega_C': np.zeros(1),
        'p_C': np.zeros(1),
    }
    kw = {'num_nodes': 1, 'corners': lay.n}  # the vehicle assembly's own equations
    motion = MountMotionComp(a=lay.a, y=lay.y, roll=True, **kw).evaluate(values)
    rotation = MountRotationComp(side=np.array([c.side for c in lay.corners]), **kw).evaluate(
        values
    )
    poses = (motion['z_M'], motion['v_M'], rotation['psi_M'], rotation['w_M'])
    mk = s.marker_names.index('spring_mount')
    x_mount = s.marker_reference()[mk, 0]
    assert x_mount < mod.mount_point[0]  # inboard of the wheel
    for c, corner in enumerate(lay.corners):
        pose = tuple(p[:, c] for p in poses)
        kin = mod.kinematics(pose[0], np.zeros(1), pose=pose)
        dz = s.marker_positions(kin.state.q)[0, mk, 1] - s.marker_reference()[mk, 1]
        y = corner.y + corner.side * (x_mount - mod.mount_point[0])
        expected = 0.01 - corner.a * 0.002 + y * phi
        # second order: the 0.5 m high mount point turns by ψ, ½ ψ² 0.5 m ≈ 2.5e-9 m
        assert abs(dz - expected) < 1e-8, (corner.label, dz, expected)
        mirrored_wrong = expected - 2 * corner.side * (x_mount - mod.mount_point[0]) * phi
        assert corner.side == 0 or abs(dz - mirrored_wrong) > 5e-6


@pytest.fixture(scope='module')
def full_chassis_problem(scales):
    """The default full car (bars) with chassis-mounted modules on a 3-segment grid, run at
    a state guess of its half-car-like time marching (non-converged)."""
    from suspopt.transcription.problem import VehicleProblem
    from suspopt.verification.timemarching import simulate

    full = full_car_defaults()
    full = with_mount(
        config_from_dict(
            {
                **full.to_dict(),
                'maneuver': {'horizon': 1.0},
                'objective': {
                    'normalization': 'custom',
                    'scales': dict.fromkeys(full.terms(), 1.0),
                },
            }
        ),
        'chassis',
    )
    # a structure test: 3 segments (too coarse for results, refused in a study file)
    full = full.replace(transcription=dataclasses.replace(full.transcription, segments=3))
    with VehicleProblem(full, 'mixed', (dict.fromkeys(full.terms(), 1.0),)) as vp:
        vp.set_initial_guess(simulate(full, 'low', rtol=1e-6, atol=1e-9))
        vp.problem.run_model()
        yield vp


def test_full_car_roll_balance_at_every_node(full_chassis_problem):
    """Full car with anti-roll bars: at every node the chassis' heave, pitch and roll
    equations hold with every module's force F_z and moment about P queried at the solved
    mount accelerations (roll moment y_c (F_z + F_R) + side M_P), to 1e-9."""
    vp = full_chassis_problem
    p, cfg = vp.problem, vp.config
    get = lambda name: np.asarray(p.get_val(f'traj.s0.rhs_all.{name}'))  # noqa: E731
    lay = cfg.layout()
    acc = np.stack([get('zdd_C'), get('thdd_C'), get('phidd_C')], -1)
    L = eq.mount_map(lay.a, lay.y, [c.side for c in lay.corners], True)
    a_M = eq.mount_accelerations(acc, L)
    F_W, F_R, F_M = get('F_W'), get('F_R'), get('F_M')
    nn = acc.shape[0]
    Q = np.zeros((nn, 3))
    for i, corner in enumerate(lay.corners):
        mod = vp.modules[cfg.vehicle.axles[corner.axle].mechanism]
        pose = (get('z_M')[:, i], get('v_M')[:, i], get('psi_M')[:, i], get('w_M')[:, i])
        kin = mod.kinematics(get('z_W')[:, i], get('v_W')[:, i], pose=pose)
        F, M = linkage_balance(
            mod, kin, np.full(nn, get('k_S')[i]), np.full(nn, get('c_S')[i]), F_W[:, i], a_M[:, i]
        )
        np.testing.assert_allclose(F_M[:, i], F[:, 1], rtol=0, atol=1e-9 * np.max(np.abs(F_W)))
        Fz = F[:, 1] + F_R[:, i]
        Q += np.stack([Fz, -corner.a * Fz, corner.y * Fz + corner.side * M], -1)
    v = cfg.vehicle
    inertia = np.array([v.chassis_mass, v.chassis_pitch_inertia, v.chassis_roll_inertia])
    err = np.max(np.abs(inertia * acc - Q), axis=0) / np.max(np.abs(Q), axis=0)
    print(f'\nfull car, {nn} nodes: heave, pitch, roll residuals {err}')
    assert np.all(np.max(np.abs(acc), axis=0) > 0.0) and np.all(err < 1e-9)


# ------------------------------------------------------------------ end to end (slow)
@pytest.mark.slow
def test_reduced_gradient_matches_fd_of_the_converged_coupled_model(cfg, scales):
    """df/dx of the converged chassis-mounted model (its NLP's total Jacobian: the MAUD
    assembly of analytic partials, the closed loop and the black boxes' forward FD)
    against central differences of converged collocation solutions (to 1e-13): 1e-5."""
    from test_mixed_fidelity import _reduced_gradient

    from suspopt.transcription.problem import VehicleProblem
    from suspopt.verification.timemarching import simulate

    base = with_mount(
        cfg.replace(
            transcription=dataclasses.replace(cfg.transcription, segments=30),
            optimizer=dataclasses.replace(
                cfg.optimizer, tol=1e-13, options={'constr_viol_tol': 1e-14}
            ),
        ),
        'chassis',
    )
    with VehicleProblem(base, 'mixed', scales, optimize_design=False) as vp:
        vp.set_design(X0)
        vp.set_initial_guess(simulate(base, 'low', X0, rtol=1e-7, atol=1e-10))
        assert vp.solve(optimize=False).success
        grad = _reduced_gradient(vp)
        fd = []
        for name in vp.design_names:
            h = 1e-4 * X0[name]
            vals = []
            for sign in (1.0, -1.0):
                vp.set_design({**X0, name: X0[name] + sign * h})
                assert vp.solve(optimize=False).success
                vals.append(vp.objective())
            fd.append((vals[0] - vals[1]) / (2 * h))
    print(
        f'\nreduced gradient vs central differences of the converged model: '
        f'{np.max(np.abs(grad / np.array(fd) - 1)):.1e}'
    )
    np.testing.assert_allclose(grad, fd, rtol=1e-5)


@pytest.mark.slow
def test_collocation_matches_time_marching_on_the_default_grid(cfg, scales):
    """The chassis-mounted model on the default 80 × 5 grid at the initial design: every
    J_k within 0.1 % of time marching; the multibody constraints hold (1e-10 m)."""
    from suspopt.studies.run import evaluate

    res = evaluate(with_mount(cfg, 'chassis'), 'mixed', scales=scales)
    v = res.verification.comparison
    print(f'\ncollocation vs time marching: {v.max_rel_diff:.1e} ({v.scenarios[0].worst_term})')
    assert res.verified and v.max_rel_diff < 1e-3
    assert res.max_constraint_residual_m < 1e-10
    assert v.scenarios[0].max_constraint_residual_m < 1e-10


@pytest.mark.slow
def test_coupling_command_table_and_report(tmp_path, capsys):
    """`suspopt coupling` on a 1 s horizon (the first bump under both wheels): 4
    designs × 3 models, every cell by collocation and verified by time marching; each
    optimum is the best design in its own model; the paper's coupling and the
    consistent one give different optima; `suspopt report` re-renders the table."""
    import json

    from suspopt.cli.main import main

    study = tmp_path / 'short.toml'
    study.write_text('[maneuver]\nhorizon = 1.0\n[transcription]\nsegments = 16\n')
    out = tmp_path / 'coupling'
    assert main(['coupling', '--config', str(study), '--out', str(out), '--quiet']) == 0
    res = json.loads((out / 'coupling.json').read_text())
    assert res['complete'] and res['verified'] is True
    ev = res['evaluations']
    assert {m: sorted(v) for m, v in ev.items()} == {
        m: sorted(['initial', 'low_optimum', 'ground_optimum', 'chassis_optimum'])
        for m in ('low', 'ground', 'chassis')
    }
    assert all(e['verified'] for v in ev.values() for e in v.values())
    for model in ('low', 'ground', 'chassis'):
        own = ev[model][f'{model}_optimum']['objective']
        assert all(own <= e['objective'] * (1 + 1e-6) for e in ev[model].values()), model
    g, c = res['designs']['ground_optimum'], res['designs']['chassis_optimum']
    assert max(abs(c[n] / g[n] - 1) for n in g) > 0.05
    table = (out / 'table.md').read_text()
    assert 'multibody, chassis mount' in table and 'What the coupling assumption moves' in table
    assert (out / 'figures' / 'coupling.png').stat().st_size > 0
    (out / 'table.md').unlink()
    assert main(['report', str(out)]) == 0
    assert (out / 'table.md').read_text() == table
