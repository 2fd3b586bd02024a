"""Revolute (pin) joint between two bodies, or a body and the ground (paper eq. 11).

    C = r_i + A(φ_i) u_i - r_j - A(φ_j) u_j = 0                      (2 equations)
    C_q = [ I   B_i u_i   -I   -B_j u_j ],   γ = A_i u_i φ̇_i² - A_j u_j φ̇_j²

with ``u`` the joint point in body axes: the joint applies ``-λ`` on the first body and
``+λ`` on the second, both at the joint point.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from suspopt.multibody.elements.base import GROUND, JointGroup, coincidence_jacobian, rot_apply


@dataclass(frozen=True)
class RevoluteJoint:
    """A pin joint between ``bodies[0]`` and ``bodies[1]`` (or ``'ground'``) at ``point``."""

    name: str
    bodies: tuple[str, str]
    point: tuple[float, float]
    type: ClassVar[str] = 'revolute'
    keys: ClassVar[dict[str, bool]] = {'name': True, 'type': False, 'bodies': True,
                                       'point': True}

    @classmethod
    def read(cls, rd, data: dict, where: str, name: str) -> RevoluteJoint:
        a, b = rd.body_pair(data, where)
        if a == GROUND:  # the ground second: λ is then the force on the moving body's pin
            a, b = b, a
        return cls(name=name, bodies=(a, b), point=rd.vec2(data, 'point', where))


class RevoluteGroup(JointGroup):
    n_equations = 2

    def __init__(self, specs, layout):
        super().__init__(specs, layout)
        pts = np.array([s.point for s in specs], dtype=float).reshape(-1, 1, 2)
        self.u = layout.local(self.bodies, pts)  # (ne, 2, 2): joint point in both bodies

    def arms(self, qe: np.ndarray) -> np.ndarray:
        return rot_apply(qe[:, self.bodies, 2], self.u)  # (N, ne, 2, 2)

    def _residual(self, qe, arm):
        pos = qe[:, self.bodies, :2]
        return pos[:, :, 0] + arm[:, :, 0] - pos[:, :, 1] - arm[:, :, 1]

    def residual(self, qe, drive=None):
        return self._residual(qe, self.arms(qe))

    def jacobian(self, qe):
        return coincidence_jacobian(self.arms(qe))

    def residual_jacobian(self, qe, drive=None):
        arm = self.arms(qe)
        return self._residual(qe, arm), coincidence_jacobian(arm)

    def gamma(self, qe, qde, drive=None):
        g = self.arms(qe) * qde[:, self.bodies, 2, None] ** 2
        return g[:, :, 0] - g[:, :, 1]


RevoluteJoint.group = RevoluteGroup
