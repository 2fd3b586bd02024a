"""The reduced model of a suspension linkage (:mod:`suspopt.multibody.reduced`) against
the full augmented solve (:class:`SuspensionModule`): the same kinematics, wheel-travel
accelerations, spring forces and chassis-mount responses to 1e-9 of each quantity's
scale, over the travel range and beyond it (where the full module answers), for every
shipped mechanism, both mounts, with and without gravity; a damaged table is detected;
the compiled kernels equal the NumPy evaluation; the time marching's right-hand side
takes the reduced modules unchanged."""

from __future__ import annotations

import dataclasses
import tomllib

import numpy as np
import pytest

from suspopt.errors import MultibodyError
from suspopt.multibody.mechanism import builtin_mechanisms, mechanism_from_dict, mechanism_path
from suspopt.multibody.reduced import (
    ReducedSuspensionModule,
    TravelTable,
    reduced_modules,
    reducible,
)
from suspopt.multibody.suspension import SuspensionModule

MECHANISMS = builtin_mechanisms()
#: agreement with the full solve, relative to each quantity's largest magnitude
TOL = 1e-9
_MODULES: dict = {}


def modules(name: str, mount: str, gravity: bool = False):
    """(full, reduced) modules of a shipped mechanism, built once per test session."""
    key = (name, mount, gravity)
    if key not in _MODULES:
        with mechanism_path(name).open('rb') as fh:
            data = tomllib.load(fh)
        if gravity:
            data['gravity'] = [0.3, -9.81]  # (x too: every gravity term is exercised)
        mech = mechanism_from_dict(data, source=name, suspension=True)
        full = SuspensionModule(mech, mount=mount)
        _MODULES[key] = (full, ReducedSuspensionModule(full))
    return _MODULES[key]


def states(N: int, seed: int, lo=-0.1, hi=0.1, roll: bool = False):
    """Wheel travels over [lo, hi] (both ends included), rates, mount motion, spring
    settings, tyre loads and the chassis mount's pose."""
    rng = np.random.default_rng(seed)
    z = rng.uniform(lo, hi, N)
    z[:2] = lo, hi
    v = rng.uniform(-3.0, 3.0, N)
    z_M, v_M = rng.uniform(-0.03, 0.03, N), rng.uniform(-1.0, 1.0, N)
    k, c = rng.uniform(1e4, 8e4, N), rng.uniform(5e2, 8e3, N)
    F_T = rng.uniform(-6e3, 6e3, N)
    psi = rng.uniform(-0.06, 0.06, N) if roll else np.zeros(N)
    w = rng.uniform(-1.5, 1.5, N) if roll else np.zeros(N)
    return z, v, z_M, v_M, k, c, F_T, psi, w


def agree(got, want, what: str, tol: float = TOL) -> None:
    got, want = np.asarray(got), np.asarray(want)
    assert got.shape == want.shape, what
    scale = np.max(np.abs(want))
    err = np.max(np.abs(got - want)) / (scale if scale > 0 else 1.0)
    assert err <= tol, f'{what}: relative error {err:.2e}'


def same_kinematics(kr, kf):
    agree(kr.q_W, kf.q_W, 'q_W')
    agree(kr.qd_W, kf.qd_W, 'qd_W')
    agree(kr.state.q, kf.state.q, 'q')
    agree(kr.state.qd, kf.state.qd, 'qd')


@pytest.mark.parametrize('name', MECHANISMS)
def test_table_meets_its_tolerance(name):
    full, red = modules(name, 'ground')
    err = red.verify_table()
    assert max(err.values()) <= red.tolerance
    assert red.table_residual < 1e-13
    assert red.table.degree <= 64


@pytest.mark.parametrize('gravity', [False, True])
@pytest.mark.parametrize('name', MECHANISMS)
def test_ground_mount_agrees_with_the_augmented_solve(name, gravity):
    full, red = modules(name, 'ground', gravity)
    z, v, z_M, v_M, k, c, F_T, *_ = states(40, seed=1)
    kf, kr = full.kinematics(z, v), red.kinematics(z, v)
    same_kinematics(kr, kf)
    af, Ff, _ = full.dynamics(kf.state, z_M, v_M, k, c, F_T)
    ar, Fr, reactions = red.dynamics(kr.state, z_M, v_M, k, c, F_T)
    agree(ar, af, 'wheel-travel acceleration')
    agree(Fr, Ff, 'F_S')
    assert reactions is None
    assert red.fallbacks == 0
    assert red.constraint_residual(kr.state) < 1e-13


