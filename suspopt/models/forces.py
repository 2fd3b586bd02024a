"""Force elements: the chassis above each wheel, suspension (paper eqs. 9 and 12),
anti-roll bars (full car) and tyre (eqs. 10 and 13)."""

from __future__ import annotations

import numpy as np

from suspopt.models import equations as eq
from suspopt.models.base import NodeComponent


class MountMotionComp(NodeComponent):
    """Vertical displacement and velocity of the chassis above each corner (the chassis
    side of eq. 9): ``z_M = z_C - a θ_C + y φ_C``, ``v_M = v_C - a ω_C + y p_C``."""

    def initialize(self) -> None:
        super().initialize()
        self.options.declare('a', types=np.ndarray, desc='corner positions ahead of the CG [m]')
        self.options.declare('y', types=np.ndarray, desc='corner positions left of the CG [m]')
        self.options.declare('roll', types=bool, default=False, desc='the chassis rolls')
        self.options.declare('pitch', types=bool, default=True, desc='the chassis pitches')

    def _pairs(self):
        chassis = [('z_C', 'v_C', 'm', 'm/s', 1.0)]
        if self.options['pitch']:
            chassis.append(('theta_C', 'omega_C', 'rad', 'rad/s', -1.0))
        if self.options['roll']:
            chassis.append(('phi_C', 'p_C', 'rad', 'rad/s', 1.0))
        return chassis

    def setup(self) -> None:
        nn, nc = self._shape
        a, y = self.options['a'], self.options['y']
        levers = [np.ones(nc)] + ([-a] if self.options['pitch'] else []) + [y]
        for pos, vel, pu, vu, _ in self._pairs():
            self.add_input(pos, shape=(nn,), units=pu)
            self.add_input(vel, shape=(nn,), units=vu)
        self.add_output('z_M', shape=(nn, nc), units='m', desc='chassis above each wheel')
        self.add_output('v_M', shape=(nn, nc), units='m/s', desc='its vertical velocity')
        for (pos, vel, *_), lever in zip(self._pairs(), levers):
            self._spread_partials('z_M', pos, val=np.tile(lever, nn))
            self._spread_partials('v_M', vel, val=np.tile(lever, nn))

    def evaluate(self, inputs):
        o = self.options
        pitch, roll = o['pitch'], o['roll']
        return {
            pos: eq.mount_motion(
                inputs[z],
                inputs[th] if pitch else 0.0,
                inputs[ph] if roll else 0.0,
                o['a'],
                o['y'],
            )
            for pos, z, th, ph in (
                ('z_M', 'z_C', 'theta_C', 'phi_C'),
                ('v_M', 'v_C', 'omega_C', 'p_C'),
            )
        }


class SuspensionForceComp(NodeComponent):
    """Spring-damper force between the chassis and each wheel, eq. 9 (low fidelity) /
    eq. 12: ``F_S = k_S (z_W - z_M) + c_S (v_W - v_M)``, positive pushing the chassis up.

    ``z_W``/``v_W`` is the displacement/velocity of the suspension's wheel-side end: the
    wheel itself in the half car (eq. 9), the spring point ``q^z_U`` of the linkage in the
    mixed-fidelity model (eq. 12). ``k_S``, ``c_S`` are the per-corner settings.
    """

    def setup(self) -> None:
        nn, nc = self._shape
        for name, units in (('z_W', 'm'), ('v_W', 'm/s'), ('z_M', 'm'), ('v_M', 'm/s')):
            self.add_input(name, shape=(nn, nc), units=units)
        self.add_input('k_S', shape=(nc,), units='N/m', desc='spring rate per corner')
        self.add_input('c_S', shape=(nc,), units='N*s/m', desc='damping per corner')
        self.add_output('F_S', shape=(nn, nc), units='N', desc='suspension force on the chassis')
        for wrt in ('z_W', 'v_W', 'z_M', 'v_M'):
            self._corner_partials('F_S', wrt)
        for wrt in ('k_S', 'c_S'):
            self._setting_partials('F_S', wrt)

    def evaluate(self, inputs):
        return {
            'F_S': eq.suspension_force(
                inputs['k_S'],
                inputs['c_S'],
                inputs['z_W'],
                inputs['v_W'],
                inputs['z_M'],
                inputs['v_M'],
            )
        }

    def compute_partials(self, inputs, partials) -> None:
        nn = self.options['num_nodes']
        k, c = np.tile(inputs['k_S'], nn), np.tile(inputs['c_S'], nn)
        partials['F_S', 'z_W'] = k
        partials['F_S', 'z_M'] = -k
        partials['F_S', 'v_W'] = c
        partials['F_S', 'v_M'] = -c
        partials['F_S', 'k_S'] = (inputs['z_W'] - inputs['z_M']).ravel()
        partials['F_S', 'c_S'] = (inputs['v_W'] - inputs['v_M']).ravel()


