"""Wheel (unsprung mass) of the half car: paper eqs. 7-8."""
from __future__ import annotations

import numpy as np

from suspopt.models import equations as eq
from suspopt.models.base import NodeComponent


class WheelDynamicsComp(NodeComponent):
    """Wheel hop of one axle, eqs. 7-8: ``m z''_W = -F_S + F_T``.

    In the mixed-fidelity model this equation is replaced by the multibody module
    (:mod:`suspopt.multibody.components`).
    """

    def setup(self) -> None:
        nn = self.options['num_nodes']
        self.add_input('F_S', shape=(nn,), units='N', desc='suspension force (on the chassis)')
        self.add_input('F_T', shape=(nn,), units='N', desc='tyre force (on the wheel)')
        self.add_input('m', val=120.0, units='kg', desc='wheel (unsprung) mass')
        self.add_output('zdd_W', shape=(nn,), units='m/s**2', desc='wheel vertical acceleration')
        self._node_partials('zdd_W', 'F_S')
        self._node_partials('zdd_W', 'F_T')
        self._param_partials('zdd_W', 'm')

    def compute(self, inputs, outputs) -> None:
        outputs['zdd_W'] = eq.wheel_acceleration(inputs['F_S'], inputs['F_T'], inputs['m'])

    def compute_partials(self, inputs, partials) -> None:
        m = inputs['m'][0]
        nn = self.options['num_nodes']
        partials['zdd_W', 'F_S'] = np.full(nn, -1.0 / m)
        partials['zdd_W', 'F_T'] = np.full(nn, 1.0 / m)
        partials['zdd_W', 'm'] = -(inputs['F_T'] - inputs['F_S']) / m**2
