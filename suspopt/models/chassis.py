"""Rigid chassis: heave (paper eq. 5), pitch (eq. 6) and, in the full car, roll."""

from __future__ import annotations

import numpy as np

from suspopt.models import equations as eq
from suspopt.models.base import NodeComponent


class _ChassisComp(NodeComponent):
    """Shared setup: the suspension's vertical forces on the chassis at each corner
    (``forces``: input names, summed, e.g. springs and anti-roll bars)."""

    output = ''
    units = ''

    def initialize(self) -> None:
        super().initialize()
        self.options.declare(
            'forces',
            types=tuple,
            default=('F_S',),
            desc='names of the (nodes, corners) forces on the chassis [N]',
        )

    def setup(self) -> None:
        nn, nc = self._shape
        for name in self.options['forces']:
            self.add_input(name, shape=(nn, nc), units='N', desc='force on the chassis, up')
        self.add_output(self.output, shape=(nn,), units=self.units)
        for name in self.options['forces']:
            self._sum_partials(self.output, name, val=np.tile(self._lever(), nn))

    def _lever(self) -> np.ndarray:
        raise NotImplementedError

    def _total(self, inputs) -> np.ndarray:
        return sum(inputs[name] for name in self.options['forces'])


class ChassisHeaveComp(_ChassisComp):
    """Chassis heave, eq. 5: ``M z''_C = Σ_c F_c``."""

    output, units = 'zdd_C', 'm/s**2'

    def initialize(self) -> None:
        super().initialize()
        self.options.declare('M', types=float, desc='chassis (sprung) mass [kg]')

    def _lever(self) -> np.ndarray:
        return np.full(self.options['corners'], 1.0 / self.options['M'])

    def evaluate(self, inputs):
        return {'zdd_C': eq.chassis_heave_acceleration(self._total(inputs), self.options['M'])}


class ChassisPitchComp(_ChassisComp):
    """Chassis pitch, eq. 6: ``I θ''_C = -Σ_c a_c F_c`` (θ positive nose down)."""

    output, units = 'thdd_C', 'rad/s**2'

    def initialize(self) -> None:
        super().initialize()
        self.options.declare('a', types=np.ndarray, desc='corner positions ahead of the CG [m]')
        self.options.declare('I', types=float, desc='chassis pitch inertia [kg m^2]')

    def _lever(self) -> np.ndarray:
        return -self.options['a'] / self.options['I']

    def evaluate(self, inputs):
        F = self._total(inputs)
        return {'thdd_C': eq.chassis_pitch_acceleration(F, self.options['a'], self.options['I'])}


class ChassisRollComp(_ChassisComp):
    """Chassis roll (full car): ``I_x φ''_C = Σ_c y_c F_c`` (φ positive left side up)."""

    output, units = 'phidd_C', 'rad/s**2'

    def initialize(self) -> None:
        super().initialize()
        self.options.declare('y', types=np.ndarray, desc='corner positions left of the CG [m]')
        self.options.declare('I_x', types=float, desc='chassis roll inertia [kg m^2]')

    def _lever(self) -> np.ndarray:
        return self.options['y'] / self.options['I_x']

    def evaluate(self, inputs):
        F = self._total(inputs)
        return {'phidd_C': eq.chassis_roll_acceleration(F, self.options['y'], self.options['I_x'])}
