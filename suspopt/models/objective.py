"""The objective (paper eq. 4, SPEC §5): integrands along the trajectory and the weighted sum."""
from __future__ import annotations

import numpy as np
import openmdao.api as om

from suspopt.models import equations as eq
from suspopt.models.base import NodeComponent

#: Names of the four objective terms, in order.
TERMS = ('J1', 'J2', 'J3', 'J4')


class ObjectiveIntegrandComp(NodeComponent):
    """Integrands of ``J_1..J_4`` (eq. 4): ``z''_C², theta''_C², z_W1², z_W2²``.

    The output ``dJ_dt`` (num_nodes × 4) is integrated over the horizon by
    :class:`ObjectiveQuadratureComp` with the collocation's own quadrature (SPEC §5). The
    four terms have different units; the vector is declared unitless and documented here.
    """

    def setup(self) -> None:
        nn = self.options['num_nodes']
        self.add_input('zdd_C', shape=(nn,), units='m/s**2')
        self.add_input('thdd_C', shape=(nn,), units='rad/s**2')
        self.add_input('z_W1', shape=(nn,), units='m')
        self.add_input('z_W2', shape=(nn,), units='m')
        self.add_output('dJ_dt', shape=(nn, 4), units=None,
                        desc='[(m/s²)², (rad/s²)², m², m²] integrands of J1..J4')
        ar = np.arange(nn)
        for k, wrt in enumerate(('zdd_C', 'thdd_C', 'z_W1', 'z_W2')):
            self.declare_partials('dJ_dt', wrt, rows=4 * ar + k, cols=ar)

    def compute(self, inputs, outputs) -> None:
        outputs['dJ_dt'] = eq.objective_integrands(inputs['zdd_C'], inputs['thdd_C'],
                                                   inputs['z_W1'], inputs['z_W2'])

    def compute_partials(self, inputs, partials) -> None:
        for wrt in ('zdd_C', 'thdd_C', 'z_W1', 'z_W2'):
            partials['dJ_dt', wrt] = 2.0 * inputs[wrt]


class ObjectiveQuadratureComp(om.ExplicitComponent):
    """The integrals ``J_k = ∫_0^T dJ_k/dt dt`` (eq. 4) by the transcription's quadrature.

    ``weights`` (option, one per node) are the Radau (LGR) quadrature weights of the grid
    times each segment's dt/dτ, zero at the segment ends that are not collocation points.
    This is exactly the value an integrated state ``J' = dJ_dt`` would reach under Radau
    collocation, without 4 × (number of nodes) extra NLP variables and defects: IPOPT's
    KKT system of the 80 × 5 problem shrinks from 9604 to 6404 rows.
    """

    def initialize(self) -> None:
        self.options.declare('weights', types=np.ndarray, desc='quadrature weight per node [s]')

    def setup(self) -> None:
        w = self.options['weights']
        nn = w.size
        self.add_input('dJ_dt', shape=(nn, 4), units=None, desc='integrands at the nodes')
        self.add_output('J', shape=(4,), units=None, desc='J1..J4 over the horizon')
        nodes = np.nonzero(w)[0]
        rows = np.tile(np.arange(4), nodes.size)
        cols = (4 * nodes[:, None] + np.arange(4)).ravel()
        self.declare_partials('J', 'dJ_dt', rows=rows, cols=cols, val=np.repeat(w[nodes], 4))

    def compute(self, inputs, outputs) -> None:
        outputs['J'] = self.options['weights'] @ inputs['dJ_dt']


class WeightedObjectiveComp(om.ExplicitComponent):
    """The scalar objective ``f = Σ_k w_k J_k / s_k`` (eq. 4 with SPEC §5 normalization).

    Weights and scales are inputs, not options, so one built problem serves every
    weighting (Pareto sweeps) and normalization without a new setup or coloring.
    """

    def setup(self) -> None:
        self.add_input('J', shape=(4,), units=None, desc='J1..J4 at the final time')
        self.add_input('weights', val=np.full(4, 0.25), units=None)
        self.add_input('scales', val=np.ones(4), units=None)
        self.add_output('f', units=None, desc='normalized weighted objective')
        self.declare_partials('f', ['J', 'weights', 'scales'])

    def compute(self, inputs, outputs) -> None:
        outputs['f'] = np.sum(inputs['weights'] * inputs['J'] / inputs['scales'])

    def compute_partials(self, inputs, partials) -> None:
        w, J, s = inputs['weights'], inputs['J'], inputs['scales']
        partials['f', 'J'] = w / s
        partials['f', 'weights'] = J / s
        partials['f', 'scales'] = -w * J / s**2
