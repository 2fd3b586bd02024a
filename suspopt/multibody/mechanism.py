"""Planar mechanisms described as data (paper §3.2-3.3, Table 2; SPEC §3).

A mechanism is rigid bodies with body coordinates ``q = (x, z, φ)`` (x lateral, z up,
φ the rotation about the out-of-plane axis), revolute joints between two bodies or a
body and the ground, fixed bodies, named points on bodies (markers) and point loads of
fixed global direction acting at markers, whose magnitudes are supplied at run time.
The mechanism names its independent coordinates (as many as it has degrees of
freedom): the solver drives the mechanism through them (coordinate partitioning).

Mechanisms are read from TOML (see ``data/double_wishbone.toml``, the paper's Table 2)
with :func:`load_mechanism`, or built in Python from the dataclasses below. Every
geometric input is given in the global frame at the reference pose (t = 0).
"""
from __future__ import annotations

import difflib
import math
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from suspopt.errors import ConfigError

GROUND = 'ground'
COORDINATES = ('x', 'z', 'phi')


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
class RevoluteJoint:
    """A pin joint between ``bodies[0]`` and ``bodies[1]`` (or ``'ground'``) at ``point``."""

    name: str
    bodies: tuple[str, str]
    point: tuple[float, float]


@dataclass(frozen=True)
class Marker:
    """A named point fixed on ``body``, at global ``point`` in the reference pose."""

    name: str
    body: str
    point: tuple[float, float]


@dataclass(frozen=True)
class PointLoad:
    """A force of run-time magnitude along the fixed global unit ``direction``, at ``marker``."""

    name: str
    marker: str
    direction: tuple[float, float]


@dataclass(frozen=True)
class Mechanism:
    """A planar mechanism: bodies, joints, markers, loads and its independent coordinates."""

    name: str
    bodies: tuple[Body, ...]
    joints: tuple[RevoluteJoint, ...]
    markers: tuple[Marker, ...] = ()
    loads: tuple[PointLoad, ...] = ()
    independent: tuple[tuple[str, str], ...] = ()
    gravity: tuple[float, float] = (0.0, 0.0)
    roles: dict[str, str] = field(default_factory=dict, compare=False, hash=False)

    def body_index(self, name: str) -> int:
        return [b.name for b in self.bodies].index(name)

    def marker(self, name: str) -> Marker:
        return next(m for m in self.markers if m.name == name)

    def structure(self) -> dict[str, Any]:
        """The topology (no numbers): what a cached coloring may depend on."""
        return {
            'bodies': [(b.name, b.fixed) for b in self.bodies],
            'joints': [j.bodies for j in self.joints],
            'markers': [(m.name, m.body) for m in self.markers],
            'loads': [(ld.name, ld.marker) for ld in self.loads],
            'independent': list(self.independent),
        }


#: Vehicle-interface roles a suspension mechanism file must assign (SPEC §3).
SUSPENSION_ROLES = {
    'spring_marker': 'marker whose vertical displacement is q^z_U (spring end, eq. 12)',
    'wheel_marker': 'marker whose vertical displacement is q^z_W (tyre spring, eq. 13)',
    'suspension_load': 'load that carries -F_S (direction points down)',
    'tyre_load': 'load that carries +F_T (direction points up)',
}


def builtin_mechanisms() -> list[str]:
    """Names of the mechanism files shipped with suspopt."""
    return sorted(p.name.removesuffix('.toml')
                  for p in resources.files('suspopt.multibody').joinpath('data').iterdir()
                  if p.name.endswith('.toml'))


def mechanism_path(name_or_path: str) -> Path:
    """Resolve a built-in mechanism name or a file path."""
    if name_or_path in builtin_mechanisms():
        return Path(str(resources.files('suspopt.multibody').joinpath(
            'data', name_or_path + '.toml')))
    return Path(name_or_path)


def load_mechanism(name_or_path: str, *, suspension: bool = False) -> Mechanism:
    """Read and validate a mechanism TOML file (or a built-in name such as
    ``'double_wishbone'``). With ``suspension=True`` the file must also assign the vehicle
    interface roles of :data:`SUSPENSION_ROLES`. Raises :class:`ConfigError`."""
    path = mechanism_path(name_or_path)
    try:
        with path.open('rb') as fh:
            data = tomllib.load(fh)
    except FileNotFoundError:
        raise ConfigError(f'mechanism file not found: {path} '
                          f'(built-in: {", ".join(builtin_mechanisms())})') from None
    except (OSError, tomllib.TOMLDecodeError) as err:
        raise ConfigError(f'cannot read mechanism file {path}: {err}') from None
    return mechanism_from_dict(data, source=str(path), suspension=suspension)


