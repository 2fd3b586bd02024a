"""Total derivatives by propagating the colored seeds through the data flow, all at once.

The fast path beside :class:`suspopt.driver.totals.ColoredTotals` (which does one
OpenMDAO linear solve per color). After one ``model.run_linearize()`` every declared
partial's values are read (:meth:`structure.Subjac.values`) and the chain rule of the
explicit data flow (:mod:`suspopt.driver.dataflow`) is applied to every color at once:

* forward, in topological order, ``T_o = E_o + Σ_e P_e T_src(e)``, where ``E`` is the
  compressed seed (column ``c`` of ``E`` is 1 at every design-variable entry of color
  ``c``), so each ``T`` is dense with one column per color and the constraint
  Jacobian's nonzero ``(i, j)`` is ``T[i, color(j)]`` (Curtis, Powell & Reid 1974);
* reverse, in the opposite order, ``W_src(e) += P_eᵀ W_o`` from a seed at the objective
  (and at each dense constraint row the coloring leaves to reverse mode): the gradient.

One product per edge and direction instead of one pass over the model per color; the
cost stays proportional to (nonzeros of the partials) × (colors), linear in the horizon.

Only for what it covers: explicit components without cycles in the responses' data flow
(:func:`supported`); otherwise the driver uses :class:`ColoredTotals`.
``tests/test_propagation.py`` checks that both give the same derivatives on every model.
"""

from __future__ import annotations

import numpy as np
import openmdao.api as om
import scipy.sparse as sp

import suspopt.driver.structure as structure
from suspopt.driver.dataflow import DataFlow, Edge, data_flow
from suspopt.driver.sparsity import Coloring
from suspopt.driver.totals import ColoredTotals, Layout


def supported(flow: DataFlow) -> bool:
    """True if the propagation covers this data flow: OpenMDAO internals known, only
    explicit components, no cycle."""
    return (
        structure.supported()
        and not any(flow.is_cycle(g) for g in flow.groups)
        and not any(e.implicit for edges in flow.deps.values() for e in edges)
    )


class _Product:
    """One edge's sparse matrix ``P_e`` (CSR, fixed pattern) and its transpose, refilled
    with the current values of the declared partial at every linearization."""

    __slots__ = ('edge', 'P', 'PT', 'slot', 'transpose', 'duplicates')

    def __init__(self, edge: Edge):
        self.edge = edge
        nrow, ncol = edge.shape
        key = edge.rows * ncol + edge.cols
        unique, self.slot = np.unique(key, return_inverse=True)  # declared entry -> CSR slot
        self.duplicates = unique.size != key.size
        r, c = unique // ncol, unique % ncol
        self.P = sp.csr_matrix(
            (np.zeros(unique.size), c, np.searchsorted(r, np.arange(nrow + 1))), shape=edge.shape
        )  # row-major: slots in CSR order
        self.transpose = np.lexsort((r, c))  # slots in column-major (CSR of Pᵀ) order
        t = self.transpose
        self.PT = sp.csr_matrix(
            (np.zeros(unique.size), r[t], np.searchsorted(c[t], np.arange(ncol + 1))),
            shape=(ncol, nrow),
        )

    def refill(self) -> None:
        val = self.edge.subjac.values()
        data: np.ndarray
        if self.duplicates:  # repeated (row, col) pairs add up, as OpenMDAO applies them
            data = np.asarray(
                np.bincount(self.slot, weights=val, minlength=self.P.data.size), dtype=float
            )
        else:
            data = np.empty(self.P.data.size)
            data[self.slot] = val
        if self.edge.factor != 1.0:
            data *= self.edge.factor
        self.P.data[:] = data
        self.PT.data[:] = data[self.transpose]


