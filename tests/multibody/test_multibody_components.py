"""The black-box multibody components: FD partials, solver calls per Jacobian, sparsity.

Each component alone in an ``openmdao.api.Problem`` (inputs on the automatic IVC), one
corner, with num_nodes 10 and 80 and random physically sensible inputs: z_W ∈ ±0.05 m,
v_W ∈ ±0.5 m/s, chassis mount z_M ∈ ±0.02 m, v_M ∈ ±0.3 m/s, F_T ∈ ±3000 N, spring rate
k_S ∈ [1e4, 5e4] N/m, damping c_S ∈ [1e3, 5e3] N s/m. ``compute_totals`` of all outputs
w.r.t. all inputs then equals the component's FD partials (no coupling).

Reference Jacobian: an independent central difference of the module's ``kinematics`` /
``dynamics`` methods, one column (one node, one input; or a setting at every node) at a
time. Its error: truncation h²|f'''|/6 plus noise ε_f/h with ε_f ≈ Newton tolerance
(1e-13 m) and round-off, together ≲ 1e-7 of each block's largest entry.

Expected error of the component's forward FD (an absolute step of 1e-6 in the SI units
of every node-wise input, a relative one of 1e-6 for the settings): truncation h|f''|/2
plus noise ε_f/h, about 2e-5 of each block's largest entry. The check allows 1e-4, with
an absolute floor of 1e-6 of the output's largest partial for blocks that are zero in
exact arithmetic (e.g. ∂q̇_W/∂z_W of a parallelogram).
"""

from __future__ import annotations

import numpy as np
import openmdao.api as om
import pytest

from suspopt.driver.structure import declared_subjacs
from suspopt.multibody.components import SuspensionDynamicsComp, SuspensionKinematicsComp
from suspopt.multibody.suspension import SuspensionModule

RANGES = {'z_W': 0.05, 'v_W': 0.5, 'z_M': 0.02, 'v_M': 0.3, 'F_T': 3000.0}
SETTINGS = {'k_S': (1e4, 5e4), 'c_S': (1e3, 5e3)}
H_REF = {'z_W': 1e-5, 'v_W': 1e-5, 'z_M': 1e-5, 'v_M': 1e-5, 'F_T': 1e-2, 'k_S': 1.0, 'c_S': 0.1}
KIN = (SuspensionKinematicsComp, ['z_W', 'v_W'], ['q_W', 'qd_W'])
DYN = (
    SuspensionDynamicsComp,
    ['z_W', 'v_W', 'z_M', 'v_M', 'F_T', 'k_S', 'c_S'],
    ['zdd_W', 'F_S', 'reactions'],
)


def inputs(nn: int, seed: int = 0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed + nn)
    x = {k: rng.uniform(-r, r, nn) for k, r in RANGES.items()}
    x.update({k: rng.uniform(lo, hi, 1) for k, (lo, hi) in SETTINGS.items()})
    return x


def module_outputs(mod: SuspensionModule, x: dict[str, np.ndarray], kind: str):
    kin = mod.kinematics(x['z_W'], x['v_W'])
    if kind == 'kin':
        return {'q_W': kin.q_W, 'qd_W': kin.qd_W}
    n = x['z_W'].size
    acc, F_S, reac = mod.dynamics(
        kin.state, x['z_M'], x['v_M'], np.repeat(x['k_S'], n), np.repeat(x['c_S'], n), x['F_T']
    )
    return {'zdd_W': acc, 'F_S': F_S, 'reactions': reac.reshape(n, -1)}


def reference_jacobian(mod, x, kind, ins, outs):
    """Central differences, column by column: {of: {wrt: (nn*width, nn or 1)}}."""
    nn = len(x['z_W'])
    J = {o: {w: None for w in ins} for o in outs}
    for w in ins:
        cols = {o: [] for o in outs}
        for j in range(x[w].size):
            xp = {k: v.copy() for k, v in x.items()}
            xm = {k: v.copy() for k, v in x.items()}
            xp[w][j] += H_REF[w]
            xm[w][j] -= H_REF[w]
            fp, fm = module_outputs(mod, xp, kind), module_outputs(mod, xm, kind)
            for o in outs:
                cols[o].append((fp[o] - fm[o]).ravel() / (2 * H_REF[w]))
        for o in outs:
            J[o][w] = np.stack(cols[o], axis=-1)
    assert all(J[o][w].shape[0] % nn == 0 for o in outs for w in ins)
    return J


