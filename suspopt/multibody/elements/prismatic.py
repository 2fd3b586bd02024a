"""Prismatic (translational) joint: body b slides along an axis fixed in body a, without
relative rotation (Nikravesh, *Computer-Aided Analysis of Mechanical Systems*, 1988,
§5.3 "translational joint"; the constraint set of Exudyn's ``ObjectJointPrismatic2D``
with ``constrainRotation``, whose first equation takes the normal from the second body):

    C_1 = n_aᵀ (p_b - p_a) = 0,    n_a = A(φ_a) n̄  (normal to the axis, fixed in a)
    C_2 = φ_b - φ_a - (φ_b0 - φ_a0) = 0

with ``p_a``, ``p_b`` the joint point on each body (coincident at the reference pose).
``C_1`` is :func:`~suspopt.multibody.elements.base.axis_projection` along the normal, so
its Jacobian and ``γ_1 = -(C_1,q q̇)_q q̇`` are that function's; ``γ_2 = 0``. The
multiplier λ_1 is the normal force between the bodies, λ_2 the torque they transmit.
"""

from __future__ import annotations

import builtins
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from suspopt.multibody.elements.base import AxisProjection, JointGroup, gather, perp, rot_apply


@dataclass(frozen=True)
class PrismaticJoint:
    """``bodies[1]`` slides on ``bodies[0]`` (either may be the ground) along the unit
    ``axis`` (global, at the reference pose) through ``point``."""

    name: str
    bodies: tuple[str, str]
    point: tuple[float, float]
    axis: tuple[float, float]
    type: ClassVar[str] = 'prismatic'
    #: the group class of the type (set below its definition)
    group: ClassVar[builtins.type[PrismaticGroup]]
    keys: ClassVar[dict[str, bool]] = {
        'name': True,
        'type': True,
        'bodies': True,
        'point': True,
        'axis': True,
    }

    @classmethod
    def read(cls, rd, data: dict, where: str, name: str) -> PrismaticJoint:
        return cls(
            name=name,
            bodies=rd.body_pair(data, where),
            point=rd.vec2(data, 'point', where),
            axis=rd.unit_axis(data, 'axis', where),
        )


class PrismaticGroup(JointGroup):
    n_equations = 2
    constant_force_jacobian = False  # the normal turns with body a

    def __init__(self, specs, layout):
        super().__init__(specs, layout)
        pts = np.array([s.point for s in specs], dtype=float).reshape(-1, 1, 2)
        self.u = layout.local(self.bodies, pts)
        ang = layout.angle0(self.bodies)
        axis = np.array([s.axis for s in specs], dtype=float).reshape(-1, 2)
        self.normal = perp(rot_apply(-ang[:, 0], axis))  # in body a's axes
        self.angle = ang[:, 1] - ang[:, 0]
        self.projection = AxisProjection(self.bodies, self.u, self.normal)

    def residual(self, qe, drive=None):
        C = np.empty((qe.shape[0], len(self.names), 2))
        C[..., 0] = self.projection.measure(qe)[0]
        phi = gather(qe, self.projection.points.phi)
        C[..., 1] = phi[:, :, 1] - phi[:, :, 0] - self.angle
        return C

    def jacobian(self, qe):
        G = self.projection.measure(qe)[1]
        J = np.zeros(G.shape[:3] + (2, 3))
        J[:, :, :, 0] = G
        J[:, :, 0, 1, 2] = -1.0
        J[:, :, 1, 1, 2] = 1.0
        return J

    def gamma(self, qe, qde, drive=None):
        g = np.zeros((qe.shape[0], len(self.names), 2))
        g[..., 0] = -self.projection.quadratic(qe, qde)
        return g


PrismaticJoint.group = PrismaticGroup
