"""The Hessian of the Lagrangian by finite differences of its gradient along Hessian colors.

IPOPT's Newton step uses the Hessian of the Lagrangian ``L = σ f + λᵀ c``. Here it is
computed, in the driver's scaling, by forward differences of ``∇L`` — one model
evaluation, one linearization and one reverse propagation (:mod:`suspopt.driver.propagation`)
per color — on a pattern and a coloring derived from the model's structure:

* **pattern** (:func:`hessian_sparsity`). Through the explicit data flow
  (:mod:`suspopt.driver.dataflow`) the Hessian is ``Σ_r μ_r J_rᵀ ∇²φ_r J_r``, one term per
  entry ``r`` of every component output ``y_r = φ_r(u)`` (``μ_r`` its adjoint, ``J_r`` the
  total Jacobian of its inputs; Gower & Mello, "A new framework for the computation of
  Hessians", Optim. Methods Softw. 27(2), 2012). ``∇²φ_r`` is nonzero only among the inputs
  whose partial ``∂y_r/∂u`` is not constant, so the pattern is the union over ``r`` of
  ``N_rᵀ N_r``, ``N_r`` the pattern of those inputs' total derivatives (the same boolean
  propagation of declared patterns as the Jacobian's, :mod:`suspopt.driver.sparsity`).
  Which declared partial entries are not constant is read off two linearizations at two
  random points (:func:`varying_entries`): a linear term (a collocation defect's
  differentiation matrix, a quadrature, a weighted sum) has bitwise equal partials at
  both, a nonlinear one almost surely not. For the vehicle models this gives node-wise
  blocks (the states of one node) plus the design variables' rows and columns.
* **coloring** (:func:`color_hessian`). The longest rows (the design variables, which
  touch every node) each get a color of their own; the other columns are colored so that
  no two of one color share a row outside those (:func:`suspopt.driver.sparsity.color_columns`).
  Each nonzero ``(i, j)`` is then read directly, from column ``j``'s color at row ``i`` or,
  by symmetry, from column ``i``'s color at row ``j`` (Coleman & Moré, "Estimation of
  sparse Hessian matrices and graph coloring problems", Math. Program. 28, 1984).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import openmdao.api as om
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from suspopt.driver.dataflow import DataFlow, Edge
from suspopt.driver.propagation import PropagatedTotals
from suspopt.driver.sparsity import Variable, color_columns, forward_patterns

#: one declared partial of the data flow: (output, position in ``flow.deps[output]``)
EdgeKey = tuple[str, int]


def edge_values(flow: DataFlow) -> dict[EdgeKey, np.ndarray]:
    """The values of every declared partial of ``flow`` at the model's last linearization."""
    return {
        (o, k): np.array(e.subjac.values(), dtype=float)
        for o, edges in flow.deps.items()
        for k, e in enumerate(edges)
    }


def varying_entries(
    a: dict[EdgeKey, np.ndarray], b: dict[EdgeKey, np.ndarray]
) -> dict[EdgeKey, np.ndarray]:
    """For every edge whose partial differs between two linearizations ``a`` and ``b``,
    the mask of its declared entries that differ (the entries of a nonlinear term)."""
    out = {}
    for key, va in a.items():
        differ = ~np.equal(va, b[key])  # NaN on either side counts as differing
        if differ.any():
            out[key] = differ
    return out


