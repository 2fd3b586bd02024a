"""Planar mechanisms described as data (paper §3.2-3.3, Table 2; docs/model.md).

A mechanism is rigid bodies with body coordinates ``q = (x, z, φ)`` (x lateral, z up,
φ the rotation about the out-of-plane axis), joints (``[[joints]]``, chosen by ``type``:
revolute, prismatic, fixed, prescribed; see :mod:`suspopt.multibody.elements`), named
points on bodies or on the ground (markers) and force elements (``[[forces]]`` by
``type``: point_load, spring_damper, linear_spring_damper; ``[[loads]]`` are point loads)
whose run-time values (load magnitudes, stiffness, damping) the caller may supply. A body
with ``fixed = true`` is welded to the ground. The mechanism names its independent
coordinates (as many as it has degrees of freedom): the solver drives the mechanism
through them (coordinate partitioning).

Mechanisms are read from TOML (see ``data/double_wishbone.toml``, the paper's Table 2)
with :func:`load_mechanism`, or built in Python from the dataclasses below. Every
geometric input is given in the global frame at the reference pose (t = 0).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from suspopt.errors import ConfigError
from suspopt.inputs import check_path, read_toml
from suspopt.multibody.elements import (
    FORCE_TYPES,
    JOINT_TYPES,
    FixedJoint,
    ForceSpec,
    JointSpec,
    LinearSpringDamper,
    PointLoad,
    PrescribedJoint,
    PrismaticJoint,
    RevoluteJoint,
    SpringDamper,
    is_spring,
)
from suspopt.multibody.elements.base import COORDINATES
from suspopt.multibody.reading import GROUND, Reader, close

#: wheel travel range a suspension file gets when its ``[suspension]`` table names none
DEFAULT_TRAVEL = (-0.1, 0.1)


@dataclass(frozen=True)
class Body:
    """A rigid body: mass [kg], inertia about its CG and the out-of-plane axis [kg m²],
    CG position ``(x, z)`` [m] and angle [rad] at the reference pose."""

    name: str
    mass: float
    inertia: float
    position: tuple[float, float]
    angle: float = 0.0
    fixed: bool = False


@dataclass(frozen=True)
class Marker:
    """A named point fixed on ``body`` (or the ground), at global ``point`` in the
    reference pose."""

    name: str
    body: str
    point: tuple[float, float]


@dataclass(frozen=True)
class Mechanism:
    """A planar mechanism: bodies, joints, markers, loads, force elements and its
    independent coordinates; ``roles`` and ``travel`` are the vehicle interface
    (``[suspension]``), if requested."""

    name: str
    bodies: tuple[Body, ...]
    joints: tuple[JointSpec, ...]
    markers: tuple[Marker, ...] = ()
    loads: tuple[PointLoad, ...] = ()
    independent: tuple[tuple[str, str], ...] = ()
    gravity: tuple[float, float] = (0.0, 0.0)
    forces: tuple[ForceSpec, ...] = ()
    roles: dict[str, str] = field(default_factory=dict, compare=False, hash=False)
    travel: tuple[float, float] | None = field(default=None, compare=False, hash=False)
    #: lateral position x of the vehicle's centre line in the front view [m] (the
    #: ``[suspension]`` key ``centre_line``, default 0: the file's origin), where the
    #: kinematic roll centre lies (:mod:`suspopt.multibody.kinematics`)
    centre_line: float = field(default=0.0, compare=False, hash=False)

    def body_index(self, name: str) -> int:
        return [b.name for b in self.bodies].index(name)

    def marker(self, name: str) -> Marker:
        return next(m for m in self.markers if m.name == name)

    def force(self, name: str) -> ForceSpec:
        """The force element (or load) called ``name``."""
        return next(f for f in self.loads + self.forces if f.name == name)

    def structure(self) -> dict[str, Any]:
        """The topology (no numbers): what a cached coloring may depend on."""
        return {
            'bodies': [(b.name, b.fixed) for b in self.bodies],
            'joints': [(j.type, j.bodies) for j in self.joints],
            'markers': [(m.name, m.body) for m in self.markers],
            'loads': [(ld.name, ld.marker) for ld in self.loads],
            'forces': [
                (f.type, f.name, getattr(f, 'markers', getattr(f, 'marker', None)))
                for f in self.forces
            ],
            'independent': list(self.independent),
        }


#: Vehicle-interface roles a suspension mechanism file must assign (docs/model.md).
SUSPENSION_ROLES = {
    'wheel_marker': 'marker whose vertical displacement is q^z_W (tyre spring, eq. 13)',
    'tyre_load': 'load that carries +F_T (direction points up)',
    'spring': 'force element of the suspension spring between the chassis-side mount and '
    'the linkage, k_S and c_S (a spring type)',
}
#: optional ``[suspension]`` key: the wheel travel range [m] the linkage must pass
#: without locking, ``[min, max]`` (default :data:`DEFAULT_TRAVEL`)
TRAVEL_KEY = 'travel'
#: optional ``[suspension]`` key: the vehicle centre line's lateral coordinate x [m] in the
#: file's front view (default 0); it must be inboard of the contact patch
CENTRE_LINE_KEY = 'centre_line'


def builtin_mechanisms() -> list[str]:
    """Names of the mechanism files shipped with suspopt."""
    return sorted(
        p.name.removesuffix('.toml')
        for p in resources.files('suspopt.multibody').joinpath('data').iterdir()
        if p.name.endswith('.toml')
    )


def mechanism_path(name_or_path: str) -> Path:
    """Resolve a built-in mechanism name or a file path."""
    if name_or_path in builtin_mechanisms():
        return Path(
            str(resources.files('suspopt.multibody').joinpath('data', name_or_path + '.toml'))
        )
    return Path(name_or_path)


def load_mechanism(name_or_path: str, *, suspension: bool = False) -> Mechanism:
    """Read and validate a mechanism TOML file (or a built-in name such as
    ``'double_wishbone'``). With ``suspension=True`` the file must also assign the vehicle
    interface roles of :data:`SUSPENSION_ROLES`. Raises :class:`ConfigError`."""
    check_path(name_or_path, 'mechanism file')
    path = mechanism_path(name_or_path)
    data = read_toml(path, 'mechanism file', hint=f'built-in: {", ".join(builtin_mechanisms())}')
    return mechanism_from_dict(data, source=str(path), suspension=suspension)


def mechanism_from_dict(
    data: dict[str, Any], source: str = 'mechanism', suspension: bool = False
) -> Mechanism:
    """Build and validate a :class:`Mechanism` from the TOML structure (see the data files)."""
    rd = Reader(source)
    rd.table(
        data,
        '',
        {
            'name': False,
            'gravity': False,
            'bodies': True,
            'joints': True,
            'markers': False,
            'loads': False,
            'forces': False,
            'independent': True,
            'suspension': suspension,
        },
    )
    bodies = _read_bodies(rd, data)
    rd.body_names = [b.name for b in bodies]

    markers = _read_markers(rd, data)

    seen: set[str] = set()
    joints: list[JointSpec] = _elements(
        rd, data, 'joints', JOINT_TYPES, 'joint', default_type='revolute'
    )
    loads: list[PointLoad] = _elements(
        rd,
        data,
        'loads',
        {'point_load': PointLoad},
        'load',
        default_type='point_load',
        seen=seen,
    )
    forces: list[ForceSpec] = _elements(rd, data, 'forces', FORCE_TYPES, 'force', seen=seen)

    independent = _read_independent(rd, data, bodies)

    roles: dict[str, str] = {}
    travel = None
    centre_line = 0.0
    if suspension:
        fixed = (
            {b.name for b in bodies if b.fixed}
            | {GROUND}
            | {
                b
                for j in joints
                if isinstance(j, FixedJoint) and GROUND in j.bodies
                for b in j.bodies
            }
        )
        roles, travel = _suspension_roles(rd, data, loads + forces, independent, fixed)
        centre_line = _centre_line(rd, data, loads + forces)

    mech = Mechanism(
        name=str(data.get('name', Path(source).stem)),
        bodies=tuple(bodies),
        joints=tuple(joints),
        markers=tuple(markers),
        loads=tuple(loads),
        independent=tuple(independent),
        gravity=rd.vec2({'gravity': data.get('gravity', [0.0, 0.0])}, 'gravity', '')
        if 'gravity' in data
        else (0.0, 0.0),
        forces=tuple(forces),
        roles=roles,
        travel=travel,
        centre_line=centre_line,
    )
    if rd.errors:
        raise ConfigError(rd.errors)
    return mech


def _read_bodies(rd: Reader, data: dict) -> list[Body]:
    """The ``[[bodies]]`` tables."""
    bodies: list[Body] = []
    names: set[str] = set()
    for i, b in enumerate(_list_of_tables(rd, data, 'bodies')):
        w = f'bodies[{i}]'
        rd.table(
            b,
            w,
            {
                'name': True,
                'mass': True,
                'inertia': True,
                'position': True,
                'angle': False,
                'fixed': False,
            },
        )
        fixed = b.get('fixed', False)
        if not isinstance(fixed, bool):
            rd.err(f'{w}.fixed', f'must be true or false, got {fixed!r}')
        bodies.append(
            Body(
                name=rd.name(b, w, names),
                mass=rd.number(b, 'mass', w, positive=True),
                inertia=rd.number(b, 'inertia', w, positive=True),
                position=rd.vec2(b, 'position', w),
                angle=rd.number(b, 'angle', w, default=0.0),
                fixed=bool(fixed),
            )
        )
    return bodies


def _read_markers(rd: Reader, data: dict) -> list[Marker]:
    """The ``[[markers]]`` tables (each also remembered by ``rd`` for the elements)."""
    markers: list[Marker] = []
    mnames: set[str] = set()
    for i, m in enumerate(_list_of_tables(rd, data, 'markers')):
        w = f'markers[{i}]'
        rd.table(m, w, {'name': True, 'body': True, 'point': True})
        mk = Marker(
            name=rd.name(m, w, mnames),
            body=rd.body(m.get('body'), f'{w}.body', allow_ground=True),
            point=rd.vec2(m, 'point', w),
        )
        markers.append(mk)
        rd.markers[mk.name] = (mk.body, mk.point)
    return markers


def _read_independent(rd: Reader, data: dict, bodies: list[Body]) -> list[tuple[str, str]]:
    """The ``[[independent]]`` coordinates: (body, coordinate) each."""
    independent: list[tuple[str, str]] = []
    for i, c in enumerate(_list_of_tables(rd, data, 'independent')):
        w = f'independent[{i}]'
        rd.table(c, w, {'body': True, 'coordinate': True})
        body = rd.body(c.get('body'), f'{w}.body', allow_ground=False)
        if c.get('coordinate') not in COORDINATES:
            rd.err(
                f'{w}.coordinate',
                f'must be one of {", ".join(COORDINATES)}, got {c.get("coordinate")!r}',
            )
        if any(bd.name == body and bd.fixed for bd in bodies):
            rd.err(f'{w}.body', f'{body!r} is fixed and cannot be an independent coordinate')
        independent.append((body, str(c.get('coordinate'))))
    return independent


def _elements(
    rd: Reader,
    data: dict,
    key: str,
    types: Mapping[str, type[JointSpec] | type[ForceSpec]],
    kind: str,
    *,
    default_type: str | None = None,
    seen: set[str] | None = None,
) -> list[Any]:
    """Read ``[[key]]`` tables, each by the spec class of its ``type``."""
    out, seen = [], set() if seen is None else seen
    for i, table in enumerate(_list_of_tables(rd, data, key)):
        w = f'{key}[{i}]'
        name = rd.name(table, w, seen)
        rd.element = f'({kind} {name!r})'
        try:
            typ = table.get('type', default_type)
            if not isinstance(typ, str) or typ not in types:
                have = sorted(types)
                rd.err(
                    f'{w}.type',
                    (
                        'missing value'
                        if typ is None
                        else f'unknown {kind} type {typ!r}{close(str(typ), have)}'
                    )
                    + f' (types: {", ".join(have)})',
                )
                continue
            spec = types[typ]
            rd.table(table, w, spec.keys)
            out.append(spec.read(rd, table, w, name))
        finally:
            rd.element = ''
    return out


def _suspension_roles(rd: Reader, data: dict, forces: list, independent: list, fixed: set[str]):
    """The ``[suspension]`` table: the vehicle interface roles and the travel range."""
    sus = data.get('suspension', {})
    if not isinstance(sus, dict):
        rd.err('suspension', 'must be a table')
        sus = {}
    rd.table(
        sus,
        'suspension',
        {**{k: k != 'spring' for k in SUSPENSION_ROLES}, TRAVEL_KEY: False, CENTRE_LINE_KEY: False},
    )
    if 'wheel_marker' in sus:
        rd.marker(sus['wheel_marker'], 'suspension.wheel_marker')
    by_name = {f.name: f for f in forces}
    loads = [f.name for f in forces if isinstance(f, PointLoad)]
    for key in ('tyre_load',):
        if key in sus and sus[key] not in loads:
            rd.err(f'suspension.{key}', f'unknown load {sus[key]!r}{close(str(sus[key]), loads)}')
        elif key in sus:
            _check_tyre_direction(rd, by_name[sus[key]], data)
    springs = [f.name for f in forces if is_spring(f)]
    if 'spring' in sus and not (
        isinstance(sus['spring'], str)
        and sus['spring'] in by_name
        and is_spring(by_name[sus['spring']])
    ):
        rd.err(
            'suspension.spring',
            f'{sus["spring"]!r} is not a spring force element '
            + (
                f'(springs: {", ".join(springs)})'
                if springs
                else '(the mechanism has none: add a spring_damper or linear_spring_damper to '
                '[[forces]])'
            ),
        )
    elif 'spring' in sus:
        ends = [rd.markers[m][0] for m in by_name[sus['spring']].markers if m in rd.markers]
        on_chassis = [b for b in ends if b in fixed]
        if len(ends) == 2 and len(on_chassis) != 1:
            rd.err(
                'suspension.spring',
                f'{sus["spring"]!r} must connect the chassis side (a '
                f'fixed body or the ground) to the linkage; its ends are on {ends}',
            )
    else:
        rd.err(
            'suspension.spring',
            'missing value: name the suspension spring ('
            + (
                f'springs: {", ".join(springs)})'
                if springs
                else 'the mechanism has none: add a spring_damper or linear_spring_damper to '
                '[[forces]])'
            ),
        )
    travel = DEFAULT_TRAVEL
    if TRAVEL_KEY in sus:
        lo, hi = rd.vec2(sus, TRAVEL_KEY, 'suspension')
        if not lo < 0.0 < hi:
            rd.err(
                f'suspension.{TRAVEL_KEY}',
                f'must be [min, max] with min < 0 < max '
                f'(wheel travel from the reference pose, m), got {[lo, hi]}',
            )
        travel = (lo, hi)
    if len(independent) != 1:
        rd.err(
            'independent',
            'a suspension module needs exactly one independent '
            f'coordinate (the wheel travel), got {len(independent)}',
        )
    elif independent[0][1] != 'z':
        rd.err(
            'independent[0].coordinate',
            'a suspension module is driven by a vertical '
            f"wheel travel: must be 'z', got {independent[0][1]!r}",
        )
    roles = {k: str(v) for k, v in sus.items() if k in SUSPENSION_ROLES}
    return roles, travel


def _centre_line(rd: Reader, data: dict, forces: list) -> float:
    """The ``[suspension]`` key ``centre_line``: a number inboard of the contact patch."""
    sus = data.get('suspension', {})
    if not isinstance(sus, dict) or CENTRE_LINE_KEY not in sus:
        return 0.0
    x_c = rd.number(sus, CENTRE_LINE_KEY, 'suspension')
    tyre = next((f for f in forces if f.name == sus.get('tyre_load')), None)
    if tyre is not None and tyre.marker in rd.markers and math.isfinite(x_c):
        x_p = rd.markers[tyre.marker][1][0]
        if not x_c < x_p:
            rd.err(
                f'suspension.{CENTRE_LINE_KEY}',
                f'the centre line must be inboard of the contact patch (x < {x_p:g} m, x '
                f'outboard), got {x_c:g}',
            )
    return x_c


def _check_tyre_direction(rd: Reader, load: PointLoad, data: dict) -> None:
    """The tyre load carries +F_T, the road pushing the wheel up (eq. 13): straight up."""
    dx, dz = load.direction
    if not (math.isfinite(dx) and math.isfinite(dz)) or (dz > 0.0 and abs(dx) <= 1e-9):
        return  # fine, or already reported
    where = 'suspension.tyre_load'
    for table in ('loads', 'forces'):
        names = [t.get('name') for t in data.get(table, []) if isinstance(t, dict)]
        if load.name in names:
            where = f'{table}[{names.index(load.name)}].direction'
            break
    rd.element = f'(load {load.name!r}, the suspension.tyre_load)'
    rd.err(
        where,
        'the tyre load must point straight up, [0.0, 1.0] (it carries +F_T, the '
        f'road pushing the wheel up: eq. 13), got {list(load.direction)}'
        + (': it points down' if dz < 0.0 else ''),
    )
    rd.element = ''


def _list_of_tables(rd: Reader, data: dict, key: str) -> list[dict]:
    val = data.get(key, [])
    if not isinstance(val, list) or not all(isinstance(v, dict) for v in val):
        rd.err(key, f'must be an array of tables ([[{key}]])')
        return []
    return val


__all__ = [
    'COORDINATES',
    'DEFAULT_TRAVEL',
    'GROUND',
    'SUSPENSION_ROLES',
    'Body',
    'FixedJoint',
    'LinearSpringDamper',
    'Marker',
    'Mechanism',
    'PointLoad',
    'PrescribedJoint',
    'PrismaticJoint',
    'RevoluteJoint',
    'SpringDamper',
    'builtin_mechanisms',
    'load_mechanism',
    'mechanism_from_dict',
    'mechanism_path',
]
