"""The suspension settings at each corner from the design variables (paper eq. 3)."""

from __future__ import annotations

import functools
from collections.abc import Mapping
from typing import Any

import numpy as np
import openmdao.api as om

from suspopt.models.design import GAIN_KINDS, corner_of_design, design_id


@functools.lru_cache(maxsize=64)
def _plan(
    names: tuple[str, ...], labels: tuple[str, ...]
) -> tuple[dict[str, int], dict[str, list[tuple[str, int]]]]:
    """Each output's size (``k_S``, ``c_S`` per corner always, ``k_R`` per bar, the curve
    settings and feedback gains of the design per corner) and where each variable acts
    (:func:`~suspopt.models.design.corner_of_design`): a function of the names, once."""
    nc = len(labels)
    ids = [design_id(n) for n in names]
    sizes = {'k_S': nc, 'c_S': nc, 'k_R': sum(1 for d in ids if d.kind.per_bar)}
    sizes.update({d.kind.setting: nc for d in ids if d.kind.slot or d.kind.symbol in GAIN_KINDS})
    return {k: v for k, v in sizes.items() if v}, corner_of_design(names, labels)


class SuspensionSettingsComp(om.ExplicitComponent):
    """Per-corner spring rates ``k_S`` and damping ``c_S`` (and per-bar anti-roll rates
    ``k_R``, per-corner feedback gains ``g_sky`` ...) from the design variables: each
    setting is the value of its variable (per axle by default, left = right, or per
    corner); a gain is zero at a corner no variable sets.

    A curve parameter that is a design variable (``c_bump_low_1``) sets the per-corner
    signal ``curve_c_bump_low`` (:attr:`~suspopt.models.design.DesignKind.setting`); its
    corners that no variable sets keep their value in ``curve_defaults`` (by signal, one
    value per corner: the hardware's own, ``docs/nonlinear_hardware.md``)."""

    def initialize(self) -> None:
        self.options.declare('design', types=tuple, desc='design-variable names')
        self.options.declare('labels', types=tuple, desc='corner labels')
        self.options.declare(
            'curve_defaults',
            types=dict,
            default={},
            desc='per-corner values of the curve settings at corners no variable sets',
        )

    def _sizes(self) -> dict[str, int]:
        """Each output's size: ``k_S``, ``c_S`` per corner always, ``k_R`` per bar, the
        curve settings of the design per corner."""
        return _plan(self.options['design'], self.options['labels'])[0]

    def setup(self) -> None:
        names, labels = self.options['design'], self.options['labels']
        where = corner_of_design(names, labels)
        units = {design_id(n).kind.setting: design_id(n).kind.units for n in names}
        units.update({'k_S': 'N/m', 'c_S': 'N*s/m'})
        for setting, size in self._sizes().items():
            self.add_output(setting, shape=(size,), units=units[setting])
        for n in names:
            kind = design_id(n).kind
            self.add_input(n, val=1.0, units=kind.units)
            rows = [i for _, i in where[n]]
            self.declare_partials(
                kind.setting,
                n,
                rows=rows,
                cols=np.zeros(len(rows), dtype=int),
                val=np.ones(len(rows)),
            )

    def evaluate(self, inputs: Mapping[str, Any]) -> dict[str, np.ndarray]:
        """The settings from the design variables (the vehicle assembly's equation)."""
        names, labels = self.options['design'], self.options['labels']
        defaults = self.options['curve_defaults']
        dtype = np.result_type(float, *(np.asarray(inputs[n]) for n in names))  # complex step
        out = {}
        for setting, size in self._sizes().items():
            out[setting] = np.zeros(size, dtype=dtype)
            if setting in defaults:
                out[setting][:] = defaults[setting]
        for n, targets in _plan(names, labels)[1].items():
            for setting, i in targets:
                out[setting][i] = np.asarray(inputs[n]).ravel()[0]
        return out

    def compute(self, inputs, outputs) -> None:
        for name, value in self.evaluate(inputs).items():
            outputs[name] = value
