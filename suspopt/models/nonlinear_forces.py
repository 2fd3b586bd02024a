"""Nonlinear suspension force of the low-fidelity model: eq. 9 with curves for the spring,
the damper and the stops (:mod:`suspopt.curves`)."""

from __future__ import annotations

import numpy as np

from suspopt.curves import SpringDamperUnit
from suspopt.models.base import NodeComponent


class NonlinearSuspensionForceComp(NodeComponent):
    """Spring, damper and stops between the chassis and each wheel, eq. 9 generalized:

        F_S = S(x) + D(v) + B(x) + R(x),   x = z_W - z_M,   v = v_W - v_M

    positive pushing the chassis up (the :class:`~suspopt.models.forces.SuspensionForceComp`
    convention: bump positive). The option ``unit`` (a
    :class:`~suspopt.curves.SpringDamperUnit`) fixes the curves' forms (polynomial
    degree, table points, blend widths, which stops); every curve parameter is a
    per-corner input of its name, units and size (:meth:`SpringDamperUnit.parameters`),
    defaulting to the unit's values, so any of them can be a design variable. With
    ``SpringDamperUnit.linear(k, c)`` the inputs are ``k_S`` and ``c_S`` and the component
    is ``SuspensionForceComp``, values and partials alike.
    """

    def initialize(self) -> None:
        super().initialize()
        self.options.declare(
            'unit',
            types=SpringDamperUnit,
            recordable=False,
            desc='the curves (forms and default parameter values)',
        )

    def setup(self) -> None:
        nn, nc = self._shape
        unit: SpringDamperUnit = self.options['unit']
        for name, units in (('z_W', 'm'), ('v_W', 'm/s'), ('z_M', 'm'), ('v_M', 'm/s')):
            self.add_input(name, shape=(nn, nc), units=units)
        values = unit.parameter_values()
        self._params = unit.parameters()
        for p in self._params:
            shape = (nc,) if p.size == 1 else (nc, p.size)
            self.add_input(
                p.name,
                val=np.broadcast_to(values[p.name], shape),
                shape=shape,
                units=p.units,
                desc='curve parameter per corner',
            )
        self.add_output('F_S', shape=(nn, nc), units='N', desc='suspension force on the chassis')
        for wrt in ('z_W', 'v_W', 'z_M', 'v_M'):
            self._corner_partials('F_S', wrt)
        corner = np.tile(np.arange(nc), nn)
        for p in self._params:
            if p.size == 1:
                self._setting_partials('F_S', p.name)
            else:  # every point of the corner's table
                self.declare_partials(
                    'F_S',
                    p.name,
                    rows=np.repeat(np.arange(nn * nc), p.size),
                    cols=(corner[:, None] * p.size + np.arange(p.size)).ravel(),
                )

    def _force(self, inputs, partials: bool):
        unit: SpringDamperUnit = self.options['unit']
        params = {p.name: inputs[p.name] for p in self._params}
        return unit.force(
            inputs['z_W'] - inputs['z_M'], inputs['v_W'] - inputs['v_M'], params, partials
        )

    def compute(self, inputs, outputs) -> None:
        outputs['F_S'] = self._force(inputs, False).value

    def compute_partials(self, inputs, partials) -> None:
        f = self._force(inputs, True)
        d_x, d_v = f.d_x.ravel(), f.d_v.ravel()
        partials['F_S', 'z_W'] = d_x
        partials['F_S', 'z_M'] = -d_x
        partials['F_S', 'v_W'] = d_v
        partials['F_S', 'v_M'] = -d_v
        for p in self._params:
            partials['F_S', p.name] = f.partials[p.name].ravel()
