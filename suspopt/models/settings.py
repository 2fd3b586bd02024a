"""The suspension settings at each corner from the design variables (paper eq. 3)."""
from __future__ import annotations

import numpy as np
import openmdao.api as om

#: units of each kind of design variable: spring rate, damping, anti-roll bar rate
DESIGN_UNITS = {'k_S': 'N/m', 'c_S': 'N*s/m', 'k_R': 'N*m/rad'}


def design_kind(name: str) -> str:
    """``k_S``, ``c_S`` or ``k_R`` of a design variable's name (``k_S1``, ``c_S2L``, ``k_R1``)."""
    return name[:3]


def corner_of_design(names: tuple[str, ...], labels: tuple[str, ...]
                     ) -> dict[str, list[tuple[str, int]]]:
    """Where each design variable acts: ``{name: [(setting, index), ...]}`` with setting
    ``k_S``/``c_S`` (index: a corner) or ``k_R`` (index: a bar, in axle order). A per-axle
    variable (``k_S1``) acts on every corner of its axle, a per-corner one (``k_S1L``) on
    its own."""
    bars = sorted(n for n in names if design_kind(n) == 'k_R')
    out = {}
    for n in names:
        kind, group = design_kind(n), n[3:]
        if kind == 'k_R':
            out[n] = [('k_R', bars.index(n))]
        else:
            out[n] = [(kind, i) for i, lab in enumerate(labels)
                      if lab == group or (len(group) == 1 and lab[0] == group)]
    return out


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
            self.declare_partials(kind, n, rows=rows, cols=np.zeros(len(rows), dtype=int),
                                  val=np.ones(len(rows)))
        self._where = where

    def compute(self, inputs, outputs) -> None:
        for n, targets in self._where.items():
            for kind, i in targets:
                outputs[kind][i] = inputs[n][0]