class AntiRollBarComp(NodeComponent):
    """The anti-roll bars' forces on the chassis at each corner (full car): a bar of rate
    ``k_R`` across track ``t`` pushes up by ``k_R (s_L - s_R) / t²`` on the left and down
    by as much on the right, ``s = z_W - z_M`` the suspension deflection
    (:func:`~suspopt.models.equations.anti_roll_force`)."""

    def initialize(self) -> None:
        super().initialize()
        self.options.declare('left', types=tuple, desc='left corner of each bar')
        self.options.declare('right', types=tuple, desc='right corner of each bar')
        self.options.declare('track', types=tuple, desc='track width of each bar [m]')

    def setup(self) -> None:
        nn, nc = self._shape
        nb = len(self.options['left'])
        self.add_input('z_W', shape=(nn, nc), units='m')
        self.add_input('z_M', shape=(nn, nc), units='m')
        self.add_input('k_R', shape=(nb,), units='N*m/rad', desc='bar rate')
        self.add_output('F_R', shape=(nn, nc), units='N', desc='bar force on the chassis')
        L, R = np.array(self.options['left']), np.array(self.options['right'])
        node = np.arange(nn)[:, None] * nc
        # F_L and F_R of each bar depend on s_L and s_R of the same node
        rows = np.concatenate(
            [(node + L).ravel(), (node + L).ravel(), (node + R).ravel(), (node + R).ravel()]
        )
        cols = np.concatenate(
            [(node + L).ravel(), (node + R).ravel(), (node + L).ravel(), (node + R).ravel()]
        )
        for wrt in ('z_W', 'z_M'):
            self.declare_partials('F_R', wrt, rows=rows, cols=cols)
        self.declare_partials(
            'F_R',
            'k_R',
            rows=np.concatenate([(node + L).ravel(), (node + R).ravel()]),
            cols=np.tile(np.tile(np.arange(nb), nn), 2),
        )

    def evaluate(self, inputs):
        o = self.options
        return {
            'F_R': eq.anti_roll_force(
                inputs['k_R'],
                inputs['z_W'],
                inputs['z_M'],
                np.array(o['track']),
                o['left'],
                o['right'],
            )
        }

    def compute_partials(self, inputs, partials) -> None:
        o = self.options
        nn = o['num_nodes']
        L, R = list(o['left']), list(o['right'])
        g = np.tile(inputs['k_R'] / np.array(o['track']) ** 2, nn)  # per (node, bar)
        d = np.concatenate([g, -g, -g, g])
        partials['F_R', 'z_W'] = d
        partials['F_R', 'z_M'] = -d
        s = inputs['z_W'] - inputs['z_M']
        per = ((s[:, L] - s[:, R]) / np.array(o['track']) ** 2).ravel()
        partials['F_R', 'k_R'] = np.concatenate([per, -per])


class TyreForceComp(NodeComponent):
    """Linear tyre spring between road and wheel, eq. 10 / eq. 13: ``F_T = k_T (δ - z_W)``.

    ``z_W`` is the wheel displacement (``q^z_W`` in the mixed-fidelity model). The tyre may
    pull (no lift-off), as in the paper.
    """

    def initialize(self) -> None:
        super().initialize()
        self.options.declare('k_T', types=np.ndarray, desc='tyre vertical rate per corner [N/m]')

    def setup(self) -> None:
        nn, nc = self._shape
        self.add_input('delta', shape=(nn, nc), units='m', desc='road height under the tyre')
        self.add_input('z_W', shape=(nn, nc), units='m', desc='wheel vertical displacement')
        self.add_output('F_T', shape=(nn, nc), units='N', desc='tyre force on the wheel, up')
        k = np.tile(self.options['k_T'], nn)
        self._corner_partials('F_T', 'delta', val=k)
        self._corner_partials('F_T', 'z_W', val=-k)

    def evaluate(self, inputs):
        return {'F_T': eq.tyre_force(self.options['k_T'], inputs['delta'], inputs['z_W'])}


class WheelLoadComp(NodeComponent):
    """The vertical load on each wheel of the mixed-fidelity full car at its contact patch:
    the tyre force minus the anti-roll bar's force on the chassis (the bar pushes the wheel
    the other way; its drop link on the upright is not modelled): ``F_W = F_T - F_R``."""

    def setup(self) -> None:
        nn, nc = self._shape
        self.add_input('F_T', shape=(nn, nc), units='N')
        self.add_input('F_R', shape=(nn, nc), units='N')
        self.add_output('F_W', shape=(nn, nc), units='N', desc='load on the wheel, up')
        self._corner_partials('F_W', 'F_T', val=np.ones(nn * nc))
        self._corner_partials('F_W', 'F_R', val=-np.ones(nn * nc))

    def evaluate(self, inputs):
        return {'F_W': inputs['F_T'] - inputs['F_R']}
