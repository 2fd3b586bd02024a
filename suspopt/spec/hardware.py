"""The suspension hardware of a study as curves (``docs/nonlinear_hardware.md``): each
axle's ``spring_curve``, ``damper_curve``, ``bump_stop`` and ``rebound_stop`` tables read
into a :class:`~suspopt.curves.SpringDamperUnit`, and the curve parameters that may be
design variables.

The curves are the spring-damper unit's, in the coordinates of the design variables
``k_S`` and ``c_S``: the low-fidelity model applies them between the wheel and the
chassis (``x = z_W - z_M``, motion ratio 1, as it does ``k_S``), the mixed model on the
mechanism's suspension spring element (its compression from the reference length). An
axle without any of the four tables has today's linear spring and damper, exactly.

The spring's rate ``k_S`` (of a linear or polynomial spring) and a linear damper's
``c_S`` stay the design variables ``k_S<axle>`` and ``c_S<axle>``; every other scalar
parameter of the curves (the damper's slopes and knees, a polynomial's higher
coefficients, the stops' gaps and coefficients; not a table's points) becomes a design
variable ``<parameter>_<axle>[<side>]`` when it is named in ``[design]``. A variable's
initial value defaults to the hardware's value (a polynomial spring's first
coefficient for ``k_S``); given, it is the start and the hardware's value its default."""

from __future__ import annotations

import copy
import math
from typing import Any

from suspopt.curves import SLOTS, SpringDamperUnit
from suspopt.errors import ConfigError
from suspopt.models.design import KINDS, curve_variable, design_id
from suspopt.spec.schema import AxleConfig, StudyConfig, VehicleConfig

#: the axles' names in the study file, by index
AXLE_KEYS = ('front', 'rear')


def axle_key(axle: int) -> str:
    """``vehicle.front`` / ``vehicle.rear``."""
    return f'vehicle.{AXLE_KEYS[axle]}'


def curve_tables(ax: AxleConfig) -> dict[str, dict[str, Any]]:
    """The axle's curve tables by slot (:data:`~suspopt.curves.SLOTS`), the given ones."""
    return {slot: getattr(ax, slot) for slot in SLOTS if getattr(ax, slot)}


def axle_travel(vehicle: VehicleConfig, constraints: Any, axle: int) -> tuple[float, float] | None:
    """The deflection range an axle's curves must serve, (min, max) from static [m]:
    ``[constraints.travel]`` (rebound, bump) where given, else the axle's mechanism's
    wheel-travel range; None if neither is known."""
    tr = constraints.travel
    if tr.enabled and (tr.bump > 0.0 or tr.rebound > 0.0):
        return (
            -tr.rebound if tr.rebound > 0.0 else -math.inf,
            tr.bump if tr.bump > 0.0 else math.inf,
        )
    from suspopt.multibody.mechanism import load_mechanism  # the mechanism files, lazily

    try:
        travel = load_mechanism(vehicle.axles[axle].mechanism, suspension=True).travel
    except ConfigError:  # its own check names the problem
        return None
    return None if travel is None else (float(travel[0]), float(travel[1]))


def build_unit(
    ax: AxleConfig,
    key: str,
    stiffness: float | None,
    damping: float | None,
    travel: tuple[float, float] | None = None,
) -> SpringDamperUnit | None:
    """The axle's hardware (None: no curve table, the linear spring and damper); the
    linear spring's ``stiffness`` and damper's ``damping`` where no curve replaces them.
    Raises :class:`~suspopt.errors.ConfigError` naming the keys ``key.<slot>.<field>``."""
    tables = curve_tables(ax)
    if not tables:
        return None
    return SpringDamperUnit.from_dict(tables, key, stiffness, damping, travel)


def curve_parameters(ax: AxleConfig) -> tuple[str, ...]:
    """The curve parameters of the axle's hardware that may be design variables: its
    scalar parameters but ``k_S`` and ``c_S`` (the linear variables) and a table's points,
    in the unit's order; none if the tables do not read."""
    try:
        unit = build_unit(ax, '', 0.0, 0.0)
    except ConfigError:
        return ()
    if unit is None:
        return ()
    return tuple(
        p.name
        for p in unit.parameters()
        if p.size == 1 and p.name in KINDS and p.name not in ('k_S', 'c_S')
    )


def curve_defaults(ax: AxleConfig) -> dict[str, float]:
    """The hardware's values of its :func:`curve_parameters` and of a polynomial spring's
    rate ``k_S`` (the defaults of their design variables' initial values)."""
    try:
        unit = build_unit(ax, '', 0.0, 0.0)
    except ConfigError:
        return {}
    if unit is None:
        return {}
    own = unit.scalar_parameters()
    out = {n: own[n] for n in curve_parameters(ax)}
    if 'coefficients' in ax.spring_curve and 'k_S' in own:
        out['k_S'] = own['k_S']
    return out