def hessian_sparsity(
    flow: DataFlow, wrt: list[Variable], varying: dict[EdgeKey, np.ndarray] | None
) -> sp.csr_matrix:
    """The symmetric pattern (n × n, ``wrt`` entries in order) of the Hessian of any linear
    combination of the outputs of ``flow``: the union over every component output entry of
    the outer product of the total-derivative pattern of its nonlinear inputs.
    ``varying``: the nonlinear declared entries (:func:`varying_entries`); None takes every
    declared entry as nonlinear (a bound, far less sparse)."""
    n = sum(v.size for v in wrt)
    if varying is None:
        varying = {
            (o, k): np.ones(e.rows.size, dtype=bool)
            for o, edges in flow.deps.items()
            for k, e in enumerate(edges)
        }
    by_output: dict[str, list[tuple[Edge, np.ndarray]]] = {}
    for (o, k), mask in varying.items():
        by_output.setdefault(o, []).append((flow.deps[o][k], mask))
    sources = {e.src for items in by_output.values() for e, _ in items}
    # the total-derivative patterns of the nonlinear terms' sources only
    S = forward_patterns(flow.ancestors(sources), wrt, keep=sources)
    H = sp.csr_matrix((n, n), dtype=np.float32)
    for items in by_output.values():
        rows = None
        for e, mask in items:
            s = S.get(e.src)
            if s is None or s.nnz == 0:
                continue
            NL = sp.csr_matrix(
                (np.ones(int(mask.sum()), dtype=np.float32), (e.rows[mask], e.cols[mask])),
                shape=e.shape,
            )
            term = NL @ s
            rows = term if rows is None else rows + term
        if rows is not None and rows.nnz:
            rows = _bool(rows)
            H = H + _bool(rows.T @ rows)
    return _bool(H)


def _bool(m: sp.spmatrix) -> sp.csr_matrix:
    m = sp.csr_matrix(m)
    m.sum_duplicates()
    m.data = np.ones(m.data.size, dtype=np.float32)
    return m


@dataclass
class HessianColoring:
    """A symmetric coloring of a Hessian pattern for direct recovery.

    ``rows``/``cols``: the lower triangle's nonzeros (``rows >= cols``, IPOPT's structure);
    ``colors[j]``: the color of column ``j`` (-1: needed by no entry); each nonzero ``k`` is
    ``(g(x + Σ_{color c} h_j e_j) - g(x))[source_row[k]] / h[step_col[k]]`` with
    ``c = source_color[k]``.
    """

    n: int
    rows: np.ndarray
    cols: np.ndarray
    colors: np.ndarray
    source_color: np.ndarray
    source_row: np.ndarray
    step_col: np.ndarray

    @property
    def n_colors(self) -> int:
        return int(self.colors.max(initial=-1)) + 1

    @property
    def nnz(self) -> int:
        return int(self.rows.size)

    def color_groups(self) -> list[np.ndarray]:
        """The columns of each color, in color order."""
        order = np.argsort(self.colors, kind='stable')
        colored = order[self.colors[order] >= 0]
        bounds = np.searchsorted(self.colors[colored], np.arange(self.n_colors + 1))
        return [colored[a:b] for a, b in zip(bounds[:-1], bounds[1:])]

    def recover(self, products: np.ndarray, h: np.ndarray) -> np.ndarray:
        """The lower triangle's values from ``products`` (colors × n: the difference of
        the gradient along each color's steps) and the steps ``h`` (n,)."""
        return products[self.source_color, self.source_row] / h[self.step_col]


