"""The study description: one plain, serializable object for the car, road, design space,
objective, transcription and optimizer (SPEC §1-§6 are its defaults).

A :class:`StudyConfig` is a tree of frozen dataclasses. It round-trips through plain
dictionaries (:meth:`StudyConfig.to_dict`, :func:`config_from_dict`) and TOML files
(:func:`load_config`, :func:`default_config_toml`), holds no live objects, and is all a
worker needs to rebuild a model, so many studies can be built and run side by side.

Validation happens before any work starts and reports every problem at once, one line
per problem, each naming its key (``vehicle.front.wheel_mass: must be > 0, got -5``), as a
:class:`~suspopt.errors.ConfigError` (exit code 2 on the command line).
"""
from __future__ import annotations

import dataclasses
import difflib
import math
import tomllib
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from suspopt.errors import ConfigError
from suspopt.road import PROFILES, RoadProfile, make_road, profile_fields

#: Names of the design variables, in the paper's order (eq. 3).
DESIGN_NAMES = ('k_S1', 'k_S2', 'c_S1', 'c_S2')
#: The paper's printed normalization factors (§4.2).
PAPER_SCALES = (0.1, 0.01, 1.0, 1.0)
NORMALIZATIONS = ('reference', 'paper', 'custom')


def _check(kind: str, **kw: Any) -> dict[str, Any]:
    return {'check': kind, **kw}


@dataclass(frozen=True)
class AxleConfig:
    """One axle: position, half-car wheel, tyre and the multibody mechanism."""

    axle_position: float = field(default=1.271, metadata={'doc': 'a_i [m], + ahead of the CG'})
    wheel_mass: float = field(default=120.0, metadata=_check('positive', doc='m_i [kg]'))
    tyre_stiffness: float = field(default=200000.0, metadata=_check('positive', doc='k_Ti [N/m]'))
    mechanism: str = field(default='double_wishbone',
                           metadata={'doc': 'built-in name or path of a mechanism TOML'})


@dataclass(frozen=True)
class VehicleConfig:
    """The half car of SPEC §2 (paper Table 1)."""

    chassis_mass: float = field(default=1414.0, metadata=_check('positive', doc='M [kg]'))
    chassis_pitch_inertia: float = field(default=2782.0,
                                         metadata=_check('positive', doc='I [kg m^2]'))
    front: AxleConfig = field(default_factory=AxleConfig)
    rear: AxleConfig = field(default_factory=lambda: AxleConfig(axle_position=-1.713))

    @property
    def wheelbase(self) -> float:
        """``L = a1 - a2`` [m]."""
        return self.front.axle_position - self.rear.axle_position


@dataclass(frozen=True)
class ManeuverConfig:
    """Constant-speed drive over the road for the time horizon (SPEC §1, §4)."""

    speed: float = field(default=10.0, metadata=_check('positive', doc='v [m/s]'))
    horizon: float = field(default=5.0, metadata=_check('positive', doc='T [s]'))


@dataclass(frozen=True)
class DesignVariable:
    """One design variable: initial value and bounds; ``optimize = false`` holds it fixed."""

    initial: float
    lower: float
    upper: float
    optimize: bool = True


@dataclass(frozen=True)
class DesignConfig:
    """Spring rates [N/m] and damping [N s/m], front (1) and rear (2), paper Table 3."""

    k_S1: DesignVariable = field(default_factory=lambda: DesignVariable(30000.0, 10000.0, 50000.0))
    k_S2: DesignVariable = field(default_factory=lambda: DesignVariable(30000.0, 10000.0, 50000.0))
    c_S1: DesignVariable = field(default_factory=lambda: DesignVariable(3000.0, 1000.0, 5000.0))
    c_S2: DesignVariable = field(default_factory=lambda: DesignVariable(3000.0, 1000.0, 5000.0))

    def initial(self) -> dict[str, float]:
        return {n: getattr(self, n).initial for n in DESIGN_NAMES}

    def bounds(self) -> dict[str, tuple[float, float]]:
        return {n: (getattr(self, n).lower, getattr(self, n).upper) for n in DESIGN_NAMES}