def curve_variable_names(
    vehicle: VehicleConfig, per_corner: bool, given: set[str] | dict[str, Any]
) -> tuple[str, ...]:
    """The curve parameters' design variables of a car named in ``given`` (the keys of
    ``[design]``), kind by kind in the hardware's order, axle (corner) by axle: per axle
    ``c_bump_low_1``; with ``per_corner`` every corner of an axle named by its axle's
    variable or its own (``c_bump_low_1L``)."""
    sides = (1, -1) if per_corner and vehicle.model == 'full_car' else (0,)
    axles = range(1 if vehicle.model == 'quarter_car' else 2)
    params = {a: curve_parameters(vehicle.axles[a]) for a in axles}
    out = []
    for symbol in dict.fromkeys(p for a in axles for p in params[a]):
        for a in axles:
            if symbol not in params[a]:
                continue
            for side in sides:
                name = curve_variable(symbol, a, side)
                if name in given or curve_variable(symbol, a) in given:
                    out.append(name)
    return tuple(out)


def allowed_curve_variables(vehicle: VehicleConfig, per_corner: bool) -> tuple[str, ...]:
    """Every name a curve parameter's design variable of this car may take in ``[design]``
    (per axle, and per corner with ``per_corner``)."""
    out = []
    for a in range(1 if vehicle.model == 'quarter_car' else 2):
        for symbol in curve_parameters(vehicle.axles[a]):
            out.append(curve_variable(symbol, a))
            if per_corner and vehicle.model == 'full_car':
                out += [curve_variable(symbol, a, side) for side in (1, -1)]
    return tuple(out)


def default_bounds(
    symbol: str, initial: float, travel: tuple[float, float] | None
) -> tuple[float, float]:
    """Bounds of a curve parameter's variable not given in ``[design]``: a gap from 0 to
    4 times its value (at most the travel on its side), anything else from a quarter to
    4 times its value."""
    if symbol.endswith('_gap'):
        reach = math.inf
        if travel is not None:
            reach = travel[1] if symbol.startswith('bump') else -travel[0]
        return 0.0, max(initial, min(4.0 * initial, reach))
    return (initial / 4.0, 4.0 * initial) if initial >= 0.0 else (4.0 * initial, initial / 4.0)


def _set(tables: dict[str, dict[str, Any]], symbol: str, value: float) -> None:
    """Set the scalar curve parameter ``symbol`` (or a polynomial's ``k_S``) in the axle's
    tables, in place."""
    kind = KINDS[symbol]
    slot = kind.slot or 'spring_curve'
    table = tables[slot]
    if slot == 'damper_curve':
        table[symbol] = value
        return
    if symbol.endswith('_gap'):
        table['gap'] = value
        return
    if symbol == 'k_S':
        power = 1
    elif symbol.startswith('k_S'):
        power = int(symbol[3:])
    else:
        power = int(symbol.rsplit('_k', 1)[1])
    first = 1 if slot == 'spring_curve' else 2  # a polynomial's k_1, a stop's k_2
    coefficients = list(table['coefficients'])
    coefficients[power - first] = value
    table['coefficients'] = coefficients


def unit_problems_at(
    ax: AxleConfig,
    key: str,
    values: dict[str, float],
    travel: tuple[float, float] | None,
) -> list[str]:
    """The hardware's problems with some of its parameters at ``values`` (by symbol: a
    design variable's bound), each line naming the hardware's key."""
    tables = {slot: copy.deepcopy(t) for slot, t in curve_tables(ax).items()}
    for symbol, value in values.items():
        _set(tables, symbol, value)
    try:
        SpringDamperUnit.from_dict(tables, key, 0.0, 0.0, travel)
    except ConfigError as err:
        return err.problems
    return []


def study_units(config: StudyConfig) -> tuple[SpringDamperUnit | None, ...]:
    """Each axle's hardware (None: linear), with the design's initial ``k_S``, ``c_S`` as
    the linear spring's and damper's values where no curve replaces them (resolved once
    per description)."""
    cached = config.__dict__.get('_units')
    if cached is not None:
        return cached
    v = config.vehicle
    initial = config.design.initial()
    out = []
    for a in range(1 if v.model == 'quarter_car' else 2):

        def start(symbol: str, a: int = a) -> float | None:
            for n, x in initial.items():
                d = design_id(n)
                if d.kind.symbol == symbol and d.axle == a:
                    return x
            return None

        out.append(build_unit(v.axles[a], axle_key(a), start('k_S'), start('c_S')))
    units = tuple(out)
    object.__setattr__(config, '_units', units)
    return units


def corner_units(config: StudyConfig) -> tuple[SpringDamperUnit | None, ...]:
    """Each corner's hardware (:func:`study_units` of its axle)."""
    units = study_units(config)
    return tuple(units[c.axle] for c in config.layout().corners)


def curves_structure(config: StudyConfig) -> list[Any] | None:
    """The structure of every axle's curves (forms, not values; None: all linear): what a
    cached coloring depends on beyond the design's names."""
    units = study_units(config)
    if not any(units):
        return None
    return [None if u is None else u.structure() for u in units]


__all__ = [
    'AXLE_KEYS',
    'allowed_curve_variables',
    'axle_key',
    'axle_travel',
    'build_unit',
    'corner_units',
    'curve_defaults',
    'curve_parameters',
    'curve_tables',
    'curve_variable_names',
    'curves_structure',
    'default_bounds',
    'study_units',
    'unit_problems_at',
]