@dataclass
class HessianStructure:
    """What the exact Hessian needs beyond the values, computed once per model structure:
    the nonlinear declared partial entries (:func:`varying_entries`) and the pattern's
    coloring. Saved and loaded like :class:`~suspopt.driver.sparsity.Coloring` (the
    coloring cache, :mod:`suspopt.transcription.coloring_cache`)."""

    coloring: HessianColoring
    varying: dict[EdgeKey, np.ndarray]

    def save(self, path: str | Path) -> None:
        c = self.coloring
        keys = list(self.varying)
        masks = [np.asarray(self.varying[k], dtype=bool) for k in keys]
        with open(path, 'wb') as fh:
            np.savez(
                fh,
                n=np.asarray(c.n),
                rows=c.rows,
                cols=c.cols,
                colors=c.colors,
                source_color=c.source_color,
                source_row=c.source_row,
                step_col=c.step_col,
                edges=np.asarray(json.dumps([[o, k] for o, k in keys])),
                mask_sizes=np.asarray([m.size for m in masks], dtype=np.int64),
                masks=np.concatenate(masks) if masks else np.zeros(0, dtype=bool),
            )

    @classmethod
    def load(cls, path: str | Path) -> HessianStructure:
        with np.load(path) as d:
            coloring = HessianColoring(
                n=int(d['n']),
                rows=d['rows'],
                cols=d['cols'],
                colors=d['colors'],
                source_color=d['source_color'],
                source_row=d['source_row'],
                step_col=d['step_col'],
            )
            keys = [(str(o), int(k)) for o, k in json.loads(str(d['edges']))]
            masks = np.split(d['masks'], np.cumsum(d['mask_sizes'])[:-1]) if keys else []
        return cls(coloring=coloring, varying=dict(zip(keys, masks)))

    def matches(self, flow: DataFlow, n: int) -> bool:
        """True if this structure belongs to ``flow`` with ``n`` variables (a cached one
        may be stale)."""
        if self.coloring.n != n:
            return False
        for (o, k), mask in self.varying.items():
            edges = flow.deps.get(o)
            if edges is None or k >= len(edges) or edges[k].rows.size != mask.size:
                return False
        return True


def hessian_structure(
    flow: DataFlow, wrt: list[Variable], varying: dict | None
) -> HessianStructure:
    """The pattern's coloring and the nonlinear entries (None: every declared entry)."""
    if varying is None:
        varying = {
            (o, k): np.ones(e.rows.size, dtype=bool)
            for o, edges in flow.deps.items()
            for k, e in enumerate(edges)
        }
    return HessianStructure(color_hessian(hessian_sparsity(flow, wrt, varying)), varying)


def _own_color_rows(row_nnz: np.ndarray) -> np.ndarray:
    """The rows to give a color each: the k longest for the k that minimizes k plus the
    length of the longest row left (a lower bound on the colors the others need)."""
    order = np.argsort(-row_nnz, kind='stable')
    length = np.append(row_nnz[order], 0)
    k = int(np.argmin(np.arange(length.size) + length))
    return np.sort(order[:k])


def _color_by_components(R: sp.csr_matrix) -> np.ndarray:
    """A column coloring of the symmetric pattern ``R`` (columns of one color share no
    row; -1 for empty columns): each connected component of its graph is colored on its
    own (:func:`~suspopt.driver.sparsity.color_columns` on its block), and components
    with the same block (a grid's nodes) share one coloring."""
    n = R.shape[0]
    colors = np.full(n, -1, dtype=np.int64)
    G = R.tocoo()
    if G.nnz == 0:
        return colors
    n_comp, label = connected_components(G, directed=False)
    order = np.argsort(label, kind='stable')
    start = np.searchsorted(label[order], np.arange(n_comp + 1))
    local = np.empty(n, dtype=np.int64)
    local[order] = np.arange(n) - start[label[order]]
    keys = np.lexsort((local[G.col], local[G.row], label[G.row]))
    r, c = local[G.row[keys]], local[G.col[keys]]
    entry_start = np.searchsorted(label[G.row[keys]], np.arange(n_comp + 1))
    known: dict[tuple[int, bytes], np.ndarray] = {}
    for k in range(n_comp):
        a, b = entry_start[k], entry_start[k + 1]
        if a == b:
            continue
        size = int(start[k + 1] - start[k])
        key = (size, np.stack([r[a:b], c[a:b]]).tobytes())
        if key not in known:
            sub = sp.csr_matrix((np.ones(b - a, dtype=np.float32), (r[a:b], c[a:b])), (size, size))
            known[key] = color_columns(sub)
        colors[order[start[k] : start[k + 1]]] = known[key]
    return colors


