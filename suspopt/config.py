"""The study description: one plain, serializable object for the car, roads, design space,
objective, transcription and optimizer (SPEC §1-§6 are the half car's defaults).

A :class:`StudyConfig` is a tree of frozen dataclasses. It round-trips through plain
dictionaries (:meth:`StudyConfig.to_dict`, :func:`config_from_dict`) and TOML files
(:func:`load_config`, :func:`default_config_toml`), holds no live objects, and is all a
worker needs to rebuild a model, so many studies can be built and run side by side.

Two vehicle models share one description (``vehicle.model``): the paper's half car (two
corners, SPEC §2) and the full car (four corners, roll, optional anti-roll bars). Every
key is optional; a missing key takes the value of that model's default car (SPEC for the
half car, :func:`full_car_defaults` for the full car). Design variables, objective terms
and their weights are named (``k_S1``, ``c_S2``, ``k_R1``; ``heave``, ``pitch``, ``roll``,
``wheel_1`` ...) and depend on the model: :meth:`StudyConfig.design_names`,
:meth:`StudyConfig.terms`.

A study may list several load cases (``[[scenario]]``: road, speed, horizon, grid,
weight) that share one design; without them the study has one scenario made of its
``maneuver``, ``road`` and ``transcription`` tables (:meth:`StudyConfig.scenarios`).

Validation happens before any work starts and reports every problem at once, one line
per problem, each naming its key (``vehicle.front.wheel_mass: must be > 0, got -5``), as a
:class:`~suspopt.errors.ConfigError` (exit code 2 on the command line).
"""

from __future__ import annotations

import dataclasses
import difflib
import functools
import math
import tomllib
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from suspopt.errors import ConfigError
from suspopt.models.design import DESIGN_UNITS, design_kind  # noqa: F401 (re-exported)
from suspopt.models.layout import VehicleLayout, full_car, half_car
from suspopt.road import PROFILES, TWO_TRACKS, RoadProfile, make_road, profile_fields

MODELS = ('half_car', 'full_car')
NORMALIZATIONS = ('reference', 'paper', 'custom')
AGGREGATES = ('sum', 'max')
#: how a multibody module's frame is coupled to the chassis (``multibody.mount``)
MOUNTS = ('ground', 'chassis')
#: The paper's printed normalization factors (§4.2), for the half car's four terms.
PAPER_SCALES = {'heave': 0.1, 'pitch': 0.01, 'wheel_1': 1.0, 'wheel_2': 1.0}
#: Largest NLP suspopt builds, all scenarios together: nodes × states (a guard against a
#: typo such as segments = 100000: the build's time and memory grow faster than its size)
MAX_NLP_VARIABLES = 150_000
#: Design variables' largest plausible values by kind (a guard against a unit typo).
DESIGN_LIMITS = {'k_S': 1e7, 'c_S': 1e6, 'k_R': 1e7}


def _check(kind: str, **kw: Any) -> dict[str, Any]:
    return {'check': kind, **kw}


def _plausible(
    lo: float, hi: float, unit: str, what: str, hint: str = '', **kw: Any
) -> dict[str, Any]:
    """A number that must lie in [lo, hi] (a road vehicle's range): outside it, it is a
    typo (a unit, a missing digit), refused before any work."""
    return {'range': (lo, hi, unit, what, hint), **kw}


#: maneuver limits (also for scenarios)
SPEED_RANGE = (
    0.0,
    150.0,
    'm/s',
    "a road vehicle's speed",
    'speeds are in m/s: 100 km/h is 27.8 m/s',
)
HORIZON_RANGE = (0.0, 600.0, 's', 'a maneuver (collocation resolves a few tens of seconds)', '')


def _range_problem(val: float, limits: tuple) -> str | None:
    lo, hi, unit, what, hint = limits
    if lo <= val <= hi:
        return None
    u = f' {unit}' if unit else ''
    return f'{val:g}{u} is implausible for {what}: expected {lo:g} to {hi:g}{u}' + (
        f' ({hint})' if hint else ' (a typo?)'
    )


# ---------------------------------------------------------------------------- vehicle
@dataclass(frozen=True)
class AxleConfig:
    """One axle: position, wheel (per corner), tyre, multibody mechanism, track width and
    anti-roll bar (full car)."""

    axle_position: float = field(
        default=1.271,
        metadata=_plausible(-20.0, 20.0, 'm', 'an axle position', doc='a_i [m], + ahead of the CG'),
    )
    wheel_mass: float = field(
        default=120.0,
        metadata=_plausible(
            10.0, 2000.0, 'kg', "a road vehicle's wheel", check='positive', doc='m_i [kg]'
        ),
    )
    tyre_stiffness: float = field(
        default=200000.0,
        metadata=_plausible(1e4, 1e7, 'N/m', 'a tyre', check='positive', doc='k_Ti [N/m]'),
    )
    mechanism: str = field(
        default='double_wishbone', metadata={'doc': 'built-in name or path of a mechanism TOML'}
    )
    track: float = field(
        default=0.0,
        metadata=_plausible(0.0, 5.0, 'm', 'a wheel track', doc='full car: wheel track width [m]'),
    )
    anti_roll_bar: bool = field(
        default=False, metadata={'doc': 'full car: a bar whose rate k_R is designed'}
    )


