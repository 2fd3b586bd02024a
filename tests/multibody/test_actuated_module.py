"""An actuator in parallel with a linkage's spring-damper (``docs/codesign.md``): the
full augmented solve (the force as a change of the spring's tension) against the reduced
model (the force added to its affine answers), for every shipped mechanism and both
mounts; the chassis receives ``u e_z`` more; the spring's compression rate against a
difference of its length along the motion; the black-box components' new inputs and
outputs, differenced node-wise."""

from __future__ import annotations

import numpy as np
import pytest
from test_reduced_module import agree, modules, states

from suspopt.multibody.components import (
    ChassisMountDynamicsComp,
    SuspensionDynamicsComp,
    SuspensionKinematicsComp,
)
from suspopt.multibody.mechanism import builtin_mechanisms

MECHANISMS = builtin_mechanisms()


def forces(N: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-3e3, 3e3, N)


@pytest.mark.parametrize('name', MECHANISMS)
def test_ground_mount_actuator_full_and_reduced_agree(name):
    full, red = modules(name, 'ground')
    z, v, z_M, v_M, k, c, F_T, *_ = states(30, seed=11)
    u = forces(30, 12)
    kf, kr = full.kinematics(z, v), red.kinematics(z, v)
    a0, F0, _ = full.dynamics(kf.state, z_M, v_M, k, c, F_T)
    af, Ff, _ = full.dynamics(kf.state, z_M, v_M, k, c, F_T, actuator=u)
    ar, Fr, _ = red.dynamics(kr.state, z_M, v_M, k, c, F_T, actuator=u)
    agree(ar, af, 'wheel-travel acceleration with an actuator')
    agree(Fr, Ff, 'F_S with an actuator')
    # the chassis receives the actuator's vertical component more
    agree(Ff - F0, u * full.axis_vertical(kf.state), 'the actuator on the chassis')
    assert np.max(np.abs(af - a0)) > 1e-3 * np.max(np.abs(a0))  # it moves the wheel


def test_a_vertical_strut_passes_the_actuator_force_unchanged():
    """The paper's double wishbone has a vertical spring (eq. 12): the chassis gets ``u``."""
    full, _ = modules('double_wishbone', 'ground')
    z, v, z_M, v_M, k, c, F_T, *_ = states(10, seed=13)
    u = forces(10, 14)
    kin = full.kinematics(z, v)
    F0 = full.dynamics(kin.state, z_M, v_M, k, c, F_T)[1]
    F1 = full.dynamics(kin.state, z_M, v_M, k, c, F_T, actuator=u)[1]
    np.testing.assert_allclose(F1 - F0, u, rtol=1e-12, atol=1e-9)


@pytest.mark.parametrize('roll', [False, True])
@pytest.mark.parametrize('name', MECHANISMS)
def test_chassis_mount_actuator_full_and_reduced_agree(name, roll):
    full, red = modules(name, 'chassis')
    z, v, z_M, v_M, k, c, F_T, psi, w = states(30, seed=15, lo=-0.07, hi=0.07, roll=roll)
    pose = (z_M, v_M, psi, w)
    z = z + z_M
    u = forces(30, 16)
    kf, kr = full.kinematics(z, v, pose=pose), red.kinematics(z, v, pose=pose)
    R0, F0 = full.mount_response(kf, k, c, F_T, rotation=roll)
    Rf, Ff = full.mount_response(kf, k, c, F_T, rotation=roll, actuator=u)
    Rr, Fr = red.mount_response(kr, k, c, F_T, rotation=roll, actuator=u)
    for b in range(Rr.shape[1]):
        for j in range(4):
            agree(Rr[:, b, j], Rf[:, b, j], f'entry {j}, block {b}, with an actuator')
    agree(Fr, Ff, 'F_S with an actuator')
    assert np.max(np.abs(Rf[:, 0, 0] - R0[:, 0, 0])) > 1e-3 * np.max(np.abs(R0[:, 0, 0]))
    acc = np.random.default_rng(17).normal(0.0, 5.0, (30, 2))
    Rf, _ = full.mount_response(kf, k, c, F_T, acceleration=acc, actuator=u)
    Rr, _ = red.mount_response(kr, k, c, F_T, acceleration=acc, actuator=u)
    for j in range(4):
        agree(Rr[:, 0, j], Rf[:, 0, j], f'entry {j} at mount accelerations, with an actuator')


@pytest.mark.parametrize('mount', ['ground', 'chassis'])
@pytest.mark.parametrize('name', MECHANISMS)
def test_strut_rate_is_the_springs_compression_rate(name, mount):
    """Against a central difference of the spring's length along the motion (positions
    only), less the chassis end's motion along the line on the ground mount; the reduced
    module agrees with the full one."""
    full, red = modules(name, mount)
    roll = mount == 'chassis'
    z, v, z_M, v_M, *_, psi, w = states(12, seed=18, lo=-0.06, hi=0.06, roll=roll)
    if roll:
        z = z + z_M
    pose = (z_M, v_M, psi, w) if roll else None
    kf = full.kinematics(z, v, pose=pose)
    rate = full.strut_rate(kf, None if roll else v_M)
    agree(red.strut_rate(red.kinematics(z, v, pose=pose), None if roll else v_M), rate, 'v_A')
    h = 1e-6

    def length(dt: float) -> np.ndarray:
        moved = None if pose is None else (z_M + v_M * dt, v_M, psi + w * dt, w)
        kin = full.kinematics(z + v * dt, v, pose=moved)
        return full.solver.spring(full.spring_name, kin.state.q).length

    ell_dot = (length(h) - length(-h)) / (2.0 * h)
    expected = -ell_dot
    if not roll:
        expected = expected - full.axis_vertical(kf.state) * v_M
    agree(rate, expected, 'compression rate against the length difference', tol=1e-6)