def color_hessian(pattern: sp.spmatrix) -> HessianColoring:
    """A coloring of the symmetric ``pattern`` from which every nonzero is read directly
    (see the module docstring)."""
    H = _bool(pattern)
    n = H.shape[0]
    row_nnz = np.diff(H.indptr)
    own = _own_color_rows(row_nnz)
    is_own = np.zeros(n, dtype=bool)
    is_own[own] = True
    keep = sp.diags((~is_own).astype(np.float32))
    reduced = _bool(keep @ H @ keep)  # no own row or column
    colors = _color_by_components(reduced)
    colors[own] = int(colors.max(initial=-1)) + 1 + np.arange(own.size)
    lower = sp.tril(H).tocoo()
    i, j = lower.row.astype(np.int64), lower.col.astype(np.int64)
    order = np.lexsort((i, j))
    i, j = i[order], j[order]
    from_j = ~is_own[i] | is_own[j]  # column j's color at row i, else column i's at row j
    return HessianColoring(
        n=n,
        rows=i,
        cols=j,
        colors=colors,
        source_color=np.where(from_j, colors[j], colors[i]),
        source_row=np.where(from_j, i, j),
        step_col=np.where(from_j, j, i),
    )


def fd_hessian(
    gradient: Callable[[np.ndarray], np.ndarray],
    x: np.ndarray,
    coloring: HessianColoring,
    g0: np.ndarray | None = None,
    rel_step: float = np.sqrt(np.finfo(float).eps),
) -> np.ndarray:
    """The lower triangle's values of the Jacobian of ``gradient`` at ``x`` by forward
    differences along the colors (step ``rel_step · max(1, |x_j|)``); ``g0``:
    ``gradient(x)`` if known. ``gradient`` may raise to report an evaluation that fails;
    a color whose forward step fails is then differenced backward."""
    h = rel_step * np.maximum(1.0, np.abs(x))
    g0 = gradient(x) if g0 is None else g0
    products = np.empty((coloring.n_colors, x.size))
    for c, cols in enumerate(coloring.color_groups()):
        x1 = x.copy()
        x1[cols] += h[cols]
        try:
            products[c] = gradient(x1) - g0
        except Exception:
            x1[cols] = x[cols] - h[cols]
            products[c] = g0 - gradient(x1)
    return coloring.recover(products, h)


@dataclass
class _Input:
    """One input of a nonlinear component: its entries in the model's input vector, its
    source output, the source entry of each of its entries and the unit factor."""

    start: int
    stop: int
    src: str
    src_indices: np.ndarray | None
    factor: float


@dataclass
class _Nonlinear:
    """A component with partials that vary: its inputs and its varying partials."""

    component: om.ExplicitComponent
    inputs: list[_Input]
    edges: list[Edge]