@dataclass(frozen=True)
class VehicleConfig:
    """The car: the half car of SPEC §2 (paper Table 1) or a full car."""

    model: str = 'half_car'
    chassis_mass: float = field(
        default=1414.0,
        metadata=_plausible(
            50.0, 1e5, 'kg', "a road vehicle's sprung mass", check='positive', doc='M [kg]'
        ),
    )
    chassis_pitch_inertia: float = field(
        default=2782.0,
        metadata=_plausible(
            1.0, 1e7, 'kg m^2', 'a pitch inertia', check='positive', doc='I [kg m^2]'
        ),
    )
    chassis_roll_inertia: float = field(
        default=0.0,
        metadata=_plausible(0.0, 1e7, 'kg m^2', 'a roll inertia', doc='full car: I_x [kg m^2]'),
    )
    front: AxleConfig = field(default_factory=AxleConfig)
    rear: AxleConfig = field(default_factory=lambda: AxleConfig(axle_position=-1.713))

    @property
    def wheelbase(self) -> float:
        """``L = a1 - a2`` [m]."""
        return self.front.axle_position - self.rear.axle_position

    @property
    def axles(self) -> tuple[AxleConfig, AxleConfig]:
        return (self.front, self.rear)

    def layout(self) -> VehicleLayout:
        """The corners of this car (:mod:`suspopt.models.layout`)."""
        a1, a2 = self.front.axle_position, self.rear.axle_position
        if self.model == 'full_car':
            return full_car(a1, a2, self.front.track, self.rear.track)
        return half_car(a1, a2)


@dataclass(frozen=True)
class ManeuverConfig:
    """Constant-speed drive over the road for the time horizon (SPEC §1, §4)."""

    speed: float = field(
        default=10.0, metadata={'range': SPEED_RANGE, 'check': 'positive', 'doc': 'v [m/s]'}
    )
    horizon: float = field(
        default=5.0, metadata={'range': HORIZON_RANGE, 'check': 'positive', 'doc': 'T [s]'}
    )


# ---------------------------------------------------------------------------- design
@dataclass(frozen=True)
class DesignVariable:
    """One design variable: initial value and bounds; ``optimize = false`` holds it fixed."""

    initial: float
    lower: float
    upper: float
    optimize: bool = True


#: default (initial, lower, upper) by kind: spring rate [N/m], damping [N s/m], anti-roll
#: bar rate [N m/rad] (paper Table 3 for the first two)
DESIGN_DEFAULTS = {
    'k_S': (30000.0, 10000.0, 50000.0),
    'c_S': (3000.0, 1000.0, 5000.0),
    'k_R': (20000.0, 0.0, 100000.0),
}


def design_names(vehicle: VehicleConfig, per_corner: bool = False) -> tuple[str, ...]:
    """The design variables of a car: spring rate and damping per axle (``k_S1``, ``c_S2``)
    or per corner (``k_S1L`` ...), then each anti-roll bar's rate (``k_R1``)."""
    groups = vehicle.layout().labels if per_corner and vehicle.model == 'full_car' else ('1', '2')
    names = [f'k_S{g}' for g in groups] + [f'c_S{g}' for g in groups]
    if vehicle.model == 'full_car':
        names += [f'k_R{i + 1}' for i, ax in enumerate(vehicle.axles) if ax.anti_roll_bar]
    return tuple(names)


@dataclass(frozen=True)
class DesignConfig:
    """The design variables by name (paper Table 3 for the half car), per axle or, with
    ``per_corner`` (full car), per corner."""

    per_corner: bool = False
    variables: dict[str, DesignVariable] = field(
        default_factory=lambda: {
            n: DesignVariable(*DESIGN_DEFAULTS[design_kind(n)])
            for n in ('k_S1', 'k_S2', 'c_S1', 'c_S2')
        }
    )

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.variables)

    def __getitem__(self, name: str) -> DesignVariable:
        return self.variables[name]

    def initial(self) -> dict[str, float]:
        return {n: v.initial for n, v in self.variables.items()}

    def bounds(self) -> dict[str, tuple[float, float]]:
        return {n: (v.lower, v.upper) for n, v in self.variables.items()}


# ---------------------------------------------------------------------------- objective
def objective_terms(layout: VehicleLayout) -> tuple[str, ...]:
    """The objective's integrals (paper eq. 4, extended): chassis ``heave``, ``pitch`` (and
    ``roll``) accelerations squared, and each wheel's travel squared (``wheel_<corner>``)."""
    return (
        ('heave', 'pitch')
        + (('roll',) if layout.has_roll else ())
        + tuple(f'wheel_{c}' for c in layout.labels)
    )


def default_weights(layout: VehicleLayout) -> dict[str, float]:
    """Half comfort, half road holding: the paper's 0.25 each for the half car; for the
    full car 1/6 on each chassis term and 1/8 on each wheel."""
    terms = objective_terms(layout)
    chassis = [t for t in terms if not t.startswith('wheel_')]
    return {
        t: (0.5 / len(chassis) if t in chassis else 0.5 / (len(terms) - len(chassis)))
        for t in terms
    }


