"""Fixed joint: a body welded to another body or to the ground.

At the weld point ``p`` (default: the first body's CG) the two bodies coincide as in a
revolute joint, and their relative angle keeps its reference value:

    C_1,2 = r_i + A(φ_i) u_i - r_j - A(φ_j) u_j,     C_3 = φ_i - φ_j - (φ_i0 - φ_j0)

A body with ``fixed = true`` is a fixed joint to the ground at its CG, ``C = q_b - q_b0``.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from suspopt.multibody.elements.base import GROUND, JointGroup, coincidence_jacobian, rot_apply


@dataclass(frozen=True)
class FixedJoint:
    """``bodies[0]`` welded to ``bodies[1]`` (or ``'ground'``) at ``point`` (None: the CG
    of the first body)."""

    name: str
    bodies: tuple[str, str]
    point: tuple[float, float] | None = None
    type: ClassVar[str] = 'fixed'
    keys: ClassVar[dict[str, bool]] = {'name': True, 'type': True, 'bodies': True,
                                       'point': False}

    @classmethod
    def read(cls, rd, data: dict, where: str, name: str) -> FixedJoint:
        a, b = rd.body_pair(data, where)
        if a == GROUND:
            a, b = b, a
        point = rd.vec2(data, 'point', where) if 'point' in data else None
        return cls(name=name, bodies=(a, b), point=point)


class FixedGroup(JointGroup):
    n_equations = 3

    def __init__(self, specs, layout):
        super().__init__(specs, layout)
        cg = layout.q0e[self.bodies[:, 0], :2]
        pts = np.array([cg[k] if s.point is None else s.point for k, s in enumerate(specs)],
                       dtype=float).reshape(-1, 1, 2)
        self.u = layout.local(self.bodies, pts)
        self.at_cg = not np.any(self.u)
        ang = layout.angle0(self.bodies)
        self.angle = (ang[:, 0] - ang[:, 1]).reshape(-1)

    def _residual(self, q, arm):
        C = np.empty(q.shape[:2] + (3,))
        C[..., :2] = q[:, :, 0, :2] + arm[:, :, 0] - q[:, :, 1, :2] - arm[:, :, 1]
        C[..., 2] = q[:, :, 0, 2] - q[:, :, 1, 2] - self.angle
        return C

    @staticmethod
    def _jacobian(arm):
        J = coincidence_jacobian(arm, 3)
        J[:, :, 0, 2, 2] = 1.0
        J[:, :, 1, 2, 2] = -1.0
        return J

    def _arms(self, q):
        """``A u`` of both bodies; zero for welds at the CG (``fixed = true`` bodies)."""
        if self.at_cg:
            return np.zeros(q.shape[:-1] + (2,))
        return rot_apply(q[..., 2], self.u)

    def residual(self, qe, drive=None):
        q = qe[:, self.bodies]
        return self._residual(q, self._arms(q))

    def jacobian(self, qe):
        return self._jacobian(self._arms(qe[:, self.bodies]))

    def residual_jacobian(self, qe, drive=None):
        q = qe[:, self.bodies]
        arm = self._arms(q)
        return self._residual(q, arm), self._jacobian(arm)

    def gamma(self, qe, qde, drive=None):
        g = self._arms(qe[:, self.bodies]) * qde[:, self.bodies, 2, None] ** 2
        out = np.zeros(g.shape[:2] + (3,))
        out[..., :2] = g[:, :, 0] - g[:, :, 1]
        return out


FixedJoint.group = FixedGroup
