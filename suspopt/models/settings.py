"""The suspension settings at each corner from the design variables (paper eq. 3)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import openmdao.api as om

from suspopt.models.design import DESIGN_UNITS, GAIN_KINDS, corner_of_design, design_kind


def _sizes(names: tuple[str, ...], labels: tuple[str, ...]) -> dict[str, int]:
    """The settings and their sizes: ``k_S``, ``c_S`` per corner, ``k_R`` per bar, and each
    feedback gain any variable sets, per corner (0: absent)."""
    kinds = {design_kind(n) for n in names}
    return {
        'k_S': len(labels),
        'c_S': len(labels),
        'k_R': sum(1 for n in names if design_kind(n) == 'k_R'),
        **{g: len(labels) for g in GAIN_KINDS if g in kinds},
    }


class SuspensionSettingsComp(om.ExplicitComponent):
    """Per-corner spring rates ``k_S`` and damping ``c_S`` (and per-bar anti-roll rates
    ``k_R``, per-corner feedback gains ``g_sky`` ...) from the design variables: each
    setting is the value of its variable (per axle by default, left = right, or per
    corner); a gain is zero at a corner no variable sets."""

    def initialize(self) -> None:
        self.options.declare('design', types=tuple, desc='design-variable names')
        self.options.declare('labels', types=tuple, desc='corner labels')

    def setup(self) -> None:
        names, labels = self.options['design'], self.options['labels']
        where = corner_of_design(names, labels)
        sizes = _sizes(names, labels)
        for kind in sizes:
            if sizes[kind]:
                self.add_output(kind, shape=(sizes[kind],), units=DESIGN_UNITS[kind])
        for n in names:
            kind = design_kind(n)
            self.add_input(n, val=1.0, units=DESIGN_UNITS[kind])
            rows = [i for _, i in where[n]]
            self.declare_partials(
                kind, n, rows=rows, cols=np.zeros(len(rows), dtype=int), val=np.ones(len(rows))
            )

    def evaluate(self, inputs: Mapping[str, Any]) -> dict[str, np.ndarray]:
        """The settings from the design variables (the vehicle assembly's equation)."""
        names, labels = self.options['design'], self.options['labels']
        dtype = np.result_type(float, *(np.asarray(inputs[n]) for n in names))  # complex step
        sizes = _sizes(names, labels)
        out = {kind: np.zeros(size, dtype=dtype) for kind, size in sizes.items() if size}
        for n, targets in corner_of_design(names, labels).items():
            for kind, i in targets:
                out[kind][i] = np.asarray(inputs[n]).ravel()[0]
        return out

    def compute(self, inputs, outputs) -> None:
        for name, value in self.evaluate(inputs).items():
            outputs[name] = value