def _close(word: str, options: list[str]) -> str:
    near = difflib.get_close_matches(word, options, n=1)
    return f" (did you mean '{near[0]}'?)" if near else ''


class _Reader:
    """Collects one message per problem, each naming the offending key."""

    def __init__(self, source: str):
        self.source = source
        self.errors: list[str] = []

    def err(self, key: str, msg: str) -> None:
        self.errors.append(f'{self.source}: {key}: {msg}')

    def table(self, data: dict, key: str, allowed: dict[str, bool]) -> None:
        for k in data:
            if k not in allowed:
                self.err(f'{key}.{k}' if key else k,
                         'unknown key' + _close(k, list(allowed)))
        for k, required in allowed.items():
            if required and k not in data:
                self.err(f'{key}.{k}' if key else k, 'missing value')

    def number(self, data: dict, key: str, where: str, *, positive: bool = False,
               default: float | None = None) -> float:
        val = data.get(key, default)
        if val is None:
            return math.nan
        if isinstance(val, bool) or not isinstance(val, (int, float)):
            self.err(f'{where}.{key}', f'must be a number, got {val!r}')
            return math.nan
        if not math.isfinite(val):
            self.err(f'{where}.{key}', f'must be finite, got {val}')
        elif positive and val <= 0.0:
            self.err(f'{where}.{key}', f'must be > 0, got {val}')
        return float(val)

    def vec2(self, data: dict, key: str, where: str, default=None) -> tuple[float, float]:
        val = data.get(key, default)
        where = f'{where}.{key}' if where else key
        if (not isinstance(val, (list, tuple)) or len(val) != 2
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                           for v in val)):
            self.err(where, f'must be two numbers [x, z], got {val!r}')
            return (math.nan, math.nan)
        if not all(math.isfinite(v) for v in val):
            self.err(where, f'must be finite, got {val!r}')
        return (float(val[0]), float(val[1]))

    def name(self, data: dict, where: str, seen: set[str]) -> str:
        val = data.get('name')
        if not isinstance(val, str) or not val:
            self.err(f'{where}.name', f'must be a non-empty string, got {val!r}')
            return f'?{where}'
        if val in seen:
            self.err(f'{where}.name', f'duplicate name {val!r}')
        seen.add(val)
        return val


