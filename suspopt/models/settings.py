"""The suspension settings at each corner from the design variables (paper eq. 3)."""

from __future__ import annotations

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
        self._where = where

    def compute(self, inputs, outputs) -> None:
        for n, targets in self._where.items():
            for kind, i in targets:
                outputs[kind][i] = inputs[n][0]
