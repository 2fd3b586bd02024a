"""The study description's schema: one plain, serializable tree of frozen dataclasses for
the car, roads, design space, objective, transcription and optimizer (``docs/study-file.md``).

A :class:`StudyConfig` holds no live objects and is all a worker needs to rebuild a model,
so many studies can be built and run side by side. It round-trips through plain
dictionaries (:meth:`StudyConfig.to_dict`, :func:`suspopt.spec.load.config_from_dict`) and
TOML files (:func:`suspopt.spec.load.load_config`, :mod:`suspopt.spec.template`).

Two vehicle models share one description (``vehicle.model``): the paper's half car (two
corners) and the full car (four corners, roll, optional anti-roll bars). Every key is
optional; a missing key takes the value of that model's default car. Design variables,
objective terms and their weights are named (``k_S1``, ``c_S2``, ``k_R1``; ``heave``,
``pitch``, ``roll``, ``wheel_1`` ...) and depend on the model.

A study may list several load cases (``[[scenario]]``: road, speed, horizon, grid,
weight) that share one design; without them the study has one scenario made of its
``maneuver``, ``road`` and ``transcription`` tables (:meth:`StudyConfig.scenarios`,
resolved once per description by :mod:`suspopt.spec.resolve`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

from suspopt.models.design import design_id, design_kind
from suspopt.models.layout import VehicleLayout, full_car, half_car, quarter_car
from suspopt.models.metrics import objective_terms as metric_terms
from suspopt.road import RoadProfile, make_road
from suspopt.spec.resolve import Scenario
from suspopt.spec.resolve import scenarios as resolve_scenarios
from suspopt.spec.values import check as _check
from suspopt.spec.values import plausible as _plausible

MODELS = ('quarter_car', 'half_car', 'full_car')
NORMALIZATIONS = ('reference', 'paper', 'custom')
AGGREGATES = ('sum', 'max')
#: how a multibody module's frame is coupled to the chassis (``multibody.mount``)
MOUNTS = ('ground', 'chassis')
#: The paper's printed normalization factors (§4.2), for the half car's four terms.
PAPER_SCALES = {'heave': 0.1, 'pitch': 0.01, 'wheel_1': 1.0, 'wheel_2': 1.0}
#: Largest NLP suspopt builds, all scenarios together: nodes × states (a guard against a
#: typo such as segments = 100000: the build's time and memory grow faster than its size)
MAX_NLP_VARIABLES = 150_000
#: Design variables' largest plausible values by kind (a guard against a unit typo); a
#: curve parameter's by its units (:func:`design_limit`)
DESIGN_LIMITS = {
    'k_S': 1e7,
    'c_S': 1e6,
    'k_R': 1e7,
    'g_sky': 1e6,
    'g_gnd': 1e6,
    'g_tr': 1e7,
    'g_rt': 1e6,
}
#: the largest plausible value of a curve parameter by its units: damping, knee
#: velocity, gap
CURVE_LIMITS = {'N*s/m': 1e6, 'm/s': 20.0, 'm': 1.0}


def design_limit(name: str) -> float:
    """The largest plausible value of design variable ``name`` (a unit typo above)."""
    kind = design_id(name).kind
    if kind.symbol in DESIGN_LIMITS:
        return DESIGN_LIMITS[kind.symbol]
    return CURVE_LIMITS.get(kind.units, math.inf)  # a polynomial's coefficient: any


#: the controlled suspensions (``[control] kind``) and their control laws (``law``)
CONTROL_KINDS = ('none', 'active', 'semi_active')
CONTROL_LAWS = ('open_loop', 'feedback')
#: the feedback gains of each kind of controlled suspension (``docs/codesign.md``)
FEEDBACK_GAINS = {'semi_active': ('g_sky', 'g_gnd'), 'active': ('g_sky', 'g_gnd', 'g_tr', 'g_rt')}


#: maneuver limits (also for scenarios)
SPEED_RANGE = (
    0.0,
    150.0,
    'm/s',
    "a road vehicle's speed",
    'speeds are in m/s: 100 km/h is 27.8 m/s',
)
HORIZON_RANGE = (0.0, 600.0, 's', 'a maneuver (collocation resolves a few tens of seconds)', '')


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
    roll_centre_height: float = field(
        default=0.0,
        metadata=_plausible(
            -1.0, 2.0, 'm', 'a roll centre height', doc='kinematic roll centre above ground [m]'
        ),
    )
    # the suspension hardware as curves (docs/nonlinear_hardware.md); {}: the linear
    # spring k_S and damper c_S of the design
    spring_curve: dict[str, Any] = field(
        default_factory=dict,
        metadata={
            'doc': 'progressive spring: coefficients = [k_1, k_2, ..] [N/m^i] (k_1 is the '
            'design variable k_S) or deflections [m], forces [N] (a table)'
        },
    )
    damper_curve: dict[str, Any] = field(
        default_factory=dict,
        metadata={
            'doc': 'damper curve replacing c_S: c_bump_low, v_bump_knee, c_bump_high, '
            'c_rebound_low, v_rebound_knee, c_rebound_high [N s/m, m/s] (v_zero, '
            'knee_width) or velocities [m/s], forces [N] (a table)'
        },
    )
    bump_stop: dict[str, Any] = field(
        default_factory=dict,
        metadata={'doc': 'gap [m] from static, coefficients = [k_2, k_3, ..] [N/m^i]'},
    )
    rebound_stop: dict[str, Any] = field(
        default_factory=dict,
        metadata={'doc': 'gap [m] from static, coefficients = [k_2, k_3, ..] [N/m^i]'},
    )

    @property
    def has_curves(self) -> bool:
        """Whether the axle's hardware has curves (any of the four tables given)."""
        return bool(self.spring_curve or self.damper_curve or self.bump_stop or self.rebound_stop)

    @property
    def has_spring_rate(self) -> bool:
        """Whether the axle's spring has the rate ``k_S`` (linear or polynomial, not a
        table)."""
        return not ({'deflections', 'forces'} & set(self.spring_curve))

    @property
    def has_linear_damper(self) -> bool:
        """Whether the axle's damper is the linear ``c_S`` (no damper curve)."""
        return not self.damper_curve