@dataclass(frozen=True)
class ObjectiveConfig:
    """``f = Σ w_k J_k / s_k`` (SPEC §5). ``normalization``: ``reference`` (s_k = J_k of the
    low-fidelity model at the initial design, by time marching), ``paper`` (0.1, 0.01, 1, 1;
    half car) or ``custom`` (``scales`` given). With several scenarios, ``aggregate`` combines
    their objectives: ``sum`` (Σ w_s f_s) or ``max`` (the worst case, in epigraph form)."""

    weights: dict[str, float] = field(default_factory=dict)
    normalization: str = 'reference'
    scales: dict[str, float] = field(default_factory=dict)
    aggregate: str = 'sum'


# ---------------------------------------------------------------------------- the rest
@dataclass(frozen=True)
class TranscriptionConfig:
    """Dymos Radau collocation grid (SPEC §6) and the states' initial guess. ``segments`` is
    a number or ``"auto"`` (:func:`suspopt.transcription.grid.auto_segments`)."""

    segments: Any = field(default=80, metadata={'doc': 'uniform segments, or "auto"'})
    order: int = field(default=5, metadata=_check('positive'))
    initial_guess: str = field(
        default='auto',
        metadata={
            'doc': 'auto (zero for the half car, simulate for '
            "the mixed model), simulate (the half car's "
            'time marching at the start design) or zero'
        },
    )


@dataclass(frozen=True)
class OptimizerConfig:
    """IPOPT settings (defaults: IPOPT's own convergence criteria, L-BFGS Hessian)."""

    max_iter: int = field(default=500, metadata=_check('positive'))
    tol: float = field(default=1e-8, metadata=_check('positive'))
    print_level: int = 0
    options: dict[str, Any] = field(default_factory=dict, metadata={'doc': 'raw IPOPT options'})


@dataclass(frozen=True)
class MultibodyConfig:
    """Finite differencing of the black-box multibody module, and how its frame is
    coupled to the chassis (``mount``, see :mod:`suspopt.multibody.suspension`)."""

    fd_form: str = 'forward'
    fd_step: float = field(
        default=1e-6,
        metadata=_plausible(
            1e-10,
            1e-2,
            '',
            'a finite-difference step (SI units: m, m/s, N)',
            check='positive',
            doc='absolute step in the SI units of every input (m, m/s, N)',
        ),
    )
    mount: str = field(
        default='ground',
        metadata={
            'doc': 'ground: the frame is fixed and the chassis feels the spring only (the '
            "paper's coupling); chassis: the frame moves with the chassis and the "
            'chassis feels every chassis-side reaction'
        },
    )


@dataclass(frozen=True)
class ScenarioConfig:
    """One load case: a road driven at a speed for a horizon on a grid, with a weight."""

    name: str = ''
    weight: float = 1.0
    speed: float = 0.0
    horizon: float = 0.0
    road: dict[str, Any] = field(default_factory=dict)
    segments: Any = 0
    order: int = 0


@dataclass(frozen=True)
class Scenario:
    """A resolved load case (every value set)."""

    name: str
    weight: float
    speed: float
    horizon: float
    road: dict[str, Any]
    segments: int
    order: int

    @property
    def length(self) -> float:
        """Distance driven [m]."""
        return self.speed * self.horizon


@dataclass(frozen=True)
class StudyConfig:
    """Everything a study needs; the defaults reproduce SPEC exactly."""

    vehicle: VehicleConfig = field(default_factory=VehicleConfig)
    maneuver: ManeuverConfig = field(default_factory=ManeuverConfig)
    road: dict[str, Any] = field(default_factory=lambda: make_road({}).to_dict())
    design: DesignConfig = field(default_factory=DesignConfig)
    objective: ObjectiveConfig = field(
        default_factory=lambda: ObjectiveConfig(weights=default_weights(half_car(1.271, -1.713)))
    )
    transcription: TranscriptionConfig = field(default_factory=TranscriptionConfig)
    optimizer: OptimizerConfig = field(default_factory=OptimizerConfig)
    multibody: MultibodyConfig = field(default_factory=MultibodyConfig)
    scenario: tuple[ScenarioConfig, ...] = ()

    def layout(self) -> VehicleLayout:
        return self.vehicle.layout()

    def terms(self) -> tuple[str, ...]:
        return objective_terms(self.layout())

    def design_names(self) -> tuple[str, ...]:
        return self.design.names

    def weights(self) -> tuple[float, ...]:
        """The objective weights in term order."""
        return tuple(self.objective.weights[t] for t in self.terms())

    def scenarios(self) -> tuple[Scenario, ...]:
        """The load cases, every value resolved (the top-level tables fill the gaps)."""
        from suspopt.transcription.grid import resolve_segments

        base = Scenario(
            name='main',
            weight=1.0,
            speed=self.maneuver.speed,
            horizon=self.maneuver.horizon,
            road=dict(self.road),
            segments=0,
            order=self.transcription.order,
        )
        listed = self.scenario or (ScenarioConfig(name='main'),)
        out = []
        for i, sc in enumerate(listed):
            s = Scenario(
                name=sc.name or f's{i}',
                weight=sc.weight,
                speed=sc.speed or base.speed,
                horizon=sc.horizon or base.horizon,
                road=dict(sc.road) if sc.road else base.road,
                segments=0,
                order=sc.order or base.order,
            )
            segments = sc.segments or self.transcription.segments
            out.append(dataclasses.replace(s, segments=resolve_segments(self, s, segments)))
        return tuple(out)

    def road_profile(self) -> RoadProfile:
        return make_road(self.road)

    def to_dict(self) -> dict[str, Any]:
        """A plain (JSON/TOML-able) dictionary; :func:`config_from_dict` inverts it."""
        return _to_plain(self)

    def replace(self, **changes: Any) -> StudyConfig:
        return dataclasses.replace(self, **changes)

    def with_weights(self, weights: dict[str, float]) -> StudyConfig:
        return dataclasses.replace(
            self,
            objective=dataclasses.replace(
                self.objective, weights={t: float(weights.get(t, 0.0)) for t in self.terms()}
            ),
        )