def _component_problem(comp, seed: int = 0):
    import openmdao.api as om

    p = om.Problem(reports=False)
    p.model.add_subsystem('comp', comp)
    p.setup()
    rng = np.random.default_rng(seed)
    shapes = {
        n: m['shape']
        for n, m in comp.list_inputs(
            out_stream=None, prom_name=False, shape=True, return_format='dict'
        ).items()
    }
    for name, shape in shapes.items():
        val = {
            'z_W': rng.uniform(-0.05, 0.05, shape),
            'v_W': rng.uniform(-1.0, 1.0, shape),
            'z_M': rng.uniform(-0.02, 0.02, shape),
            'v_M': rng.uniform(-0.5, 0.5, shape),
            'F_T': rng.uniform(-2e3, 2e3, shape),
            'F_A': rng.uniform(-1e3, 1e3, shape),
            'k_S': rng.uniform(2e4, 4e4, shape),
            'c_S': rng.uniform(1e3, 3e3, shape),
        }.get(name, np.zeros(shape))
        p.set_val(f'comp.{name}', val)
    p.run_model()
    return p


@pytest.mark.parametrize(
    'make',
    [
        lambda mods: SuspensionKinematicsComp(
            num_nodes=4, corners=2, modules=mods, strut_rate=True, fd_form='central'
        ),
        lambda mods: SuspensionDynamicsComp(
            num_nodes=4, corners=2, modules=mods, actuator=True, fd_form='central'
        ),
    ],
    ids=['kinematics_strut_rate', 'dynamics_actuator'],
)
def test_black_box_components_difference_the_new_signals(make):
    """The new node-wise input (F_A) and output (v_A) are differenced like the others:
    the component's own partials against OpenMDAO's central differences."""
    full, _ = modules('double_wishbone', 'ground')
    comp = make((full, full))
    p = _component_problem(comp)
    data = p.check_partials(
        method='fd', form='central', step=1e-6, out_stream=None, compact_print=True
    )
    for (of, wrt), d in data['comp'].items():
        if of == 'reactions':
            continue
        err = d['rel error'].forward if hasattr(d['rel error'], 'forward') else d['rel error']
        J = d['J_fwd']
        assert np.allclose(J, d['J_fd'], rtol=1e-4, atol=1e-6 * max(1.0, np.abs(J).max())), (
            f'd{of}/d{wrt}: {err}'
        )


def test_chassis_mount_dynamics_component_takes_the_actuator():
    full, _ = modules('double_wishbone', 'chassis')
    comp = ChassisMountDynamicsComp(
        num_nodes=3, corners=1, modules=(full,), actuator=True, roll=False
    )
    p = _component_problem(comp, seed=1)
    F_S = p.get_val('comp.F_S').copy()
    p.set_val('comp.F_A', p.get_val('comp.F_A') + 100.0)
    p.run_model()
    np.testing.assert_allclose(p.get_val('comp.F_S') - F_S, 100.0, rtol=1e-9)


@pytest.mark.parametrize('kind', ['kinematics_strut_rate', 'dynamics_actuator'])
def test_black_box_calls_per_jacobian_do_not_grow_with_the_actuator(kind):
    """The actuator's force is one more node-wise input, its compression rate one more
    output: the module's solver calls per Jacobian are the same at 4 and 40 nodes, and the
    dynamics take one augmented solve more per Jacobian than without the force (central
    differences: two)."""
    counts = {}
    for nn in (4, 40):
        full, _ = modules('double_wishbone', 'ground')
        if kind == 'kinematics_strut_rate':
            comp = SuspensionKinematicsComp(
                num_nodes=nn, corners=1, modules=(full,), strut_rate=True, fd_form='central'
            )
            of, wrt = ['q_W', 'qd_W', 'v_A'], ['z_W', 'v_W', 'v_M']
        else:
            comp = SuspensionDynamicsComp(
                num_nodes=nn, corners=1, modules=(full,), actuator=True, fd_form='central'
            )
            of = ['zdd_W', 'F_S']
            wrt = ['z_W', 'v_W', 'z_M', 'v_M', 'F_T', 'F_A', 'k_S', 'c_S']
        p = _component_problem(comp)
        c0 = dict(full.solver.calls)
        p.compute_totals(of=[f'comp.{n}' for n in of], wrt=[f'comp.{n}' for n in wrt])
        counts[nn] = {k: full.solver.calls[k] - c0[k] for k in c0}
    assert counts[4] == counts[40], counts
    if kind == 'dynamics_actuator':
        assert counts[4]['augmented'] == 2 * 8, counts  # central: two per node-wise input
