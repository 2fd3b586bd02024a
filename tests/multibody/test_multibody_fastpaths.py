"""The multibody module's fast paths give, bit for bit, what the solver's general methods
give: the position analysis' C_q, max |C| and the coincidence joints' pool taken from its
last Newton iteration; a small batch iterated as a whole (converged states held by a zero
step) and a large one by subsets; SuspensionModule.dynamics from shared geometry and the
pool; constraint_residual from the last kinematics; joint_reactions from one matrix."""

from __future__ import annotations

import numpy as np
import pytest

from suspopt.errors import MultibodyError
from suspopt.multibody import solver as solver_mod
from suspopt.multibody.suspension import SuspensionModule

MECHANISMS = ['double_wishbone', 'macpherson', 'sla_double_wishbone']


def travels(N, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(-0.06, 0.06, N), rng.uniform(-1.0, 1.0, N)


def same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape
    assert np.array_equal(a, b, equal_nan=True), np.max(np.abs(a - b))


@pytest.mark.parametrize('mechanism', MECHANISMS)
@pytest.mark.parametrize('N', [1, 3, solver_mod.SMALL_BATCH + 4])
def test_analysed_positions_are_the_general_analyses(mechanism, N):
    s = SuspensionModule(mechanism).solver
    z, _ = travels(N)
    q_ind = z[:, None] + s.q0[s.ind[0]]
    q, Cq, err, pool = s._analysed_positions(q_ind)
    same(q, s.positions(q_ind))
    same(Cq, s.constraint_jacobian(q))
    same(err, np.max(np.abs(s.constraints(q)), axis=1, initial=0.0))
    if pool is not None:
        same(
            s._gamma_all(q, np.ones_like(q), [None] * len(s.joint_groups), pool=pool),
            s.gamma(q, np.ones_like(q)),
        )


@pytest.mark.parametrize('mechanism', MECHANISMS)
def test_small_batch_newton_equals_single_states_and_subsets(mechanism):
    s = SuspensionModule(mechanism).solver
    z, _ = travels(solver_mod.SMALL_BATCH + 4, seed=1)
    z[2] = 0.0  # converged at the first iteration: held by a zero step in a small batch
    q_ind = z[:, None] + s.q0[s.ind[0]]
    large = s.positions(q_ind)  # > SMALL_BATCH: subsets
    small = s.positions(q_ind[:4])  # whole-batch iterations
    single = np.concatenate([s.positions(q_ind[i : i + 1]) for i in range(4)])
    same(small, large[:4])
    same(single, large[:4])


@pytest.mark.parametrize('mechanism', MECHANISMS)
@pytest.mark.parametrize('N', [1, 4])
def test_module_dynamics_is_the_general_route(mechanism, N):
    mod = SuspensionModule(mechanism)
    s = mod.solver
    z, v = travels(N, seed=2)
    kin = mod.kinematics(z, v)
    rng = np.random.default_rng(3)
    z_M, v_M = 0.2 * z, 0.3 * v
    k_S, c_S = rng.uniform(2e4, 5e4, N), rng.uniform(1e3, 5e3, N)
    F_T = rng.uniform(-3e3, 3e3, N)
    qdd_ind, F_S, R = mod.dynamics(kin.state, z_M, v_M, k_S, c_S, F_T)

    st = kin.state
    loads = np.zeros((N, len(s.load_names)))
    loads[:, mod.tyre_load] = F_T
    params = mod.spring_params(st, z_M, v_M, k_S, c_S)
    Q = s.generalized_forces(st.q, loads, st.qd, params)
    qdd, lam = s.solve_augmented(st.q, st.qd, Q, Cq=s.constraint_jacobian(st.q))
    sp = s.spring(mod.spring_name, st.q, st.qd, params)
    same(qdd_ind, qdd[:, s.ind[0]])
    same(st.qdd, qdd)
    same(st.lam, lam)
    same(F_S, -sp.force * sp.direction[:, 1 - mod.chassis_end, 1])
    same(R, s.joint_reactions(lam, st.q))
    same(R, s.reactions(st.q, lam)[:, : s.nj, 0, :2])
    # the wheel marker from its body's columns
    same(kin.q_W, s.marker_positions(st.q)[:, mod.wheel, 1] - mod.marker_ref[mod.wheel, 1])
    same(kin.qd_W, s.marker_velocities(st.q, st.qd)[:, mod.wheel, 1])


@pytest.mark.parametrize('mechanism', MECHANISMS)
def test_dynamics_at_remembered_states_equal_fresh_modules_bit_for_bit(mechanism):
    """The partitioning (C_q,dep⁻¹, the tangent) and γ kept for remembered states (what
    the finite differences query again and again) are never stale: a sequence of queries on one
    module equals each query on a module of its own, bit for bit. The sequence: new
    loads at the same state, a new rate at the same pose (C_q kept, γ not), a new pose,
    then back to the first state."""
    z, v = travels(6, seed=4)
    z2, v2 = travels(6, seed=5)
    rng = np.random.default_rng(6)

    def loads():
        return (
            0.2 * z,
            0.3 * v,
            rng.uniform(2e4, 5e4, 6),
            rng.uniform(1e3, 5e3, 6),
            rng.uniform(-3e3, 3e3, 6),
        )

    queries = [
        (z, v, loads()),
        (z, v, loads()),
        (z, v2, loads()),
        (z2, v2, loads()),
        (z, v, loads()),
    ]
    mod = SuspensionModule(mechanism)
    for zq, vq, args in queries:
        got = mod.dynamics(mod.kinematics(zq, vq).state, *args)
        fresh = SuspensionModule(mechanism)
        want = fresh.dynamics(fresh.kinematics(zq, vq).state, *args)
        for a, b in zip(got, want):
            same(a, b)


def test_the_kept_partitioning_follows_a_view_whose_base_changes():
    """A read-only view of a writable array can still change: it is not kept by identity
    (``frozen``), so ``C_q,dep⁻¹`` follows the change; a frozen C_q's is kept."""
    from suspopt.multibody.solver import freeze, frozen

    s = SuspensionModule('double_wishbone').solver
    base = s.constraint_jacobian(s.q0[None].repeat(2, 0)).ravel().copy()
    Cq = base.reshape(2, s.m, s.n)
    Cq.flags.writeable = False
    assert not frozen(Cq)
    first = s._partition(Cq)[0].copy()
    base *= 2.0
    same(s._partition(Cq)[0], 0.5 * first)
    kept = freeze(Cq)
    assert frozen(kept) and s._partition(kept)[0] is s._partition(kept)[0]


@pytest.mark.parametrize('mount', ['ground', 'chassis'])
def test_constraint_residual_from_the_last_kinematics(mount):
    mod = SuspensionModule('double_wishbone', mount=mount)
    N = 3
    z, v = travels(N, seed=4)
    pose = None if mount == 'ground' else (0.01 * z, 0.1 * v, 0.5 * z, v)
    kin = mod.kinematics(z, v, pose=pose)
    fast = mod.constraint_residual(kin.state, kin.pose)
    motion = None if kin.pose is None else mod.mount_motion(kin.pose)
    slow = float(np.max(np.abs(mod.solver.constraints(kin.state.q, motion)), initial=0.0))
    assert fast == slow
    other = mod.kinematics(z + 0.001, v, pose=pose)  # another state: not the remembered one
    assert other.state.q is not kin.state.q
    assert mod.constraint_residual(kin.state, kin.pose) == slow


def test_lapack_solve_and_inverse_equal_numpy_public_ones():
    """``solver._lapack_solve`` and ``_lapack_inv`` (NumPy's private gufuncs behind
    ``np.linalg.solve`` and ``.inv``, for small batches) give what the public functions
    give, and raise as they do on a singular system; the public ones are their fallback."""
    from suspopt.multibody import solver as S

    rng = np.random.default_rng(0)
    A = rng.normal(size=(5, 4, 4)) + 4.0 * np.eye(4)
    b = rng.normal(size=(5, 4, 1))
    assert np.array_equal(S._lapack_solve(A, b), np.linalg.solve(A, b))
    assert np.array_equal(S._lapack_inv(A), np.linalg.inv(A))
    A[2] = 0.0
    with pytest.raises(np.linalg.LinAlgError):
        S._lapack_solve(A, b)
    with pytest.raises(np.linalg.LinAlgError):
        S._lapack_inv(A)
    with pytest.raises(MultibodyError, match='singular test system'):
        S._batched_solve(A, b[..., 0], 'test system')


@pytest.mark.parametrize('mechanism', MECHANISMS)
def test_the_pose_table_starts_position_analyses_converged(mechanism):
    """Inside the travel range the pose table's prediction already meets the Newton
    tolerance: one constraint evaluation per analysis, no Newton step, and the pose Newton
    finds from the reference's tangent. Outside the range the tangent takes over."""
    s = SuspensionModule(mechanism).solver
    lo, hi = s.mechanism.travel
    q_ind = np.random.default_rng(8).uniform(lo, hi, (500, 1)) + s.q0[s.ind]
    analyses = []
    analysis = s._analysis
    s._analysis = lambda q, drives: analyses.append(q.shape[0]) or analysis(q, drives)
    q = s.positions(q_ind)
    assert analyses[-1] == 500 and analyses.count(500) == 1  # after the table's build
    analyses.clear()
    q = s.positions(q_ind)
    assert analyses == [500]
    assert np.max(np.abs(s.constraints(q))) < s.newton_tol
    start = np.array(np.broadcast_to(s.q0, q.shape))
    start[:, s.dep] += (q_ind - s.q0[s.ind]) @ s._tangent0.T
    newton = s._positions(q_ind, start, [None] * len(s.joint_groups))
    np.testing.assert_allclose(q, newton, rtol=0, atol=1e-12)
    analyses.clear()
    out = s.positions(np.array([[hi + 0.005]]) + s.q0[s.ind])
    assert len(analyses) > 1 and np.max(np.abs(s.constraints(out))) < s.newton_tol