def full_car_defaults() -> StudyConfig:
    """The default full car: a BMW E90 (330i, 2006) as Chrono::Vehicle models it
    (``src/chrono_models/vehicle/bmw/``, data credited there to SAE 2007-01-0817/-0818):
    sprung mass, roll and pitch inertia, CG position, tracks, tyre rate; spring and damper
    rates of its front MacPherson and rear double wishbone as wheel rates; anti-roll bars.
    Driven over an ISO 8608 class C road (isotropic left/right coherence) at 20 m/s."""
    from suspopt.vehicles import BMW_E90

    return config_from_dict(BMW_E90)


def _to_plain(obj: Any) -> Any:
    if isinstance(obj, DesignConfig):
        return {'per_corner': obj.per_corner, **{n: _to_plain(v) for n, v in obj.variables.items()}}
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
    if tp is Any:
        return val
    if tp is float:
        if not _is_number(val):
            errs.add(key, f'must be a number, got {val!r}')
            return math.nan
        val = float(val)
        if not math.isfinite(val):
            errs.add(key, f'must be a finite number, got {val}')
        elif meta.get('check') == 'positive' and val <= 0.0:
            errs.add(key, f'must be > 0, got {val:g}')
        elif 'range' in meta and (problem := _range_problem(val, meta['range'])):
            errs.add(key, problem)
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
        item = typing.get_args(tp)[0]
        if dataclasses.is_dataclass(item):
            if not isinstance(val, list):
                errs.add(key, f'must be an array of tables ([[{key}]]), got {val!r}')
                return ()
            return tuple(_parse_dataclass(item, v, f'{key}[{i}]', errs) for i, v in enumerate(val))
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


@functools.cache
def _type_hints(cls: type) -> dict[str, Any]:
    """The (evaluated) field types of a config dataclass, once per class."""
    return typing.get_type_hints(cls)


def _parse_dataclass(cls: type, data: Any, key: str, errs: _Errors) -> Any:
    if not isinstance(data, dict):
        errs.add(key, f'must be a table, got {data!r}')
        data = {}
    hints = _type_hints(cls)
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


_TABLE_REPLACED = ('road', 'options', 'weights', 'scales')


def _merge(base: dict, override: dict) -> dict:
    out = dict(base)
    for k, v in override.items():
        out[k] = (
            _merge(base[k], v)
            if isinstance(v, dict) and isinstance(base.get(k), dict) and k not in _TABLE_REPLACED
            else v
        )
    return out


def _parse_design(
    data: Any, vehicle: VehicleConfig, errs: _Errors, defaults: dict[str, Any] | None = None
) -> DesignConfig:
    """The design table; a variable not given takes the default car's entry
    (``defaults``) or the kind's default (:data:`DESIGN_DEFAULTS`)."""
    defaults = defaults or {}
    if not isinstance(data, dict):
        errs.add('design', f'must be a table, got {data!r}')
        data = {}
    per_corner = data.get('per_corner', defaults.get('per_corner', False))
    if not isinstance(per_corner, bool):
        errs.add('design.per_corner', f'must be true or false, got {per_corner!r}')
        per_corner = False
    if per_corner and vehicle.model != 'full_car':
        errs.add('design.per_corner', 'only the full car has left and right corners')
        per_corner = False
    names = design_names(vehicle, per_corner)
    axle_names = design_names(vehicle, False) if per_corner else ()
    for k in data:
        if k != 'per_corner' and k not in names and k not in axle_names:
            errs.add(
                f'design.{k}',
                'unknown key'
                + _did_you_mean(k, names)
                + f' (design variables of this car: {", ".join(names)})',
            )
    variables = {}
    for n in names:
        default = dict(zip(('initial', 'lower', 'upper'), DESIGN_DEFAULTS[design_kind(n)]))
        default.update(
            defaults.get(n, defaults.get(n[:4], {})) if per_corner else defaults.get(n, {})
        )
        given = data.get(n, {})
        if per_corner and not given:  # a corner's variable defaults to its axle's
            given = data.get(n[:4], {})
        variables[n] = _parse_dataclass(
            DesignVariable,
            {**default, **given} if isinstance(given, dict) else given,
            f'design.{n}',
            errs,
        )
    return DesignConfig(per_corner=per_corner, variables=variables)


