"""Shared plumbing of the model components: vectorized over nodes and corners, with
sparse analytic partials (Dymos' idiom)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import openmdao.api as om


class NodeComponent(om.ExplicitComponent):
    """An explicit component evaluated at ``num_nodes`` collocation nodes at once, with
    per-wheel variables of shape (num_nodes, corners).

    The helpers declare the sparse partial patterns: a per-node output depends on inputs
    at the same node (and corner) only; a static per-corner setting (a design variable,
    the same at every node) enters every node of its corner.
    """

    def initialize(self) -> None:
        self.options.declare('num_nodes', types=int, desc='number of nodes evaluated at once')
        self.options.declare('corners', types=int, default=2, desc='number of wheels')

    def evaluate(self, inputs: Mapping[str, Any]) -> dict[str, np.ndarray]:
        """The component's equation: its outputs from its inputs, for any number of nodes
        (``compute`` calls it; so does the time marching, through the vehicle assembly of
        :mod:`suspopt.models.assembly`). Depends on the options only, never on ``setup``."""
        raise NotImplementedError

    def compute(self, inputs, outputs) -> None:
        for name, value in self.evaluate(inputs).items():
            outputs[name] = value

    @property
    def _shape(self) -> tuple[int, int]:
        return self.options['num_nodes'], self.options['corners']

    def _corner_partials(self, of: str, wrt: str, val=None) -> None:
        """(nodes, corners) output and input, entry by entry (OpenMDAO's diagonal
        sub-Jacobian: an element-wise product in every linear solve)."""
        self.declare_partials(of, wrt, diagonal=True, val=val)

    def _sum_partials(self, of: str, wrt: str, val=None) -> None:
        """(nodes,) output of a (nodes, corners) input: each node's corners."""
        nn, nc = self._shape
        self.declare_partials(
            of, wrt, rows=np.repeat(np.arange(nn), nc), cols=np.arange(nn * nc), val=val
        )

    def _spread_partials(self, of: str, wrt: str, val=None) -> None:
        """(nodes, corners) output of a (nodes,) input: every corner of the node."""
        nn, nc = self._shape
        self.declare_partials(
            of, wrt, rows=np.arange(nn * nc), cols=np.repeat(np.arange(nn), nc), val=val
        )

    def _setting_partials(self, of: str, wrt: str) -> None:
        """(nodes, corners) output of a static per-corner (corners,) input."""
        nn, nc = self._shape
        self.declare_partials(of, wrt, rows=np.arange(nn * nc), cols=np.tile(np.arange(nc), nn))
