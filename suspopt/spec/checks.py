"""The checks across keys of a study description, run once every value is read: the car's
geometry, the design box, the objective, the roads, the mechanisms (each loads and stands:
a positive wheel rate over its design range), the grid and the NLP's size. Each problem is
one line naming its key."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

import suspopt.spec.hardware as hardware
from suspopt.errors import ConfigError
from suspopt.models.design import DESIGN_UNITS, design_id, design_kind
from suspopt.road import PROFILES, TWO_TRACKS, CSVRoad, make_road, profile_fields
from suspopt.road.profiles import MAX_FEATURE_HEIGHT
from suspopt.spec.schema import (
    AGGREGATES,
    CONTROL_KINDS,
    CONTROL_LAWS,
    HESSIANS,
    HORIZON_RANGE,
    MAX_NLP_VARIABLES,
    MODELS,
    MOUNTS,
    NORMALIZATIONS,
    SPEED_RANGE,
    ControlConfig,
    StudyConfig,
    VehicleConfig,
    design_limit,
)
from suspopt.spec.values import Problems, did_you_mean, is_number, parse_value, range_problem


def layout_ok(v: VehicleConfig) -> bool:
    return v.model in MODELS


def canonical_road(road: dict[str, Any]) -> dict[str, Any]:
    if road.get('profile') == TWO_TRACKS:
        return {
            'profile': TWO_TRACKS,
            'left': canonical_road(road['left']),
            'right': canonical_road(road['right']),
        }
    return make_road(typed_road(road)).to_dict()


def typed_road(road: dict[str, Any]) -> dict[str, Any]:
    """The road table with ints promoted to floats where the profile expects floats."""
    kind = road.get('profile', 'two_bumps')
    fields = profile_fields(kind)
    out = {'profile': kind}
    for k, v in road.items():
        if k != 'profile':
            out[k] = float(v) if isinstance(fields.get(k), float) and is_number(v) else v
    return out


def semantic_checks(cfg: StudyConfig, sized: bool = True) -> list[str]:
    """Problems across keys; with ``sized`` (every value read), the grid and NLP size
    too (not with values already refused: their messages would repeat the cause)."""
    errs = Problems()
    errs.extend(_vehicle_checks(cfg.vehicle))
    errs.extend(_design_checks(cfg))
    errs.extend(_hardware_checks(cfg))
    errs.extend(_objective_checks(cfg))
    errs.extend(_comfort_checks(cfg))
    errs.extend(_constraint_checks(cfg))
    errs.extend(_control_checks(cfg))
    errs.extend(_numerics_checks(cfg))
    n_tracks = cfg.layout().n_tracks if layout_ok(cfg.vehicle) else 1
    errs.extend(_road_checks(cfg.road, 'road', cfg.maneuver.speed * cfg.maneuver.horizon, n_tracks))
    errs.extend(_scenario_checks(cfg, n_tracks))
    errs.extend(_mechanism_checks(cfg))
    if not errs and sized:
        errs.extend(_size_checks(cfg))
    return list(errs)


def _vehicle_checks(v: VehicleConfig) -> list[str]:
    errs = Problems()
    axles = ('front',) if v.model == 'quarter_car' else ('front', 'rear')
    if v.model == 'quarter_car':
        if v.front.axle_position != 0.0:
            errs.add(
                'vehicle.front.axle_position',
                "a quarter car's wheel is under its centre "
                f'of mass (0), got {v.front.axle_position:g}',
            )
    elif math.isfinite(v.wheelbase) and v.wheelbase <= 0.0:
        errs.add(
            'vehicle.front.axle_position',
            f'must be ahead of vehicle.rear.axle_position '
            f'({v.front.axle_position:g} <= {v.rear.axle_position:g})',
        )
    for axle in axles:
        ax = getattr(v, axle)
        if v.model == 'full_car':
            if not ax.track > 0.0:
                errs.add(f'vehicle.{axle}.track', f'must be > 0 (full car), got {ax.track:g}')
            continue
        if ax.track != 0.0:
            errs.add(
                f'vehicle.{axle}.track',
                "only the full car has a track width (vehicle.model = 'full_car')",
            )
        if ax.anti_roll_bar:
            errs.add(
                f'vehicle.{axle}.anti_roll_bar',
                f'a {v.model.replace("_", " ")} has no left and right '
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
    if v.model != 'quarter_car' and not v.chassis_pitch_inertia > 0.0:
        errs.add('vehicle.chassis_pitch_inertia', f'must be > 0, got {v.chassis_pitch_inertia:g}')
    return list(errs)


def _design_checks(cfg: StudyConfig) -> list[str]:
    errs = Problems()
    for name, dv in cfg.design.variables.items():
        key = f'design.{name}'
        vals = (dv.initial, dv.lower, dv.upper)
        if not all(math.isfinite(x) for x in vals):
            continue
        limit = design_limit(name)
        for which, x in (('initial', dv.initial), ('lower', dv.lower), ('upper', dv.upper)):
            if x > limit:
                errs.add(
                    f'{key}.{which}',
                    f'{x:g} {DESIGN_UNITS[design_kind(name)]} is '
                    f'implausible for a road vehicle: at most {limit:g} (a typo?)',
                )
        kind = design_kind(name)
        if kind in ('g_tr', 'g_rt'):  # a feedback gain on travel or its rate: either sign
            if max(abs(dv.lower), abs(dv.upper)) > limit:
                errs.add(f'{key}.lower', f'magnitudes up to {limit:g} are plausible (a typo?)')
        elif kind in ('k_R', 'g_sky', 'g_gnd'):
            if dv.lower < 0.0:
                what = 'a bar rate' if kind == 'k_R' else 'a skyhook or groundhook gain'
                errs.add(f'{key}.lower', f'must be >= 0 ({what}), got {dv.lower:g}')
        elif design_id(name).kind.slot:
            pass  # a curve parameter: the hardware's own checks (_hardware_checks)
        elif dv.lower <= 0.0:
            errs.add(f'{key}.lower', f'must be > 0 (a rate or damping), got {dv.lower:g}')
        if dv.lower > dv.upper:
            errs.add(f'{key}.lower', f'lower bound {dv.lower:g} is above upper bound {dv.upper:g}')
        elif not dv.lower <= dv.initial <= dv.upper:
            errs.add(
                f'{key}.initial',
                f'{dv.initial:g} is outside the bounds [{dv.lower:g}, {dv.upper:g}]',
            )
    return list(errs)


def _hardware_checks(cfg: StudyConfig) -> list[str]:
    """Each axle's curves read and serve its travel (``docs/nonlinear_hardware.md``:
    negative slopes, tables not increasing or not through zero, a stop's gap beyond the
    travel ...), and so do they at every bound and initial value of their parameters'
    design variables (a polynomial spring's rate ``k_S`` included)."""
    errs = Problems()
    v = cfg.vehicle
    initial = cfg.design.initial()
    for a in range(1 if v.model == 'quarter_car' else 2):
        ax, key = v.axles[a], hardware.axle_key(a)
        if not ax.has_curves:
            continue
        travel = hardware.axle_travel(v, cfg.constraints, a)
        start = {design_id(n).kind.symbol: x for n, x in initial.items() if design_id(n).axle == a}
        try:
            hardware.build_unit(ax, key, start.get('k_S'), start.get('c_S'), travel)
        except ConfigError as err:
            errs.extend(err.problems)
            continue
        for name, dv in cfg.design.variables.items():
            d = design_id(name)
            polynomial = d.kind.symbol == 'k_S' and 'coefficients' in ax.spring_curve
            if d.axle != a or not (d.kind.slot or polynomial):
                continue
            for which in ('lower', 'initial', 'upper'):
                x = getattr(dv, which)
                if not math.isfinite(x):
                    continue
                found = hardware.unit_problems_at(ax, key, {d.kind.symbol: x}, travel)
                if found:
                    errs.add(f'design.{name}.{which}', f'{x:g} {d.kind.plain} makes {found[0]}')
                    break
    return list(errs)


def _objective_checks(cfg: StudyConfig) -> list[str]:
    errs = Problems()
    obj, v = cfg.objective, cfg.vehicle
    w = list(obj.weights.values())
    if w and (any(x < 0.0 for x in w) or not any(x > 0.0 for x in w)):
        weighted = {t: x for t, x in obj.weights.items() if x}
        errs.add('objective.weights', f'must be >= 0 and not all zero, got {weighted}')
    if obj.normalization not in NORMALIZATIONS:
        errs.add(
            'objective.normalization',
            f'must be one of {", ".join(NORMALIZATIONS)}, got '
            f'{obj.normalization!r}{did_you_mean(obj.normalization, NORMALIZATIONS)}',
        )
    weighted_terms = [t for t, x in obj.weights.items() if x > 0.0]
    if obj.normalization == 'custom':
        missing = [t for t in weighted_terms if not obj.scales.get(t, 0.0) > 0.0]
        if missing:
            errs.add(
                'objective.scales',
                'custom normalization needs a positive scale for every weighted term '
                f'({", ".join(missing)} missing), got {obj.scales}',
            )
    elif obj.scales:
        errs.add('objective.scales', "only used with normalization = 'custom'")
    paper = {'heave', 'pitch', 'wheel_1', 'wheel_2'}
    if obj.normalization == 'paper' and (v.model != 'half_car' or set(weighted_terms) - paper):
        errs.add(
            'objective.normalization',
            "the paper's scales are for the half car's four terms; use 'reference' or 'custom'",
        )
    if obj.aggregate not in AGGREGATES:
        errs.add(
            'objective.aggregate',
            f'must be one of {", ".join(AGGREGATES)}, got '
            f'{obj.aggregate!r}{did_you_mean(obj.aggregate, AGGREGATES)}',
        )
    return list(errs)


def _comfort_checks(cfg: StudyConfig) -> list[str]:
    """Every seat named once and on the chassis: between the axles and within the
    track (full car), on the centre line (half car: it does not roll), at the centre of
    mass (quarter car: it only heaves)."""
    errs = Problems()
    v = cfg.vehicle
    names: set[str] = set()
    for i, seat in enumerate(cfg.comfort.seats):
        key = f'comfort.seats[{i}]'
        if not seat.name.isidentifier():
            errs.add(f'{key}.name', f'must be a name of letters, digits and _, got {seat.name!r}')
        elif seat.name in names:
            errs.add(f'{key}.name', f'duplicate seat name {seat.name!r}')
        names.add(seat.name)
        if v.model == 'quarter_car':
            if seat.x != 0.0 or seat.y != 0.0:
                errs.add(key, 'a quarter car only heaves: its seat is at x = y = 0')
            continue
        a1, a2 = v.front.axle_position, v.rear.axle_position
        if math.isfinite(seat.x) and not a2 <= seat.x <= a1:
            errs.add(
                f'{key}.x',
                f'{seat.x:g} m is outside the chassis: between the rear and '
                f'front axles ({a2:g} to {a1:g} m ahead of the centre of gravity)',
            )
        half = min(v.front.track, v.rear.track) / 2 if v.model == 'full_car' else 0.0
        if math.isfinite(seat.y) and abs(seat.y) > half:
            where = (
                f'within the track (|y| <= {half:g} m)'
                if v.model == 'full_car'
                else 'on the centre line (y = 0: a half car does not roll)'
            )
            errs.add(f'{key}.y', f'{seat.y:g} m is outside the chassis: {where}')
    return list(errs)


def _band(value: tuple[float, ...], key: str, lo: float, hi: float, unit: str) -> list[str]:
    """A [lower, upper] band within [lo, hi]."""
    if not value:
        return []
    if len(value) != 2 or not lo <= value[0] < value[1] <= hi:
        return [
            f'{key}: must be [lower, upper] with {lo:g} <= lower < upper <= {hi:g}{unit}, '
            f'got {list(value)}'
        ]
    return []


def _constraint_checks(cfg: StudyConfig) -> list[str]:
    errs = Problems()
    c, v = cfg.constraints, cfg.vehicle
    if c.travel.enabled and not (c.travel.bump > 0.0 or c.travel.rebound > 0.0):
        errs.add('constraints.travel', 'give the bump and/or rebound travel [m] (> 0)')
    if c.tyre_contact.enabled and not 0.0 <= c.tyre_contact.margin < 1.0:
        errs.add(
            'constraints.tyre_contact.margin',
            'must be in [0, 1) (the share of the static '
            f'load the tyre keeps), got {c.tyre_contact.margin:g}',
        )
    rg = c.roll_gradient
    if rg.enabled:
        if v.model != 'full_car':
            errs.add(
                'constraints.roll_gradient', "only the full car rolls (vehicle.model = 'full_car')"
            )
        elif not v.cg_height > 0.0:
            errs.add(
                'vehicle.cg_height',
                "the roll gradient needs the centre of gravity's height above ground (> 0)",
            )
        for name in ('min', 'max'):
            if getattr(rg, name) < 0.0:
                errs.add(
                    f'constraints.roll_gradient.{name}',
                    f'must be >= 0 deg/g, got {getattr(rg, name):g}',
                )
        if rg.max > 0.0 and rg.min > rg.max:
            errs.add('constraints.roll_gradient.min', f'{rg.min:g} is above max {rg.max:g}')
        if not (rg.min or rg.max or rg.front_share):
            errs.add('constraints.roll_gradient', 'give min, max [deg/g] and/or front_share')
        errs.extend(_band(rg.front_share, 'constraints.roll_gradient.front_share', 0.0, 1.0, ''))
    if not c.stability.margin >= 0.0:
        errs.add(
            'constraints.stability.margin',
            f'must be >= 0 [1/s] (a decay rate), got {c.stability.margin:g}',
        )
    rf = c.ride_frequency
    if rf.enabled:
        if not (rf.heave or rf.pitch):
            errs.add('constraints.ride_frequency', 'give heave and/or pitch [lower, upper] Hz')
        errs.extend(_band(rf.heave, 'constraints.ride_frequency.heave', 0.0, 20.0, ' Hz'))
        errs.extend(_band(rf.pitch, 'constraints.ride_frequency.pitch', 0.0, 20.0, ' Hz'))
        if rf.pitch and v.model == 'quarter_car':
            errs.add('constraints.ride_frequency.pitch', 'a quarter car does not pitch')
    return list(errs)


def _control_checks(cfg: StudyConfig) -> list[str]:
    """The controlled suspension (``docs/codesign.md``): a known kind and law, corners of
    this car, bounds that make sense for the kind."""
    errs = Problems()
    c = cfg.control
    if c.kind not in CONTROL_KINDS:
        errs.add(
            'control.kind',
            f'must be one of {", ".join(CONTROL_KINDS)}, got {c.kind!r}'
            + did_you_mean(c.kind, CONTROL_KINDS),
        )
        return list(errs)
    if c.law not in CONTROL_LAWS:
        errs.add(
            'control.law',
            f'must be one of {", ".join(CONTROL_LAWS)}, got {c.law!r}'
            + did_you_mean(c.law, CONTROL_LAWS),
        )
    given = [
        k
        for k in ('corners', 'force_max', 'power_max', 'c_min', 'c_max', 'force_scale')
        if getattr(c, k) != getattr(ControlConfig(), k)
    ]
    if not c.enabled:
        if given:
            errs.add(
                f'control.{given[0]}',
                "only with a control (control.kind = 'active' or 'semi_active')",
            )
        return list(errs)
    if layout_ok(cfg.vehicle):
        labels = cfg.layout().labels
        unknown = [x for x in c.corners if x not in labels]
        if unknown:
            errs.add(
                'control.corners',
                f'{", ".join(repr(x) for x in unknown)}: no such corner on a '
                f'{cfg.vehicle.model.replace("_", " ")} (its corners: {", ".join(labels)})',
            )
        if len(set(c.corners)) != len(c.corners):
            errs.add('control.corners', f'a corner is named twice: {list(c.corners)}')
    if c.kind == 'semi_active':
        if not c.c_max > 0.0:
            errs.add('control.c_max', f'a semi-active damper needs c_max > 0, got {c.c_max:g}')
        elif c.c_min > c.c_max:
            errs.add(
                'control.c_min', f'{c.c_min:g} N s/m is above control.c_max = {c.c_max:g} N s/m'
            )
        elif c.c_min == c.c_max:
            errs.add('control.c_min', f'equals control.c_max ({c.c_max:g}): nothing to control')
        if c.force_scale:
            errs.add('control.force_scale', "only for an active force (control.kind = 'active')")
    else:  # active
        for k in ('c_min', 'c_max'):
            if getattr(c, k):
                errs.add(f'control.{k}', "only for a semi-active damper (kind = 'semi_active')")
        if c.power_max and not c.force_max:
            errs.add(
                'control.power_max',
                'an active force needs control.force_max too: the power bound |u v| <= '
                'power_max leaves the force unbounded where the relative velocity vanishes '
                '(at rest, at every reversal)',
            )
    return list(errs)


def _numerics_checks(cfg: StudyConfig) -> list[str]:
    errs = Problems()
    tr = cfg.transcription
    if 0 < tr.order < 2:  # Radau with one point per segment degenerates (order <= 0: above)
        errs.add('transcription.order', f'must be >= 2 (Radau points per segment), got {tr.order}')
    errs.extend(_segments_check(tr.segments, 'transcription.segments'))
    op = cfg.optimizer
    if not 0 <= op.print_level <= 12:
        errs.add('optimizer.print_level', f'must be 0..12 (IPOPT), got {op.print_level}')
    if op.hessian not in HESSIANS:
        errs.add(
            'optimizer.hessian',
            f'must be one of {", ".join(HESSIANS)}, got {op.hessian!r}'
            f'{did_you_mean(op.hessian, HESSIANS)}',
        )
    if op.options:  # checked on IPOPT itself (IPOPT is imported only when needed)
        from suspopt.driver import ipopt_option_problems

        errs.extend(
            f'optimizer.options{p}' if p.startswith(': ') else f'optimizer.options.{p}'
            for p in ipopt_option_problems(op.options)
        )
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
            f'{cfg.multibody.mount!r}{did_you_mean(cfg.multibody.mount, MOUNTS)}',
        )
    return list(errs)


