"""Point-to-point spring-damper between markers on two bodies (as Exudyn's
``ObjectConnectorSpringDamper``): with ``d = p_1 - p_0``, ``L = |d|``, ``e = d / L``,

    f = k (L - L0) + c L̇  (tension),   L̇ = eᵀ ḋ,   force  f e  on end 0,  -f e  on end 1

i.e. ``Q = -f (∂L/∂q)ᵀ`` with ``∂L/∂r_0 = -eᵀ``, ``∂L/∂φ_0 = -eᵀ B_0 u_0``, ``∂L/∂r_1 = eᵀ``,
``∂L/∂φ_1 = eᵀ B_1 u_1``, and ``L̈ = L_q q̈ + eᵀ(A_0 u_0 ω_0² - A_1 u_1 ω_1²) +
(|ḋ|² - (eᵀḋ)²) / L``. The free length ``L0`` defaults to the reference distance.
"""

from __future__ import annotations

import builtins
import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from suspopt.curves import SpringDamperUnit
from suspopt.multibody.elements.base import (
    ScalarSpringGroup,
    cross,
    dot,
    gather,
    perp,
    read_spring_common,
    spring_spec_keys,
)


@dataclass(frozen=True)
class SpringDamper:
    """Spring-damper between ``markers[0]`` and ``markers[1]`` (on different bodies)."""

    name: str
    markers: tuple[str, str]
    stiffness: float = 0.0
    damping: float = 0.0
    preload: float = 0.0
    free_length: float | None = None
    #: spring, damper and stop curves (the TOML subtables spring_curve, damper_curve,
    #: bump_stop, rebound_stop); None: the linear stiffness and damping
    curves: SpringDamperUnit | None = None
    type: ClassVar[str] = 'spring_damper'
    #: the group class of the type (set below its definition)
    group: ClassVar[builtins.type[SpringDamperGroup]]
    keys: ClassVar[dict[str, bool]] = spring_spec_keys()

    @classmethod
    def read(cls, rd, data: dict, where: str, name: str) -> SpringDamper:
        common = read_spring_common(rd, data, where)
        m0, m1 = common['markers']
        if common['free_length'] is None and m0 in rd.markers and m1 in rd.markers:
            (x0, z0), (x1, z1) = rd.markers[m0][1], rd.markers[m1][1]
            if not math.hypot(x1 - x0, z1 - z0) > 0.0:
                rd.err(
                    f'{where}.free_length',
                    'the default (the reference distance of the '
                    'two markers) is not > 0: the markers coincide',
                )
        return cls(name=name, **common)


class SpringDamperGroup(ScalarSpringGroup):
    def _geometry(self, qe):
        arm, p = self.ends(qe)
        d = p[:, :, 1] - p[:, :, 0]
        L = np.sqrt(dot(d, d))
        return arm, d, L, d / L[..., None]

    def geometry(self, qe):
        return self._geometry(qe)

    def measure(self, qe, geometry=None):
        arm, d, L, e = self._geometry(qe) if geometry is None else geometry
        G = np.empty(L.shape + (2, 3))
        G[:, :, 0, :2] = -e
        G[:, :, 0, 2] = -cross(arm[:, :, 0], e)  # -eᵀ perp(A_0 u_0)
        G[:, :, 1, :2] = e
        G[:, :, 1, 2] = cross(arm[:, :, 1], e)  # eᵀ perp(A_1 u_1)
        return L, G

    def quadratic(self, qe, qde, geometry=None):
        arm, d, L, e = self._geometry(qe) if geometry is None else geometry
        vb = gather(qde, self.points.coords)
        w = vb[..., 2]
        v = vb[..., :2] + perp(arm) * w[..., None]
        dd = v[:, :, 1] - v[:, :, 0]
        centripetal = arm[:, :, 0] * w[:, :, 0, None] ** 2 - arm[:, :, 1] * w[:, :, 1, None] ** 2
        return dot(e, centripetal) + (dot(dd, dd) - dot(e, dd) ** 2) / L

    def directions(self, qe, geometry=None):
        e = (self._geometry(qe) if geometry is None else geometry)[3]
        out = np.empty(e.shape[:2] + (2, 2))
        out[:, :, 0] = e
        np.negative(e, out=out[:, :, 1])
        return out


SpringDamper.group = SpringDamperGroup