def _parse_named(
    data: Any, terms: tuple[str, ...], key: str, errs: _Errors, missing: float | None
) -> dict[str, float]:
    """A table of numbers by objective term, or a list in term order."""
    if isinstance(data, (list, tuple)):
        if len(data) != len(terms):
            errs.add(key, f'needs {len(terms)} values ({", ".join(terms)}), got {len(data)}')
            return {}
        data = dict(zip(terms, data))
    if not isinstance(data, dict):
        errs.add(key, f'must be a table by term ({", ".join(terms)}) or a list, got {data!r}')
        return {}
    out = {}
    for k, v in data.items():
        if k not in terms:
            errs.add(
                f'{key}.{k}',
                'unknown term'
                + _did_you_mean(k, terms)
                + f' (terms of this car: {", ".join(terms)})',
            )
        elif not _is_number(v) or not math.isfinite(v):
            errs.add(f'{key}.{k}', f'must be a finite number, got {v!r}')
        else:
            out[k] = float(v)
    if missing is not None:
        out = {t: out.get(t, missing) for t in terms}
    return out


def config_from_dict(data: dict[str, Any], base_dir: str | Path | None = None) -> StudyConfig:
    """Parse and validate a study description (partial: missing keys take the defaults of
    its vehicle model). ``base_dir`` resolves relative file paths (road CSV, mechanism
    files). Raises :class:`ConfigError` listing every problem."""
    errs = _Errors()
    if not isinstance(data, dict):
        raise ConfigError(f'a study description must be a table, got {type(data).__name__}')
    model = (
        (data.get('vehicle') or {}).get('model', 'half_car')
        if isinstance(data.get('vehicle'), dict)
        else 'half_car'
    )
    if model not in MODELS:
        raise ConfigError(
            f'vehicle.model: must be one of {", ".join(MODELS)}, got {model!r}'
            + _did_you_mean(str(model), MODELS)
        )
    defaults = StudyConfig().to_dict()
    if model == 'full_car':
        from suspopt.vehicles import BMW_E90

        defaults = _merge(defaults, BMW_E90)
        defaults['design'] = BMW_E90['design']
        defaults['objective']['weights'] = {}
    full = _merge(defaults, {k: v for k, v in data.items() if k not in ('design',)})
    for key in ('road',):
        if isinstance(data.get(key), dict):
            full[key] = dict(data[key])  # a road table replaces the default, not merges
    design_data = data.get('design', {})
    objective = full.get('objective', {})
    weights_data = objective.pop('weights', None) if isinstance(objective, dict) else None
    scales_data = objective.pop('scales', None) if isinstance(objective, dict) else None
    cfg = _parse_dataclass(StudyConfig, {k: v for k, v in full.items() if k != 'design'}, '', errs)
    design = _parse_design(
        design_data if design_data is not None else {}, cfg.vehicle, errs, defaults['design']
    )
    terms = objective_terms(cfg.vehicle.layout()) if _layout_ok(cfg.vehicle) else ()
    weights = (
        _parse_named(weights_data, terms, 'objective.weights', errs, 0.0)
        if weights_data not in (None, {})
        else default_weights(cfg.vehicle.layout())
        if terms
        else {}
    )
    scales = (
        _parse_named(scales_data, terms, 'objective.scales', errs, None)
        if scales_data not in (None, {}, [])
        else {}
    )
    cfg = dataclasses.replace(
        cfg,
        design=design,
        objective=dataclasses.replace(cfg.objective, weights=weights, scales=scales),
    )
    cfg = _resolve_paths(cfg, base_dir)
    errs.extend(_semantic_checks(cfg, sized=not errs))
    if errs:
        raise ConfigError(list(errs))
    # canonical road descriptions: the profile with all of its parameters
    return dataclasses.replace(
        cfg,
        road=_canonical_road(cfg.road),
        scenario=tuple(
            dataclasses.replace(s, road=_canonical_road(s.road) if s.road else {})
            for s in cfg.scenario
        ),
    )


def _layout_ok(v: VehicleConfig) -> bool:
    return v.model in MODELS


def _canonical_road(road: dict[str, Any]) -> dict[str, Any]:
    if road.get('profile') == TWO_TRACKS:
        return {
            'profile': TWO_TRACKS,
            'left': _canonical_road(road['left']),
            'right': _canonical_road(road['right']),
        }
    return make_road(_typed_road(road)).to_dict()


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

    def fix_road(road: dict[str, Any]) -> dict[str, Any]:
        road = dict(road)
        if road.get('profile') == TWO_TRACKS:
            for side in ('left', 'right'):
                if isinstance(road.get(side), dict):
                    road[side] = fix_road(road[side])
        if road.get('profile') == 'csv' and isinstance(road.get('file'), str) and road['file']:
            road['file'] = fix(road['file'])
        return road

    vehicle = cfg.vehicle
    for axle in ('front', 'rear'):
        ax = getattr(vehicle, axle)
        if ax.mechanism and ax.mechanism not in builtin_mechanisms():
            vehicle = dataclasses.replace(
                vehicle, **{axle: dataclasses.replace(ax, mechanism=fix(ax.mechanism))}
            )
    return dataclasses.replace(
        cfg,
        vehicle=vehicle,
        road=fix_road(cfg.road),
        scenario=tuple(
            dataclasses.replace(s, road=fix_road(s.road) if s.road else {}) for s in cfg.scenario
        ),
    )