def _scenario_checks(cfg: StudyConfig, n_tracks: int) -> list[str]:
    errs = Problems()
    names = set()
    worst_case = cfg.objective.aggregate == 'max' and len(cfg.scenario) > 1
    for i, sc in enumerate(cfg.scenario):
        key = f'scenario[{i}]'
        if sc.name and sc.name in names:
            errs.add(f'{key}.name', f'duplicate scenario name {sc.name!r}')
        names.add(sc.name)
        if worst_case and math.isfinite(sc.weight) and sc.weight != 1.0:
            errs.add(
                f'{key}.weight',
                f'{sc.weight:g}: the worst case (objective.aggregate = "max") minimizes '
                'max_s f_s and takes no scenario weights; remove them, or use aggregate = '
                '"sum" (Σ_s w_s f_s)',
            )
        for fld, limits in (('speed', SPEED_RANGE), ('horizon', HORIZON_RANGE)):
            val = getattr(sc, fld)
            if not (math.isfinite(val) and val >= 0.0):
                errs.add(f'{key}.{fld}', f'must be > 0 (or absent), got {val:g}')
            elif val and (problem := range_problem(val, limits)):
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
    from suspopt.spec.resolve import grid_problems, nlp_size

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
    if not errs:  # the grid can represent the motion: is the motion plausible?
        from suspopt.spec.modes import mode_problems

        errs.extend(mode_problems(cfg))
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
    errs = Problems()
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
            ends = []
            for side in ('left', 'right'):
                r = make_road(typed_road(road[side]))
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
            f'{did_you_mean(str(kind), list(PROFILES) + [TWO_TRACKS])} '
            f'(built-in: {", ".join(list(PROFILES) + [TWO_TRACKS])})',
        )
        return list(errs)
    allowed = profile_fields(kind)
    sub = Problems()
    params = {}
    for k, val in road.items():
        if k == 'profile':
            continue
        if k not in allowed:
            sub.add(f'{where}.{k}', f'unknown key for profile {kind!r}' + did_you_mean(k, allowed))
            continue
        default = allowed[k]
        if isinstance(default, tuple):
            params[k] = parse_value(tuple[float, ...], val, f'{where}.{k}', sub, {})
        elif isinstance(default, bool):
            params[k] = parse_value(bool, val, f'{where}.{k}', sub, {})
        elif isinstance(default, int):
            params[k] = parse_value(int, val, f'{where}.{k}', sub, {})
        elif isinstance(default, float):
            params[k] = parse_value(float, val, f'{where}.{k}', sub, {})
        else:
            params[k] = parse_value(str, val, f'{where}.{k}', sub, {})
    for k, val in params.items():  # a road's integers are seeds: numpy takes >= 0 only
        if isinstance(allowed[k], int) and not isinstance(allowed[k], bool) and val < 0:
            sub.add(f'{where}.{k}', f'must be >= 0 (a seed of the random phases), got {val}')
    if kind == 'csv' and not road.get('file'):
        sub.add(f'{where}.file', 'missing value (path of a distance,height CSV)')
    if sub:
        return list(sub)
    profile = make_road(typed_road({'profile': kind, **params}))
    problems = profile.validate(length, where)
    if not problems and isinstance(profile, CSVRoad):
        problems = _csv_height_problems(profile, where)
    return problems


def _csv_height_problems(road: CSVRoad, where: str) -> list[str]:
    """A measured road's heights are relative to the car's static position (the zero
    initial state): within :data:`~suspopt.road.profiles.MAX_FEATURE_HEIGHT` of it, in
    metres (an elevation above sea level, or millimetres typed as metres, is refused)."""
    s, h = road._data()
    worst = int(np.argmax(np.abs(h)))
    if abs(h[worst]) > MAX_FEATURE_HEIGHT:
        return [
            f'{where}.file: {road.file}: height {h[worst]:g} m at s = {s[worst]:g} m is '
            f"beyond a road surface (at most {MAX_FEATURE_HEIGHT:g} m from the car's "
            'static position; heights are in metres, relative to the start, not elevations)'
        ]
    return []


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
    except (OSError, ValueError):  # load_mechanism names the problem
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

    errs: list[str] = []
    seen: dict[str, Any] = {}
    axles = ('front',) if cfg.vehicle.model == 'quarter_car' else ('front', 'rear')
    for i, axle in enumerate(axles):
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
