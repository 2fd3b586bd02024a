"""The engineering constraints of a study in its NLP (``docs/metrics.md``, "Constraints").

* **Path constraints**, on every node of every scenario's phase (Dymos path constraints on
  the ODE's own signals, exact partials, one row per node: linear in the horizon):
  ``[constraints.travel]`` keeps the suspension travel within ``[-rebound, bump]`` (a side
  given as 0 is left free), ``[constraints.tyre_contact]`` keeps the tyre load ratio
  ``F_T / F_static >= margin - 1`` (the tyre keeps ``margin`` of its static load);
* **design-only constraints**, on functions of the design alone, computed once at the
  problem level by the components of :mod:`suspopt.models.design_metrics` from the design
  variables: ``[constraints.roll_gradient]`` (min, max [deg/g], ``front_share``) and
  ``[constraints.ride_frequency]`` (heave, pitch bands [Hz]).

Each side of each constraint is a :class:`Bound`, named by its study-file key
(``travel.bump``, ``tyre_contact.margin``, ``roll_gradient.max`` ...), with the quantity
an engineer reads (the bump travel, the share of the static load the tyre keeps): the
same description reports the collocation's values (:func:`path_values`,
:func:`design_values`) and the time marching's (:mod:`suspopt.verification.verify`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import openmdao.api as om

from suspopt.errors import ConfigError
from suspopt.models.design import DESIGN_UNITS, design_id, design_kind
from suspopt.models.design_metrics import (
    AxleRollStiffnessComp,
    DecayRateComp,
    RideFrequencyComp,
    RideRateComp,
    RollGradientComp,
    RollStiffnessShareComp,
    WheelRateComp,
    axle_roll_stiffness,
    roll_moment_arm,
)
from suspopt.models.metrics import GRAVITY
from suspopt.models.settings import SuspensionSettingsComp
from suspopt.spec.resolve import Scenario
from suspopt.spec.schema import StudyConfig

#: the problem-level group of the design-only metrics
GROUP = 'design_metrics'
#: a constraint is active when its margin is within this share of its scale
ACTIVE_RTOL = 1e-4


@dataclass(frozen=True)
class PathConstraint:
    """One path constraint of every phase: ``lower <= signal <= upper`` at every node
    (None: that side is free), scaled by ``ref``."""

    signal: str
    units: str | None
    lower: float | None
    upper: float | None
    ref: float


@dataclass(frozen=True)
class Bound:
    """One side of one engineering constraint, as an engineer reads it: the quantity ``q``
    named ``name`` (its study-file key) in ``units`` is at most (``upper``) or at least
    the ``bound``. A path constraint's quantity is ``sign · signal + offset`` of a signal
    of the vehicle assembly, taken at its worst over the nodes, corners and scenarios; a
    design-only one is an output of the problem's :data:`GROUP`. ``scale`` is its typical
    magnitude (the margin a constraint counts as active is relative to it)."""

    name: str
    kind: str
    signal: str
    upper: bool
    bound: float
    units: str
    scale: float
    sign: float = 1.0
    offset: float = 0.0
    label: str = ''

    def quantity(self, signal: np.ndarray) -> np.ndarray:
        return self.sign * np.asarray(signal) + self.offset

    def margin(self, value: float) -> float:
        """How far ``value`` is inside the bound (negative: violated)."""
        return self.bound - value if self.upper else value - self.bound

    def active(self, value: float) -> bool:
        return self.margin(value) <= ACTIVE_RTOL * self.scale


# ---------------------------------------------------------------------------- description
def path_constraints(config: StudyConfig) -> tuple[PathConstraint, ...]:
    """The path constraints of every phase of ``config``."""
    c = config.constraints
    out = []
    if c.travel.enabled:
        bump, rebound = c.travel.bump, c.travel.rebound
        out.append(
            PathConstraint(
                'travel',
                'm',
                -rebound if rebound > 0.0 else None,
                bump if bump > 0.0 else None,
                max(bump, rebound),
            )
        )
    if c.tyre_contact.enabled:
        out.append(PathConstraint('tyre_load_ratio', None, c.tyre_contact.margin - 1.0, None, 1.0))
    return tuple(out)


def bounds(config: StudyConfig) -> tuple[Bound, ...]:
    """Every side of every engineering constraint of ``config``, path ones first."""
    c = config.constraints
    out = []
    if c.travel.enabled:
        if c.travel.bump > 0.0:
            out.append(
                Bound(
                    'travel.bump',
                    'path',
                    'travel',
                    True,
                    c.travel.bump,
                    'm',
                    c.travel.bump,
                    label='bump travel',
                )
            )
        if c.travel.rebound > 0.0:
            out.append(
                Bound(
                    'travel.rebound',
                    'path',
                    'travel',
                    True,
                    c.travel.rebound,
                    'm',
                    c.travel.rebound,
                    sign=-1.0,
                    label='rebound travel',
                )
            )
    if c.tyre_contact.enabled:
        out.append(
            Bound(
                'tyre_contact.margin',
                'path',
                'tyre_load_ratio',
                False,
                c.tyre_contact.margin,
                '',
                1.0,
                offset=1.0,
                label='share of the static tyre load kept',
            )
        )
    rg = c.roll_gradient
    if rg.enabled:
        for side, value in (('min', rg.min), ('max', rg.max)):
            if value > 0.0:
                out.append(
                    Bound(
                        f'roll_gradient.{side}',
                        'design',
                        'roll_gradient',
                        side == 'max',
                        value,
                        'deg/g',
                        value,
                        label='roll gradient',
                    )
                )
        for side, value in zip(('min', 'max'), rg.front_share):
            out.append(
                Bound(
                    f'roll_gradient.front_share.{side}',
                    'design',
                    'front_share',
                    side == 'max',
                    value,
                    '',
                    1.0,
                    label='front share of the roll stiffness',
                )
            )
    rf = c.ride_frequency
    if rf.enabled:
        for mode, band in (('heave', rf.heave), ('pitch', rf.pitch)):
            for side, value in zip(('min', 'max'), band):
                out.append(
                    Bound(
                        f'ride_frequency.{mode}.{side}',
                        'design',
                        f'f_{mode}',
                        side == 'max',
                        value,
                        'Hz',
                        value,
                        label=f'{mode} frequency',
                    )
                )
    if stability_applies(config):
        m = c.stability.margin
        out.append(
            Bound(
                'stability.margin',
                'design',
                'decay',
                False,
                m,
                '1/s',
                max(m, 1.0),
                label='decay rate of the slowest closed-loop mode',
            )
        )
    return tuple(out)


def stability_applies(config: StudyConfig) -> bool:
    """The closed-loop stability constraint applies to an active suspension under a
    linear feedback law (no force or power bound), in either model: the only closed loop
    of suspopt that can be unstable (a semi-active damper only dissipates;
    ``docs/codesign.md``)."""
    k = config.control
    return (
        config.constraints.stability.enabled
        and k.kind == 'active'
        and k.law == 'feedback'
        and not k.force_max
        and not k.power_max
    )


def structure(config: StudyConfig) -> list[str]:
    """What the constraints add to the NLP's structure (the coloring cache's key)."""
    return [b.name for b in bounds(config)]


def distinct_nodes(segments: int, order: int) -> np.ndarray:
    """The nodes of a compressed Radau grid that carry distinct states, less the first
    (the fixed initial state): each segment's nodes but its right end, which is the next
    segment's first, and the last node."""
    per = order + 1
    nodes = (np.arange(segments)[:, None] * per + np.arange(per - 1)).ravel()
    return np.append(nodes[1:], segments * per - 1)


