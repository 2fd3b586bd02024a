"""Exact total-Jacobian sparsity from the model's declared structure, and its coloring.

The NLP's constraint Jacobian ``d constraints / d design`` is sparse: a collocation defect
depends on the states of its own segment and on the design parameters. Its pattern is
computed here from what the components *declare* (the rows/cols of every partial
derivative) and how variables are connected, by propagating boolean sparse matrices
through the data flow: for every output ``o``,

    S_o = ⋁_k P_k S_{x_k}        (P_k: the declared pattern of d o / d x_k),

with ``S = I`` at the design variables, processed in topological order (strongly
connected components, e.g. an implicit coupling, are iterated to a fixed point). Time and
memory are proportional to the nonzeros; no dense m × n array is ever formed, and the
result does not depend on any value (so a derivative that happens to be zero at the
starting point, e.g. ``dF_S/dk_S`` at zero states, is never dropped).

:func:`color_columns` then groups the columns that share no row (a greedy distance-1
coloring of the column intersection graph, largest columns first), so that one forward
linear solve per color gives all columns of that color (Curtis, Powell & Reid 1974).
"""

from __future__ import annotations

import hashlib
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import openmdao.api as om
import scipy.sparse as sp

import suspopt.driver.structure as structure
from suspopt import interrupts
from suspopt.driver.dataflow import DataFlow, data_flow


@dataclass(frozen=True)
class Variable:
    """A design variable or response in the driver's layout: its source output and the
    entries of that output it covers (None: all)."""

    name: str
    source: str
    indices: np.ndarray | None
    size: int


@dataclass
class Coloring:
    """A column coloring of a sparse Jacobian pattern.

    ``rows``/``cols`` are the nonzeros (sorted by column, then row); ``colors[j]`` is the
    color of column ``j`` among the rows solved forward (-1 for a column without such
    nonzeros); ``reverse_rows`` are the dense rows (e.g. an epigraph constraint over a whole
    trajectory), each obtained by one reverse solve instead (bidirectional: a dense row
    would otherwise make every column a color of its own).
    """

    shape: tuple[int, int]
    rows: np.ndarray
    cols: np.ndarray
    colors: np.ndarray
    info: dict = field(default_factory=dict)
    reverse_rows: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

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

    def save(self, path: str | Path) -> None:
        with open(path, 'wb') as fh:
            np.savez(
                fh,
                shape=np.asarray(self.shape),
                rows=self.rows,
                cols=self.cols,
                colors=self.colors,
                reverse_rows=self.reverse_rows,
            )

    @classmethod
    def load(cls, path: str | Path) -> Coloring:
        with np.load(path) as data:
            return cls(
                shape=(int(data['shape'][0]), int(data['shape'][1])),
                rows=data['rows'],
                cols=data['cols'],
                colors=data['colors'],
                reverse_rows=data['reverse_rows'],
            )

    def digest(self) -> str:
        h = hashlib.sha256()
        for a in (np.asarray(self.shape), self.rows, self.cols, self.colors, self.reverse_rows):
            h.update(np.ascontiguousarray(a).tobytes())
        return h.hexdigest()[:16]


def _bool(m: sp.spmatrix) -> sp.csr_matrix:
    """A CSR matrix with every stored entry set to one (pattern only)."""
    m = sp.csr_matrix(m)
    m.sum_duplicates()
    m.data = np.ones(m.data.size, dtype=np.float32)
    return m


def structural_sparsity(
    problem: om.Problem, of: list[Variable], wrt: list[Variable]
) -> sp.csr_matrix:
    """The exact pattern of ``d of / d wrt`` (rows: ``of`` entries in order, columns:
    ``wrt`` entries in order) from the declared partials of every component."""
    flow = data_flow(problem, [v.source for v in of])
    S = forward_patterns(flow, wrt, keep={v.source for v in of})
    ncol = sum(v.size for v in wrt)
    blocks = []
    for v in of:
        s = S[v.source]
        blocks.append(s if v.indices is None else s[v.indices])
    return _bool(sp.vstack(blocks, format='csr')) if blocks else sp.csr_matrix((0, ncol))


def forward_patterns(
    flow: DataFlow,
    wrt: list[Variable],
    keep: set[str],
    visit: Callable[[str, dict[str, sp.csr_matrix]], None] | None = None,
) -> dict[str, sp.csr_matrix]:
    """The pattern ``S_o`` of ``d o / d wrt`` of every output ``o`` of ``flow``, in its
    topological order; ``visit(o, S)`` is called right after ``S_o`` of an output outside
    any cycle is formed, while the patterns of all its sources are still in ``S``. Returns
    the patterns of the outputs in ``keep`` (the others are freed once read)."""
    sizes = flow.sizes
    patterns = {
        id(e): sp.csr_matrix(
            (np.ones(e.rows.size, dtype=np.float32), (e.rows, e.cols)), shape=e.shape
        )
        for edges in flow.deps.values()
        for e in edges
    }

    # columns: one per design-variable entry
    ncol = sum(v.size for v in wrt)
    seeds: dict[str, sp.csr_matrix] = {}
    start = 0
    for v in wrt:
        idx = np.arange(sizes[v.source]) if v.indices is None else v.indices
        seed = sp.csr_matrix(
            (np.ones(idx.size, dtype=np.float32), (idx, start + np.arange(idx.size))),
            shape=(sizes[v.source], ncol),
        )
        seeds[v.source] = seed if v.source not in seeds else _bool(seeds[v.source] + seed)
        start += idx.size

    consumers = flow.consumers()
    S: dict[str, sp.csr_matrix] = {}

    def evaluate(o: str) -> sp.csr_matrix:
        out = seeds.get(o, sp.csr_matrix((sizes[o], ncol), dtype=np.float32))
        for e in flow.deps[o]:
            s = S.get(e.src)
            if s is not None and s.nnz:
                out = out + patterns[id(e)] @ s
        return _bool(out)

    for group in flow.groups:
        interrupts.checkpoint()  # a signal stops the preparation at once (nothing to keep)
        if not flow.is_cycle(group):
            S[group[0]] = evaluate(group[0])
            if visit is not None:
                visit(group[0], S)
        else:  # a cycle: iterate to the fixed point (the structural closure)
            for n in group:
                S[n] = sp.csr_matrix((sizes[n], ncol), dtype=np.float32)
            while True:
                changed = False
                for n in group:
                    new = evaluate(n)
                    if new.nnz != S[n].nnz:
                        changed = True
                    S[n] = new
                if not changed:
                    break
        for n in group:  # free what no one downstream needs any more
            for e in flow.deps[n]:
                consumers[e.src] -= 1
                if consumers[e.src] == 0 and e.src not in keep and e.src in S:
                    del S[e.src]
    return {n: S[n] for n in keep if n in S}


