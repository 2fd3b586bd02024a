"""NonlinearSuspensionForceComp: exactly SuspensionForceComp with linear curves; analytic
partials against differences; the declared sparsity is the true one."""

from __future__ import annotations

import numpy as np
import openmdao.api as om
import pytest
from openmdao.utils.assert_utils import assert_check_partials

from suspopt.curves import (
    BumpStop,
    DamperCurve,
    DamperTable,
    ReboundStop,
    SpringCurve,
    SpringDamperUnit,
    SpringTable,
)
from suspopt.driver.structure import declared_subjacs
from suspopt.models.forces import SuspensionForceComp
from suspopt.models.nonlinear_forces import NonlinearSuspensionForceComp

NN, NC = 7, 4
UNITS = {
    'curves': SpringDamperUnit(
        SpringCurve((30000.0, 1.0e5, 4.0e6)),
        DamperCurve(3000.0, 0.08, 1200.0, 7000.0, 0.12, 2800.0),
        BumpStop(0.03, (2.0e6, 3.0e8)),
        ReboundStop(0.04, (5.0e6,)),
    ),
    'tables': SpringDamperUnit(
        SpringTable((-0.1, -0.04, 0.0, 0.03, 0.07, 0.1), (-2600, -1150, 0, 950, 2600, 4800)),
        DamperTable(
            (-1.0, -0.3, -0.1, 0.0, 0.1, 0.3, 1.0), (-4200, -2100, -800, 0, 260, 520, 1300)
        ),
    ),
}


def problem(comp: om.ExplicitComponent, seed: int = 0, scale: float = 0.06) -> om.Problem:
    """The component alone at random states spanning stops, knees and table ends."""
    p = om.Problem(reports=False)
    p.model.add_subsystem('comp', comp, promotes=['*'])
    p.setup()
    rng = np.random.default_rng(seed)
    for name in ('z_W', 'z_M'):
        p.set_val(name, rng.uniform(-scale, scale, (NN, NC)))
    for name in ('v_W', 'v_M'):
        p.set_val(name, rng.uniform(-0.4, 0.4, (NN, NC)))
    return p


def test_linear_unit_is_suspension_force_comp_exactly():
    """Values and every partial bit for bit (the same products and sums)."""
    rng = np.random.default_rng(3)
    k, c = rng.uniform(1e4, 5e4, NC), rng.uniform(1e3, 5e3, NC)
    ref = problem(SuspensionForceComp(num_nodes=NN, corners=NC))
    new = problem(
        NonlinearSuspensionForceComp(
            num_nodes=NN, corners=NC, unit=SpringDamperUnit.linear(30000.0, 3000.0)
        )
    )
    for p in (ref, new):
        p.set_val('k_S', k)
        p.set_val('c_S', c)
        p.run_model()
    np.testing.assert_array_equal(new.get_val('F_S'), ref.get_val('F_S'))
    J_ref = ref.compute_totals('F_S', ['z_W', 'v_W', 'z_M', 'v_M', 'k_S', 'c_S'])
    J_new = new.compute_totals('F_S', ['z_W', 'v_W', 'z_M', 'v_M', 'k_S', 'c_S'])
    for key, val in J_ref.items():
        np.testing.assert_array_equal(J_new[key], val, err_msg=str(key))


@pytest.mark.parametrize('name', sorted(UNITS))
def test_check_partials(name):
    p = problem(NonlinearSuspensionForceComp(num_nodes=NN, corners=NC, unit=UNITS[name]))
    p.run_model()
    # the curves are real-valued (clip/where): central differences
    data = p.check_partials(
        method='fd', form='central', step=1e-7, out_stream=None, compact_print=True
    )
    assert_check_partials(data, atol=2e-4, rtol=1e-6)