def _semantic_checks(cfg: StudyConfig, sized: bool = True) -> list[str]:
    """Problems across keys; with ``sized`` (every value read), the grid and NLP size
    too (not with values already refused: their messages would repeat the cause)."""
    errs = _Errors()
    v = cfg.vehicle
    if math.isfinite(v.wheelbase) and v.wheelbase <= 0.0:
        errs.add(
            'vehicle.front.axle_position',
            f'must be ahead of vehicle.rear.axle_position '
            f'({v.front.axle_position:g} <= {v.rear.axle_position:g})',
        )
    for axle in ('front', 'rear'):
        ax = getattr(v, axle)
        if v.model == 'full_car':
            if not ax.track > 0.0:
                errs.add(f'vehicle.{axle}.track', f'must be > 0 (full car), got {ax.track:g}')
        else:
            if ax.track != 0.0:
                errs.add(
                    f'vehicle.{axle}.track',
                    "only the full car has a track width (vehicle.model = 'full_car')",
                )
            if ax.anti_roll_bar:
                errs.add(
                    f'vehicle.{axle}.anti_roll_bar',
                    'a half car has no left and right '
                    "wheels to couple (vehicle.model = 'full_car')",
                )
    if v.model == 'full_car' and not v.chassis_roll_inertia > 0.0:
        errs.add(
            'vehicle.chassis_roll_inertia',
            f'must be > 0 (full car), got {v.chassis_roll_inertia:g}',
        )
    elif v.model != 'full_car' and v.chassis_roll_inertia != 0.0:
        errs.add(
            'vehicle.chassis_roll_inertia', "only the full car rolls (vehicle.model = 'full_car')"
        )
    for name, dv in cfg.design.variables.items():
        key = f'design.{name}'
        vals = (dv.initial, dv.lower, dv.upper)
        if not all(math.isfinite(x) for x in vals):
            continue
        limit = DESIGN_LIMITS[design_kind(name)]
        for which, x in (('initial', dv.initial), ('lower', dv.lower), ('upper', dv.upper)):
            if x > limit:
                errs.add(
                    f'{key}.{which}',
                    f'{x:g} {DESIGN_UNITS[design_kind(name)]} is '
                    f'implausible for a road vehicle: at most {limit:g} (a typo?)',
                )
        if design_kind(name) == 'k_R':
            if dv.lower < 0.0:
                errs.add(f'{key}.lower', f'must be >= 0 (a bar rate), got {dv.lower:g}')
        elif dv.lower <= 0.0:
            errs.add(f'{key}.lower', f'must be > 0 (a rate or damping), got {dv.lower:g}')
        if dv.lower > dv.upper:
            errs.add(f'{key}.lower', f'lower bound {dv.lower:g} is above upper bound {dv.upper:g}')
        elif not dv.lower <= dv.initial <= dv.upper:
            errs.add(
                f'{key}.initial',
                f'{dv.initial:g} is outside the bounds [{dv.lower:g}, {dv.upper:g}]',
            )
    obj = cfg.objective
    w = list(obj.weights.values())
    if w and (any(x < 0.0 for x in w) or not any(x > 0.0 for x in w)):
        errs.add('objective.weights', f'must be >= 0 and not all zero, got {obj.weights}')
    if obj.normalization not in NORMALIZATIONS:
        errs.add(
            'objective.normalization',
            f'must be one of {", ".join(NORMALIZATIONS)}, got '
            f'{obj.normalization!r}{_did_you_mean(obj.normalization, NORMALIZATIONS)}',
        )
    terms = cfg.terms() if _layout_ok(v) else ()
    if obj.normalization == 'custom':
        if set(obj.scales) != set(terms) or any(not s > 0.0 for s in obj.scales.values()):
            errs.add(
                'objective.scales',
                f'custom normalization needs a positive scale for '
                f'each term ({", ".join(terms)}), got {obj.scales}',
            )
    elif obj.scales:
        errs.add('objective.scales', "only used with normalization = 'custom'")
    if obj.normalization == 'paper' and v.model != 'half_car':
        errs.add(
            'objective.normalization',
            "the paper's scales are for the half car's four terms; use 'reference' or 'custom'",
        )
    if obj.aggregate not in AGGREGATES:
        errs.add(
            'objective.aggregate',
            f'must be one of {", ".join(AGGREGATES)}, got '
            f'{obj.aggregate!r}{_did_you_mean(obj.aggregate, AGGREGATES)}',
        )
    tr = cfg.transcription
    if 0 < tr.order < 2:  # Radau with one point per segment degenerates (order <= 0: above)
        errs.add('transcription.order', f'must be >= 2 (Radau points per segment), got {tr.order}')
    errs.extend(_segments_check(tr.segments, 'transcription.segments'))
    op = cfg.optimizer
    if not 0 <= op.print_level <= 12:
        errs.add('optimizer.print_level', f'must be 0..12 (IPOPT), got {op.print_level}')
    if op.options:  # checked on IPOPT itself (the driver's imports: only when needed)
        from suspopt.driver import ipopt_option_problems

        errs.extend(f'optimizer.options.{p}' for p in ipopt_option_problems(op.options))
    if tr.initial_guess not in ('auto', 'simulate', 'zero'):
        errs.add(
            'transcription.initial_guess',
            f"must be 'auto', 'simulate' or 'zero', got {tr.initial_guess!r}",
        )
    if cfg.multibody.fd_form not in ('forward', 'central'):
        errs.add(
            'multibody.fd_form', f"must be 'forward' or 'central', got {cfg.multibody.fd_form!r}"
        )
    if cfg.multibody.mount not in MOUNTS:
        errs.add(
            'multibody.mount',
            f'must be one of {", ".join(MOUNTS)}, got '
            f'{cfg.multibody.mount!r}{_did_you_mean(cfg.multibody.mount, MOUNTS)}',
        )
    n_tracks = 2 if v.model == 'full_car' else 1
    errs.extend(_road_checks(cfg.road, 'road', cfg.maneuver.speed * cfg.maneuver.horizon, n_tracks))
    names = set()
    for i, sc in enumerate(cfg.scenario):
        key = f'scenario[{i}]'
        if sc.name in names:
            errs.add(f'{key}.name', f'duplicate scenario name {sc.name!r}')
        names.add(sc.name)
        for fld, limits in (('speed', SPEED_RANGE), ('horizon', HORIZON_RANGE)):
            val = getattr(sc, fld)
            if not (math.isfinite(val) and val >= 0.0):
                errs.add(f'{key}.{fld}', f'must be > 0 (or absent), got {val:g}')
            elif val and (problem := _range_problem(val, limits)):
                errs.add(f'{key}.{fld}', problem)
        if not (math.isfinite(sc.weight) and sc.weight > 0.0):
            errs.add(f'{key}.weight', f'must be > 0, got {sc.weight:g}')
        if sc.order and sc.order < 2:
            errs.add(f'{key}.order', f'must be >= 2, got {sc.order}')
        if sc.segments:
            errs.extend(_segments_check(sc.segments, f'{key}.segments'))
        if sc.road:
            length = (sc.speed or cfg.maneuver.speed) * (sc.horizon or cfg.maneuver.horizon)
            errs.extend(_road_checks(sc.road, f'{key}.road', length, n_tracks))
    errs.extend(_mechanism_checks(cfg))
    if not errs and sized:
        errs.extend(_size_checks(cfg))
    return list(errs)