def make_problem(Comp, nn, mod, x, ins, **opts):
    """One corner (shape (nn, 1); settings (1,)) of module ``mod``."""
    p = om.Problem(reports=False)
    comp = p.model.add_subsystem(
        'c', Comp(num_nodes=nn, corners=1, modules=(mod,), **opts), promotes=['*']
    )
    p.setup()
    for k in ins:
        p.set_val(k, x[k] if k in SETTINGS else np.reshape(x[k], (nn, 1)))
    p.run_model()
    return p, comp


def block_mask(nn: int, width: int, cols: int) -> np.ndarray:
    """True on the node-diagonal blocks of an (nn*width, nn) sub-Jacobian, everywhere for
    a setting's (nn*width, 1) column."""
    if cols == 1:
        return np.ones((nn * width, 1), dtype=bool)
    m = np.zeros((nn, width, nn), dtype=bool)
    m[np.arange(nn), :, np.arange(nn)] = True
    return m.reshape(nn * width, nn)


@pytest.fixture(scope='module')
def module():
    return SuspensionModule('double_wishbone')


@pytest.fixture(scope='module')
def cases(module):
    """For both components and both sizes: inputs, OpenMDAO totals, reference Jacobian."""
    out = {}
    for nn in (10, 80):
        x = inputs(nn)
        for kind, (Comp, ins, outs) in (('kin', KIN), ('dyn', DYN)):
            p, _ = make_problem(Comp, nn, module, x, ins)
            J = p.compute_totals(of=outs, wrt=ins, return_format='dict')
            J = {o: {w: np.array(J[o][w]) for w in ins} for o in outs}
            out[kind, nn] = (x, J, reference_jacobian(module, x, kind, ins, outs), ins, outs)
    return out


# ------------------------------------------------------------------------ (a) FD values
@pytest.mark.parametrize('nn', [10, 80])
@pytest.mark.parametrize('kind', ['kin', 'dyn'])
def test_fd_partials_match_independent_central_differences(cases, kind, nn):
    x, J, Jref, ins, outs = cases[kind, nn]
    failures = []
    for o in outs:
        floor = 1e-6 * max(np.max(np.abs(Jref[o][w])) for w in ins)
        for w in ins:
            scale = max(np.max(np.abs(Jref[o][w])), floor / 1e-4)
            err = np.max(np.abs(J[o][w] - Jref[o][w]))
            if err > 1e-4 * scale:
                failures.append(
                    f'd{o}/d{w}: max error {err:.3e} = {err / scale:.1e} of '
                    f'the block scale {scale:.3e}'
                )
    assert not failures, (
        f'{kind}, {nn} nodes: FD partials off by more than 1e-4:\n  ' + '\n  '.join(failures)
    )


@pytest.mark.parametrize('form', ['forward', 'central'])
@pytest.mark.parametrize('kind', ['kin', 'dyn'])
def test_fd_steps_are_the_configured_steps(module, kind, form):
    """Every black-box call of a Jacobian perturbs exactly one input, at every node, by
    the configured step (+h forward; ±h central): absolute for a node-wise input, relative
    (h |x|) for a setting; the others are left alone."""
    Comp, ins, outs = KIN if kind == 'kin' else DYN
    nn, h = 10, 3e-6
    x = inputs(nn)
    p, comp = make_problem(Comp, nn, module, x, ins, fd_form=form, fd_step=h)
    seen = []
    evaluate = comp.evaluate

    def recording(values):
        seen.append({k: np.ravel(values[k]) - x[k] for k in ins})
        return evaluate(values)

    comp.evaluate = recording
    p.compute_totals(of=outs, wrt=ins)
    moved = []
    for d in seen:
        changed = [k for k in ins if np.any(d[k] != 0.0)]
        assert len(changed) <= 1, changed
        if changed:
            k = changed[0]
            step = h * np.abs(x[k]) if k in SETTINGS else h
            np.testing.assert_allclose(d[k], np.sign(d[k][0]) * step, rtol=1e-6, atol=0.0)
            moved.append((k, np.sign(d[k][0])))
    expected = [(k, s) for k in ins for s in ((1.0, -1.0) if form == 'central' else (1.0,))]
    assert sorted(moved) == sorted(expected)


