"""Shared plumbing for the vectorized, analytically differentiated model components."""
from __future__ import annotations

import numpy as np
import openmdao.api as om


class NodeComponent(om.ExplicitComponent):
    """An explicit component evaluated at ``num_nodes`` collocation nodes at once.

    Subclasses declare node-wise inputs (one value per node) and scalar parameters (one
    value for all nodes, connected from Dymos parameters as static targets) through the two
    helpers below, which also declare the sparse partial-derivative patterns: a node-wise
    output depends on a node-wise input at the same node only (a diagonal), and on a scalar
    parameter at every node (a column).
    """

    def initialize(self) -> None:
        self.options.declare('num_nodes', types=int, desc='number of nodes evaluated at once')

    def _node_partials(self, of: str, wrt: str, val: float | np.ndarray | None = None) -> None:
        # OpenMDAO's diagonal sub-Jacobian: an element-wise product in every linear solve
        # (a sparse one with rows = cols costs a bincount; ~30 % of a low-fidelity solve)
        self.declare_partials(of, wrt, diagonal=True, val=val)

    def _param_partials(self, of: str, wrt: str) -> None:
        nn = self.options['num_nodes']
        self.declare_partials(of, wrt, rows=np.arange(nn), cols=np.zeros(nn, dtype=int))