def _segments_check(segments: Any, key: str) -> list[str]:
    if segments == 'auto':
        return []
    if isinstance(segments, bool) or not isinstance(segments, int):
        return [f'{key}: must be an integer or "auto", got {segments!r}']
    if segments <= 0:
        return [f'{key}: must be > 0, got {segments}']
    return []


def _size_checks(cfg: StudyConfig) -> list[str]:
    """Refuse a grid that cannot represent the motion (too few nodes per period of the
    wheel hop or the road, :func:`~suspopt.transcription.grid.grid_problems`) and an NLP
    too large to build (a resource estimate), before any work."""
    from suspopt.transcription.grid import grid_problems, nlp_size

    errs = []
    try:
        scenarios = cfg.scenarios()
    except ConfigError as err:
        return err.problems
    sizes = []
    for i, sc in enumerate(scenarios):
        own = cfg.scenario[i].segments if cfg.scenario else 0
        key = f'scenario[{i}].segments' if own else 'transcription.segments'
        if (own or cfg.transcription.segments) != 'auto':
            errs.extend(
                grid_problems(
                    cfg, sc, key if not cfg.scenario or own else f'{key} (scenario {sc.name!r})'
                )
            )
        sizes.append((nlp_size(cfg, sc), sc, key))
    total = sum(n for n, _, _ in sizes)
    if total > MAX_NLP_VARIABLES:
        n, sc, key = max(sizes, key=lambda x: x[0])
        everything = f' ({total:.3g} with all scenarios)' if len(sizes) > 1 else ''
        errs.append(
            f'{key}: {sc.segments} segments of order {sc.order} over {sc.horizon:g} s '
            f'make {n:.3g} NLP variables{everything}, at most {MAX_NLP_VARIABLES:.3g} '
            'can be built in reasonable time and memory; check maneuver.horizon and '
            'the grid'
        )
    return errs


def _road_checks(road: dict[str, Any], where: str, length: float, n_tracks: int) -> list[str]:
    errs = _Errors()
    if not isinstance(road, dict):
        return [f'{where}: must be a table, got {road!r}']
    kind = road.get('profile', 'two_bumps')
    if not isinstance(kind, str):
        return [f'{where}.profile: must be a string (a profile name), got {kind!r}']
    if kind == TWO_TRACKS:
        if n_tracks != 2:
            return [
                f'{where}.profile: {TWO_TRACKS} needs a car with two wheel tracks '
                "(vehicle.model = 'full_car')"
            ]
        for k in road:
            if k not in ('profile', 'left', 'right'):
                errs.add(f'{where}.{k}', f'unknown key for profile {TWO_TRACKS!r} (left, right)')
        for side in ('left', 'right'):
            if not isinstance(road.get(side), dict):
                errs.add(f'{where}.{side}', 'missing table (a road profile)')
            else:
                errs.extend(_road_checks(road[side], f'{where}.{side}', length, 1))
        if not errs:
            from suspopt.road import CSVRoad

            ends = []
            for side in ('left', 'right'):
                r = make_road(_typed_road(road[side]))
                if isinstance(r, CSVRoad):
                    ends.append((side, float(r._data()[0][-1])))
            if len(ends) == 2 and abs(ends[0][1] - ends[1][1]) > 1e-9:
                errs.add(
                    f'{where}.right.file',
                    f'the tracks have different lengths: left ends '
                    f'at {ends[0][1]:g} m, right at {ends[1][1]:g} m',
                )
        return list(errs)
    if kind not in PROFILES:
        errs.add(
            f'{where}.profile',
            f'unknown profile {kind!r}'
            f'{_did_you_mean(str(kind), list(PROFILES) + [TWO_TRACKS])} '
            f'(built-in: {", ".join(list(PROFILES) + [TWO_TRACKS])})',
        )
        return list(errs)
    allowed = profile_fields(kind)
    sub = _Errors()
    params = {}
    for k, val in road.items():
        if k == 'profile':
            continue
        if k not in allowed:
            sub.add(f'{where}.{k}', f'unknown key for profile {kind!r}' + _did_you_mean(k, allowed))
            continue
        default = allowed[k]
        if isinstance(default, tuple):
            params[k] = _parse_value(tuple[float, ...], val, f'{where}.{k}', sub, {})
        elif isinstance(default, bool):
            params[k] = _parse_value(bool, val, f'{where}.{k}', sub, {})
        elif isinstance(default, int):
            params[k] = _parse_value(int, val, f'{where}.{k}', sub, {})
        elif isinstance(default, float):
            params[k] = _parse_value(float, val, f'{where}.{k}', sub, {})
        else:
            params[k] = _parse_value(str, val, f'{where}.{k}', sub, {})
    if kind == 'csv' and not road.get('file'):
        sub.add(f'{where}.file', 'missing value (path of a distance,height CSV)')
    if sub:
        return list(sub)
    return make_road(_typed_road({'profile': kind, **params})).validate(length, where)