class PropagatedHessian:
    """The Hessian of the Lagrangian by second-order adjoints on the propagated totals.

    Differentiating the reverse accumulation of ``∇L`` along a direction ``v`` gives the
    second-order adjoint recursion ``μ̇_src = Σ_e (P_eᵀ μ̇_of + Ṗ_eᵀ μ_of)``, whose value at
    the design variables is ``H v`` (forward-over-reverse; Griewank & Walther,
    "Evaluating Derivatives", 2nd ed., SIAM 2008, ch. 5). Here, for all Hessian colors at
    once:

    * ``μ``: the adjoints of every output, one reverse propagation;
    * the tangents ``ẏ`` of every output along each color's steps, one forward
      propagation (as for the Jacobian);
    * ``Ṗ_e``, only for the partials that vary (:func:`varying_entries`): each such
      component is run and linearized with its inputs moved by their tangents, once per
      color, and ``(P_e(u + u̇) - P_e(u))ᵀ μ_of`` is gathered at the edge's source; the
      component is then run again at ``u``, which leaves the model as it was;
    * ``μ̇``: one reverse propagation of those sources, all colors at once.

    Only the nonlinear components are evaluated again (not the whole model) and nothing
    is differenced twice: the cost per color is one call of each nonlinear component."""

    def __init__(
        self,
        problem: om.Problem,
        totals: PropagatedTotals,
        coloring: HessianColoring,
        varying: dict[EdgeKey, np.ndarray],
    ):
        self.totals, self.coloring = totals, coloring
        flow = totals.flow
        model = problem.model
        components = {
            c.pathname: c for c in model.system_iter(recurse=True, typ=om.ExplicitComponent)
        }
        inputs_vec = model.get_nonlinear_vectors()[0]
        reach = set(totals.design_sources)  # the outputs the design moves
        for group in flow.groups:
            for o in group:
                if any(e.src in reach for e in flow.deps[o]):
                    reach.add(o)
        by_component: dict[str, list[Edge]] = {}
        for o, k in varying:  # a partial whose source the design does not move adds nothing
            e = flow.deps[o][k]
            if e.src in reach:
                by_component.setdefault(e.component, []).append(e)
        all_edges: dict[str, list[Edge]] = {}
        for edges in flow.deps.values():
            for e in edges:
                all_edges.setdefault(e.component, []).append(e)
        self._nonlinear = []
        for path, edges in by_component.items():
            seen: dict[str, _Input] = {}
            for e in all_edges[path]:  # every connected input of the component in the flow
                if e.wrt in seen or e.wrt == e.src or e.src not in reach:
                    continue
                start, stop = inputs_vec.get_range(e.wrt)
                seen[e.wrt] = _Input(start, stop, e.src, e.src_indices, e.factor)
            self._nonlinear.append(_Nonlinear(components[path], list(seen.values()), edges))
        self._inputs = inputs_vec
        self._keep = {i.src for nl in self._nonlinear for i in nl.inputs}

    def compute(
        self, steps: np.ndarray, w_obj: float, w_con: np.ndarray, linearized: bool = False
    ) -> np.ndarray:
        """The products of the Hessian of ``w_obj f + Σ w_con[i] c_i`` (unscaled) with each
        color's steps (``steps``: (n,) physical steps of the design entries): (colors, n).
        The model must be run at the point (and, if ``linearized``, the totals' last
        linearization be there); it is left there, linearized."""
        totals, coloring = self.totals, self.coloring
        n_colors = coloring.n_colors
        if not linearized:
            totals.linearize()
        mu, _ = totals.adjoints(w_obj, w_con)
        E = np.zeros((steps.size, n_colors))
        colored = coloring.colors >= 0
        E[np.nonzero(colored)[0], coloring.colors[colored]] = steps[colored]
        T = totals.forward(totals.design_seeds(E), self._keep)
        sizes = totals.flow.sizes
        sources: dict[str, np.ndarray] = {}
        u = self._inputs.asarray()
        for nl in self._nonlinear:
            comp = nl.component
            base = [np.array(e.subjac.values(), dtype=float) for e in nl.edges]
            weights = [e.factor * mu[e.of][e.rows, 0] if e.of in mu else None for e in nl.edges]
            saved = [u[i.start : i.stop].copy() for i in nl.inputs]
            try:
                for c in range(n_colors):
                    for i, u0 in zip(nl.inputs, saved):
                        t = T.get(i.src)
                        if t is not None:
                            d = t[:, c] if i.src_indices is None else t[i.src_indices, c]
                            u[i.start : i.stop] = u0 + i.factor * d
                    comp.run_solve_nonlinear()
                    comp.run_linearize()
                    for e, v0, w in zip(nl.edges, base, weights):
                        if w is None:
                            continue
                        dP = np.asarray(e.subjac.values(), dtype=float) - v0
                        S = sources.setdefault(e.src, np.zeros((sizes[e.src], n_colors)))
                        S[:, c] += np.bincount(e.cols, weights=dP * w, minlength=sizes[e.src])
            finally:
                for i, u0 in zip(nl.inputs, saved):
                    u[i.start : i.stop] = u0
                comp.run_solve_nonlinear()
                comp.run_linearize()
        return totals.reverse(sources, n_colors).T