@pytest.mark.parametrize('gravity', [False, True])
@pytest.mark.parametrize('roll', [False, True])
@pytest.mark.parametrize('name', MECHANISMS)
def test_chassis_mount_agrees_with_the_augmented_solve(name, roll, gravity):
    """The linkage's travel inside the table (the wheel moves with the mount), the mount
    heaving, turning and accelerating: kinematics, the response blocks and the response
    at given mount accelerations."""
    full, red = modules(name, 'chassis', gravity)
    z, v, z_M, v_M, k, c, F_T, psi, w = states(40, seed=2, lo=-0.07, hi=0.07, roll=roll)
    pose = (z_M, v_M, psi, w)
    z = z + z_M
    kf, kr = full.kinematics(z, v, pose=pose), red.kinematics(z, v, pose=pose)
    same_kinematics(kr, kf)
    Rf, Ff = full.mount_response(kf, k, c, F_T, rotation=roll)
    Rr, Fr = red.mount_response(kr, k, c, F_T, rotation=roll)
    assert Rr.shape == Rf.shape[:2] + (4,)
    for b in range(Rf.shape[1]):
        for j, entry in enumerate(('zdd_W', 'F_z', 'M_P', 'F_x')):
            agree(Rr[:, b, j], Rf[:, b, j], f'{entry}, block {b}')
    agree(Fr, Ff, 'F_S')
    acc = np.random.default_rng(3).normal(0.0, 5.0, (40, 2))
    Rf, _ = full.mount_response(kf, k, c, F_T, acceleration=acc)
    Rr, _ = red.mount_response(kr, k, c, F_T, acceleration=acc)
    for j in range(4):
        agree(Rr[:, 0, j], Rf[:, 0, j], f'response at the mount accelerations, entry {j}')
    assert red.fallbacks == 0


@pytest.mark.parametrize('mount', ['ground', 'chassis'])
def test_states_outside_the_table_are_the_full_modules(mount):
    """Travels beyond the table's range, mixed with states inside and alone: the full
    module answers those (counted), the result is the same as the full module's."""
    full, red = modules('double_wishbone', mount)
    roll = mount == 'chassis'
    z, v, z_M, v_M, k, c, F_T, psi, w = states(12, seed=4, lo=-0.14, hi=0.14, roll=roll)
    lo, hi = red.table.lo, red.table.hi
    pose = (z_M, v_M, psi, w) if roll else None
    travel = z - z_M if roll else z
    outside = (travel < lo - 0.002) | (travel > hi + 0.002)
    assert 2 <= np.count_nonzero(outside) <= 10
    for rows in (np.arange(12), np.flatnonzero(outside)):
        before = red.fallbacks
        sub = None if pose is None else tuple(p[rows] for p in pose)
        kf = full.kinematics(z[rows], v[rows], pose=sub)
        kr = red.kinematics(z[rows], v[rows], pose=sub)
        assert red.fallbacks - before == np.count_nonzero(outside[rows])
        same_kinematics(kr, kf)
        args = (k[rows], c[rows], F_T[rows])
        if roll:
            Rf, Ff = full.mount_response(kf, *args, rotation=True)
            Rr, Fr = red.mount_response(kr, *args, rotation=True)
            agree(Rr, Rf[:, :, :4], 'response')
            acc = np.ones((rows.size, 2))
            agree(
                red.mount_response(kr, *args, acceleration=acc)[0],
                full.mount_response(kf, *args, acceleration=acc)[0][:, :, :4],
                'response at mount accelerations',
            )
        else:
            af, Ff, _ = full.dynamics(kf.state, z_M[rows], v_M[rows], *args)
            ar, Fr, _ = red.dynamics(kr.state, z_M[rows], v_M[rows], *args)
            agree(ar, af, 'wheel-travel acceleration')
        agree(Fr, Ff, 'F_S')
        assert red.constraint_residual(kr.state, kr.pose) < 1e-12


def test_a_damaged_table_is_detected():
    """One coefficient changed by 1e-7 of the series' scale: the check against the
    linkage's analyses finds it; an unreachable tolerance is refused when fitting."""
    _, red = modules('macpherson', 'ground')
    good = red.table
    coef = good.coefficients.copy()
    col = good.columns['mass'].start
    coef[7, col] += 1e-7 * good.scale['mass']
    red.table = dataclasses.replace(good, coefficients=coef)
    try:
        with pytest.raises(MultibodyError, match="'mass'"):
            red.verify_table()
    finally:
        red.table = good
    red.verify_table()
    with pytest.raises(MultibodyError, match='misses the tolerance'):
        TravelTable.fit(red._exact, good.lo, good.hi, good.columns, 1e-20, degrees=(16,))


