"""Fixed joint: a body welded to another body or to the ground.

At the weld point ``p`` (default: the first body's CG) the two bodies coincide as in a
revolute joint, and their relative angle keeps its reference value:

    C_1,2 = r_i + A(φ_i) u_i - r_j - A(φ_j) u_j,     C_3 = φ_i - φ_j - (φ_i0 - φ_j0)

A body with ``fixed = true`` is a fixed joint to the ground at its CG, ``C = q_b - q_b0``.
"""

from __future__ import annotations

import builtins
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from suspopt.multibody.elements.base import GROUND, CoincidenceJointGroup


@dataclass(frozen=True)
class FixedJoint:
    """``bodies[0]`` welded to ``bodies[1]`` (or ``'ground'``) at ``point`` (None: the CG
    of the first body)."""

    name: str
    bodies: tuple[str, str]
    point: tuple[float, float] | None = None
    type: ClassVar[str] = 'fixed'
    #: the group class of the type (set below its definition)
    group: ClassVar[builtins.type[FixedGroup]]
    keys: ClassVar[dict[str, bool]] = {'name': True, 'type': True, 'bodies': True, 'point': False}

    @classmethod
    def read(cls, rd, data: dict, where: str, name: str) -> FixedJoint:
        a, b = rd.body_pair(data, where)
        if a == GROUND:
            a, b = b, a
        point = rd.vec2(data, 'point', where) if 'point' in data else None
        return cls(name=name, bodies=(a, b), point=point)


class FixedGroup(CoincidenceJointGroup):
    n_equations = 3
    angle_equation = True

    def joint_points(self, specs, layout):
        cg = layout.q0e[self.bodies[:, 0], :2]
        pts = np.array(
            [cg[k] if s.point is None else s.point for k, s in enumerate(specs)], dtype=float
        ).reshape(-1, 1, 2)
        return layout.local(self.bodies, pts)


FixedJoint.group = FixedGroup