@dataclass(frozen=True)
class VehicleConfig:
    """The car: the half car of docs/model.md (paper Table 1) or a full car."""

    model: str = field(
        default='half_car', metadata={'doc': 'quarter_car | half_car | full_car (the dofs)'}
    )
    chassis_mass: float = field(
        default=1414.0,
        metadata=_plausible(
            50.0, 1e5, 'kg', "a road vehicle's sprung mass", check='positive', doc='M [kg]'
        ),
    )
    chassis_pitch_inertia: float = field(
        default=2782.0,
        metadata=_plausible(0.0, 1e7, 'kg m^2', 'a pitch inertia', doc='I [kg m^2]'),
    )
    chassis_roll_inertia: float = field(
        default=0.0,
        metadata=_plausible(0.0, 1e7, 'kg m^2', 'a roll inertia', doc='full car: I_x [kg m^2]'),
    )
    cg_height: float = field(
        default=0.0,
        metadata=_plausible(
            0.0, 5.0, 'm', "a road vehicle's centre of gravity", doc='CG above ground [m]'
        ),
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
        if self.model == 'quarter_car':
            return quarter_car()
        return half_car(a1, a2)


@dataclass(frozen=True)
class ManeuverConfig:
    """Constant-speed drive over the road for the time horizon (docs/model.md)."""

    speed: float = field(
        default=10.0, metadata={'range': SPEED_RANGE, 'check': 'positive', 'doc': 'v [m/s]'}
    )
    horizon: float = field(
        default=5.0, metadata={'range': HORIZON_RANGE, 'check': 'positive', 'doc': 'T [s]'}
    )


# ---------------------------------------------------------------------------- control
@dataclass(frozen=True)
class ControlConfig:
    """An active or semi-active suspension at some corners, optimized with the passive
    hardware (``docs/codesign.md``). ``kind``: ``none``, ``active`` (an actuator force
    ``u`` between body and wheel, in parallel with the spring-damper) or ``semi_active`` (a
    damper of coefficient ``c(t)`` in ``[c_min, c_max]`` in parallel with the passive
    damper: it can only dissipate). ``law``: ``open_loop`` (the control's time history is
    optimized: a Dymos control, the bound of any controller with full preview of the road)
    or ``feedback`` (a state-feedback law whose gains are design variables)."""

    kind: str = field(default='none', metadata={'doc': 'none, active or semi_active'})
    law: str = field(default='open_loop', metadata={'doc': 'open_loop or feedback'})
    corners: tuple[str, ...] = field(
        default=(), metadata={'doc': 'the controlled corners (labels; default: every corner)'}
    )
    force_max: float = field(
        default=0.0,
        metadata=_plausible(0.0, 1e6, 'N', 'an actuator force', doc='|u| bound [N] (0: none)'),
    )
    power_max: float = field(
        default=0.0,
        metadata=_plausible(0.0, 1e7, 'W', "an actuator's power", doc='|u v| bound [W] (0: none)'),
    )
    c_min: float = field(
        default=0.0,
        metadata=_plausible(0.0, 1e6, 'N s/m', 'a damping', doc='semi_active: c(t) lower bound'),
    )
    c_max: float = field(
        default=0.0,
        metadata=_plausible(0.0, 1e6, 'N s/m', 'a damping', doc='semi_active: c(t) upper bound'),
    )
    force_scale: float = field(
        default=0.0,
        metadata=_plausible(
            0.0,
            1e6,
            'N',
            'an actuator force',
            doc="the NLP's scale of an active force [N] (0: force_max, else a tenth of the "
            "corner's static load)",
        ),
    )
    smoothing: float = field(
        default=0.02,
        metadata=_plausible(
            1e-4,
            0.5,
            '',
            'a smoothing fraction',
            doc='semi_active feedback: width of the smooth clip to [c_min, c_max], a '
            'fraction of c_max - c_min',
        ),
    )
    velocity_floor: float = field(
        default=0.005,
        metadata=_plausible(
            1e-6,
            1.0,
            'm/s',
            'a relative velocity',
            doc='semi_active feedback: relative velocity [m/s] below which the demanded '
            'force over the velocity is regularized',
        ),
    )

    @property
    def enabled(self) -> bool:
        return self.kind != 'none'

    def controlled(self, labels: tuple[str, ...]) -> tuple[str, ...]:
        """The controlled corners' labels among a car's ``labels`` (in the car's order)."""
        if not self.enabled:
            return ()
        return tuple(c for c in labels if not self.corners or c in self.corners)

    def gains(self) -> tuple[str, ...]:
        """The feedback gains' kinds (none for an open-loop control)."""
        return FEEDBACK_GAINS.get(self.kind, ()) if self.law == 'feedback' else ()


# ---------------------------------------------------------------------------- design
@dataclass(frozen=True)
class DesignVariable:
    """One design variable: initial value and bounds; ``optimize = false`` holds it fixed."""

    initial: float = field(metadata={'doc': 'start value (SI units of the variable)'})
    lower: float = field(metadata={'doc': 'lower bound'})
    upper: float = field(metadata={'doc': 'upper bound'})
    optimize: bool = field(default=True, metadata={'doc': 'false: held at `initial`'})


#: default (initial, lower, upper) by kind: spring rate [N/m], damping [N s/m], anti-roll
#: bar rate [N m/rad] (paper Table 3 for the first two), and the feedback gains: skyhook,
#: groundhook [N s/m], travel [N/m], travel rate [N s/m] (``docs/codesign.md``)
DESIGN_DEFAULTS = {
    'k_S': (30000.0, 10000.0, 50000.0),
    'c_S': (3000.0, 1000.0, 5000.0),
    'k_R': (20000.0, 0.0, 100000.0),
    'g_sky': (1000.0, 0.0, 20000.0),
    'g_gnd': (100.0, 0.0, 20000.0),
    'g_tr': (0.0, -50000.0, 50000.0),
    'g_rt': (0.0, -5000.0, 5000.0),
}


def design_names(
    vehicle: VehicleConfig, per_corner: bool = False, control: ControlConfig | None = None
) -> tuple[str, ...]:
    """The design variables of a car: spring rate and damping per axle (``k_S1``, ``c_S2``)
    or per corner (``k_S1L`` ...), then each anti-roll bar's rate (``k_R1``). An axle
    whose spring is a table has no ``k_S``, one with a damper curve no ``c_S`` (its
    curves' parameters may be variables instead: :mod:`suspopt.spec.hardware`); then a
    feedback ``control``'s gains on each axle (or corner) it controls (``g_sky1`` ...)."""
    groups = (
        vehicle.layout().labels
        if per_corner and vehicle.model == 'full_car'
        else ('1',)
        if vehicle.model == 'quarter_car'
        else ('1', '2')
    )

    def axle(g: str) -> AxleConfig:
        return vehicle.axles[int(g[0]) - 1]

    names = [f'k_S{g}' for g in groups if axle(g).has_spring_rate]
    names += [f'c_S{g}' for g in groups if axle(g).has_linear_damper]
    if vehicle.model == 'full_car':
        names += [f'k_R{i + 1}' for i, ax in enumerate(vehicle.axles) if ax.anti_roll_bar]
    if control is not None and control.gains() and vehicle.model in MODELS:
        controlled = control.controlled(vehicle.layout().labels)
        mine = [g for g in groups if any(c.startswith(g) for c in controlled)]
        names += [f'{k}{g}' for k in control.gains() for g in mine]
    return tuple(names)


@dataclass(frozen=True)
class DesignConfig:
    """The design variables by name (paper Table 3 for the half car), per axle or, with
    ``per_corner`` (full car), per corner."""

    per_corner: bool = field(
        default=False, metadata={'doc': 'full car: one variable per corner (k_S1L ...)'}
    )
    variables: dict[str, DesignVariable] = field(
        default_factory=lambda: {
            n: DesignVariable(*DESIGN_DEFAULTS[design_kind(n)])
            for n in ('k_S1', 'k_S2', 'c_S1', 'c_S2')
        },
        metadata={'doc': 'the variables by name: the `[design.<name>]` tables below'},
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
def objective_terms(
    layout: VehicleLayout, seats: tuple[str, ...] = (), controlled: tuple[str, ...] = ()
) -> tuple[str, ...]:
    """The objective's terms (:func:`suspopt.models.metrics.objective_terms`): the
    chassis accelerations, each wheel's displacement (the paper's eq. 4), each corner's
    dynamic tyre load and suspension travel, the comfort at each seat and the actuator
    force at each controlled corner."""
    return metric_terms(layout, seats, controlled=controlled)


def default_weights(layout: VehicleLayout) -> dict[str, float]:
    """Half comfort, half road holding over the paper's terms: its 0.25 each for the half
    car; for the full car 1/6 on each chassis term and 1/8 on each wheel."""
    chassis = list(layout.dofs)
    wheels = [f'wheel_{c}' for c in layout.labels]
    out = dict.fromkeys(objective_terms(layout), 0.0)
    out.update({t: 0.5 / len(chassis) for t in chassis})
    out.update({t: 0.5 / len(wheels) for t in wheels})
    return out


@dataclass(frozen=True)
class ObjectiveConfig:
    """``f = Σ w_k J_k / s_k`` (docs/model.md). ``normalization``: ``reference`` (s_k = J_k of the
    low-fidelity model at the initial design, by time marching), ``paper`` (0.1, 0.01, 1, 1;
    half car) or ``custom`` (``scales`` given). With several scenarios, ``aggregate`` combines
    their objectives: ``sum`` (Σ w_s f_s) or ``max`` (the worst case, in epigraph form)."""

    weights: dict[str, float] = field(default_factory=dict)
    normalization: str = field(
        default='reference',
        metadata={
            'doc': 'reference (s_k: J_k at the initial design), paper (its scales) or '
            'custom (`scales`)'
        },
    )
    scales: dict[str, float] = field(default_factory=dict)
    aggregate: str = field(
        default='sum',
        metadata={'doc': 'scenarios combined: sum (Σ w_s f_s) or max (the worst case)'},
    )


# ---------------------------------------------------------------------------- the rest
@dataclass(frozen=True)
class TranscriptionConfig:
    """Dymos Radau collocation grid (docs/model.md) and the states' initial guess. ``segments`` is
    a number or ``"auto"`` (:func:`suspopt.transcription.grid.auto_segments`)."""

    segments: Any = field(default=80, metadata={'doc': 'uniform segments, or "auto"'})
    order: int = field(
        default=5, metadata=_check('positive', doc='Radau nodes per segment (the paper: 5)')
    )
    initial_guess: str = field(
        default='auto',
        metadata={
            'doc': 'auto (zero for the half car, simulate for '
            "the mixed model), simulate (the half car's "
            'time marching at the start design) or zero'
        },
    )


#: the Lagrangian's Hessians the driver gives IPOPT: IPOPT's L-BFGS, the exact one
#: (:mod:`suspopt.driver.hessian`), or the choice by problem size
#: (``suspopt.transcription.problem.auto_hessian``)
HESSIANS = ('limited-memory', 'exact', 'auto')


@dataclass(frozen=True)
class OptimizerConfig:
    """IPOPT settings (defaults: IPOPT's own convergence criteria; the Hessian by problem
    size, docs/model.md)."""

    max_iter: int = field(default=500, metadata=_check('positive', doc="IPOPT's iteration limit"))
    tol: float = field(
        default=1e-8, metadata=_check('positive', doc="IPOPT's convergence tolerance")
    )
    print_level: int = field(default=0, metadata={'doc': "IPOPT's own console output (0-12)"})
    hessian: str = field(
        default='auto',
        metadata={
            'doc': "the Lagrangian's Hessian: 'limited-memory' (IPOPT's L-BFGS), 'exact' "
            "(second-order adjoints), or 'auto' (exact only where it pays: the "
            'low-fidelity half car on long grids)'
        },
    )
    options: dict[str, Any] = field(default_factory=dict, metadata={'doc': 'raw IPOPT options'})


@dataclass(frozen=True)
class MultibodyConfig:
    """Finite differencing of the black-box multibody module, and how its frame is
    coupled to the chassis (``mount``, see :mod:`suspopt.multibody.suspension`)."""

    fd_form: str = field(
        default='forward',
        metadata={'doc': "black box's finite differences: forward | central"},
    )
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
class Seat:
    """A seat on the chassis, where the ride comfort is measured (ISO 2631-1 Wk)."""

    name: str = field(default='driver', metadata={'doc': 'its name (the term comfort_<name>)'})
    x: float = field(
        default=0.0,
        metadata=_plausible(-10.0, 10.0, 'm', 'a seat position', doc='ahead of the CG [m]'),
    )
    y: float = field(
        default=0.0,
        metadata=_plausible(-3.0, 3.0, 'm', 'a seat position', doc='left of the CG [m]'),
    )


@dataclass(frozen=True)
class ComfortConfig:
    """The seats where the ISO 2631-1 frequency-weighted acceleration is measured (the
    terms ``comfort_<seat>``; ``docs/metrics.md``)."""

    seats: tuple[Seat, ...] = ()


#: the meaning of every constraint's ``enabled`` key
_ENABLED = "true when its table is given; false turns off a default car's constraint"


@dataclass(frozen=True)
class TravelConstraint:
    """The suspension travel (wheel relative to the body) within the stops, every node."""

    enabled: bool = field(default=False, metadata={'doc': _ENABLED})
    bump: float = field(
        default=0.0,
        metadata=_plausible(0.0, 1.0, 'm', 'a suspension travel', doc='bump travel [m]'),
    )
    rebound: float = field(
        default=0.0,
        metadata=_plausible(0.0, 1.0, 'm', 'a suspension travel', doc='rebound travel [m]'),
    )


@dataclass(frozen=True)
class TyreContactConstraint:
    """The tyre keeps at least ``margin`` of its static load, every node (no lift-off)."""

    enabled: bool = field(default=False, metadata={'doc': _ENABLED})
    margin: float = field(default=0.1, metadata={'doc': 'share of the static load kept'})


@dataclass(frozen=True)
class RollGradientConstraint:
    """The steady-state roll per g of lateral acceleration within [min, max] deg/g, and the
    front axle's share of the roll stiffness within ``front_share`` (full car)."""

    enabled: bool = field(default=False, metadata={'doc': _ENABLED})
    min: float = field(default=0.0, metadata={'doc': 'lower bound [deg/g] (0: none)'})
    max: float = field(default=0.0, metadata={'doc': 'upper bound [deg/g] (0: none)'})
    front_share: tuple[float, ...] = field(
        default=(), metadata={'doc': '[lower, upper] front share of the roll stiffness'}
    )


@dataclass(frozen=True)
class RideFrequencyConstraint:
    """The undamped heave and pitch frequencies of the sprung mass within bands [Hz]."""

    enabled: bool = field(default=False, metadata={'doc': _ENABLED})
    heave: tuple[float, ...] = field(default=(), metadata={'doc': '[lower, upper] [Hz]'})
    pitch: tuple[float, ...] = field(default=(), metadata={'doc': '[lower, upper] [Hz]'})


@dataclass(frozen=True)
class StabilityConstraint:
    """An active suspension's feedback law keeps the car stable: the slowest mode of the
    closed loop decays at least ``margin`` fast (a linear law: no force or power bound).
    On by default: the collocation can hide an unstable closed loop."""

    enabled: bool = field(
        default=True, metadata={'doc': 'false: no stability constraint on a feedback law'}
    )
    margin: float = field(
        default=0.0,
        metadata={'doc': 'least decay rate of the slowest mode (smoothed -max Re λ) [1/s]'},
    )


@dataclass(frozen=True)
class ConstraintsConfig:
    """Engineering constraints of the design (``docs/metrics.md``): each applies when its
    table is given."""

    travel: TravelConstraint = field(default_factory=TravelConstraint)
    tyre_contact: TyreContactConstraint = field(default_factory=TyreContactConstraint)
    roll_gradient: RollGradientConstraint = field(default_factory=RollGradientConstraint)
    ride_frequency: RideFrequencyConstraint = field(default_factory=RideFrequencyConstraint)
    stability: StabilityConstraint = field(default_factory=StabilityConstraint)


@dataclass(frozen=True)
class ScenarioConfig:
    """One load case: a road driven at a speed for a horizon on a grid, with a weight."""

    name: str = field(default='', metadata={'doc': 'its name in tables (default: its index)'})
    weight: float = field(default=1.0, metadata={'doc': 'w_s with aggregate = "sum"'})
    speed: float = field(default=0.0, metadata={'doc': "[m/s] (0: the maneuver's)"})
    horizon: float = field(default=0.0, metadata={'doc': "[s] (0: the maneuver's)"})
    road: dict[str, Any] = field(
        default_factory=dict, metadata={'doc': "a road table (empty: the study's road)"}
    )
    segments: Any = field(default=0, metadata={'doc': "grid (0: the transcription's)"})
    order: int = field(default=0, metadata={'doc': "Radau order (0: the transcription's)"})


@dataclass(frozen=True)
class StudyConfig:
    """Everything a study needs; the defaults reproduce the paper's case."""

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
    comfort: ComfortConfig = field(default_factory=ComfortConfig)
    constraints: ConstraintsConfig = field(default_factory=ConstraintsConfig)
    control: ControlConfig = field(default_factory=ControlConfig)
    scenario: tuple[ScenarioConfig, ...] = ()

    def layout(self) -> VehicleLayout:
        return self.vehicle.layout()

    def controlled(self) -> tuple[str, ...]:
        """The labels of the corners with an actuator (``[control]``)."""
        return self.control.controlled(self.layout().labels)

    def terms(self) -> tuple[str, ...]:
        return objective_terms(
            self.layout(), tuple(s.name for s in self.comfort.seats), self.controlled()
        )

    def design_names(self) -> tuple[str, ...]:
        return self.design.names

    def weights(self) -> tuple[float, ...]:
        """The objective weights in term order."""
        return tuple(self.objective.weights[t] for t in self.terms())

    def scenarios(self) -> tuple[Scenario, ...]:
        """The load cases, every value resolved, the grids included
        (:func:`suspopt.spec.resolve.scenarios`); resolved once per description."""
        cached = self.__dict__.get('_scenarios')
        if cached is None:
            cached = resolve_scenarios(self)
            object.__setattr__(self, '_scenarios', cached)
        return cached

    def road_profile(self) -> RoadProfile:
        return make_road(self.road)

    def to_dict(self) -> dict[str, Any]:
        """A plain (JSON/TOML-able) dictionary; :func:`config_from_dict` inverts it (a
        quarter car's has no keys of the corners and motions it does not have)."""
        out = _to_plain(self)
        if self.vehicle.model == 'quarter_car':
            out['vehicle'].pop('rear', None)
            out['vehicle'].pop('chassis_pitch_inertia', None)
        return out

    def replace(self, **changes: Any) -> StudyConfig:
        return dataclasses.replace(self, **changes)

    def with_weights(self, weights: dict[str, float]) -> StudyConfig:
        return dataclasses.replace(
            self,
            objective=dataclasses.replace(
                self.objective, weights={t: float(weights.get(t, 0.0)) for t in self.terms()}
            ),
        )


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
