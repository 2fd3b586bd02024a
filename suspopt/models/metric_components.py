"""The ride metrics' components (:mod:`suspopt.models.metrics`): the suspension travel,
the tyre load relative to its static value, and the objective's integrands, vectorized
over nodes and corners with exact sparse partials."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from suspopt.models import equations as eq
from suspopt.models.base import NodeComponent


class SuspensionTravelComp(NodeComponent):
    """The suspension travel at each corner, the wheel relative to the chassis above it
    (positive in bump, compressing the suspension): ``s = z_W - z_M``
    (:func:`~suspopt.models.equations.suspension_travel`)."""

    def setup(self) -> None:
        nn, nc = self._shape
        self.add_input('wheel_z', shape=(nn, nc), units='m', desc='wheel displacement, up')
        self.add_input('z_M', shape=(nn, nc), units='m', desc='chassis above the corner, up')
        self.add_output('travel', shape=(nn, nc), units='m', desc='suspension travel, bump +')
        self._corner_partials('travel', 'wheel_z', val=np.ones(nn * nc))
        self._corner_partials('travel', 'z_M', val=-np.ones(nn * nc))

    def evaluate(self, inputs: Mapping[str, Any]) -> dict[str, np.ndarray]:
        return {'travel': eq.suspension_travel(inputs['wheel_z'], inputs['z_M'])}


class TyreLoadRatioComp(NodeComponent):
    """The dynamic tyre load relative to the static one, ``F_T / F_static`` (the tyre
    keeps contact while it is above -1: the total load ``F_static + F_T`` is positive)."""

    def initialize(self) -> None:
        super().initialize()
        self.options.declare('static', types=np.ndarray, desc='static tyre load per corner [N]')

    def setup(self) -> None:
        nn, nc = self._shape
        self.add_input('F_T', shape=(nn, nc), units='N', desc='dynamic tyre load, up')
        self.add_output('tyre_load_ratio', shape=(nn, nc), units=None, desc='F_T / F_static')
        self._corner_partials(
            'tyre_load_ratio', 'F_T', val=np.tile(1.0 / self.options['static'], nn)
        )

    def evaluate(self, inputs: Mapping[str, Any]) -> dict[str, np.ndarray]:
        return {'tyre_load_ratio': eq.tyre_load_ratio(inputs['F_T'], self.options['static'])}


class SquaredSignalsComp(NodeComponent):
    """The objective's integrands (eq. 4, extended): the squares of the metric signals,
    stacked as the columns of ``dJ_dt`` (nodes × terms, in ``signals`` order). Its columns
    have different units (:func:`term_units`), so the vector is declared unitless."""

    def initialize(self) -> None:
        super().initialize()
        self.options.declare(
            'signals',
            types=tuple,
            desc='(signal, units, columns) of every metric signal, in term order',
        )

    def setup(self) -> None:
        nn = self.options['num_nodes']
        signals = self.options['signals']
        nt = sum(max(width, 1) for _, _, width in signals)
        self.add_output('dJ_dt', shape=(nn, nt), units=None, desc='integrand of each term')
        node = np.arange(nn)[:, None]
        k = 0
        for name, units, width in signals:
            shape = (nn,) if width == 0 else (nn, width)
            self.add_input(name, shape=shape, units=units)
            cols = np.arange(max(width, 1))
            self.declare_partials(
                'dJ_dt',
                name,
                rows=(nt * node + k + cols).ravel(),
                cols=(max(width, 1) * node + cols).ravel(),
            )
            k += max(width, 1)

    def evaluate(self, inputs: Mapping[str, Any]) -> dict[str, np.ndarray]:
        return {'dJ_dt': eq.squared_signals([inputs[n] for n, _, _ in self.options['signals']])}

    def compute_partials(self, inputs, partials) -> None:
        for name, _, _ in self.options['signals']:
            partials['dJ_dt', name] = 2.0 * np.asarray(inputs[name]).ravel()
