"""Reading a study description: TOML or a plain dictionary to the schema
(:mod:`suspopt.spec.schema`), every problem reported at once, one line per problem naming
its key, as a :class:`~suspopt.errors.ConfigError` (exit code 2 on the command line).

A missing key takes the value of its vehicle model's default car (the paper's half car,
or :func:`full_car_defaults`); relative file paths (road CSV, mechanism files) are resolved
against the file's folder; the checks across keys run once every value is read
(:mod:`suspopt.spec.checks`)."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import suspopt.spec.hardware as hardware
from suspopt.errors import ConfigError
from suspopt.inputs import read_toml
from suspopt.models.design import GAIN_KINDS, design_id, design_kind
from suspopt.models.metrics import term_groups
from suspopt.road import TWO_TRACKS
from suspopt.spec.checks import canonical_road, layout_ok, semantic_checks
from suspopt.spec.schema import (
    CONTROL_KINDS,
    DESIGN_DEFAULTS,
    MODELS,
    ControlConfig,
    DesignConfig,
    DesignVariable,
    StudyConfig,
    VehicleConfig,
    default_weights,
    design_names,
)
from suspopt.spec.values import Problems, did_you_mean, is_number, parse_dataclass
from suspopt.spec.vehicles import BMW_E90, QUARTER_CAR


def full_car_defaults() -> StudyConfig:
    """The default full car: a BMW E90 (330i, 2006) as Chrono::Vehicle models it
    (``src/chrono_models/vehicle/bmw/``, data credited there to SAE 2007-01-0817/-0818):
    sprung mass, roll and pitch inertia, CG position, tracks, tyre rate; spring and damper
    rates of its front MacPherson and rear double wishbone as wheel rates; anti-roll bars.
    Driven over an ISO 8608 class C road (isotropic left/right coherence) at 20 m/s."""
    return config_from_dict(BMW_E90)


#: tables a study file's own replaces (not merged key by key with the default car's)
_TABLE_REPLACED = (
    'road',
    'options',
    'weights',
    'scales',
    'spring_curve',
    'damper_curve',
    'bump_stop',
    'rebound_stop',
)

#: the default car of each vehicle model besides the paper's half car (the schema's)
MODEL_DEFAULTS: dict[str, dict[str, Any]] = {'full_car': BMW_E90, 'quarter_car': QUARTER_CAR}


def _model_problems(model: str, data: dict[str, Any]) -> list[str]:
    """Keys the vehicle model has no use for: a quarter car has one corner (``front``) at
    its centre of mass and does not pitch."""
    vehicle = data.get('vehicle')
    if model != 'quarter_car' or not isinstance(vehicle, dict):
        return []
    out = []
    # a written quarter car (StudyConfig.to_dict) carries the defaults of both: accepted
    written = StudyConfig().to_dict()['vehicle']
    if 'rear' in vehicle and vehicle['rear'] != written['rear']:
        out.append('vehicle.rear: a quarter car has one corner (vehicle.front)')
    if vehicle.get('chassis_pitch_inertia', 0.0) != 0.0:
        out.append('vehicle.chassis_pitch_inertia: a quarter car does not pitch')
    return out


def _enable_given_constraints(full: dict[str, Any], data: dict[str, Any]) -> None:
    """A constraint applies when its table is given (``enabled`` unless the table says)."""
    given = data.get('constraints')
    if not isinstance(given, dict):
        return
    for name, table in given.items():
        target = full.get('constraints', {}).get(name)
        if isinstance(table, dict) and isinstance(target, dict) and 'enabled' not in table:
            target['enabled'] = True


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
    data: Any,
    vehicle: VehicleConfig,
    errs: Problems,
    defaults: dict[str, Any] | None = None,
    constraints: Any = None,
    control: ControlConfig | None = None,
) -> DesignConfig:
    """The design table; a variable not given takes the default car's entry
    (``defaults``) or the kind's default (:data:`DESIGN_DEFAULTS`). A curve parameter's
    variable (``c_bump_low_1``, :mod:`suspopt.spec.hardware`) exists when named; its
    initial value defaults to the hardware's, its bounds to
    :func:`~suspopt.spec.hardware.default_bounds`. A feedback ``control``'s gains are
    design variables too."""
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
    base = design_names(vehicle, per_corner, control)
    curves = hardware.curve_variable_names(vehicle, per_corner, data)
    last = ('k_R', *GAIN_KINDS)  # the bars' rates, then the feedback gains, after the curves
    names = tuple(n for n in base if design_kind(n) not in last) + curves
    names += tuple(n for k in last for n in base if design_kind(n) == k)
    axle_names = design_names(vehicle, False, control) if per_corner else ()
    allowed = (
        set(names) | set(axle_names) | set(hardware.allowed_curve_variables(vehicle, per_corner))
    )
    for k in data:
        if k != 'per_corner' and k not in allowed:
            errs.add(f'design.{k}', _unknown_design(k, vehicle, names, allowed))
    hardware_values = {a: hardware.curve_defaults(ax) for a, ax in enumerate(vehicle.axles)}
    travels: dict[int, tuple[float, float] | None] = {}
    variables = {}
    for n in names:
        d = design_id(n)
        default: dict[str, Any]
        own = hardware_values[d.axle].get(d.kind.symbol)
        if d.kind.slot:  # a curve parameter: the hardware's value, bounds around it
            if d.axle not in travels and constraints is not None:
                travels[d.axle] = hardware.axle_travel(vehicle, constraints, d.axle)
            lower, upper = hardware.default_bounds(d.kind.symbol, own or 0.0, travels.get(d.axle))
            default = {'initial': own, 'lower': lower, 'upper': upper}
        else:
            default = dict(zip(('initial', 'lower', 'upper'), DESIGN_DEFAULTS[d.kind.symbol]))
            default.update(
                defaults.get(n, defaults.get(d.axle_name, {}))
                if per_corner
                else defaults.get(n, {})
            )
            if own is not None:  # a polynomial spring's rate: its first coefficient
                default['initial'] = own
        given = data.get(n, {})
        if per_corner and not given:  # a corner's variable defaults to its axle's
            given = data.get(d.axle_name, {})
        variables[n] = parse_dataclass(
            DesignVariable,
            {**default, **given} if isinstance(given, dict) else given,
            f'design.{n}',
            errs,
        )
    return DesignConfig(per_corner=per_corner, variables=variables)


def _unknown_design(
    key: str, vehicle: VehicleConfig, names: tuple[str, ...], allowed: set[str]
) -> str:
    """Why ``key`` is no design variable of this car (and what is)."""
    try:
        d = design_id(key)
    except ValueError:
        d = None
    if d is not None and d.axle < len(vehicle.axles):
        ax, where = vehicle.axles[d.axle], hardware.axle_key(d.axle)
        if d.kind.symbol == 'c_S' and not ax.has_linear_damper:
            return (
                f'the damper of {where} is a curve ({where}.damper_curve): its parameters '
                'are the design variables ('
                + ', '.join(
                    n for n in sorted(allowed) if n.startswith(('c_bump', 'c_rebound', 'v_'))
                )
                + ')'
            )
        if d.kind.symbol == 'k_S' and not ax.has_spring_rate:
            return f'the spring of {where} is a table ({where}.spring_curve): it has no rate k_S'
        if d.kind.slot and d.kind.symbol not in hardware.curve_parameters(ax):
            return (
                f'{where} has no curve parameter {d.kind.symbol!r} (its curves: '
                + (', '.join(hardware.curve_parameters(ax)) or f'none; give {where}.{d.kind.slot}')
                + ')'
            )
    return (
        'unknown key'
        + did_you_mean(key, sorted(allowed))
        + f' (design variables of this car: {", ".join(names)})'
    )


def _paper_terms(terms: tuple[str, ...]) -> tuple[str, ...]:
    """The terms of the paper's eq. 4 among ``terms``: the chassis' and the wheels'."""
    return tuple(t for t in terms if t in ('heave', 'pitch', 'roll') or t.startswith('wheel_'))