def mechanism_from_dict(data: dict[str, Any], source: str = 'mechanism',
                        suspension: bool = False) -> Mechanism:
    """Build and validate a :class:`Mechanism` from the TOML structure (see the data files)."""
    rd = _Reader(source)
    rd.table(data, '', {'name': False, 'gravity': False, 'bodies': True, 'joints': True,
                        'markers': False, 'loads': False, 'independent': True,
                        'suspension': suspension})
    bodies, names = [], set()
    for i, b in enumerate(_list_of_tables(rd, data, 'bodies')):
        w = f'bodies[{i}]'
        rd.table(b, w, {'name': True, 'mass': True, 'inertia': True, 'position': True,
                        'angle': False, 'fixed': False})
        fixed = b.get('fixed', False)
        if not isinstance(fixed, bool):
            rd.err(f'{w}.fixed', f'must be true or false, got {fixed!r}')
        bodies.append(Body(name=rd.name(b, w, names),
                           mass=rd.number(b, 'mass', w, positive=True),
                           inertia=rd.number(b, 'inertia', w, positive=True),
                           position=rd.vec2(b, 'position', w),
                           angle=rd.number(b, 'angle', w, default=0.0),
                           fixed=bool(fixed)))
    body_names = [b.name for b in bodies]

    def body_ref(val: Any, key: str, allow_ground: bool) -> str:
        ok = body_names + ([GROUND] if allow_ground else [])
        if val not in ok:
            rd.err(key, f'unknown body {val!r}{_close(str(val), ok)} '
                   f'(bodies: {", ".join(ok)})')
        return str(val)

    joints, jnames = [], set()
    for i, j in enumerate(_list_of_tables(rd, data, 'joints')):
        w = f'joints[{i}]'
        rd.table(j, w, {'name': True, 'type': False, 'bodies': True, 'point': True})
        if j.get('type', 'revolute') != 'revolute':
            rd.err(f'{w}.type', f"only 'revolute' joints are supported, got {j.get('type')!r}")
        pair = j.get('bodies')
        if not isinstance(pair, list) or len(pair) != 2:
            rd.err(f'{w}.bodies', f'must be two body names, got {pair!r}')
            pair = ['?', '?']
        else:
            pair = [body_ref(p, f'{w}.bodies', allow_ground=True) for p in pair]
            if pair[0] == pair[1]:
                rd.err(f'{w}.bodies', f'a joint needs two different bodies, got {pair!r}')
            if pair[0] == GROUND:
                pair = [pair[1], pair[0]]
        joints.append(RevoluteJoint(name=rd.name(j, w, jnames), bodies=(pair[0], pair[1]),
                                    point=rd.vec2(j, 'point', w)))

    markers, mnames = [], set()
    for i, m in enumerate(_list_of_tables(rd, data, 'markers')):
        w = f'markers[{i}]'
        rd.table(m, w, {'name': True, 'body': True, 'point': True})
        markers.append(Marker(name=rd.name(m, w, mnames),
                              body=body_ref(m.get('body'), f'{w}.body', allow_ground=False),
                              point=rd.vec2(m, 'point', w)))
    marker_names = [m.name for m in markers]

    loads, lnames = [], set()
    for i, ld in enumerate(_list_of_tables(rd, data, 'loads')):
        w = f'loads[{i}]'
        rd.table(ld, w, {'name': True, 'marker': True, 'direction': True})
        mk = ld.get('marker')
        if mk not in marker_names:
            rd.err(f'{w}.marker', f'unknown marker {mk!r}{_close(str(mk), marker_names)}')
        d = rd.vec2(ld, 'direction', w)
        norm = math.hypot(*d)
        if math.isfinite(norm) and abs(norm - 1.0) > 1e-9:
            rd.err(f'{w}.direction', f'must be a unit vector, got {list(d)} (length {norm:g})')
        loads.append(PointLoad(name=rd.name(ld, w, lnames), marker=str(mk), direction=d))

    independent = []
    for i, c in enumerate(_list_of_tables(rd, data, 'independent')):
        w = f'independent[{i}]'
        rd.table(c, w, {'body': True, 'coordinate': True})
        b = body_ref(c.get('body'), f'{w}.body', allow_ground=False)
        if c.get('coordinate') not in COORDINATES:
            rd.err(f'{w}.coordinate', f'must be one of {", ".join(COORDINATES)}, '
                   f'got {c.get("coordinate")!r}')
        if any(bd.name == b and bd.fixed for bd in bodies):
            rd.err(f'{w}.body', f'{b!r} is fixed and cannot be an independent coordinate')
        independent.append((b, str(c.get('coordinate'))))

    roles: dict[str, str] = {}
    if suspension:
        sus = data.get('suspension', {})
        if not isinstance(sus, dict):
            rd.err('suspension', 'must be a table')
            sus = {}
        rd.table(sus, 'suspension', {k: True for k in SUSPENSION_ROLES})
        for key in ('spring_marker', 'wheel_marker'):
            if key in sus and sus[key] not in marker_names:
                rd.err(f'suspension.{key}',
                       f'unknown marker {sus[key]!r}{_close(str(sus[key]), marker_names)}')
        load_names = [ld.name for ld in loads]
        for key in ('suspension_load', 'tyre_load'):
            if key in sus and sus[key] not in load_names:
                rd.err(f'suspension.{key}',
                       f'unknown load {sus[key]!r}{_close(str(sus[key]), load_names)}')
        if len(independent) != 1:
            rd.err('independent', 'a suspension module needs exactly one independent '
                   f'coordinate (the wheel travel), got {len(independent)}')
        elif independent[0][1] != 'z':
            rd.err('independent[0].coordinate', "a suspension module is driven by a vertical "
                   f"wheel travel: must be 'z', got {independent[0][1]!r}")
        roles = {k: str(v) for k, v in sus.items() if k in SUSPENSION_ROLES}

    mech = Mechanism(name=str(data.get('name', Path(source).stem)), bodies=tuple(bodies),
                     joints=tuple(joints), markers=tuple(markers), loads=tuple(loads),
                     independent=tuple(independent),
                     gravity=rd.vec2({'gravity': data.get('gravity', [0.0, 0.0])}, 'gravity', '')
                     if 'gravity' in data else (0.0, 0.0),
                     roles=roles)
    if rd.errors:
        raise ConfigError(rd.errors)
    return mech


def _list_of_tables(rd: _Reader, data: dict, key: str) -> list[dict]:
    val = data.get(key, [])
    if not isinstance(val, list) or not all(isinstance(v, dict) for v in val):
        rd.err(key, 'must be an array of tables ([[%s]])' % key)
        return []
    return val
