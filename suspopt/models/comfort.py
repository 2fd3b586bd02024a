"""Ride comfort after ISO 2631-1: the vertical acceleration at the seats and the
frequency-weighting filters as ODE states (Dymos), with exact sparse partials.

The weighted signal ``a_w`` of each channel is the output of a linear filter whose states
are integrated with the vehicle's: :class:`WeightingFilterComp` gives their rates (a
Dymos ``rate_source``) and ``a_w`` at every node; ``∫ a_w² dt`` over the horizon ``T``
gives the weighted r.m.s. value ``sqrt(J / T)`` (ISO 2631-1 eq. 1). The filters are
:mod:`suspopt.models.iso2631`'s, the single source of the matrices for collocation, time
marching and spectral methods.

Dymos' Radau collocates at each segment's left end; its stability function grows without
bound for stiff modes, so a segment of length ``h`` must keep ``|λ| h`` of every filter
pole below a bound that grows with the order (tests/models/test_comfort_components.py).
The stiffest pole is the 100 Hz band-limiting low pass (``|λ| = 2π·100 rad/s``): keep
the segments short enough for it, or drop it in collocation with
``dataclasses.replace(weighting, f2=None)``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import openmdao.api as om

from suspopt.errors import ConfigError
from suspopt.models import equations as eq
from suspopt.models.iso2631 import FilterBank, Weighting, filter_bank


class SeatAccelerationComp(om.ExplicitComponent):
    """Vertical acceleration at seat positions on the rigid chassis,
    ``z''_S = z''_C - x θ''_C + y φ''_C`` (:func:`~suspopt.models.equations.seat_acceleration`;
    θ positive nose down, φ positive left side up), at every node.

    Options ``x`` (forward of the CG) and ``y`` (left of it) [m], one entry per seat;
    ``roll`` adds the input ``phidd_C`` (full car; without it ``y`` is unused)."""

    def initialize(self) -> None:
        self.options.declare('num_nodes', types=int, desc='number of nodes evaluated at once')
        self.options.declare('x', types=np.ndarray, desc='seat positions ahead of the CG [m]')
        self.options.declare(
            'y',
            types=(np.ndarray, type(None)),
            default=None,
            desc='seat positions left of the CG [m]',
        )
        self.options.declare('roll', types=bool, default=False, desc='the chassis rolls')
        self.options.declare('pitch', types=bool, default=True, desc='the chassis pitches')

    def _positions(self) -> tuple[np.ndarray, np.ndarray]:
        x = np.asarray(self.options['x'], dtype=float).ravel()
        y = self.options['y']
        y = np.zeros_like(x) if y is None else np.asarray(y, dtype=float).ravel()
        if y.shape != x.shape:
            raise ConfigError(f'seats.y: {y.size} positions for {x.size} seats in seats.x')
        return x, y

    def setup(self) -> None:
        nn = self.options['num_nodes']
        x, y = self._positions()
        levers = [('zdd_C', 'm/s**2', np.ones_like(x))]
        if self.options['pitch']:
            levers.append(('thdd_C', 'rad/s**2', -x))
        if self.options['roll']:
            levers.append(('phidd_C', 'rad/s**2', y))
        ns = x.size
        for name, units, _ in levers:
            self.add_input(name, shape=(nn,), units=units)
        self.add_output('a_seat', shape=(nn, ns), units='m/s**2', desc='vertical, up, per seat')
        rows = np.arange(nn * ns).reshape(nn, ns)
        cols = np.repeat(np.arange(nn), ns).reshape(nn, ns)
        for name, _, lever in levers:
            nz = lever != 0.0  # a seat on the pitch (roll) axis does not see it
            if nz.any():
                self.declare_partials(
                    'a_seat',
                    name,
                    rows=rows[:, nz].ravel(),
                    cols=cols[:, nz].ravel(),
                    val=np.tile(lever[nz], nn),
                )

    def evaluate(self, inputs: Mapping[str, Any]) -> dict[str, np.ndarray]:
        """The seat accelerations (the vehicle assembly's equation)."""
        o = self.options
        thdd = inputs['thdd_C'] if o['pitch'] else 0.0
        phidd = inputs['phidd_C'] if o['roll'] else 0.0
        x, y = self._positions()
        return {'a_seat': eq.seat_acceleration(inputs['zdd_C'], thdd, phidd, x, y)}

    def compute(self, inputs, outputs) -> None:
        outputs['a_seat'] = self.evaluate(inputs)['a_seat']


def _block_pattern(M: np.ndarray, nn: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows, cols and values of ``M``'s nonzeros repeated on the diagonal blocks of ``nn``
    nodes (node-major flattening of (nodes, rows) and (nodes, cols) arrays)."""
    i, j = np.nonzero(M)
    node = np.arange(nn)[:, None]
    rows = (node * M.shape[0] + i).ravel()
    cols = (node * M.shape[1] + j).ravel()
    return rows, cols, np.tile(M[i, j], nn)


class WeightingFilterComp(om.ExplicitComponent):
    """ISO 2631-1 weighting filters as Dymos ODE states, ``x' = A x + B u`` and
    ``a_w = C x + D u`` at every node, one channel per entry of ``weightings`` (names
    such as ``'Wk'`` or :class:`~suspopt.models.iso2631.Weighting`), block diagonal
    (:func:`~suspopt.models.iso2631.filter_bank`).

    Inputs ``filter_x`` (nodes, states) and ``signal`` (nodes, channels); outputs
    ``filter_x_dot`` (nodes, states), the rates for the Dymos state's ``rate_source``,
    and ``weighted`` (nodes, channels). ``units``: of the signal, the states and the
    weighted signal (``m/s**2`` for accelerations, ``rad/s**2`` for We on rotations)."""

    def initialize(self) -> None:
        self.options.declare('num_nodes', types=int, desc='number of nodes evaluated at once')
        self.options.declare(
            'weightings', types=(tuple, list), desc='one ISO 2631-1 weighting per channel'
        )
        self.options.declare(
            'units', types=(str, type(None)), default='m/s**2', desc='units of the signals'
        )

    @property
    def bank(self) -> FilterBank:
        bank = getattr(self, '_bank', None)
        if bank is None:
            ws: Sequence[str | Weighting] = self.options['weightings']
            bank = self._bank = filter_bank(ws)
        return bank

    def setup(self) -> None:
        nn, units = self.options['num_nodes'], self.options['units']
        bank = self.bank
        ns, nch = bank.n_states, bank.channels
        rate_units = None if units is None else f'{units}/s'
        self.add_input('filter_x', shape=(nn, ns), units=units, desc='weighting filter states')
        self.add_input('signal', shape=(nn, nch), units=units, desc='unweighted signal')
        self.add_output('filter_x_dot', shape=(nn, ns), units=rate_units, desc='state rates')
        self.add_output('weighted', shape=(nn, nch), units=units, desc='weighted signal a_w')
        ss = bank.system
        for of, wrt, M in (
            ('filter_x_dot', 'filter_x', ss.A),
            ('filter_x_dot', 'signal', ss.B),
            ('weighted', 'filter_x', ss.C),
            ('weighted', 'signal', ss.D),
        ):
            if np.any(M):
                rows, cols, val = _block_pattern(M, nn)
                self.declare_partials(of, wrt, rows=rows, cols=cols, val=val)

    def evaluate(self, inputs: Mapping[str, Any]) -> dict[str, np.ndarray]:
        """The filter states' rates and the weighted signals (the assembly's equation)."""
        ss = self.bank.system
        return {
            'filter_x_dot': ss.rates(inputs['filter_x'], inputs['signal']),
            'weighted': ss.output(inputs['filter_x'], inputs['signal']),
        }

    def compute(self, inputs, outputs) -> None:
        for name, value in self.evaluate(inputs).items():
            outputs[name] = value