def add_path_constraints(
    model: om.Group,
    ode: str,
    constraints: tuple[PathConstraint, ...],
    scenario: Scenario,
    corners: int,
) -> None:
    """Constrain the ODE's signals at every distinct node of a scenario's phase."""
    nodes = distinct_nodes(scenario.segments, scenario.order)
    flat = (nodes[:, None] * corners + np.arange(corners)).ravel()
    for pc in constraints:
        model.add_constraint(
            f'{ode}.{pc.signal}',
            indices=flat,
            flat_indices=True,
            lower=pc.lower,
            upper=pc.upper,
            ref=pc.ref,
            units=pc.units,
        )


# ---------------------------------------------------------------------------- design-only
@dataclass(frozen=True)
class WheelRates:
    """The wheel rate per corner as ``slope · k_S + offset``."""

    slope: np.ndarray
    offset: np.ndarray


def wheel_rates(config: StudyConfig, fidelity: str, modules: Mapping[str, Any]) -> WheelRates:
    """The wheel rates of the model: ``k_S`` itself (low fidelity: the spring acts at the
    wheel) or each corner's linkage at its reference pose (mixed)."""
    lay = config.layout()
    nc = lay.n
    if fidelity != 'mixed':
        return WheelRates(np.ones(nc), np.zeros(nc))
    from suspopt.multibody.kinematics import reference_wheel_rate

    rates = {
        name: reference_wheel_rate(getattr(m, 'base_mechanism', m))[:2]
        for name, m in modules.items()
    }
    per = [rates[config.vehicle.axles[c.axle].mechanism] for c in lay.corners]
    return WheelRates(np.array([p[0] for p in per]), np.array([p[1] for p in per]))


