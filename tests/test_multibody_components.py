"""The black-box multibody components: FD partials, solver calls per Jacobian, sparsity.

Each component alone in an ``openmdao.api.Problem`` (inputs on the automatic IVC), with
num_nodes 10 and 80 and random physically sensible inputs: z_W ∈ ±0.05 m, v_W ∈ ±0.5 m/s,
F_S, F_T ∈ ±3000 N. ``compute_totals`` of all outputs w.r.t. all inputs then equals the
component's FD partials (no coupling).

Reference Jacobian: an independent central difference of the module's ``kinematics`` /
``dynamics`` methods, one column (one node, one input) at a time, steps 1e-5 m, 1e-5 m/s,
1e-2 N. Its error: truncation h²|f'''|/6 plus noise ε_f/h with ε_f ≈ Newton tolerance
(1e-13 m) and round-off, together ≲ 1e-7 of each block's largest entry.

Expected error of the component's forward FD with its absolute step of 1e-6 in the SI
units of every input: truncation h|f''|/2 plus noise ε_f/h, about 2e-5 of each block's
largest entry. The check allows 1e-4, with an absolute floor of 1e-6 of the output's
largest partial for blocks that are zero in exact arithmetic (e.g. ∂q̇_U/∂z_W).
"""
from __future__ import annotations

import numpy as np
import openmdao.api as om
import pytest

from suspopt.driver.structure import declared_subjacs
from suspopt.multibody.components import SuspensionDynamicsComp, SuspensionKinematicsComp
from suspopt.multibody.suspension import SuspensionModule

RANGES = {'z_W': 0.05, 'v_W': 0.5, 'F_S': 3000.0, 'F_T': 3000.0}
H_REF = {'z_W': 1e-5, 'v_W': 1e-5, 'F_S': 1e-2, 'F_T': 1e-2}
KIN = (SuspensionKinematicsComp, ['z_W', 'v_W'], ['q_U', 'qd_U', 'q_W', 'qd_W'])
DYN = (SuspensionDynamicsComp, ['z_W', 'v_W', 'F_S', 'F_T'], ['zdd_W', 'reactions'])


def inputs(nn: int, seed: int = 0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed + nn)
    return {k: rng.uniform(-r, r, nn) for k, r in RANGES.items()}


def module_outputs(mod: SuspensionModule, x: dict[str, np.ndarray], kind: str):
    kin = mod.kinematics(x['z_W'], x['v_W'])
    if kind == 'kin':
        return {'q_U': kin.q_U, 'qd_U': kin.qd_U, 'q_W': kin.q_W, 'qd_W': kin.qd_W}
    acc, reac = mod.dynamics(kin.state, x['F_S'], x['F_T'])
    return {'zdd_W': acc, 'reactions': reac.reshape(len(acc), -1)}


def reference_jacobian(mod, x, kind, ins, outs):
    """Central differences, column by column: {of: {wrt: (nn*width, nn)}}."""
    nn = len(x['z_W'])
    J = {o: {w: None for w in ins} for o in outs}
    for w in ins:
        cols = {o: [] for o in outs}
        for j in range(nn):
            xp = {k: v.copy() for k, v in x.items()}
            xm = {k: v.copy() for k, v in x.items()}
            xp[w][j] += H_REF[w]
            xm[w][j] -= H_REF[w]
            fp, fm = module_outputs(mod, xp, kind), module_outputs(mod, xm, kind)
            for o in outs:
                cols[o].append((fp[o] - fm[o]).ravel() / (2 * H_REF[w]))
        for o in outs:
            J[o][w] = np.stack(cols[o], axis=-1)
    return J


def make_problem(Comp, nn, mod, x, ins, **opts):
    """One corner (shape (nn, 1)) of module ``mod``."""
    p = om.Problem(reports=False)
    comp = p.model.add_subsystem('c', Comp(num_nodes=nn, corners=1, modules=(mod,), **opts),
                                 promotes=['*'])
    p.setup()
    for k in ins:
        p.set_val(k, np.reshape(x[k], (nn, 1)))
    p.run_model()
    return p, comp


def block_mask(nn: int, width: int) -> np.ndarray:
    """True on the node-diagonal blocks of an (nn*width, nn) sub-Jacobian."""
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
                failures.append(f'd{o}/d{w}: max error {err:.3e} = {err / scale:.1e} of '
                                f'the block scale {scale:.3e}')
    assert not failures, (f'{kind}, {nn} nodes: FD partials off by more than 1e-4:\n  '
                          + '\n  '.join(failures))


@pytest.mark.parametrize('form', ['forward', 'central'])
@pytest.mark.parametrize('kind', ['kin', 'dyn'])
def test_fd_steps_are_the_configured_absolute_step(module, kind, form):
    """Every black-box call of a Jacobian perturbs exactly one input, at every node, by
    the configured absolute step (+h forward; ±h central) and leaves the others alone."""
    Comp, ins, outs = KIN if kind == 'kin' else DYN
    nn, h = 10, 3e-6
    x = inputs(nn)
    p, comp = make_problem(Comp, nn, module, x, ins, fd_form=form, fd_step=h)
    seen = []
    evaluate = comp.evaluate

    def recording(values):
        seen.append({k: values[k][:, 0] - x[k] for k in ins})
        return evaluate(values)

    comp.evaluate = recording
    p.compute_totals(of=outs, wrt=ins)
    moved = []
    for d in seen:
        changed = [k for k in ins if np.any(d[k] != 0.0)]
        assert len(changed) <= 1, changed
        if changed:
            k = changed[0]
            np.testing.assert_allclose(d[k], np.sign(d[k][0]) * h, rtol=1e-6, atol=0.0)
            moved.append((k, np.sign(d[k][0])))
    expected = [(k, s) for k in ins for s in ((1.0, -1.0) if form == 'central' else (1.0,))]
    assert sorted(moved) == sorted(expected)