# ------------------------------------------------------------------------ (b) call counts
@pytest.mark.parametrize('mechanism', ['double_wishbone', 'macpherson'])
@pytest.mark.parametrize('form, factor', [('forward', 1), ('central', 2)])
@pytest.mark.parametrize('kind', ['kin', 'dyn'])
def test_solver_calls_per_jacobian_do_not_grow_with_nodes(kind, form, factor, mechanism):
    Comp, ins, outs = KIN if kind == 'kin' else DYN
    counts = {}
    for nn in (10, 80):
        mod = SuspensionModule(mechanism)
        p, comp = make_problem(Comp, nn, mod, inputs(nn), ins, fd_form=form)
        n_compute = [0]
        evaluate = comp.evaluate

        def counting(values, n_compute=n_compute, evaluate=evaluate):
            n_compute[0] += 1
            return evaluate(values)

        comp.evaluate = counting
        for _ in range(2):
            c0 = dict(mod.solver.calls)
            n_compute[0] = 0
            p.compute_totals(of=outs, wrt=ins)
            calls = {k: mod.solver.calls[k] - c0[k] for k in c0}
            counts.setdefault(nn, []).append((n_compute[0], calls))
    n_in = len(ins)
    augmented = factor * n_in if kind == 'dyn' else 0
    # every Jacobian runs the black box once per input variable and FD perturbation; the
    # module analyses positions anew only where the wheel travel changed (the z_W
    # perturbations), and nothing anew at a point it has just analysed. Factorizations:
    # C_q,dep inverted once per new pose (for the velocity analysis and eq. 11), and kept
    new = (1, 0) if form == 'forward' else (2, 0)
    expected = [
        (factor * n_in, {'positions': factor, 'augmented': augmented, 'factorizations': new[0]}),
        (factor * n_in, {'positions': 0, 'augmented': augmented, 'factorizations': new[1]}),
    ]
    for nn in (10, 80):
        assert counts[nn] == expected, (nn, counts[nn])
    assert counts[10] == counts[80]


def test_remembered_analyses_equal_fresh_ones():
    """The module's memory (repeated queries answered from the last analyses) changes no
    result: a sequence of queries as the optimizer makes them gives bit for bit what a
    fresh module gives for each query."""
    rng = np.random.default_rng(5)
    mod = SuspensionModule('double_wishbone')
    z = rng.uniform(-0.04, 0.04, 50)
    v = rng.uniform(-0.5, 0.5, 50)
    k, c = np.full(50, 3e4), np.full(50, 2e3)
    queries = [
        (z, v),
        (z + 1e-6, v),
        (z, v + 1e-6),
        (z, v),
        (z + 0.01, v),
        (z + 1e-6, v),
        (-z, 2 * v),
        (z, v),
    ]
    for zq, vq in queries:
        kin = mod.kinematics(zq, vq)
        out = mod.dynamics(kin.state, 0.1 * zq, 0.2 * vq, k, c, 1000.0 * vq)
        fresh = SuspensionModule('double_wishbone')
        ref = fresh.kinematics(zq, vq)
        out_ref = fresh.dynamics(ref.state, 0.1 * zq, 0.2 * vq, k, c, 1000.0 * vq)
        for a, b in (
            (kin.q_W, ref.q_W),
            (kin.qd_W, ref.qd_W),
            (kin.state.q, ref.state.q),
            *zip(out, out_ref),
        ):
            assert np.array_equal(a, b)
    assert mod.reused >= 4  # the repeated positions and states were not recomputed
    assert mod.solver.calls['positions'] == 4  # one per distinct wheel travel


def test_spring_force_is_eq_12_for_the_vertical_spring():
    """The double wishbone's spring element coupled to the chassis gives the force of
    paper eq. 12 at the spring point, F_S = k (q^z_U - z_M) + c (q̇^z_U - v_M), computed
    here from the spring point's own motion (the marker U's CG)."""
    rng = np.random.default_rng(2)
    mod = SuspensionModule('double_wishbone')
    s = mod.solver
    n = 20
    z, v = rng.uniform(-0.05, 0.05, n), rng.uniform(-0.5, 0.5, n)
    zM, vM = rng.uniform(-0.02, 0.02, n), rng.uniform(-0.3, 0.3, n)
    k, c = rng.uniform(1e4, 5e4, n), rng.uniform(1e3, 5e3, n)
    kin = mod.kinematics(z, v)
    i = s.marker_names.index('spring_point')
    q_U = s.marker_positions(kin.state.q)[:, i, 1] - s.marker_reference()[i, 1]
    qd_U = s.marker_velocities(kin.state.q, kin.state.qd)[:, i, 1]
    _, F_S, _ = mod.dynamics(kin.state, zM, vM, k, c, np.zeros(n))
    np.testing.assert_allclose(F_S, k * (q_U - zM) + c * (qd_U - vM), rtol=1e-12)


