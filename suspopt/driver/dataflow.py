"""The model's data flow as a graph of outputs: who depends on whom, through which partials.

Each *edge* is one declared partial derivative ``d of / d x`` of a component, carried to
the output ``src`` that feeds ``x`` (through the connection, its source indices and its
unit conversion), so that to first order

    d of = Σ_edges P_e · d src_e,        P_e = (unit factor) · (declared d of / d x)[:, idx]

The exact total-Jacobian sparsity (:mod:`suspopt.driver.sparsity`) and the propagated
total derivatives (:mod:`suspopt.driver.propagation`) both walk this graph, in the
topological order of its strongly connected components, from the design variables to the
responses. The declared patterns and the connections come from :mod:`structure`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import openmdao.api as om
import scipy.sparse as sp
from openmdao.utils.units import unit_conversion
from scipy.sparse.csgraph import connected_components

import suspopt.driver.structure as structure


@dataclass(frozen=True)
class Edge:
    """One partial derivative carried to its source output: ``P`` has ``rows`` (entries
    of ``of``) and ``cols`` (entries of ``src``), shape ``shape``; ``factor`` converts the
    source's units into the input's; ``subjac`` holds the component's declared values.
    ``component`` is the component's path, ``wrt`` the input (or output) differentiated and
    ``src_indices`` the source entry of each of its entries (None: all, in order)."""

    of: str
    src: str
    rows: np.ndarray
    cols: np.ndarray
    shape: tuple[int, int]
    factor: float
    subjac: structure.Subjac
    implicit: bool
    component: str = ''
    wrt: str = ''
    src_indices: np.ndarray | None = None


@dataclass
class DataFlow:
    """The edges into every output, the output sizes, and the evaluation order."""

    deps: dict[str, list[Edge]]
    sizes: dict[str, int]
    #: the strongly connected components of the outputs the responses depend on, in
    #: topological order (a group of more than one output, or one that depends on
    #: itself, is a cycle)
    groups: list[list[str]]

    def is_cycle(self, group: list[str]) -> bool:
        return len(group) > 1 or any(e.src == group[0] for e in self.deps.get(group[0], ()))

    def ancestors(self, outputs: set[str]) -> DataFlow:
        """The part of this flow that ``outputs`` depend on (themselves included)."""
        needed, stack = set(), [o for o in outputs if o in self.deps]
        while stack:
            name = stack.pop()
            if name not in needed:
                needed.add(name)
                stack.extend(e.src for e in self.deps[name])
        groups = [g for g in self.groups if g[0] in needed]
        return DataFlow(deps={n: self.deps[n] for n in needed}, sizes=self.sizes, groups=groups)

    def consumers(self) -> dict[str, int]:
        """How many outputs of the flow read each output (to free what is no longer needed)."""
        count = {n: 0 for g in self.groups for n in g}
        for g in self.groups:
            for n in g:
                for e in self.deps.get(n, ()):
                    count[e.src] += 1
        return count


def data_flow(problem: om.Problem, responses: list[str]) -> DataFlow:
    """The data flow of ``problem``'s model restricted to the ancestors of ``responses``
    (source output names)."""
    model = problem.model
    sources = structure.input_sources(model)
    meta_out = model.get_io_metadata(
        iotypes='output', metadata_keys=['size', 'units'], return_rel_names=False
    )
    meta_in = model.get_io_metadata(
        iotypes='input', metadata_keys=['units'], return_rel_names=False
    )
    sizes = {name: int(m['size']) for name, m in meta_out.items()}

    deps: dict[str, list[Edge]] = {}
    for comp in model.system_iter(recurse=True):
        if not isinstance(comp, (om.ExplicitComponent, om.ImplicitComponent)):
            continue
        implicit = isinstance(comp, om.ImplicitComponent)
        for sj in structure.declared_subjacs(comp):
            factor = 1.0
            idx = None
            if sj.wrt in sources:  # an input: through its connection
                src, idx = sources[sj.wrt]
                cols = sj.cols if idx is None else idx[sj.cols]
                us, ui = meta_out[src]['units'], meta_in[sj.wrt]['units']
                if us is not None and ui is not None and us != ui:
                    factor = float(unit_conversion(us, ui)[0])
            elif sj.wrt in sizes:  # an output (implicit component)
                src, cols = sj.wrt, sj.cols
            else:  # an unconnected input: a constant
                continue
            if sj.rows.size == 0:
                continue
            deps.setdefault(sj.of, []).append(
                Edge(
                    of=sj.of,
                    src=src,
                    rows=sj.rows,
                    cols=cols,
                    shape=(sj.shape[0], sizes[src]),
                    factor=factor,
                    subjac=sj,
                    implicit=implicit,
                    component=comp.pathname,
                    wrt=sj.wrt,
                    src_indices=idx,
                )
            )

    needed, stack = set(), list(responses)
    while stack:
        name = stack.pop()
        if name in needed:
            continue
        needed.add(name)
        stack.extend(e.src for e in deps.get(name, ()))
    names = sorted(needed)
    index = {n: i for i, n in enumerate(names)}
    edges = [(index[e.src], index[o]) for o in names for e in deps.get(o, ())]
    graph = sp.csr_matrix(
        (np.ones(len(edges)), tuple(np.array(edges, dtype=np.int64).T) if edges else ([], [])),
        shape=(len(names), len(names)),
    )
    n_scc, label = connected_components(graph, directed=True, connection='strong')
    members: dict[int, list[str]] = {}
    for n in names:
        members.setdefault(int(label[index[n]]), []).append(n)
    groups = [members[c] for c in _topological_order(graph, n_scc, label)]
    return DataFlow(deps={n: deps.get(n, []) for n in names}, sizes=sizes, groups=groups)


def _topological_order(graph: sp.csr_matrix, n_scc: int, label: np.ndarray) -> list[int]:
    """The strongly connected components of ``graph`` in topological order (Kahn)."""
    g = graph.tocoo()
    a, b = label[g.row], label[g.col]
    keep = a != b
    cond = sp.csr_matrix((np.ones(int(keep.sum())), (a[keep], b[keep])), shape=(n_scc, n_scc))
    cond.sum_duplicates()
    indeg = np.asarray((cond > 0).sum(axis=0)).ravel()
    ready = list(np.nonzero(indeg == 0)[0])
    order = []
    while ready:
        c = ready.pop()
        order.append(int(c))
        for d in cond.indices[cond.indptr[c] : cond.indptr[c + 1]]:
            indeg[d] -= 1
            if indeg[d] == 0:
                ready.append(d)
    if len(order) != n_scc:  # pragma: no cover - the condensation is acyclic by definition
        raise RuntimeError('internal error: cyclic condensation')
    return order