# ------------------------------------------------------------------------ (b) call counts
@pytest.mark.parametrize('form, factor', [('forward', 1), ('central', 2)])
@pytest.mark.parametrize('kind', ['kin', 'dyn'])
def test_solver_calls_per_jacobian_do_not_grow_with_nodes(kind, form, factor):
    Comp, ins, outs = KIN if kind == 'kin' else DYN
    counts = {}
    for nn in (10, 80):
        mod = SuspensionModule('double_wishbone')
        p, comp = make_problem(Comp, nn, mod, inputs(nn), ins, fd_form=form)
        n_compute = [0]
        evaluate = comp.evaluate

        def counting(values):
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
    # perturbations), and nothing anew at a point it has just analysed
    expected = [(factor * n_in, {'positions': factor, 'augmented': augmented}),
                (factor * n_in, {'positions': 0, 'augmented': augmented})]
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
    queries = [(z, v), (z + 1e-6, v), (z, v + 1e-6), (z, v), (z + 0.01, v), (z + 1e-6, v),
               (-z, 2 * v), (z, v)]
    for zq, vq in queries:
        kin = mod.kinematics(zq, vq)
        acc, reac = mod.dynamics(kin.state, 100.0 * zq, 1000.0 * vq)
        fresh = SuspensionModule('double_wishbone')
        ref = fresh.kinematics(zq, vq)
        acc_ref, reac_ref = fresh.dynamics(ref.state, 100.0 * zq, 1000.0 * vq)
        for a, b in ((kin.q_U, ref.q_U), (kin.qd_U, ref.qd_U), (kin.q_W, ref.q_W),
                     (kin.qd_W, ref.qd_W), (kin.state.q, ref.state.q), (acc, acc_ref),
                     (reac, reac_ref)):
            assert np.array_equal(a, b)
    assert mod.reused >= 4  # the repeated positions and states were not recomputed
    assert mod.solver.calls['positions'] == 4  # one per distinct wheel travel


# ------------------------------------------------------------------------ (c) sparsity
@pytest.mark.parametrize('nn', [10, 80])
@pytest.mark.parametrize('kind', ['kin', 'dyn'])
def test_declared_sparsity_is_the_true_one(cases, module, kind, nn):
    x, J, Jref, ins, outs = cases[kind, nn]
    Comp = KIN[0] if kind == 'kin' else DYN[0]
    # the true Jacobian (central differences, one node perturbed at a time) has exactly
    # zero off-diagonal node blocks, and its diagonal blocks are not empty
    for o in outs:
        width = Jref[o][ins[0]].shape[0] // nn
        mask = block_mask(nn, width)
        for w in ins:
            assert np.all(Jref[o][w][~mask] == 0.0), (o, w)
            # OpenMDAO's assembled partials are zero there too
            assert np.all(J[o][w][~mask] == 0.0), (o, w)
        assert any(np.any(Jref[o][w][mask] != 0.0) for w in ins), o
    # the declared pattern (rows/cols of declare_partials) is the full node-diagonal block
    p, comp = make_problem(Comp, nn, module, x, ins)
    declared = {(sj.of.split('.')[-1], sj.wrt.split('.')[-1]): sj
                for sj in declared_subjacs(comp)}
    for o in outs:
        width = Jref[o][ins[0]].shape[0] // nn
        for w in ins:
            sj = declared[o, w]
            pattern = np.zeros((nn * width, nn), dtype=bool)
            pattern[sj.rows, sj.cols] = True
            assert np.array_equal(pattern, block_mask(nn, width)), (o, w)


def test_corners_of_two_mechanisms_in_one_component():
    """Four corners, two mechanisms (front parallelogram, rear SLA) in one black box: the
    outputs equal each module's own answer, and a Jacobian costs one black-box call per
    input (each call analyses both mechanisms once, in one batch per mechanism)."""
    nn = 6
    dw, sla = SuspensionModule('double_wishbone'), SuspensionModule('sla_double_wishbone')
    mods = (dw, dw, sla, sla)
    rng = np.random.default_rng(11)
    x = {k: rng.uniform(-r, r, (nn, 4)) for k, r in RANGES.items()}
    p = om.Problem(reports=False)
    comp = p.model.add_subsystem('c', SuspensionDynamicsComp(num_nodes=nn, corners=4,
                                                            modules=mods), promotes=['*'])
    p.setup()
    for k in DYN[1]:
        p.set_val(k, x[k])
    p.run_model()
    for c, mod in enumerate(mods):
        kin = mod.kinematics(x['z_W'][:, c], x['v_W'][:, c])
        acc, reac = mod.dynamics(kin.state, x['F_S'][:, c], x['F_T'][:, c])
        np.testing.assert_array_equal(p.get_val('zdd_W')[:, c], acc)
        np.testing.assert_array_equal(p.get_val('reactions')[:, c, :reac.shape[1]], reac)
    calls = [0]
    evaluate = comp.evaluate

    def counting(values):
        calls[0] += 1
        return evaluate(values)

    comp.evaluate = counting
    J = p.compute_totals(of=['zdd_W'], wrt=['F_T'], return_format='array')
    assert calls[0] == len(DYN[1])
    # node- and corner-wise: d zdd_W / d F_T is diagonal, and nonzero
    assert np.count_nonzero(J - np.diag(np.diag(J))) == 0 and np.all(np.diag(J) != 0.0)