@dataclass(frozen=True)
class ObjectiveConfig:
    """``f = Σ w_k J_k / s_k`` (SPEC §5). ``normalization``: ``reference`` (s_k = J_k of the
    low-fidelity model at the initial design, by time marching), ``paper`` (0.1, 0.01, 1, 1)
    or ``custom`` (``scales`` given)."""

    weights: tuple[float, ...] = (0.25, 0.25, 0.25, 0.25)
    normalization: str = 'reference'
    scales: tuple[float, ...] = ()


@dataclass(frozen=True)
class TranscriptionConfig:
    """Dymos Radau collocation grid (SPEC §6) and the states' initial guess."""

    segments: int = field(default=80, metadata=_check('positive'))
    order: int = field(default=5, metadata=_check('positive'))
    initial_guess: str = field(default='auto',
                               metadata={'doc': "auto (zero for the half car, simulate for "
                                                "the mixed model), simulate (the half car's "
                                                'time marching at the start design) or zero'})


@dataclass(frozen=True)
class OptimizerConfig:
    """IPOPT settings (defaults: IPOPT's own convergence criteria, L-BFGS Hessian)."""

    max_iter: int = field(default=500, metadata=_check('positive'))
    tol: float = field(default=1e-8, metadata=_check('positive'))
    print_level: int = 0
    options: dict[str, Any] = field(default_factory=dict,
                                    metadata={'doc': 'raw IPOPT options'})


@dataclass(frozen=True)
class MultibodyConfig:
    """Finite differencing of the black-box multibody module."""

    fd_form: str = 'forward'
    fd_step: float = field(default=1e-6, metadata=_check(
        'positive', doc='absolute step in the SI units of every input (m, m/s, N)'))


@dataclass(frozen=True)
class StudyConfig:
    """Everything a study needs; the defaults reproduce SPEC exactly."""

    vehicle: VehicleConfig = field(default_factory=VehicleConfig)
    maneuver: ManeuverConfig = field(default_factory=ManeuverConfig)
    road: dict[str, Any] = field(default_factory=lambda: make_road({}).to_dict())
    design: DesignConfig = field(default_factory=DesignConfig)
    objective: ObjectiveConfig = field(default_factory=ObjectiveConfig)
    transcription: TranscriptionConfig = field(default_factory=TranscriptionConfig)
    optimizer: OptimizerConfig = field(default_factory=OptimizerConfig)
    multibody: MultibodyConfig = field(default_factory=MultibodyConfig)

    def road_profile(self) -> RoadProfile:
        return make_road(self.road)

    def to_dict(self) -> dict[str, Any]:
        """A plain (JSON/TOML-able) dictionary; :func:`config_from_dict` inverts it."""
        return _to_plain(self)

    def replace(self, **changes: Any) -> 'StudyConfig':
        return dataclasses.replace(self, **changes)

    def with_design(self, **initial: float) -> 'StudyConfig':
        """A copy whose design variables start from the given values."""
        d = self.design
        for name, val in initial.items():
            d = dataclasses.replace(d, **{name: dataclasses.replace(getattr(d, name),
                                                                    initial=float(val))})
        return dataclasses.replace(self, design=d)