def color_columns(pattern: sp.spmatrix) -> np.ndarray:
    """A greedy column coloring: columns of one color share no row; -1 for empty columns.

    Each column gets the smallest color that none of its neighbours in the column
    intersection graph (columns sharing a row) has; the dense columns (the design
    parameters, which touch every node) go first, then the others by their first row (the
    banded order of a collocation grid). Cost: proportional to the nonzeros of that graph."""
    J = _bool(pattern)
    m, n = J.shape
    Jc = J.tocsc()
    Jc.sort_indices()
    degree = np.diff(Jc.indptr)
    first = np.where(degree > 0, Jc.indices[np.minimum(Jc.indptr[:-1], max(Jc.nnz - 1, 0))], m)
    dense = degree > 0.5 * m
    order = np.lexsort((first, ~dense))
    G = (Jc.T @ J.tocsr()).tocsr()  # columns sharing a row
    colors = np.full(n, -1, dtype=np.int64)
    taken = np.zeros(n + 1, dtype=bool)
    for i, c in enumerate(order):
        if not i % 4096:
            interrupts.checkpoint()  # a signal stops the preparation at once
        if degree[c] == 0:
            continue
        nb = colors[G.indices[G.indptr[c] : G.indptr[c + 1]]]
        nb = nb[nb >= 0]
        taken[nb] = True
        colors[c] = int(np.argmin(taken[: nb.size + 1]))
        taken[nb] = False
    return colors


#: only a constraint row with more nonzeros than this may be computed by a reverse solve
DENSE_ROW_MIN = 200


def dense_rows(row_nnz: np.ndarray) -> np.ndarray:
    """The rows left to reverse solves (sorted indices): the k longest, for the k that
    minimizes k (one reverse seed each) plus the length of the longest row left forward (a
    lower bound on the forward colors: its columns all need colors of their own). Only
    rows longer than :data:`DENSE_ROW_MIN` are candidates. E.g. the worst-case bounds
    ``f_s ≤ t``, each dense over its own scenario's states, however many scenarios share
    the NLP."""
    order = np.argsort(-row_nnz, kind='stable')
    length = np.append(row_nnz[order], 0)
    k_max = int(np.count_nonzero(row_nnz > DENSE_ROW_MIN))
    k = int(np.argmin(np.arange(k_max + 1) + length[: k_max + 1]))
    return np.sort(order[:k])


def compute_coloring(problem: om.Problem, of: list[Variable], wrt: list[Variable]) -> Coloring:
    """The sparsity of ``d of / d wrt`` and its column coloring, from the declared
    structure (OpenMDAO's public, dense total coloring where :mod:`structure` does not
    support this OpenMDAO version)."""
    t0 = time.perf_counter()
    interrupts.stage('coloring')
    if structure.supported():
        pattern, method = structural_sparsity(problem, of, wrt).tocsc(), 'structure'
    else:
        pattern, method = _dense_sparsity(problem, of, wrt).tocsc(), 'openmdao'
    t1 = time.perf_counter()
    pattern.sort_indices()
    coo = pattern.tocoo()
    m = pattern.shape[0]
    row_nnz = np.bincount(coo.row, minlength=m)
    reverse = dense_rows(row_nnz)
    forward = pattern.tocsr()
    if reverse.size:
        keep = np.ones(m, dtype=bool)
        keep[reverse] = False
        forward = sp.diags(keep.astype(np.float32)) @ forward
        forward.eliminate_zeros()
    colors = color_columns(forward)
    t2 = time.perf_counter()
    return Coloring(
        shape=tuple(pattern.shape),
        rows=coo.row.astype(np.int64),
        cols=coo.col.astype(np.int64),
        colors=colors,
        reverse_rows=reverse.astype(np.int64),
        info={'method': method, 'sparsity_s': t1 - t0, 'coloring_s': t2 - t1},
    )


def _dense_sparsity(problem: om.Problem, of: list[Variable], wrt: list[Variable]) -> sp.csr_matrix:
    """OpenMDAO's own (public) total sparsity: randomized dense total Jacobians. Cost and
    memory grow with m × n; the fallback for an OpenMDAO whose internals are unknown."""
    from openmdao.utils.coloring import compute_total_coloring

    coloring = compute_total_coloring(
        problem, of=[v.name for v in of], wrt=[v.name for v in wrt], num_full_jacs=2
    )
    return sp.csr_matrix(coloring.get_dense_sparsity(dtype=bool))
