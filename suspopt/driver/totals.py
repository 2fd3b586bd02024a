"""Colored total derivatives of an OpenMDAO problem through its public API (MAUD).

The NLP's variables, constraints and objective are read from the model's public metadata
(``get_design_vars``, ``get_constraints``, ``get_objectives``). One iterate's derivatives
are

* one linearization, ``model.run_linearize()`` (every component computes its partials
  once: analytic ones, and the black boxes' finite differences);
* one forward linear solve, ``model.run_solve_linear('fwd')``, per color of the
  constraint Jacobian (:mod:`suspopt.driver.sparsity`): the seed is -1 in the residuals of
  every design-variable entry of the color (as ``Problem.compute_jacvec_product`` seeds
  it) and each nonzero is gathered from the solved ``d_outputs`` straight into the
  Jacobian's nonzero array, in the coloring's order;
* one reverse solve, ``model.run_solve_linear('rev')``, for the objective gradient (an
  objective that integrates over all nodes would make every column share its row), and
  one for each dense constraint row the coloring leaves to reverse mode.

OpenMDAO prunes each linear solve to the systems relevant to the model's design variables
and responses. Nothing here forms a dense m × n array.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import openmdao.api as om

from suspopt.driver.sparsity import Coloring, Variable


@dataclass
class Layout:
    """The NLP as the model declares it, in the driver's order."""

    design_vars: list[Variable]
    constraints: list[Variable]
    objective: Variable
    dv_meta: dict
    con_meta: dict
    obj_meta: dict

    @property
    def n(self) -> int:
        return sum(v.size for v in self.design_vars)

    @property
    def m(self) -> int:
        return sum(v.size for v in self.constraints)


def _indices(meta: dict) -> np.ndarray | None:
    idx = meta.get('indices')
    return None if idx is None else np.asarray(idx.as_array(), dtype=np.int64).ravel()


def nlp_layout(problem: om.Problem) -> Layout:
    """Design variables, constraints and the objective of ``problem`` (a constraint declared
    linear is passed to IPOPT like any other)."""
    model = problem.model
    dvs = model.get_design_vars(recurse=True, get_sizes=True)
    cons = model.get_constraints(recurse=True, get_sizes=True)
    objs = model.get_objectives(recurse=True, get_sizes=True)
    if len(objs) != 1:
        raise ValueError(f'the model needs exactly one objective, has {len(objs)}')
    ((oname, ometa),) = objs.items()

    def var(name: str, meta: dict) -> Variable:
        return Variable(
            name=name, source=meta['source'], indices=_indices(meta), size=int(meta['size'])
        )

    return Layout(
        design_vars=[var(k, v) for k, v in dvs.items()],
        constraints=[var(k, v) for k, v in cons.items()],
        objective=var(oname, ometa),
        dv_meta=dvs,
        con_meta=cons,
        obj_meta=ometa,
    )


def flat_positions(vector, variables: list[Variable]) -> np.ndarray:
    """Positions of the variables' entries in ``vector.asarray()``."""
    out = []
    for v in variables:
        start, stop = vector.get_range(v.source)
        local = np.arange(stop - start) if v.indices is None else v.indices
        out.append(start + local)
    return np.concatenate(out) if out else np.zeros(0, dtype=np.int64)


class ColoredTotals:
    """Unscaled objective gradient and constraint-Jacobian nonzeros of ``problem`` at its
    current point, by one linearization and one linear solve per color."""

    def __init__(self, problem: om.Problem, layout: Layout, coloring: Coloring | None):
        self.problem, self.layout, self.coloring = problem, layout, coloring
        model = problem.model
        _, d_out, d_res = model.get_linear_vectors()
        self._d_out, self._d_res = d_out, d_res
        self._dv_res = flat_positions(d_res, layout.design_vars)
        self._con_out = flat_positions(d_out, layout.constraints)
        self._obj_out = flat_positions(d_out, [layout.objective])
        self._colors, self._reverse = [], []
        if coloring is not None and layout.m:
            if tuple(coloring.shape) != (layout.m, layout.n):
                raise ValueError(
                    f'coloring shape {coloring.shape} does not match the '
                    f'constraint Jacobian ({layout.m}, {layout.n})'
                )
            col_of_nz = coloring.cols
            forward = ~np.isin(coloring.rows, coloring.reverse_rows)
            for cols in coloring.color_groups():
                # nonzeros of these columns (coloring sorted by column): positions, rows
                lo = np.searchsorted(col_of_nz, cols, side='left')
                hi = np.searchsorted(col_of_nz, cols, side='right')
                pos = np.concatenate([np.arange(a, b) for a, b in zip(lo, hi)])
                pos = pos[forward[pos]]
                self._colors.append((self._dv_res[cols], pos, self._con_out[coloring.rows[pos]]))
            for row in coloring.reverse_rows:
                pos = np.nonzero(coloring.rows == row)[0]
                self._reverse.append((self._con_out[row], pos, self._dv_res[coloring.cols[pos]]))

    def compute(self) -> tuple[np.ndarray, np.ndarray]:
        """(objective gradient (n,), Jacobian values at the coloring's nonzeros)."""
        model = self.problem.model
        model.run_linearize()
        d_out, d_res = self._d_out, self._d_res
        jac = np.zeros(self.coloring.nnz if self.coloring is not None else 0)
        for seeds, pos, rows in self._colors:
            d_res.set_val(0.0)
            d_out.set_val(0.0)
            d_res.asarray()[seeds] = -1.0
            model.run_solve_linear('fwd')
            jac[pos] = d_out.asarray()[rows]
        for seed, pos, cols in self._reverse:
            d_res.set_val(0.0)
            d_out.set_val(0.0)
            d_out.asarray()[seed] = -1.0
            model.run_solve_linear('rev')
            jac[pos] = d_res.asarray()[cols]
        d_res.set_val(0.0)
        d_out.set_val(0.0)
        d_out.asarray()[self._obj_out] = -1.0
        model.run_solve_linear('rev')
        return d_res.asarray()[self._dv_res].copy(), jac

    def lagrangian_gradient(self, w_obj: float, w_con: np.ndarray) -> np.ndarray:
        """``w_obj ∇f + Σ_i w_con[i] ∇c_i`` (unscaled, (n,)) at the model's current point:
        one linearization and one reverse solve."""
        model = self.problem.model
        model.run_linearize()
        d_out, d_res = self._d_out, self._d_res
        d_res.set_val(0.0)
        d_out.set_val(0.0)
        seed = d_out.asarray()
        np.subtract.at(seed, self._obj_out, w_obj)
        np.subtract.at(seed, self._con_out, w_con)
        model.run_solve_linear('rev')
        return d_res.asarray()[self._dv_res].copy()