def jacobian_pattern(p: om.Problem, comp, wrt: str) -> np.ndarray:
    """The true pattern of dF_S/d(wrt) from differences of ``compute``, entry by entry."""
    ins = {k: np.array(p.get_val(k), dtype=float) for k in comp._var_rel_names['input']}
    out = {'F_S': np.zeros((NN, NC))}
    comp.compute(ins, out)
    base = out['F_S'].ravel().copy()
    x = ins[wrt]
    cols = []
    for j in range(x.size):
        moved = {k: v.copy() for k, v in ins.items()}
        h = 1e-6 * max(1.0, abs(x.flat[j]))
        moved[wrt].flat[j] += h
        comp.compute(moved, out)
        cols.append((out['F_S'].ravel() - base) / h)
    J = np.stack(cols, axis=1)
    return np.abs(J) > 1e-9 * max(1.0, np.max(np.abs(J)))


@pytest.mark.parametrize('name', sorted(UNITS))
def test_declared_sparsity_is_the_true_sparsity(name):
    """No true nonzero outside the declared pattern (at random states over every region of
    the curves: knees, stops, table ends), and every declared entry a true nonzero: the
    states' diagonals at every entry; a curve parameter's column at some node of its
    corner (a curve parameter's derivative is zero by value where its region is not
    reached, e.g. a stop's before contact, a table point's away from its intervals)."""
    unit = UNITS[name]
    comp = NonlinearSuspensionForceComp(num_nodes=NN, corners=NC, unit=unit)
    problem(comp).final_setup()
    declared = {
        sj.wrt.split('.', 1)[1]: sj for sj in declared_subjacs(comp) if sj.of.endswith('F_S')
    }
    assert set(declared) == {'z_W', 'v_W', 'z_M', 'v_M'} | {q.name for q in unit.parameters()}
    seen = {wrt: False for wrt in declared}
    for seed in range(4):
        p = problem(comp, seed=seed, scale=0.08 if name == 'curves' else 0.12)
        for wrt, sj in declared.items():
            true = jacobian_pattern(p, comp, wrt)
            decl = np.zeros_like(true)
            decl[sj.rows, sj.cols] = True
            assert not (true & ~decl).any(), f'dF_S/d{wrt}: undeclared true nonzeros'
            if wrt in ('z_W', 'v_W', 'z_M', 'v_M'):
                assert np.array_equal(true, decl), f'dF_S/d{wrt}'
            seen[wrt] = seen[wrt] | true
    corner = np.tile(np.arange(NC), NN)
    for wrt, sj in declared.items():
        decl = np.zeros_like(seen[wrt])
        decl[sj.rows, sj.cols] = True
        for c in range(NC):
            rows = corner == c
            assert np.array_equal(seen[wrt][rows].any(0), decl[rows].any(0)), (wrt, c)


def test_sparsity_check_fails_on_a_dense_table_partial_declared_per_node():
    """The pattern test can fail: a table partial declared for the first corner's points
    only is caught."""

    class FirstCorner(NonlinearSuspensionForceComp):
        def declare_partials(self, of, wrt, **kwargs):
            if wrt == 'damper_forces':
                rows, cols = kwargs['rows'], kwargs['cols']
                keep = cols < 7
                kwargs = dict(kwargs, rows=rows[keep], cols=cols[keep])
            return super().declare_partials(of, wrt, **kwargs)

        def compute_partials(self, inputs, partials):
            _, d_x, d_v, d_p = self.force(inputs, True)
            for wrt, d in (('z_W', d_x), ('z_M', -d_x), ('v_W', d_v), ('v_M', -d_v)):
                partials['F_S', wrt] = d.ravel()
            partials['F_S', 'spring_forces'] = d_p['spring_forces'].ravel()
            partials['F_S', 'damper_forces'] = d_p['damper_forces'][:, 0].ravel()

    comp = FirstCorner(num_nodes=NN, corners=NC, unit=UNITS['tables'])
    p = problem(comp)
    p.run_model()
    sj = next(s for s in declared_subjacs(comp) if s.wrt.endswith('damper_forces'))
    decl = np.zeros((NN * NC, NC * 7), dtype=bool)
    decl[sj.rows, sj.cols] = True
    assert (jacobian_pattern(p, comp, 'damper_forces') & ~decl).any()
