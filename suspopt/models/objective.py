"""The objective (paper eq. 4, ``docs/model.md``): the terms' integrals by the
collocation's quadrature (their integrands are the metrics' squares,
:class:`~suspopt.models.metrics.SquaredSignalsComp`), the normalized weighted sum, and the
scenarios' aggregate."""

from __future__ import annotations

import numpy as np
import openmdao.api as om

from suspopt.models import metrics

#: units of each term's integral (stated in the metrics table)
term_units = metrics.term_units


class ObjectiveQuadratureComp(om.ExplicitComponent):
    """The integrals ``J_k = ∫_0^T dJ_k/dt dt`` (eq. 4) by the transcription's quadrature.

    ``weights`` (option, one per node) are the Radau (LGR) quadrature weights of the grid
    times each segment's dt/dτ, zero at the segment ends that are not collocation points.
    This is exactly the value an integrated state ``J' = dJ_dt`` would reach under Radau
    collocation, without (terms × nodes) extra NLP variables and defects.
    """

    def initialize(self) -> None:
        self.options.declare('weights', types=np.ndarray, desc='quadrature weight per node [s]')
        self.options.declare('terms', types=int, desc='number of objective terms')

    def setup(self) -> None:
        w, nt = self.options['weights'], self.options['terms']
        nn = w.size
        self.add_input('dJ_dt', shape=(nn, nt), units=None, desc='integrands at the nodes')
        self.add_output('J', shape=(nt,), units=None, desc='the terms over the horizon')
        nodes = np.nonzero(w)[0]
        rows = np.tile(np.arange(nt), nodes.size)
        cols = (nt * nodes[:, None] + np.arange(nt)).ravel()
        self.declare_partials('J', 'dJ_dt', rows=rows, cols=cols, val=np.repeat(w[nodes], nt))

    def compute(self, inputs, outputs) -> None:
        outputs['J'] = self.options['weights'] @ inputs['dJ_dt']


class WeightedObjectiveComp(om.ExplicitComponent):
    """The scalar objective ``f = Σ_k w_k J_k / s_k`` (eq. 4 with docs/model.md normalization).

    Weights and scales are inputs, not options, so one built problem serves every
    weighting (Pareto sweeps) and normalization without a new setup or coloring.
    """

    def initialize(self) -> None:
        self.options.declare('terms', types=int, desc='number of objective terms')

    def setup(self) -> None:
        nt = self.options['terms']
        self.add_input('J', shape=(nt,), units=None, desc='the terms over the horizon')
        self.add_input('weights', val=np.full(nt, 1.0 / nt), units=None)
        self.add_input('scales', val=np.ones(nt), units=None)
        self.add_output('f', units=None, desc='normalized weighted objective')
        self.declare_partials('f', ['J', 'weights', 'scales'])

    def compute(self, inputs, outputs) -> None:
        outputs['f'] = np.sum(inputs['weights'] * inputs['J'] / inputs['scales'])

    def compute_partials(self, inputs, partials) -> None:
        w, J, s = inputs['weights'], inputs['J'], inputs['scales']
        partials['f', 'J'] = w / s
        partials['f', 'weights'] = J / s
        partials['f', 'scales'] = -w * J / s**2


class ScenarioObjectiveComp(om.ExplicitComponent):
    """Several scenarios' objectives into one: ``Σ_s w_s f_s`` (robust design, sum)."""

    def initialize(self) -> None:
        self.options.declare('weights', types=tuple, desc='scenario weights')

    def setup(self) -> None:
        for i in range(len(self.options['weights'])):
            self.add_input(f'f{i}', val=0.0)
        self.add_output('f', val=0.0, desc='the combined objective')
        for i, w in enumerate(self.options['weights']):
            self.declare_partials('f', f'f{i}', val=float(w))

    def compute(self, inputs, outputs) -> None:
        outputs['f'] = sum(w * inputs[f'f{i}'] for i, w in enumerate(self.options['weights']))


class WorstCaseGapComp(om.ExplicitComponent):
    """The epigraph of the worst case (``aggregate = "max"``): ``g_s = f_s - t`` (constrained
    ≤ 0), so minimizing ``t`` minimizes ``max_s f_s`` with smooth functions."""

    def initialize(self) -> None:
        self.options.declare('n', types=int, desc='number of scenarios')

    def setup(self) -> None:
        n = self.options['n']
        for i in range(n):
            self.add_input(f'f{i}', val=0.0)
        self.add_input('t', val=0.0, desc='bound on every scenario objective')
        self.add_output('gap', shape=(n,), desc='f_s - t')
        for i in range(n):
            self.declare_partials('gap', f'f{i}', rows=[i], cols=[0], val=1.0)
        self.declare_partials(
            'gap', 't', rows=np.arange(n), cols=np.zeros(n, dtype=int), val=-np.ones(n)
        )

    def compute(self, inputs, outputs) -> None:
        outputs['gap'] = (
            np.array([inputs[f'f{i}'][0] for i in range(self.options['n'])]) - inputs['t'][0]
        )