def _parse_weights(data: Any, terms: tuple[str, ...], errs: Problems) -> dict[str, float]:
    """The objective weights by term; a list in term order (every term, or the paper's
    terms: the chassis' and the wheels'); or by group: a group's weight (``tyre_load =
    0.5``) is split equally among its terms (every corner's ``tyre_load_<c>``), and a term
    named on its own takes its own weight."""
    paper = _paper_terms(terms)
    if isinstance(data, (list, tuple)):
        if len(data) not in (len(paper), len(terms)):
            errs.add(
                'objective.weights',
                f"needs {len(paper)} values (the paper's terms: {', '.join(paper)}) or "
                f'{len(terms)} (every term: {", ".join(terms)}), got {len(data)}',
            )
            return {}
        data = dict(zip(paper if len(data) == len(paper) else terms, data))
    groups = term_groups(terms) if isinstance(data, dict) else {}
    if groups:
        expanded: dict[str, Any] = {}
        for k, v in data.items():
            if k in groups and is_number(v):
                expanded.update({t: v / len(groups[k]) for t in groups[k]})
        expanded.update({k: v for k, v in data.items() if k not in groups})
        data = expanded
    return _parse_named(data, terms, 'objective.weights', errs, 0.0, groups=tuple(groups))


def _parse_named(
    data: Any,
    terms: tuple[str, ...],
    key: str,
    errs: Problems,
    missing: float | None,
    groups: tuple[str, ...] = (),
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
                + did_you_mean(k, terms + groups)
                + f' (terms of this car: {", ".join(terms)}'
                + (f'; groups: {", ".join(groups)}' if groups else '')
                + ')',
            )
        elif not is_number(v) or not math.isfinite(v):
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
    errs = Problems()
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
            + did_you_mean(str(model), MODELS)
        )
    defaults = StudyConfig().to_dict()
    car = MODEL_DEFAULTS.get(model)
    if car is not None:
        defaults = _merge(defaults, car)
        defaults['design'] = car['design']
        defaults['objective']['weights'] = car.get('objective', {}).get('weights', {})
    errs.extend(_model_problems(model, data))
    full = _merge(defaults, {k: v for k, v in data.items() if k not in ('design',)})
    _enable_given_constraints(full, data)
    for key in ('road',):
        if isinstance(data.get(key), dict):
            full[key] = dict(data[key])  # a road table replaces the default, not merges
    design_data = data.get('design', {})
    objective = full.get('objective', {})
    weights_data = objective.pop('weights', None) if isinstance(objective, dict) else None
    scales_data = objective.pop('scales', None) if isinstance(objective, dict) else None
    cfg = parse_dataclass(StudyConfig, {k: v for k, v in full.items() if k != 'design'}, '', errs)
    design = _parse_design(
        design_data if design_data is not None else {},
        cfg.vehicle,
        errs,
        defaults['design'],
        cfg.constraints,
        cfg.control if cfg.control.kind in CONTROL_KINDS else None,
    )
    terms = cfg.terms() if layout_ok(cfg.vehicle) else ()
    weights = (
        _parse_weights(weights_data, terms, errs)
        if weights_data not in (None, {})
        else default_weights(cfg.vehicle.layout())
        if terms
        else {}
    )
    weighted = tuple(t for t in terms if weights.get(t, 0.0) > 0.0)
    scales = (  # a list: the weighted terms' scales, in term order
        _parse_named(
            scales_data,
            weighted if isinstance(scales_data, list) else terms,
            'objective.scales',
            errs,
            None,
        )
        if scales_data not in (None, {}, [])
        else {}
    )
    cfg = dataclasses.replace(
        cfg,
        design=design,
        objective=dataclasses.replace(cfg.objective, weights=weights, scales=scales),
    )
    cfg = _resolve_paths(cfg, base_dir)
    errs.extend(semantic_checks(cfg, sized=not errs))
    if errs:
        raise ConfigError(list(errs))
    # canonical road descriptions: the profile with all of its parameters
    return dataclasses.replace(
        cfg,
        road=canonical_road(cfg.road),
        scenario=tuple(
            dataclasses.replace(s, road=canonical_road(s.road) if s.road else {})
            for s in cfg.scenario
        ),
    )


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


def load_config(path: str | Path) -> StudyConfig:
    """Read and validate a study TOML file (:func:`suspopt.inputs.read_toml`: one line
    naming the file for a missing, unreadable, non-UTF-8 or invalid one). Raises
    :class:`ConfigError`."""
    data = read_toml(path, 'config file')
    try:
        return config_from_dict(data, base_dir=Path(path).parent)
    except ConfigError as err:
        raise ConfigError([f'{path}: {p}' for p in err.problems]) from None
