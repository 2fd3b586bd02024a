"""Prescribed (driven) body: its pose follows run-time offsets ``d(t)`` from its
reference pose, a rheonomic driving constraint (Haug, *Computer-Aided Kinematics and
Dynamics of Mechanical Systems*, 1989, §3.4):

    C = q_b - q_b0 - d(t) = 0,    C_q = I,    ν = -C_t = ḋ,    γ = -C_tt = d̈

The multipliers are the force (x, z) and torque that drive the body, with the opposite
sign: the joint's reaction on the body is ``-λ`` (see
:meth:`~suspopt.multibody.elements.base.JointGroup.reactions`). The run-time values come
as a :class:`PrescribedMotion` per joint; none given means the reference pose at rest.
"""

from __future__ import annotations

import builtins
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike

from suspopt.multibody.elements.base import JointGroup, flat_index, gather


@dataclass(frozen=True)
class PrescribedJoint:
    """``body`` moves with prescribed pose offsets (x, z, φ) from its reference pose."""

    name: str
    body: str
    type: ClassVar[str] = 'prescribed'
    #: the group class of the type (set below its definition)
    group: ClassVar[builtins.type[PrescribedGroup]]
    keys: ClassVar[dict[str, bool]] = {'name': True, 'type': True, 'body': True}

    @property
    def bodies(self) -> tuple[str]:
        return (self.body,)

    @classmethod
    def read(cls, rd, data: dict, where: str, name: str) -> PrescribedJoint:
        return cls(name=name, body=rd.body(data.get('body'), f'{where}.body', allow_ground=False))


@dataclass(frozen=True)
class PrescribedMotion:
    """Offsets of a prescribed body's (x, z, φ) from its reference pose and their first
    and second time derivatives, per state: arrays (N, 3), or (3,) for all states."""

    offset: ArrayLike
    velocity: ArrayLike = 0.0
    acceleration: ArrayLike = 0.0


_EYE = np.eye(3)


class PrescribedGroup(JointGroup):
    n_equations = 3
    n_bodies = 1
    rheonomic = True

    def __init__(self, specs, layout):
        super().__init__(specs, layout)
        self.q0 = layout.q0e[self.bodies[:, 0]]  # (ne, 3)
        self._coords = flat_index(self.bodies[:, 0])

    def residual(self, qe, drive=None):
        C = gather(qe, self._coords) - self.q0
        return C if drive is None else C - drive[0]

    def jacobian(self, qe):
        J = np.zeros((qe.shape[0], len(self.names), 1, 3, 3))
        J[:, :, 0] = _EYE
        return J

    def gamma(self, qe, qde, drive=None):
        if drive is None:
            return np.zeros((qe.shape[0], len(self.names), 3))
        return np.array(np.broadcast_to(drive[2], (qe.shape[0], len(self.names), 3)))

    def velocity_term(self, drive):
        return drive[1]

    def drive(self, values, N):
        """(offset, velocity, acceleration) of every element, (3, N, ne, 3)."""
        d = np.zeros((3, N, len(self.names), 3))
        for k, pm in enumerate(values):
            if pm is not None:
                for c, val in enumerate((pm.offset, pm.velocity, pm.acceleration)):
                    d[c, :, k] = np.broadcast_to(np.asarray(val, dtype=float), (N, 3))
        return d


PrescribedJoint.group = PrescribedGroup
