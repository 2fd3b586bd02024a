"""Linear spring-damper along an axis fixed in the body of its first marker (Exudyn's
``ObjectConnectorLinearSpringDamper``, made conservative): the length is the distance
along the axis from marker 0 to marker 1,

    ℓ = (A(φ_0) ā)ᵀ (p_1 - p_0),   f = k (ℓ - ℓ0) + c ℓ̇  (tension),   Q = -f (∂ℓ/∂q)ᵀ

(:func:`~suspopt.multibody.elements.base.axis_projection`): force ``-f n`` on end 1 and
``+f n`` on body 0, ``n = A(φ_0) ā``. ``Q = -∂V/∂q`` of ``V = ½ k (ℓ - ℓ0)²``, so body 0's
force acts on the line through ``p_1``; Exudyn's element applies it at ``p_0`` and takes
``ℓ̇`` without the axis' rotation. Both are the same when body 0 does not rotate (a fixed
or translating frame, e.g. the vertical suspension spring of docs/model.md, which with the
spring point on the arm as end 1 gives the point load ``-F_S`` of paper eq. 12 there,
``F_S = k q^z_U + c q̇^z_U``). ``ℓ0`` defaults to the reference value of ``ℓ``, which must
be > 0: the axis points from marker 0 towards marker 1.
"""

from __future__ import annotations

import builtins
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from suspopt.curves import SpringDamperUnit
from suspopt.multibody.elements.base import (
    AxisProjection,
    ScalarSpringGroup,
    read_spring_common,
    rot_apply,
    spring_spec_keys,
)


@dataclass(frozen=True)
class LinearSpringDamper:
    """Spring-damper along the unit ``axis`` (global at the reference pose, fixed in the
    body of ``markers[0]``) between ``markers[0]`` and ``markers[1]``."""

    name: str
    markers: tuple[str, str]
    axis: tuple[float, float]
    stiffness: float = 0.0
    damping: float = 0.0
    preload: float = 0.0
    free_length: float | None = None
    #: spring, damper and stop curves (the TOML subtables spring_curve, damper_curve,
    #: bump_stop, rebound_stop); None: the linear stiffness and damping
    curves: SpringDamperUnit | None = None
    type: ClassVar[str] = 'linear_spring_damper'
    #: the group class of the type (set below its definition)
    group: ClassVar[builtins.type[LinearSpringDamperGroup]]
    keys: ClassVar[dict[str, bool]] = {**spring_spec_keys(), 'axis': True}

    @classmethod
    def read(cls, rd, data: dict, where: str, name: str) -> LinearSpringDamper:
        common = read_spring_common(rd, data, where)
        axis = rd.unit_axis(data, 'axis', where)
        m0, m1 = common['markers']
        if (
            m0 in rd.markers
            and m1 in rd.markers
            and np.all(np.isfinite(axis))
            and rd.markers[m0][0] != rd.markers[m1][0]
        ):
            (x0, z0), (x1, z1) = rd.markers[m0][1], rd.markers[m1][1]
            ref = axis[0] * (x1 - x0) + axis[1] * (z1 - z0)
            if not ref > 0.0:
                rd.err(
                    f'{where}.axis',
                    f'must point from marker {m0!r} towards marker '
                    f'{m1!r}: their reference distance along it is {ref:g}, not > 0',
                )
        return cls(name=name, axis=axis, **common)


class LinearSpringDamperGroup(ScalarSpringGroup):
    def setup(self, specs, layout):
        axis = np.array([s.axis for s in specs], dtype=float).reshape(-1, 2)
        self.axis = rot_apply(-layout.angle0(self.bodies[:, 0]), axis)  # in body 0's axes
        self.projection = AxisProjection(self.bodies, self.u, self.axis)

    def geometry(self, qe):
        return self.projection.geometry(qe)

    def measure(self, qe, geometry=None):
        return self.projection.measure(qe, geometry)

    def quadratic(self, qe, qde, geometry=None):
        return self.projection.quadratic(qe, qde, geometry)

    def directions(self, qe, geometry=None):
        n = self.projection.normal(qe) if geometry is None else geometry[3]
        out = np.empty(n.shape[:2] + (2, 2))
        out[:, :, 0] = n
        np.negative(n, out=out[:, :, 1])
        return out


LinearSpringDamper.group = LinearSpringDamperGroup
