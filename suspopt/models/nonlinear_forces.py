"""Nonlinear suspension force of the low-fidelity model: eq. 9 with curves for the spring,
the damper and the stops (:mod:`suspopt.curves`, ``docs/nonlinear_hardware.md``)."""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from suspopt.curves import Parameter, SpringDamperUnit, UnitForce
from suspopt.models.base import NodeComponent


@dataclass(frozen=True)
class CurvePlan:
    """How the corners' curves are evaluated: ``groups``, the corners of each distinct
    curve form (a unit of that form, its corners); ``inputs``, the curve parameters that
    are inputs, name → (parameter, the corners that have it, each corner's own value and
    0 elsewhere)."""

    groups: tuple[tuple[SpringDamperUnit, np.ndarray], ...]
    inputs: dict[str, tuple[Parameter, np.ndarray, np.ndarray]]


@functools.lru_cache(maxsize=32)
def curve_plan(
    units: tuple[SpringDamperUnit | None, ...], settings: tuple[str, ...] | None
) -> CurvePlan:
    """The :class:`CurvePlan` of the corners' ``units`` (None: the linear spring and
    damper, parameters ``k_S``, ``c_S``) with the parameters ``settings`` as inputs
    (None: every one)."""
    full = tuple(SpringDamperUnit.linear(0.0, 0.0) if u is None else u for u in units)
    by: dict[tuple, tuple[SpringDamperUnit, list[int]]] = {}
    for c, u in enumerate(full):
        by.setdefault(u.structure(), (u, []))[1].append(c)
    inputs: dict[str, tuple[Parameter, np.ndarray, np.ndarray]] = {}
    for p in dict.fromkeys(q for u in full for q in u.parameters()):
        if (settings is not None and p.name not in settings) or p.name in inputs:
            continue
        have = [c for c, u in enumerate(full) if p.name in u.parameter_values()]
        sizes = {np.size(full[c].parameter_values()[p.name]) for c in have}  # a table's points
        if len(sizes) > 1:
            raise ValueError(
                f'curve parameter {p.name!r}: its tables have {sorted(sizes)} points at '
                'different corners (one size needed to be an input)'
            )
        default = np.zeros((len(full),) if p.size == 1 else (len(full), p.size))
        for c in have:
            default[c] = full[c].parameter_values()[p.name]
        default.flags.writeable = False
        inputs[p.name] = (p, np.array(have), default)
    return CurvePlan(tuple((u, np.array(c)) for u, c in by.values()), inputs)