class PropagatedTotals:
    """Unscaled objective gradient and constraint-Jacobian nonzeros of ``problem`` at its
    current point (the same as :class:`ColoredTotals`), by one linearization and one
    propagation of all colors through the data flow ``flow``."""

    def __init__(self, problem: om.Problem, layout: Layout, coloring: Coloring, flow: DataFlow):
        if not supported(flow):
            raise ValueError('the propagated totals need an explicit, acyclic data flow')
        if tuple(coloring.shape) != (layout.m, layout.n):
            raise ValueError(
                f'coloring shape {coloring.shape} does not match the '
                f'constraint Jacobian ({layout.m}, {layout.n})'
            )
        self.problem, self.layout, self.coloring, self.flow = problem, layout, coloring, flow
        sizes = flow.sizes
        self._order = [g[0] for g in flow.groups]
        self._products = {n: [_Product(e) for e in flow.deps[n]] for n in self._order}
        self._consumers = flow.consumers()

        def entries(v):
            return np.arange(sizes[v.source]) if v.indices is None else v.indices

        # forward: the compressed seeds, and where each forward nonzero is read
        n_colors = coloring.n_colors
        self._seeds: dict[str, np.ndarray] = {}
        start = 0
        for v in layout.design_vars:
            idx = entries(v)
            color = coloring.colors[start : start + idx.size]
            ok = color >= 0
            E = self._seeds.setdefault(v.source, np.zeros((sizes[v.source], n_colors)))
            E[idx[ok], color[ok]] += 1.0
            start += idx.size
        row_var = np.concatenate([np.full(v.size, k) for k, v in enumerate(layout.constraints)])
        row_entry = np.concatenate([entries(v) for v in layout.constraints])
        forward = np.nonzero(~np.isin(coloring.rows, coloring.reverse_rows))[0]
        self._gather = []
        for k, v in enumerate(layout.constraints):
            pos = forward[row_var[coloring.rows[forward]] == k]
            self._gather.append(
                (v.source, pos, row_entry[coloring.rows[pos]], coloring.colors[coloring.cols[pos]])
            )
        # reverse: the objective (column 0) and the dense constraint rows
        n_rev = 1 + coloring.reverse_rows.size
        self._rseeds: dict[str, np.ndarray] = {}
        targets = [(layout.objective.source, entries(layout.objective))]
        targets += [
            (layout.constraints[row_var[r]].source, row_entry[r : r + 1])
            for r in coloring.reverse_rows
        ]
        for j, (src, idx) in enumerate(targets):
            W = self._rseeds.setdefault(src, np.zeros((sizes[src], n_rev)))
            W[idx, j] += 1.0
        self._rev_pos = [np.nonzero(coloring.rows == r)[0] for r in coloring.reverse_rows]
        self._dv = [(v.source, entries(v)) for v in layout.design_vars]

        # the Lagrangian's reverse seeds: where each objective / constraint entry sits
        self._lag_obj = (layout.objective.source, entries(layout.objective))
        starts = np.cumsum([0] + [v.size for v in layout.constraints])
        self._lag_con = [
            (v.source, entries(v), slice(a, b))
            for v, a, b in zip(layout.constraints, starts[:-1], starts[1:])
        ]

    def _linearize(self) -> None:
        self.problem.model.run_linearize()
        for products in self._products.values():
            for p in products:
                p.refill()

    def linearize(self) -> None:
        """Linearize the model and read every declared partial's values."""
        self._linearize()

    def forward(self, seeds: dict[str, np.ndarray], keep: set[str]) -> dict[str, np.ndarray]:
        """Propagate the forward seeds (output → (size, width)) through the last
        linearization: the tangents of the outputs in ``keep`` (the others are freed once
        read)."""
        T: dict[str, np.ndarray] = {}
        left = dict(self._consumers)
        for n in self._order:
            out = seeds.get(n)
            out = None if out is None else out.copy()
            for p in self._products[n]:
                s = T.get(p.edge.src)
                if s is not None:
                    out = p.P @ s if out is None else out + p.P @ s
            if out is not None:
                T[n] = out
            for p in self._products[n]:
                src = p.edge.src
                left[src] -= 1
                if left[src] == 0 and src not in keep:
                    T.pop(src, None)
        return {n: t for n, t in T.items() if n in keep}

    def _reverse(self, W: dict[str, np.ndarray], width: int, keep_all: bool = False) -> np.ndarray:
        """Propagate the reverse seeds ``W`` (output → (size, width)) to the design
        variables: (n, width). ``W`` is consumed, unless ``keep_all``: then it ends holding
        every output's adjoint."""
        for n in reversed(self._order):
            w = W.pop(n, None) if n not in self._seeds and not keep_all else W.get(n)
            if w is None:
                continue
            for p in self._products[n]:
                prod = p.PT @ w
                src = p.edge.src
                W[src] = prod if src not in W else W[src] + prod
        return np.concatenate(
            [W[src][idx] if src in W else np.zeros((idx.size, width)) for src, idx in self._dv]
        )

    def compute(self) -> tuple[np.ndarray, np.ndarray]:
        """(objective gradient (n,), Jacobian values at the coloring's nonzeros)."""
        self._linearize()
        jac = np.zeros(self.coloring.nnz)

        # forward: every color at once; each T freed once its last reader is done
        T = self.forward(self._seeds, {src for src, *_ in self._gather})
        for src, pos, entry, color in self._gather:
            t = T.get(src)
            if t is not None and pos.size:
                jac[pos] = t[entry, color]

        # reverse: the objective gradient and the dense rows
        n_rev = 1 + self.coloring.reverse_rows.size
        G = self._reverse({n: w.copy() for n, w in self._rseeds.items()}, n_rev)
        for k, pos in enumerate(self._rev_pos):
            jac[pos] = G[self.coloring.cols[pos], 1 + k]
        return G[:, 0].copy(), jac

    def lagrangian_gradient(self, w_obj: float, w_con: np.ndarray) -> np.ndarray:
        """``w_obj ∇f + Σ_i w_con[i] ∇c_i`` (unscaled, (n,)) at the model's current point:
        one linearization and one reverse propagation."""
        self._linearize()
        return self.adjoints(w_obj, w_con)[1]

    def adjoints(self, w_obj: float, w_con: np.ndarray) -> tuple[dict[str, np.ndarray], np.ndarray]:
        """The adjoint ``∂L/∂y`` of every output ``y`` ((size, 1) each) of the Lagrangian
        ``L = w_obj f + Σ_i w_con[i] c_i`` through the last linearization, and its gradient
        (unscaled, (n,))."""
        sizes = self.flow.sizes
        W: dict[str, np.ndarray] = {}

        def seed(src: str, idx: np.ndarray, val: np.ndarray | float) -> None:
            w = W.setdefault(src, np.zeros((sizes[src], 1)))
            w[idx, 0] += val  # entries of one variable are distinct

        seed(*self._lag_obj, w_obj)
        for src, idx, sl in self._lag_con:
            seed(src, idx, w_con[sl])
        G = self._reverse(W, 1, keep_all=True)
        return W, G[:, 0]

    @property
    def design_sources(self) -> list[str]:
        """The outputs that hold the design variables."""
        return [src for src, _ in self._dv]

    def reverse(self, W: dict[str, np.ndarray], width: int) -> np.ndarray:
        """Propagate reverse seeds (output → (size, width), consumed) through the last
        linearization to the design variables: (n, width)."""
        return self._reverse(W, width)

    def design_seeds(self, columns: np.ndarray) -> dict[str, np.ndarray]:
        """Forward seeds: ``columns`` (n, width), one row per design-variable entry in
        the layout's order, placed at those entries of their source outputs."""
        out: dict[str, np.ndarray] = {}
        start = 0
        for src, idx in self._dv:
            E = out.setdefault(src, np.zeros((self.flow.sizes[src], columns.shape[1])))
            E[idx] += columns[start : start + idx.size]
            start += idx.size
        return out


#: how the driver computes total derivatives: 'auto' (propagated where supported, else one
#: linear solve per color), 'propagated', or 'solves' (OpenMDAO's public linear solves)
TOTALS_METHODS = ('auto', 'propagated', 'solves')


def make_totals(
    problem: om.Problem, layout: Layout, coloring: Coloring | None, method: str = 'auto'
) -> ColoredTotals | PropagatedTotals:
    """The total-derivative engine for ``problem``: :class:`PropagatedTotals` where it is
    supported (and asked for), else :class:`ColoredTotals`."""
    if method not in TOTALS_METHODS:
        raise ValueError(f'totals method must be one of {TOTALS_METHODS}, got {method!r}')
    if method != 'solves' and coloring is not None and layout.m:
        flow = (
            data_flow(problem, [v.source for v in layout.constraints] + [layout.objective.source])
            if structure.supported()
            else None
        )
        if flow is not None and supported(flow):
            return PropagatedTotals(problem, layout, coloring, flow)
    if method == 'propagated':
        raise ValueError(
            'the propagated totals do not cover this model (implicit '
            'components, a cycle, or an untested OpenMDAO version)'
        )
    return ColoredTotals(problem, layout, coloring)
