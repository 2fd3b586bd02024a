"""Rigid chassis: heave (paper eq. 5) and pitch (eq. 6)."""
from __future__ import annotations

import numpy as np

from suspopt.models import equations as eq
from suspopt.models.base import NodeComponent


class ChassisHeaveComp(NodeComponent):
    """Chassis heave, eq. 5: ``M z''_C = F_S1 + F_S2``."""

    def setup(self) -> None:
        nn = self.options['num_nodes']
        self.add_input('F_S1', shape=(nn,), units='N', desc='front suspension force')
        self.add_input('F_S2', shape=(nn,), units='N', desc='rear suspension force')
        self.add_input('M', val=1414.0, units='kg', desc='chassis mass')
        self.add_output('zdd_C', shape=(nn,), units='m/s**2', desc='chassis heave acceleration')
        self._node_partials('zdd_C', 'F_S1')
        self._node_partials('zdd_C', 'F_S2')
        self._param_partials('zdd_C', 'M')

    def compute(self, inputs, outputs) -> None:
        outputs['zdd_C'] = eq.chassis_heave_acceleration(inputs['F_S1'], inputs['F_S2'],
                                                         inputs['M'])

    def compute_partials(self, inputs, partials) -> None:
        M = inputs['M'][0]
        nn = self.options['num_nodes']
        partials['zdd_C', 'F_S1'] = np.full(nn, 1.0 / M)
        partials['zdd_C', 'F_S2'] = np.full(nn, 1.0 / M)
        partials['zdd_C', 'M'] = -(inputs['F_S1'] + inputs['F_S2']) / M**2


class ChassisPitchComp(NodeComponent):
    """Chassis pitch, eq. 6: ``I theta''_C = -a1 F_S1 - a2 F_S2`` (theta positive nose down)."""

    def setup(self) -> None:
        nn = self.options['num_nodes']
        self.add_input('F_S1', shape=(nn,), units='N', desc='front suspension force')
        self.add_input('F_S2', shape=(nn,), units='N', desc='rear suspension force')
        self.add_input('a1', val=1.271, units='m', desc='front axle ahead of the CG')
        self.add_input('a2', val=-1.713, units='m', desc='rear axle ahead of the CG (< 0)')
        self.add_input('I', val=2782.0, units='kg*m**2', desc='chassis pitch inertia')
        self.add_output('thdd_C', shape=(nn,), units='rad/s**2',
                        desc='chassis pitch acceleration')
        self._node_partials('thdd_C', 'F_S1')
        self._node_partials('thdd_C', 'F_S2')
        for wrt in ('a1', 'a2', 'I'):
            self._param_partials('thdd_C', wrt)

    def compute(self, inputs, outputs) -> None:
        outputs['thdd_C'] = eq.chassis_pitch_acceleration(
            inputs['F_S1'], inputs['F_S2'], inputs['a1'], inputs['a2'], inputs['I'])

    def compute_partials(self, inputs, partials) -> None:
        a1, a2, I = inputs['a1'][0], inputs['a2'][0], inputs['I'][0]
        nn = self.options['num_nodes']
        F1, F2 = inputs['F_S1'], inputs['F_S2']
        partials['thdd_C', 'F_S1'] = np.full(nn, -a1 / I)
        partials['thdd_C', 'F_S2'] = np.full(nn, -a2 / I)
        partials['thdd_C', 'a1'] = -F1 / I
        partials['thdd_C', 'a2'] = -F2 / I
        partials['thdd_C', 'I'] = (a1 * F1 + a2 * F2) / I**2
