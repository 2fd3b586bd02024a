"""The suspension settings at each corner from the design variables (paper eq. 3)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import openmdao.api as om

from suspopt.models.design import DESIGN_UNITS, corner_of_design, design_kind


class SuspensionSettingsComp(om.ExplicitComponent):
    """Per-corner spring rates ``k_S`` and damping ``c_S`` (and per-bar anti-roll rates
    ``k_R``) from the design variables: each setting is the value of its variable
    (per axle by default, left = right, or per corner)."""

    def initialize(self) -> None:
        self.options.declare('design', types=tuple, desc='design-variable names')
        self.options.declare('labels', types=tuple, desc='corner labels')

    def setup(self) -> None:
        names, labels = self.options['design'], self.options['labels']
        where = corner_of_design(names, labels)
        nb = sum(1 for n in names if design_kind(n) == 'k_R')
        sizes = {'k_S': len(labels), 'c_S': len(labels), 'k_R': nb}
        for kind in ('k_S', 'c_S', 'k_R'):
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
        nb = sum(1 for n in names if design_kind(n) == 'k_R')
        dtype = np.result_type(float, *(np.asarray(inputs[n]) for n in names))  # complex step
        sizes = {'k_S': len(labels), 'c_S': len(labels), 'k_R': nb}
        out = {kind: np.zeros(size, dtype=dtype) for kind, size in sizes.items()}
        for n, targets in corner_of_design(names, labels).items():
            for kind, i in targets:
                out[kind][i] = np.asarray(inputs[n]).ravel()[0]
        return out if nb else {k: v for k, v in out.items() if k != 'k_R'}

    def compute(self, inputs, outputs) -> None:
        for name, value in self.evaluate(inputs).items():
            outputs[name] = value