class NonlinearSuspensionForceComp(NodeComponent):
    """Spring, damper and stops between the chassis and each wheel, eq. 9 generalized:

        F_S = S(x) + D(v) + B(x) + R(x),   x = z_W - z_M,   v = v_W - v_M

    positive pushing the chassis up (the :class:`~suspopt.models.forces.SuspensionForceComp`
    convention: bump positive). The curves' forms (polynomial degree, table points, blend
    widths, which stops) are options: ``unit`` (a :class:`~suspopt.curves.SpringDamperUnit`)
    for every corner, or ``units``, one per corner (None: the linear spring and damper,
    ``SpringDamperUnit.linear``), the corners of one form evaluated together. Every curve
    parameter named in ``settings`` (default: all of them) is a per-corner input of its
    name, units and size (:meth:`SpringDamperUnit.parameters`), defaulting to each
    corner's own value (0 at a corner whose unit lacks it: it has no partials there);
    the others keep the units' values. With ``SpringDamperUnit.linear(k, c)`` the inputs
    are ``k_S`` and ``c_S`` and the component is ``SuspensionForceComp``, values and
    partials alike.
    """

    def initialize(self) -> None:
        super().initialize()
        self.options.declare(
            'unit',
            types=SpringDamperUnit,
            default=None,
            allow_none=True,
            recordable=False,
            desc='the curves of every corner (forms and default parameter values)',
        )
        self.options.declare(
            'units',
            types=tuple,
            default=None,
            allow_none=True,
            recordable=False,
            desc='the curves of each corner (None: linear), instead of unit',
        )
        self.options.declare(
            'settings',
            types=tuple,
            default=None,
            allow_none=True,
            desc='the curve parameters that are inputs (default: every one)',
        )

    # ------------------------------------------------------------ the corners' curves
    def _units(self) -> tuple[SpringDamperUnit | None, ...]:
        o = self.options
        nc = o['corners']
        if (o['unit'] is None) == (o['units'] is None):
            raise ValueError('give unit (every corner) or units (one per corner)')
        units = (o['unit'],) * nc if o['units'] is None else o['units']
        if len(units) != nc:
            raise ValueError(f'units: one per corner ({nc}), got {len(units)}')
        return tuple(units)

    def plan(self) -> CurvePlan:
        """The corners' curve forms and the parameters that are inputs (:func:`curve_plan`);
        a function of the options, remembered for the time marching's every call."""
        key = (self.options['unit'], self.options['units'], self.options['settings'])
        memo = self.__dict__.get('_plan_memo')
        if memo is None or any(a is not b for a, b in zip(memo[0], key)):
            memo = (key, curve_plan(self._units(), self.options['settings']))
            self.__dict__['_plan_memo'] = memo
        return memo[1]

    # ------------------------------------------------------------ OpenMDAO
    def setup(self) -> None:
        nn, nc = self._shape
        for name, units in (('z_W', 'm'), ('v_W', 'm/s'), ('z_M', 'm'), ('v_M', 'm/s')):
            self.add_input(name, shape=(nn, nc), units=units)
        self._curve_inputs = self.plan().inputs
        for name, (p, _, default) in self._curve_inputs.items():
            self.add_input(name, val=default, units=p.units, desc='curve parameter per corner')
        self.add_output('F_S', shape=(nn, nc), units='N', desc='suspension force on the chassis')
        for wrt in ('z_W', 'v_W', 'z_M', 'v_M'):
            self._corner_partials('F_S', wrt)
        node = np.arange(nn)[:, None] * nc
        for name, (p, have, _) in self._curve_inputs.items():
            if p.size == 1 and have.size == nc:
                self._setting_partials('F_S', name)
                continue
            # every node of each corner that has it; a table: every point of that corner
            rows = np.repeat((node + have).ravel(), p.size)
            cols = (np.tile(have, nn)[:, None] * p.size + np.arange(p.size)).ravel()
            self.declare_partials('F_S', name, rows=rows, cols=cols)

    def force(
        self, inputs: Mapping[str, Any], partials: bool
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """``F_S``, ``∂F/∂x``, ``∂F/∂v`` (nodes, corners) and the parameter derivatives by
        input name ((nodes, corners[, points]), zero at corners without the parameter).
        An input missing from ``inputs`` takes the units' values."""
        plan = self.plan()
        x = np.asarray(inputs['z_W']) - np.asarray(inputs['z_M'])
        v = np.asarray(inputs['v_W']) - np.asarray(inputs['v_M'])
        given = {n: np.asarray(inputs[n]) for n in plan.inputs if n in inputs}
        F, d_x, d_v = np.empty(x.shape), np.empty(x.shape), np.empty(x.shape)
        d_p: dict[str, np.ndarray] = {}
        for unit, cols in plan.groups:
            own = unit.parameter_values()
            params = {n: a[cols] for n, a in given.items() if n in own}
            f: UnitForce = unit.force(x[:, cols], v[:, cols], params, partials)
            F[:, cols], d_x[:, cols], d_v[:, cols] = f.value, f.d_x, f.d_v
            for n in params if partials else ():
                if n not in d_p:
                    d_p[n] = np.zeros(x.shape + np.shape(given[n])[1:])
                d_p[n][:, cols] = f.partials[n]
        return F, d_x, d_v, d_p

    def evaluate(self, inputs: Mapping[str, Any]) -> dict[str, np.ndarray]:
        return {'F_S': self.force(inputs, False)[0]}

    def compute_partials(self, inputs, partials) -> None:
        _, d_x, d_v, d_p = self.force(inputs, True)
        partials['F_S', 'z_W'] = d_x.ravel()
        partials['F_S', 'z_M'] = -d_x.ravel()
        partials['F_S', 'v_W'] = d_v.ravel()
        partials['F_S', 'v_M'] = -d_v.ravel()
        for name, (_, have, _) in self._curve_inputs.items():
            partials['F_S', name] = d_p[name][:, have].ravel()