def _to_plain(obj: Any) -> Any:
    if dataclasses.is_dataclass(obj):
        return {f.name: _to_plain(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, (tuple, list)):
        return [_to_plain(v) for v in obj]
    if isinstance(obj, dict):
        return {k: _to_plain(v) for k, v in obj.items()}
    return obj


# ---------------------------------------------------------------------------- parsing
class _Errors(list):
    def add(self, key: str, msg: str) -> None:
        self.append(f'{key}: {msg}')


def _did_you_mean(word: str, options) -> str:
    near = difflib.get_close_matches(word, list(options), n=1)
    return f" (did you mean '{near[0]}'?)" if near else ''


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _parse_value(tp: Any, val: Any, key: str, errs: _Errors, meta: dict) -> Any:
    origin = typing.get_origin(tp)
    if dataclasses.is_dataclass(tp):
        return _parse_dataclass(tp, val, key, errs)
    if tp is float:
        if not _is_number(val):
            errs.add(key, f'must be a number, got {val!r}')
            return math.nan
        val = float(val)
        if not math.isfinite(val):
            errs.add(key, f'must be a finite number, got {val}')
        elif meta.get('check') == 'positive' and val <= 0.0:
            errs.add(key, f'must be > 0, got {val:g}')
        return val
    if tp is int:
        if isinstance(val, bool) or not isinstance(val, int):
            errs.add(key, f'must be an integer, got {val!r}')
            return 0
        if meta.get('check') == 'positive' and val <= 0:
            errs.add(key, f'must be > 0, got {val}')
        return val
    if tp is bool:
        if not isinstance(val, bool):
            errs.add(key, f'must be true or false, got {val!r}')
        return bool(val)
    if tp is str:
        if not isinstance(val, str):
            errs.add(key, f'must be a string, got {val!r}')
            return ''
        return val
    if origin is tuple:
        if not isinstance(val, (list, tuple)) or not all(_is_number(v) for v in val):
            errs.add(key, f'must be a list of numbers, got {val!r}')
            return ()
        out = tuple(float(v) for v in val)
        if not all(math.isfinite(v) for v in out):
            errs.add(key, f'must contain finite numbers only, got {list(val)}')
        return out
    if origin is dict or tp is dict:
        if not isinstance(val, dict):
            errs.add(key, f'must be a table, got {val!r}')
            return {}
        return dict(val)
    raise TypeError(f'unsupported config type {tp!r}')  # pragma: no cover


def _parse_dataclass(cls: type, data: Any, key: str, errs: _Errors) -> Any:
    if not isinstance(data, dict):
        errs.add(key, f'must be a table, got {data!r}')
        data = {}
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    for k in data:
        if k not in fields:
            errs.add(f'{key}.{k}' if key else k, 'unknown key' + _did_you_mean(k, fields))
    kwargs = {}
    for name, f in fields.items():
        sub = f'{key}.{name}' if key else name
        if name in data:
            kwargs[name] = _parse_value(hints[name], data[name], sub, errs, dict(f.metadata))
        elif f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
            errs.add(sub, 'missing value')
            kwargs[name] = math.nan if hints[name] is float else hints[name]()
    return cls(**kwargs)


def _merge(base: dict, override: dict) -> dict:
    out = dict(base)
    for k, v in override.items():
        out[k] = _merge(base[k], v) if isinstance(v, dict) and isinstance(base.get(k), dict) \
            and k not in ('road', 'options') else v
    return out


def config_from_dict(data: dict[str, Any], base_dir: str | Path | None = None) -> StudyConfig:
    """Parse and validate a study description (partial: missing keys take SPEC defaults).

    ``base_dir`` resolves relative file paths (road CSV, mechanism files).
    Raises :class:`ConfigError` listing every problem.
    """
    errs = _Errors()
    full = _merge(StudyConfig().to_dict(), data) if isinstance(data, dict) else data
    if isinstance(data, dict) and 'road' in data and isinstance(data['road'], dict):
        full['road'] = dict(data['road'])  # a road table replaces the default, not merges
    cfg = _parse_dataclass(StudyConfig, full, '', errs)
    cfg = _resolve_paths(cfg, base_dir)
    errs.extend(_semantic_checks(cfg))
    if errs:
        raise ConfigError(list(errs))
    # canonical road description: the profile with all of its parameters
    return dataclasses.replace(cfg, road=make_road(_typed_road(cfg.road)).to_dict())


def _typed_road(road: dict[str, Any]) -> dict[str, Any]:
    """The road table with ints promoted to floats where the profile expects floats."""
    kind = road.get('profile', 'two_bumps')
    fields = profile_fields(kind)
    out = {'profile': kind}
    for k, v in road.items():
        if k != 'profile':
            out[k] = float(v) if isinstance(fields.get(k), float) and _is_number(v) else v
    return out


def _resolve_paths(cfg: StudyConfig, base_dir: str | Path | None) -> StudyConfig:
    if base_dir is None:
        return cfg
    from suspopt.multibody.mechanism import builtin_mechanisms
    base = Path(base_dir)

    def fix(p: str) -> str:
        return p if Path(p).is_absolute() else str((base / p).resolve())

    vehicle = cfg.vehicle
    for axle in ('front', 'rear'):
        ax = getattr(vehicle, axle)
        if ax.mechanism and ax.mechanism not in builtin_mechanisms():
            vehicle = dataclasses.replace(vehicle, **{axle: dataclasses.replace(
                ax, mechanism=fix(ax.mechanism))})
    road = dict(cfg.road)
    if road.get('profile') == 'csv' and isinstance(road.get('file'), str) and road['file']:
        road['file'] = fix(road['file'])
    return dataclasses.replace(cfg, vehicle=vehicle, road=road)


def _semantic_checks(cfg: StudyConfig) -> list[str]:
    errs = _Errors()
    v = cfg.vehicle
    if math.isfinite(v.wheelbase) and v.wheelbase <= 0.0:
        errs.add('vehicle.front.axle_position',
                 f'must be ahead of vehicle.rear.axle_position '
                 f'({v.front.axle_position:g} <= {v.rear.axle_position:g})')
    for name in DESIGN_NAMES:
        dv: DesignVariable = getattr(cfg.design, name)
        key = f'design.{name}'
        vals = (dv.initial, dv.lower, dv.upper)
        if not all(math.isfinite(x) for x in vals):
            continue
        if dv.lower <= 0.0:
            errs.add(f'{key}.lower', f'must be > 0 (a rate or damping), got {dv.lower:g}')
        if dv.lower > dv.upper:
            errs.add(f'{key}.lower', f'lower bound {dv.lower:g} is above upper bound {dv.upper:g}')
        elif not dv.lower <= dv.initial <= dv.upper:
            errs.add(f'{key}.initial',
                     f'{dv.initial:g} is outside the bounds [{dv.lower:g}, {dv.upper:g}]')
    obj = cfg.objective
    if len(obj.weights) != 4:
        errs.add('objective.weights', f'needs 4 weights (J1..J4), got {len(obj.weights)}')
    elif any(w < 0.0 for w in obj.weights) or not any(w > 0.0 for w in obj.weights):
        errs.add('objective.weights', f'must be >= 0 and not all zero, got {list(obj.weights)}')
    if obj.normalization not in NORMALIZATIONS:
        errs.add('objective.normalization', f'must be one of {", ".join(NORMALIZATIONS)}, got '
                 f'{obj.normalization!r}{_did_you_mean(obj.normalization, NORMALIZATIONS)}')
    if obj.normalization == 'custom':
        if len(obj.scales) != 4 or any(not s > 0.0 for s in obj.scales):
            errs.add('objective.scales', f'custom normalization needs 4 positive scales, '
                     f'got {list(obj.scales)}')
    elif obj.scales:
        errs.add('objective.scales', "only used with normalization = 'custom'")
    tr = cfg.transcription
    if 0 < tr.order < 2:  # Radau with one point per segment degenerates (order <= 0: above)
        errs.add('transcription.order', f'must be >= 2 (Radau points per segment), got {tr.order}')
    op = cfg.optimizer
    if not 0 <= op.print_level <= 12:
        errs.add('optimizer.print_level', f'must be 0..12 (IPOPT), got {op.print_level}')
    from suspopt.driver import ipopt_option_problems
    errs.extend(f'optimizer.options.{p}' for p in ipopt_option_problems(op.options))
    if tr.initial_guess not in ('auto', 'simulate', 'zero'):
        errs.add('transcription.initial_guess', f"must be 'auto', 'simulate' or 'zero', "
                 f'got {tr.initial_guess!r}')
    if cfg.multibody.fd_form not in ('forward', 'central'):
        errs.add('multibody.fd_form', f"must be 'forward' or 'central', "
                 f'got {cfg.multibody.fd_form!r}')
    errs.extend(_road_checks(cfg))
    errs.extend(_mechanism_checks(cfg))
    return list(errs)


def _road_checks(cfg: StudyConfig) -> list[str]:
    errs = _Errors()
    road = cfg.road
    kind = road.get('profile', 'two_bumps')
    if kind not in PROFILES:
        errs.add('road.profile', f'unknown profile {kind!r}{_did_you_mean(str(kind), PROFILES)} '
                 f'(built-in: {", ".join(PROFILES)})')
        return list(errs)
    allowed = profile_fields(kind)
    sub = _Errors()
    params = {}
    for k, val in road.items():
        if k == 'profile':
            continue
        if k not in allowed:
            sub.add(f'road.{k}', f'unknown key for profile {kind!r}' + _did_you_mean(k, allowed))
            continue
        default = allowed[k]
        if isinstance(default, tuple):
            params[k] = _parse_value(tuple[float, ...], val, f'road.{k}', sub, {})
        elif isinstance(default, bool):
            params[k] = _parse_value(bool, val, f'road.{k}', sub, {})
        elif isinstance(default, int):
            params[k] = _parse_value(int, val, f'road.{k}', sub, {})
        elif isinstance(default, float):
            params[k] = _parse_value(float, val, f'road.{k}', sub, {})
        else:
            params[k] = _parse_value(str, val, f'road.{k}', sub, {})
    if kind == 'csv' and not road.get('file'):
        sub.add('road.file', 'missing value (path of a distance,height CSV)')
    if sub:
        return list(sub)
    length = cfg.maneuver.speed * cfg.maneuver.horizon
    return make_road(_typed_road({'profile': kind, **params})).validate(length, 'road')


def _mechanism_checks(cfg: StudyConfig) -> list[str]:
    from suspopt.multibody.mechanism import load_mechanism
    from suspopt.multibody.solver import PlanarMultibodySolver
    errs = []
    seen: dict[str, list[str]] = {}
    for axle in ('front', 'rear'):
        name = getattr(cfg.vehicle, axle).mechanism
        if name in seen:
            errs.extend(f'vehicle.{axle}.mechanism: {m}' for m in seen[name])
            continue
        try:
            PlanarMultibodySolver(load_mechanism(name, suspension=True))
            seen[name] = []
        except ConfigError as err:
            seen[name] = err.problems
            errs.extend(f'vehicle.{axle}.mechanism: {m}' for m in err.problems)
    return errs


def load_config(path: str | Path) -> StudyConfig:
    """Read and validate a study TOML file. Raises :class:`ConfigError`."""
    path = Path(path)
    try:
        with path.open('rb') as fh:
            data = tomllib.load(fh)
    except FileNotFoundError:
        raise ConfigError(f'config file not found: {path}') from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
        raise ConfigError(f'{path}: not valid TOML: {err}') from None
    except OSError as err:
        raise ConfigError(f'cannot read config file {path}: {err.strerror}') from None
    try:
        return config_from_dict(data, base_dir=path.parent)
    except ConfigError as err:
        raise ConfigError([f'{path}: {p}' for p in err.problems]) from None


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return 'true' if v else 'false'
    if isinstance(v, str):
        return '"' + v.replace('\\', '\\\\').replace('"', '\\"') + '"'
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, (list, tuple)):
        return '[' + ', '.join(_toml_value(x) for x in v) + ']'
    if isinstance(v, dict):
        return '{' + ', '.join(f'{k} = {_toml_value(x)}' for k, x in v.items()) + '}'
    return str(v)