#: a wheel rate below this fraction of the spring rate at the reference pose is zero:
#: the linkage barely moves the spring (motion ratio below 0.03)
WHEEL_RATE_FLOOR = 1e-3


#: _mechanism_standing's answers by (name, file content): a sweep validates the same
#: mechanism for every task (a memo of a function of the file alone)
_STANDING: dict[tuple[str, bytes], Any] = {}


def _mechanism_standing(name: str) -> tuple[float, float, float, str] | list[str]:
    """``(a, b, MR, spring)`` of :func:`reference_wheel_rate` for mechanism ``name``, or
    the problems of its file."""
    from suspopt.multibody.kinematics import reference_wheel_rate
    from suspopt.multibody.mechanism import load_mechanism, mechanism_path
    from suspopt.multibody.solver import PlanarMultibodySolver

    try:
        memo = (name, mechanism_path(name).read_bytes())
    except OSError:  # load_mechanism names the problem
        memo = None
    if memo in _STANDING:
        return _STANDING[memo]
    try:
        mech = load_mechanism(name, suspension=True)
        out: Any = (*reference_wheel_rate(mech, PlanarMultibodySolver(mech)), mech.roles['spring'])
    except ConfigError as err:
        out = err.problems
    if memo is not None:
        if len(_STANDING) >= 64:
            _STANDING.clear()
        _STANDING[memo] = out
    return out


def _mechanism_checks(cfg: StudyConfig) -> list[str]:
    """Every mechanism loads, passes its travel range, and stands: a positive wheel rate at
    the reference pose for every spring rate of its axle's design range."""
    from suspopt.multibody.mechanism import mechanism_path

    errs = []
    seen: dict[str, Any] = {}
    for i, axle in enumerate(('front', 'rear')):
        name = getattr(cfg.vehicle, axle).mechanism
        key = f'vehicle.{axle}.mechanism'
        if name not in seen:
            seen[name] = _mechanism_standing(name)
        if isinstance(seen[name], list):
            errs.extend(f'{key}: {m}' for m in seen[name])
            continue
        a, b, mr, spring = seen[name]
        ks = [n for n in cfg.design.names if design_kind(n) == 'k_S' and n[3] == str(i + 1)]
        for n in ks:
            dv = cfg.design[n]
            bad = [
                k
                for k in (dv.lower, dv.upper)
                if math.isfinite(k) and not a * k + b > WHEEL_RATE_FLOOR * k
            ]
            if bad:
                why = (
                    'the spring does not deflect with the wheel travel'
                    if abs(mr) < 0.03
                    else 'the other springs make it unstable'
                )
                rate, mr = a * bad[0] + b + 0.0, mr + 0.0  # no "-0"
                errs.append(
                    f'{key}: {mechanism_path(name)}: suspension.spring: wheel rate '
                    f'{rate:.4g} N/m at the reference pose for {n} = {bad[0]:g} N/m '
                    f'(motion ratio {mr:.3g}; {why}): the linkage is statically '
                    'unstable; it needs a positive wheel rate over '
                    f'[{dv.lower:g}, {dv.upper:g}] (force {spring!r})'
                )
                break
    return errs


def load_config(path: str | Path) -> StudyConfig:
    """Read and validate a study TOML file. Raises :class:`ConfigError`."""
    path = Path(path)
    try:
        with path.open('rb') as fh:
            data = tomllib.load(fh)
    except FileNotFoundError:
        raise ConfigError(f'config file not found: {path}') from None
    except IsADirectoryError:
        raise ConfigError(f'config file {path} is a directory') from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
        raise ConfigError(f'{path}: not valid TOML: {err}') from None
    except OSError as err:
        raise ConfigError(f'cannot read config file {path}: {err.strerror}') from None
    try:
        return config_from_dict(data, base_dir=path.parent)
    except ConfigError as err:
        raise ConfigError([f'{path}: {p}' for p in err.problems]) from None