def roll_arm(config: StudyConfig) -> float:
    """The CG's height above the roll axis [m] (:func:`roll_moment_arm`)."""
    v = config.vehicle
    return roll_moment_arm(
        v.cg_height,
        v.front.roll_centre_height,
        v.rear.roll_centre_height,
        v.front.axle_position,
        v.rear.axle_position,
    )


def _decay_rate_comp(
    config: StudyConfig, fidelity: str, modules: Mapping[str, Any] | None
) -> DecayRateComp:
    """The closed loop's decay rate from the assembly's state matrix at rest, affine in
    the design: read off the low-fidelity model exactly, or by central differences of the
    mixed model (each linkage reduced to its travel) at the initial design."""
    from suspopt.models.linear import affine_linearize, affine_rest_jacobian
    from suspopt.multibody.reduced import reduced_modules
    from suspopt.transcription.vehicle import vehicle_assembly

    names = config.design_names()
    units = tuple(DESIGN_UNITS[design_kind(n)] for n in names)
    scenario = config.scenarios()[0]
    if fidelity == 'low':
        lin = affine_linearize(vehicle_assembly(config, scenario, 'low'), (), names)
        return DecayRateComp(design=names, units=units, A0=lin.base.A, dA=lin.dA)
    reduced = reduced_modules(dict(modules or {}))
    assembly = vehicle_assembly(config, scenario, fidelity, reduced)
    A0, dA = affine_rest_jacobian(assembly, config.design.initial(), names)
    return DecayRateComp(design=names, units=units, A0=A0, dA=dA)


class DesignMetricsGroup(om.Group):
    """The design-only metrics of a vehicle from its design variables: the settings per
    corner, the wheel rates, and from them the roll stiffness per axle, the roll gradient
    and its front share (full car), the ride rates and the heave and pitch frequencies."""

    def initialize(self) -> None:
        self.options.declare('config', types=StudyConfig, recordable=False)
        self.options.declare('rates', types=WheelRates, recordable=False)
        self.options.declare('fidelity', default='low', values=('low', 'mixed'))
        self.options.declare('modules', default=None, recordable=False)

    def setup(self) -> None:
        config, rates = self.options['config'], self.options['rates']
        v, lay = config.vehicle, config.layout()
        k_T = np.array([v.axles[c.axle].tyre_stiffness for c in lay.corners])
        c = config.constraints
        self.add_subsystem(
            'settings',
            SuspensionSettingsComp(design=config.design_names(), labels=lay.labels),
            promotes=['*'],
        )
        self.add_subsystem(
            'wheel_rate', WheelRateComp(slope=rates.slope, offset=rates.offset), promotes=['*']
        )
        if c.roll_gradient.enabled:
            bars = np.array([i for i, ax in enumerate(v.axles) if ax.anti_roll_bar], dtype=int)
            self.add_subsystem(
                'roll_stiffness',
                AxleRollStiffnessComp(
                    y=lay.y, k_T=k_T, axle=np.array([c.axle for c in lay.corners]), bar_axle=bars
                ),
                promotes=['*'],
            )
            self.add_subsystem(
                'roll_gradient',
                RollGradientComp(sprung_mass=float(v.chassis_mass), arm=roll_arm(config)),
                promotes=['*'],
            )
            self.add_subsystem('roll_share', RollStiffnessShareComp(), promotes=['*'])
        if stability_applies(config):
            comp = _decay_rate_comp(config, self.options['fidelity'], self.options['modules'])
            self.add_subsystem('decay_rate', comp, promotes=['*'])
        if c.ride_frequency.enabled:
            self.add_subsystem('ride_rate', RideRateComp(k_T=k_T), promotes=['*'])
            self.add_subsystem(
                'ride_frequency',
                RideFrequencyComp(
                    a=lay.a,
                    sprung_mass=float(v.chassis_mass),
                    pitch_inertia=float(v.chassis_pitch_inertia),
                    pitch=lay.has_pitch,
                ),
                promotes=['*'],
            )