def default_config_toml() -> str:
    """The paper's case (SPEC defaults) as a commented study file (``suspopt init``)."""
    c = StudyConfig()
    v, f, r = c.vehicle, c.vehicle.front, c.vehicle.rear
    road = {'profile': 'two_bumps', **profile_fields('two_bumps')}
    d = c.design
    o, t, op, mb = c.objective, c.transcription, c.optimizer, c.multibody
    tv = _toml_value
    lines = [
        '# suspopt study file: the paper\'s case (../shared/SPEC.md). SI units throughout.',
        '# Every key is optional; a missing key takes the value shown here.',
        '',
        '[vehicle]                      # half car, paper Table 1',
        f'chassis_mass = {tv(v.chassis_mass)}          # M [kg]',
        f'chassis_pitch_inertia = {tv(v.chassis_pitch_inertia)} # I [kg m^2], pitch about the CG',
        '',
        '[vehicle.front]',
        f'axle_position = {tv(f.axle_position)}        # a1 [m] ahead of the CG',
        f'wheel_mass = {tv(f.wheel_mass)}            # m1 [kg] (low-fidelity wheel)',
        f'tyre_stiffness = {tv(f.tyre_stiffness)}   # k_T1 [N/m]',
        f'mechanism = {tv(f.mechanism)}  # multibody module: built-in name or TOML path',
        '',
        '[vehicle.rear]',
        f'axle_position = {tv(r.axle_position)}       # a2 [m] (negative: behind the CG)',
        f'wheel_mass = {tv(r.wheel_mass)}',
        f'tyre_stiffness = {tv(r.tyre_stiffness)}',
        f'mechanism = {tv(r.mechanism)}',
        '',
        '[maneuver]',
        f'speed = {tv(c.maneuver.speed)}     # v [m/s], constant',
        f'horizon = {tv(c.maneuver.horizon)}    # T [s]; zero initial state at t = 0',
        '',
        '[road]                         # SPEC §4: two 1-cos bumps',
        '# profile = two_bumps | bump | step | iso8608 | csv; other profiles take:',
        '#   bump:    height, length, start',
        '#   step:    height, position, ramp_length',
        '#   iso8608: road_class ("A".."H"), seed, n_min, n_max, n_waves, fade_in',
        '#   csv:     file  (distance [m], height [m] per row; header allowed)',
    ]
    lines += [f'{k} = {tv(val)}' for k, val in road.items()]
    lines += ['', '# design variables: initial value and bounds (paper Table 3);',
              '# optimize = false holds a variable at its initial value']
    for name in DESIGN_NAMES:
        dv = getattr(d, name)
        unit = 'N/m' if name.startswith('k') else 'N s/m'
        lines.append(f'[design.{name}]  # [{unit}]')
        lines.append(f'initial = {tv(dv.initial)}\nlower = {tv(dv.lower)}\n'
                     f'upper = {tv(dv.upper)}\noptimize = {tv(dv.optimize)}')
    lines += [
        '',
        '[objective]                    # f = sum_k w_k J_k / s_k (SPEC §5)',
        f'weights = {tv(list(o.weights))}',
        f'normalization = {tv(o.normalization)}  # reference | paper | custom (then set scales)',
        '',
        '[transcription]                # Dymos Radau collocation (SPEC §6)',
        f'segments = {t.segments}                 # SPEC: 64 (0.15 % off here); paper: 16 (30 % off)',
        f'order = {t.order}',
        f'initial_guess = {tv(t.initial_guess)}   # "auto": zero for the half car, its time '
        'marching for the mixed model; "simulate"; "zero"',
        '',
        '[optimizer]                    # IPOPT',
        f'max_iter = {op.max_iter}',
        f'tol = {tv(op.tol)}',
        f'print_level = {op.print_level}              # IPOPT\'s own console output (0-12)',
        'options = {}                   # any further IPOPT option, e.g. { mu_strategy = "adaptive" }',
        '',
        '[multibody]                    # finite differences of the black-box module',
        f'fd_form = {tv(mb.fd_form)}         # forward | central',
        f'fd_step = {tv(mb.fd_step)}             # absolute step, SI units of each input (m, m/s, N)',
        '',
    ]
    return '\n'.join(lines)