# ------------------------------------------------------------------------ (c) sparsity
@pytest.mark.parametrize('nn', [10, 80])
@pytest.mark.parametrize('kind', ['kin', 'dyn'])
def test_declared_sparsity_is_the_true_one(cases, module, kind, nn):
    x, J, Jref, ins, outs = cases[kind, nn]
    Comp = KIN[0] if kind == 'kin' else DYN[0]
    # the true Jacobian (central differences, one node perturbed at a time) has exactly
    # zero off-diagonal node blocks, and its diagonal blocks are not empty
    for o in outs:
        for w in ins:
            width = Jref[o][w].shape[0] // nn
            mask = block_mask(nn, width, Jref[o][w].shape[1])
            assert np.all(Jref[o][w][~mask] == 0.0), (o, w)
            assert np.all(J[o][w][~mask] == 0.0), (o, w)  # OpenMDAO's partials too
        assert any(np.any(Jref[o][w] != 0.0) for w in ins), o
    # the declared pattern (rows/cols of declare_partials) is exactly that block pattern
    p, comp = make_problem(Comp, nn, module, x, ins)
    declared = {(sj.of.split('.')[-1], sj.wrt.split('.')[-1]): sj for sj in declared_subjacs(comp)}
    for o in outs:
        for w in ins:
            sj = declared[o, w]
            pattern = np.zeros(sj.shape, dtype=bool)
            pattern[sj.rows, sj.cols] = True
            width = Jref[o][w].shape[0] // nn
            assert np.array_equal(pattern, block_mask(nn, width, sj.shape[1])), (o, w)


def test_corners_of_two_mechanisms_in_one_component():
    """Four corners, two mechanisms (front parallelogram, rear SLA) in one black box: the
    outputs equal each module's own answer, and a Jacobian costs one black-box call per
    input (each call analyses both mechanisms once, in one batch per mechanism)."""
    nn = 6
    dw, sla = SuspensionModule('double_wishbone'), SuspensionModule('sla_double_wishbone')
    mods = (dw, dw, sla, sla)
    rng = np.random.default_rng(11)
    x = {k: rng.uniform(-r, r, (nn, 4)) for k, r in RANGES.items()}
    x.update({k: rng.uniform(lo, hi, 4) for k, (lo, hi) in SETTINGS.items()})
    p = om.Problem(reports=False)
    comp = p.model.add_subsystem(
        'c', SuspensionDynamicsComp(num_nodes=nn, corners=4, modules=mods), promotes=['*']
    )
    p.setup()
    for k in DYN[1]:
        p.set_val(k, x[k])
    p.run_model()
    for c, mod in enumerate(mods):
        kin = mod.kinematics(x['z_W'][:, c], x['v_W'][:, c])
        acc, F_S, reac = mod.dynamics(
            kin.state,
            x['z_M'][:, c],
            x['v_M'][:, c],
            np.full(nn, x['k_S'][c]),
            np.full(nn, x['c_S'][c]),
            x['F_T'][:, c],
        )
        np.testing.assert_array_equal(p.get_val('zdd_W')[:, c], acc)
        np.testing.assert_array_equal(p.get_val('F_S')[:, c], F_S)
        np.testing.assert_array_equal(p.get_val('reactions')[:, c, : reac.shape[1]], reac)
    calls = [0]
    evaluate = comp.evaluate

    def counting(values):
        calls[0] += 1
        return evaluate(values)

    comp.evaluate = counting
    J = p.compute_totals(of=['zdd_W'], wrt=['F_T', 'k_S'], return_format='dict')
    assert calls[0] == len(DYN[1])
    JT, Jk = np.asarray(J['zdd_W']['F_T']), np.asarray(J['zdd_W']['k_S'])
    # node- and corner-wise: d zdd_W / d F_T is diagonal, d zdd_W / d k_S one corner each
    assert np.count_nonzero(JT - np.diag(np.diag(JT))) == 0 and np.all(np.diag(JT) != 0.0)
    corner = np.tile(np.arange(4), nn)
    assert np.all(Jk[np.arange(4 * nn), corner] != 0.0)
    assert np.count_nonzero(Jk) == 4 * nn