def check_roll_stability(config: StudyConfig, rates: WheelRates) -> None:
    """Refuse a design box whose softest design cannot hold the body in roll: the roll
    gradient's formula is finite only while the roll stiffness exceeds gravity's moment
    ``W h'`` (the stiffness grows with every rate, so the box's lower corner decides)."""
    v, lay = config.vehicle, config.layout()
    lower = {n: dv.lower for n, dv in config.design.variables.items()}
    k_S = np.array(
        [
            min(x for n, x in lower.items() if n.startswith('k_S') and _acts(n, c))
            for c in lay.corners
        ]
    )
    bars = [i for i, ax in enumerate(v.axles) if ax.anti_roll_bar]
    k_R = [lower[f'k_R{i + 1}'] for i in bars]
    k_T = np.array([v.axles[c.axle].tyre_stiffness for c in lay.corners])
    K = axle_roll_stiffness(
        rates.slope * k_S + rates.offset, k_R, k_T, lay.y, [c.axle for c in lay.corners], bars
    )
    moment = v.chassis_mass * GRAVITY * roll_arm(config)
    if not float(np.sum(K)) > moment:
        raise ConfigError(
            f'constraints.roll_gradient: the softest design of the box has a roll stiffness '
            f"of {np.sum(K):.4g} N m/rad, below the roll moment of gravity W h' = "
            f'{moment:.4g} N m/rad (the body would roll over): raise the lower bounds of '
            'the springs or anti-roll bars'
        )


def _acts(name: str, corner: Any) -> bool:
    return design_id(name).acts_on(corner.axle, corner.side)


def add_design_constraints(
    model: om.Group, config: StudyConfig, fidelity: str, modules: Mapping[str, Any]
) -> bool:
    """Add the design-only metrics of ``config`` to ``model`` (as :data:`GROUP`, fed by
    the trajectory's design parameters) and constrain them; False if there are none."""
    design = [b for b in bounds(config) if b.kind == 'design']
    if not design:
        return False
    rates = wheel_rates(config, fidelity, modules)
    if config.constraints.roll_gradient.enabled:
        check_roll_stability(config, rates)
    model.add_subsystem(
        GROUP, DesignMetricsGroup(config=config, rates=rates, fidelity=fidelity, modules=modules)
    )
    for name in config.design_names():  # the source of the trajectory's parameter
        source = f'traj.parameters:{name}'
        model.connect(source, f'{GROUP}.{name}')
        model.set_input_defaults(
            source, val=config.design[name].initial, units=DESIGN_UNITS[design_kind(name)]
        )
    for signal in dict.fromkeys(b.signal for b in design):
        sides = [b for b in design if b.signal == signal]
        lower = [b.bound for b in sides if not b.upper]
        upper = [b.bound for b in sides if b.upper]
        model.add_constraint(
            f'{GROUP}.{signal}',
            lower=lower[0] if lower else None,
            upper=upper[0] if upper else None,
            ref=max(b.scale for b in sides),
        )
    return True


# ---------------------------------------------------------------------------- values
@dataclass(frozen=True)
class Worst:
    """A constraint's worst value (the smallest margin) and where it is: the scenario,
    the corner and the time (a design-only one: nowhere)."""

    value: float
    scenario: str = ''
    corner: str = ''
    time: float | None = None

    @property
    def where(self) -> str:
        parts = [f'scenario {self.scenario}' if self.scenario else '']
        parts.append(f'corner {self.corner}' if self.corner else '')
        parts.append(f't = {self.time:.3f} s' if self.time is not None else '')
        return ', '.join(p for p in parts if p)


def worst_on_path(
    bound: Bound,
    trajectories: Sequence[tuple[str, np.ndarray, np.ndarray]],
    labels: Sequence[str],
) -> Worst | None:
    """The worst of a path constraint's quantity over every node and corner of every
    scenario: ``trajectories`` are (scenario, times (N,), signal (N, corners))."""
    best: Worst | None = None
    for name, t, signal in trajectories:
        q = bound.quantity(np.asarray(signal, dtype=float).reshape(len(t), -1))
        flat = int(np.argmax(q) if bound.upper else np.argmin(q))
        node, corner = np.unravel_index(flat, q.shape)
        value = float(q[node, corner])
        if best is None or bound.margin(value) < bound.margin(best.value):
            best = Worst(value, name, str(labels[int(corner)]), float(t[node]))
    return best
