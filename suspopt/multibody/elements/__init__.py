"""The element library: one module per joint or force type, chosen by ``type`` in the
mechanism file. A type is a spec dataclass (its TOML keys and ``read``) and a group class
(its equations, batched over all its elements and N states); registering it is one
entry below."""

from __future__ import annotations

from typing import TypeAlias, TypeGuard

from suspopt.multibody.elements.base import ScalarSpringGroup
from suspopt.multibody.elements.fixed import FixedJoint
from suspopt.multibody.elements.linear_spring_damper import LinearSpringDamper
from suspopt.multibody.elements.point_load import PointLoad
from suspopt.multibody.elements.prescribed import PrescribedJoint, PrescribedMotion
from suspopt.multibody.elements.prismatic import PrismaticJoint
from suspopt.multibody.elements.revolute import RevoluteJoint
from suspopt.multibody.elements.spring_damper import SpringDamper

#: joint types by their ``type`` in ``[[joints]]``
JOINT_TYPES = {t.type: t for t in (RevoluteJoint, PrismaticJoint, FixedJoint, PrescribedJoint)}
#: force types by their ``type`` in ``[[forces]]``
FORCE_TYPES = {t.type: t for t in (PointLoad, SpringDamper, LinearSpringDamper)}

#: any joint spec, any force spec (type hints)
JointSpec: TypeAlias = RevoluteJoint | PrismaticJoint | FixedJoint | PrescribedJoint
ForceSpec: TypeAlias = PointLoad | SpringDamper | LinearSpringDamper
#: the force types with a length, rate and tension (:func:`is_spring`)
SpringSpec: TypeAlias = SpringDamper | LinearSpringDamper


def is_spring(spec: ForceSpec) -> TypeGuard[SpringSpec]:
    """A force element with a length, rate and tension (the spring queries)."""
    return issubclass(type(spec).group, ScalarSpringGroup)


__all__ = [
    'FORCE_TYPES',
    'ForceSpec',
    'JOINT_TYPES',
    'JointSpec',
    'SpringSpec',
    'FixedJoint',
    'LinearSpringDamper',
    'PointLoad',
    'PrescribedJoint',
    'PrescribedMotion',
    'PrismaticJoint',
    'RevoluteJoint',
    'SpringDamper',
    'is_spring',
]
