"""Point load: a force of run-time magnitude along a fixed global unit direction, at a
marker (``F_e`` of paper eq. 11; docs/model.md's ``-F_S`` and ``+F_T``):

    Q_b = [ F ;  (A(φ_b) u) × F ],    F = magnitude · direction
"""

from __future__ import annotations

import builtins
import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from suspopt.multibody.elements.base import BodyPoints, ForceGroup, cross


@dataclass(frozen=True)
class PointLoad:
    """A force of run-time magnitude along the fixed global unit ``direction``, at ``marker``."""

    name: str
    marker: str
    direction: tuple[float, float]
    magnitude: float = 0.0
    type: ClassVar[str] = 'point_load'
    #: the group class of the type (set below its definition)
    group: ClassVar[builtins.type[PointLoadGroup]]
    keys: ClassVar[dict[str, bool]] = {
        'name': True,
        'type': False,
        'marker': True,
        'direction': True,
    }

    @classmethod
    def read(cls, rd, data: dict, where: str, name: str) -> PointLoad:
        mk = rd.marker(data.get('marker'), f'{where}.marker')
        d = rd.vec2(data, 'direction', where)
        norm = math.hypot(*d)
        if math.isfinite(norm) and abs(norm - 1.0) > 1e-9:
            rd.err(f'{where}.direction', f'must be a unit vector, got {list(d)} (length {norm:g})')
        return cls(name=name, marker=mk, direction=d)


class PointLoadGroup(ForceGroup):
    parameters = ('magnitude',)
    n_bodies = 1

    def __init__(self, specs, layout):
        super().__init__(specs, layout)
        self.bodies = np.array([layout.markers[s.marker][0] for s in specs], dtype=int)[:, None]
        self.u = np.array([layout.markers[s.marker][1] for s in specs], dtype=float).reshape(-1, 2)
        self.direction = np.array([s.direction for s in specs], dtype=float).reshape(-1, 2)
        self.points = BodyPoints(self.bodies[:, 0], self.u)

    def generalized_force(self, qe, qde, values):
        F = values['magnitude'][..., None] * self.direction  # (N, ne, 2)
        arm = self.points.arms(qe)
        Q = np.empty(F.shape[:2] + (1, 3))
        Q[:, :, 0, :2] = F
        Q[:, :, 0, 2] = cross(arm, F)
        return Q


PointLoad.group = PointLoadGroup
