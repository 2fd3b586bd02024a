"""Force elements: suspension (paper eqs. 9 and 12) and tyre (eqs. 10 and 13)."""
from __future__ import annotations

import numpy as np

from suspopt.models import equations as eq
from suspopt.models.base import NodeComponent


class SuspensionForceComp(NodeComponent):
    """Spring-damper force between the chassis and one axle, eq. 9 (low fidelity) / eq. 12.

    ``F_S = k_S (z_W + a theta_C - z_C) + c_S (v_W + a omega_C - v_C)``.

    ``z_W``/``v_W`` is the displacement/velocity of the suspension's wheel-side attachment:
    the wheel itself in the half car (eq. 9), the spring point ``q^z_U`` on the upper arm
    in the mixed-fidelity model (eq. 12). Positive ``F_S`` pushes the chassis up.
    """

    def setup(self) -> None:
        nn = self.options['num_nodes']
        for name, units in (('z_W', 'm'), ('v_W', 'm/s'), ('z_C', 'm'), ('v_C', 'm/s'),
                            ('theta_C', 'rad'), ('omega_C', 'rad/s')):
            self.add_input(name, shape=(nn,), units=units)
        self.add_input('k_S', val=30000.0, units='N/m', desc='spring rate')
        self.add_input('c_S', val=3000.0, units='N*s/m', desc='damping coefficient')
        self.add_input('a', val=1.0, units='m', desc='axle position ahead of the chassis CG')
        self.add_output('F_S', shape=(nn,), units='N', desc='suspension force on the chassis')

        for wrt in ('z_W', 'v_W', 'z_C', 'v_C', 'theta_C', 'omega_C'):
            self._node_partials('F_S', wrt)
        for wrt in ('k_S', 'c_S', 'a'):
            self._param_partials('F_S', wrt)

    def compute(self, inputs, outputs) -> None:
        outputs['F_S'] = eq.suspension_force(
            inputs['k_S'], inputs['c_S'], inputs['a'], inputs['z_W'], inputs['v_W'],
            inputs['z_C'], inputs['v_C'], inputs['theta_C'], inputs['omega_C'])

    def compute_partials(self, inputs, partials) -> None:
        k, c, a = inputs['k_S'][0], inputs['c_S'][0], inputs['a'][0]
        nn = self.options['num_nodes']
        partials['F_S', 'z_W'] = np.full(nn, k)
        partials['F_S', 'z_C'] = np.full(nn, -k)
        partials['F_S', 'theta_C'] = np.full(nn, k * a)
        partials['F_S', 'v_W'] = np.full(nn, c)
        partials['F_S', 'v_C'] = np.full(nn, -c)
        partials['F_S', 'omega_C'] = np.full(nn, c * a)
        partials['F_S', 'k_S'] = inputs['z_W'] + a * inputs['theta_C'] - inputs['z_C']
        partials['F_S', 'c_S'] = inputs['v_W'] + a * inputs['omega_C'] - inputs['v_C']
        partials['F_S', 'a'] = k * inputs['theta_C'] + c * inputs['omega_C']


class TyreForceComp(NodeComponent):
    """Linear tyre spring between road and wheel, eq. 10 / eq. 13: ``F_T = k_T (delta - z_W)``.

    ``z_W`` is the wheel displacement (``q^z_W`` in the mixed-fidelity model). The tyre may
    pull (no lift-off), as in the paper.
    """

    def setup(self) -> None:
        nn = self.options['num_nodes']
        self.add_input('delta', shape=(nn,), units='m', desc='road height under the tyre')
        self.add_input('z_W', shape=(nn,), units='m', desc='wheel vertical displacement')
        self.add_input('k_T', val=200000.0, units='N/m', desc='tyre vertical rate')
        self.add_output('F_T', shape=(nn,), units='N', desc='tyre force on the wheel, up')
        self._node_partials('F_T', 'delta')
        self._node_partials('F_T', 'z_W')
        self._param_partials('F_T', 'k_T')

    def compute(self, inputs, outputs) -> None:
        outputs['F_T'] = eq.tyre_force(inputs['k_T'], inputs['delta'], inputs['z_W'])

    def compute_partials(self, inputs, partials) -> None:
        k_T = inputs['k_T'][0]
        nn = self.options['num_nodes']
        partials['F_T', 'delta'] = np.full(nn, k_T)
        partials['F_T', 'z_W'] = np.full(nn, -k_T)
        partials['F_T', 'k_T'] = inputs['delta'] - inputs['z_W']