def test_compiled_kernels_equal_the_numpy_evaluation():
    pytest.importorskip('numba')
    for mount in ('ground', 'chassis'):
        full, red = modules('macpherson', mount)
        fast = ReducedSuspensionModule(full, compiled=True)
        z, v, z_M, v_M, k, c, F_T, psi, w = states(9, seed=5, lo=-0.12, hi=0.12, roll=True)
        pose = (z_M, v_M, psi, w) if mount == 'chassis' else None
        a, b = red.kinematics(z, v, pose=pose), fast.kinematics(z, v, pose=pose)
        assert fast.fallbacks == red.fallbacks > 0
        same = dict(tol=1e-13)
        agree(b.state.q, a.state.q, 'q', **same)
        agree(b.state.qd, a.state.qd, 'qd', **same)
        agree(b.qd_W, a.qd_W, 'qd_W', **same)
        if pose is None:
            for x, y in zip(
                fast.dynamics(b.state, z_M, v_M, k, c, F_T)[:2],
                red.dynamics(a.state, z_M, v_M, k, c, F_T)[:2],
            ):
                agree(x, y, 'dynamics', **same)
        else:
            for kw in ({'rotation': True}, {'acceleration': np.ones((9, 2))}):
                x, y = (
                    fast.mount_response(b, k, c, F_T, **kw),
                    red.mount_response(a, k, c, F_T, **kw),
                )
                agree(x[0], y[0], 'response', **same)
                agree(x[1], y[1], 'F_S', **same)


def test_linkages_without_a_reduced_model_keep_the_full_module():
    with mechanism_path('double_wishbone').open('rb') as fh:
        data = tomllib.load(fh)
    data['markers'].append({'name': 'bump_stop', 'body': 'L', 'point': [0.3, -0.2]})
    data['markers'].append({'name': 'bump_mount', 'body': 'F', 'point': [0.3, 0.3]})
    data['forces'].append(
        {'name': 'bump', 'type': 'spring_damper', 'markers': ['bump_mount', 'bump_stop'],
         'stiffness': 1e3}
    )  # fmt: skip
    mech = mechanism_from_dict(data, source='with a bump spring', suspension=True)
    assert 'bump' in reducible(mech)
    full = SuspensionModule(mech)
    with pytest.raises(MultibodyError, match='no reduced model'):
        ReducedSuspensionModule(full)
    shipped = SuspensionModule('double_wishbone')
    out = reduced_modules({'bump': full, 'dw': shipped})
    assert out['bump'] is full
    assert isinstance(out['dw'], ReducedSuspensionModule) and out['dw'].full is shipped


def test_a_linkage_table_is_made_once_and_shared_by_value():
    """Modules of equal mechanisms (read twice, either mount) share one table; another
    travel range is another table."""
    a = ReducedSuspensionModule(SuspensionModule('sla_double_wishbone'))
    b = ReducedSuspensionModule(SuspensionModule('sla_double_wishbone', mount='chassis'))
    assert b.table is a.table
    with mechanism_path('sla_double_wishbone').open('rb') as fh:
        data = tomllib.load(fh)
    data['suspension']['travel'] = [-0.08, 0.09]
    mech = mechanism_from_dict(data, source='shorter travel', suspension=True)
    c = ReducedSuspensionModule(SuspensionModule(mech))
    assert c.table is not a.table and (c.table.lo, c.table.hi) == (-0.08, 0.09)
    c.verify_table()


def test_a_full_modules_state_is_refused():
    full, red = modules('double_wishbone', 'ground')
    kin = full.kinematics(np.zeros(2), np.zeros(2))
    with pytest.raises(TypeError, match='its own kinematics'):
        red.dynamics(kin.state, 0.0, 0.0, 3e4, 2e3, 0.0)


@pytest.mark.parametrize('mount', ['ground', 'chassis'])
def test_the_time_marching_rhs_takes_reduced_modules(cfg, mount):
    """``VehicleRHS`` with the reduced modules passed as ``modules``: dy/dt equal to the
    full modules' at states of a half-car trajectory."""
    from suspopt.transcription.vehicle import multibody_modules
    from suspopt.verification.timemarching import VehicleRHS

    c = cfg.replace(multibody=dataclasses.replace(cfg.multibody, mount=mount))
    sc = c.scenarios()[0]
    design = dict(c.design.initial())
    full = VehicleRHS(c, 'mixed', design, sc, multibody_modules(c))
    red = VehicleRHS(c, 'mixed', design, sc, reduced_modules(multibody_modules(c)))
    rng = np.random.default_rng(6)
    n = red.n_states
    Y = np.zeros((20, n + red.nt))
    Y[:, :n] = rng.normal(0.0, 1.0, (20, n)) * np.r_[[0.02, 0.3, 0.01, 0.1], [0.03] * 2, [0.5] * 2]
    for i, t in enumerate(np.linspace(0.0, sc.horizon, 20)):
        agree(red(t, Y[i]), full(t, Y[i]), f'dy/dt at t = {t:.3g}')
    assert red.max_constraint_residual < 1e-13
