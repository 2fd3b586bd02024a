"""Wheels (unsprung masses) of the half and full car: paper eqs. 7-8."""

from __future__ import annotations

import numpy as np

from suspopt.models import equations as eq
from suspopt.models.base import NodeComponent


class WheelDynamicsComp(NodeComponent):
    """Wheel hop at every corner, eqs. 7-8: ``m z''_W = F_T - Σ F`` (the suspension's forces
    on the chassis, ``forces``, act on the wheel with the opposite sign).

    In the mixed-fidelity model this equation is replaced by the multibody module
    (:mod:`suspopt.multibody.components`).
    """

    def initialize(self) -> None:
        super().initialize()
        self.options.declare('forces', types=tuple, default=('F_S',))
        self.options.declare('m', types=np.ndarray, desc='wheel (unsprung) mass per corner [kg]')

    def setup(self) -> None:
        nn, nc = self._shape
        self.add_input('F_T', shape=(nn, nc), units='N', desc='tyre force on the wheel, up')
        for name in self.options['forces']:
            self.add_input(name, shape=(nn, nc), units='N', desc='force on the chassis, up')
        self.add_output('zdd_W', shape=(nn, nc), units='m/s**2', desc='wheel acceleration')
        inv_m = np.tile(1.0 / self.options['m'], nn)
        self._corner_partials('zdd_W', 'F_T', val=inv_m)
        for name in self.options['forces']:
            self._corner_partials('zdd_W', name, val=-inv_m)

    def evaluate(self, inputs):
        F = sum(inputs[name] for name in self.options['forces'])
        return {'zdd_W': eq.wheel_acceleration(inputs['F_T'], F, self.options['m'])}
