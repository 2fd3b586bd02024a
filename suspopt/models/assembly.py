"""The vehicle assembly: the one description of a vehicle model from which both the
collocation's OpenMDAO ODE (:class:`suspopt.models.vehicle.VehicleODE`) and the time
marching's right-hand side (:class:`AssemblyEvaluator`) are built (``docs/model.md``).

A model is an ordered list of :class:`Block` — one component per physical equation
(paper eqs. 5-13 and beyond), with the names its inputs and outputs take in the vehicle —
and its states (:class:`State`: what Dymos integrates). Every component computes its
outputs in :meth:`~suspopt.models.base.NodeComponent.evaluate`, which OpenMDAO's
``compute`` and the time marching both call, so a new force, metric or mount is written
once, here. The time-marching verification is therefore independent of the collocation's
discretization and integrator, not of the equations.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from suspopt.models.chassis import ChassisHeaveComp, ChassisPitchComp, ChassisRollComp
from suspopt.models.comfort import SeatAccelerationComp, WeightingFilterComp
from suspopt.models.control import (
    ActiveForceComp,
    LinearFeedbackComp,
    SkyGroundhookComp,
    StrutRateComp,
    VariableDamperComp,
)
from suspopt.models.design import KINDS, design_id
from suspopt.models.forces import (
    AntiRollBarComp,
    MountMotionComp,
    SuspensionForceComp,
    TyreForceComp,
    WheelLoadComp,
)
from suspopt.models.iso2631 import WK_RIDE, filter_bank
from suspopt.models.layout import VehicleLayout
from suspopt.models.metric_components import (
    SquaredSignalsComp,
    SuspensionTravelComp,
    TyreLoadRatioComp,
)
from suspopt.models.mount import ChassisMountComp, MountResponseComp, MountRotationComp
from suspopt.models.nonlinear_forces import NonlinearSuspensionForceComp
from suspopt.models.road_input import RoadInputComp
from suspopt.models.settings import SuspensionSettingsComp
from suspopt.models.wheel import WheelDynamicsComp
from suspopt.multibody.components import (
    ChassisMountDynamicsComp,
    SuspensionDynamicsComp,
    SuspensionKinematicsComp,
)

#: the two models of the paper: the low-fidelity vehicle, and the mixed-fidelity one
#: with a multibody module at every corner
FIDELITIES = ('low', 'mixed')


@dataclass(frozen=True)
class ControlSpec:
    """A controlled suspension (``docs/codesign.md``), plain values: ``kind`` ``active``
    or ``semi_active``, ``law`` ``open_loop`` or ``feedback``, the controlled corners'
    indices, the bounds (0: none) and the NLP's scale of an active force."""

    kind: str
    law: str
    corners: tuple[int, ...]
    force_max: float = 0.0
    power_max: float = 0.0
    c_min: float = 0.0
    c_max: float = 0.0
    force_scale: float = 1000.0
    smoothing: float = 0.02
    velocity_floor: float = 0.005

    @property
    def control(self) -> str:
        """The name of the control signal: ``u_A`` (a force) or ``c_A`` (a damping)."""
        return 'u_A' if self.kind == 'active' else 'c_A'


@dataclass(frozen=True)
class Control:
    """A time-varying optimization variable of the model (a Dymos control), one value per
    controlled corner at every node: its units, bounds (None: none) and the NLP's scaling
    (``ref0``, ``ref``: the values that map to 0 and 1), and the value it starts from."""

    name: str
    units: str
    shape: tuple[int, ...]
    lower: float | None
    upper: float | None
    ref0: float
    ref: float
    initial: float = 0.0


@dataclass(frozen=True)
class PathBound:
    """A signal of the model bounded at every node (a path constraint): its bounds and a
    typical magnitude ``ref`` (scales the NLP, changes no result)."""

    signal: str
    units: str
    lower: float | None
    upper: float | None
    ref: float


@dataclass(frozen=True)
class VehicleSpec:
    """Everything the model of one vehicle in one scenario needs (plain values)."""

    layout: VehicleLayout
    M: float
    I: float
    I_x: float
    m: np.ndarray
    k_T: np.ndarray
    design: tuple[str, ...]
    bars: tuple[tuple[int, ...], tuple[int, ...], tuple[float, ...]]
    tracks: tuple
    speed: float
    modules: tuple = ()
    fd_form: str = 'forward'
    fd_step: float = 1e-6
    mount: str = 'ground'
    #: the static tyre load per corner [N] (the tyre-contact metric)
    static_load: np.ndarray | None = None
    #: the seats where comfort is measured: (name, x ahead of, y left of the CG [m])
    seats: tuple[tuple[str, float, float], ...] = ()
    #: an active or semi-active suspension at some corners (None: passive)
    control: ControlSpec | None = None

    #: each corner's suspension hardware as curves (a :class:`~suspopt.curves.
    #: SpringDamperUnit`; None: the linear spring and damper); () every corner linear
    units: tuple = ()

    @property
    def has_curves(self) -> bool:
        """Whether some corner's hardware has curves (the low fidelity is then nonlinear)."""
        return any(u is not None for u in self.units)

    @property
    def curve_settings(self) -> tuple[str, ...]:
        """The curve parameters that are design variables (``c_bump_low``, ...), in the
        design's order: the curves' inputs (signals ``curve_<parameter>``)."""
        kinds = (design_id(n).kind for n in self.design)
        return tuple(dict.fromkeys(k.symbol for k in kinds if k.slot))

    def curve_defaults(self) -> dict[str, np.ndarray]:
        """The hardware's value of each of :attr:`curve_settings` at every corner (0 where
        a corner's hardware lacks the parameter): the corners no variable sets."""
        out = {}
        for p in self.curve_settings:
            values = [
                0.0 if u is None else u.scalar_parameters().get(p, 0.0) for u in self.units
            ] or [0.0] * self.layout.n
            out[KINDS[p].setting] = np.array(values)
        return out

    @property
    def chassis_states(self) -> tuple[str, ...]:
        lay = self.layout
        return (
            ('z_C', 'v_C')
            + (('theta_C', 'omega_C') if lay.has_pitch else ())
            + (('phi_C', 'p_C') if lay.has_roll else ())
        )

    @property
    def side(self) -> np.ndarray:
        return np.array([c.side for c in self.layout.corners], dtype=float)


@dataclass(frozen=True)
class State:
    """A state of the model: its rate (a signal of the assembly), units, a typical
    magnitude ``ref`` (scales the NLP, changes no result) and its shape at one node."""

    name: str
    rate: str
    units: str
    ref: float
    shape: tuple[int, ...]
    #: one value per node (the chassis' states; (N,) arrays), not a vector per node
    scalar: bool = False


class Evaluates(Protocol):
    """What a block's component offers beyond OpenMDAO: its equation as a function."""

    def evaluate(self, inputs: Mapping[str, Any]) -> dict[str, np.ndarray]: ...


@dataclass(frozen=True)
class Block:
    """One equation of the vehicle: a component made for a number of nodes, and the names
    of those of its inputs and outputs that are called otherwise in the vehicle
    (``(local, vehicle)`` pairs; every other one keeps its own name)."""

    name: str
    make: Callable[[int], Any]
    inputs: tuple[tuple[str, str], ...] = ()
    outputs: tuple[tuple[str, str], ...] = ()


@dataclass(frozen=True)
class VehicleAssembly:
    """A vehicle model: its blocks in evaluation order, its states and the signals a
    trajectory records (:func:`assemble`)."""

    spec: VehicleSpec
    fidelity: str
    blocks: tuple[Block, ...]
    states: tuple[State, ...]
    timeseries: tuple[str, ...]
    #: the time-varying optimization variables (an open-loop control), given as signals
    controls: tuple[Control, ...] = ()
    #: the signals bounded at every node (an actuator's force or power)
    path_bounds: tuple[PathBound, ...] = ()

    @property
    def wheel_signal(self) -> str:
        """The wheel's vertical displacement: the state (low) or the linkage's output."""
        return 'q_W' if self.fidelity == 'mixed' else 'z_W'


def states(spec: VehicleSpec) -> tuple[State, ...]:
    """The states (paper eq. 2): the chassis' heave, pitch (and roll) and every wheel's
    travel, each with its rate; ``ref`` is a typical magnitude over a road feature of a
    few centimetres."""
    nc = (spec.layout.n,)
    out = [
        State('z_C', 'v_C', 'm', 0.02, (1,), scalar=True),
        State('v_C', 'zdd_C', 'm/s', 0.2, (1,), scalar=True),
    ]
    if spec.layout.has_pitch:
        out += [
            State('theta_C', 'omega_C', 'rad', 0.01, (1,), scalar=True),
            State('omega_C', 'thdd_C', 'rad/s', 0.2, (1,), scalar=True),
        ]
    if spec.layout.has_roll:
        out += [
            State('phi_C', 'p_C', 'rad', 0.01, (1,), scalar=True),
            State('p_C', 'phidd_C', 'rad/s', 0.2, (1,), scalar=True),
        ]
    out += [State('z_W', 'v_W', 'm', 0.05, nc), State('v_W', 'zdd_W', 'm/s', 1.0, nc)]
    if spec.seats:  # the seats' ISO 2631-1 filters, states of the size of the acceleration
        n = filter_bank([WK_RIDE] * len(spec.seats)).n_states
        out.append(State('x_w', 'x_w_dot', 'm/s**2', 1.0, (n,)))
    return tuple(out)


def assemble(spec: VehicleSpec, fidelity: str) -> VehicleAssembly:
    """The vehicle model of ``spec`` in ``fidelity``: road, settings, the chassis above the
    corners, the suspension and wheels (low fidelity: eqs. 7-10; mixed: a multibody module
    per corner, eqs. 11-13, mounted on the ground or on the chassis), the chassis (eqs. 5-6,
    roll) and the objective's integrands (eq. 4)."""
    if fidelity not in FIDELITIES:
        raise ValueError(f'fidelity must be one of {FIDELITIES}, got {fidelity!r}')
    blocks = list(_common(spec))
    if fidelity == 'low':
        blocks += _low_fidelity(spec)
    elif spec.mount == 'chassis':
        blocks += _chassis_mounted(spec)
    else:
        blocks += _ground_mounted(spec)
    blocks += _metrics(spec, 'q_W' if fidelity == 'mixed' else 'z_W')
    return VehicleAssembly(
        spec=spec,
        fidelity=fidelity,
        blocks=tuple(blocks),
        states=states(spec),
        timeseries=_timeseries(spec, fidelity),
        controls=controls(spec),
        path_bounds=path_bounds(spec),
    )


def controls(spec: VehicleSpec) -> tuple[Control, ...]:
    """The open-loop control of ``spec`` (none for a feedback law or a passive car): an
    actuator force per controlled corner (scaled by ``force_scale``, bounded by
    ``force_max``), or a damping in ``[c_min, c_max]`` (scaled to [0, 1])."""
    c = spec.control
    if c is None or c.law != 'open_loop':
        return ()
    shape = (len(c.corners),)
    if c.kind == 'active':
        bound = c.force_max or None
        return (
            Control('u_A', 'N', shape, -bound if bound else None, bound, 0.0, c.force_scale, 0.0),
        )
    return (Control('c_A', 'N*s/m', shape, c.c_min, c.c_max, c.c_min, c.c_max, c.c_min),)


def path_bounds(spec: VehicleSpec) -> tuple[PathBound, ...]:
    """The actuator's bounds at every node: its power ``|P_A| <= power_max``; an active
    force ``|u_F| <= force_max`` where a feedback law gives it (an open-loop force has the
    bound on the control itself), a semi-active one's where given."""
    c = spec.control
    if c is None:
        return ()
    out = []
    bounded_by_control = c.kind == 'active' and c.law == 'open_loop'
    if c.force_max and not bounded_by_control:
        out.append(PathBound('u_F', 'N', -c.force_max, c.force_max, c.force_max))
    if c.power_max:
        out.append(PathBound('P_A', 'W', -c.power_max, c.power_max, c.power_max))
    return tuple(out)


def _timeseries(spec: VehicleSpec, fidelity: str) -> tuple[str, ...]:
    """Signals recorded along the trajectory (beyond the states)."""
    chassis = _accelerations(spec)
    forces = ('zdd_W', 'F_S', 'F_T', 'delta', 'z_M') + (('F_R',) if spec.bars[0] else ())
    mixed: tuple[str, ...] = ('q_W', 'reactions') if fidelity == 'mixed' else ()
    if fidelity == 'mixed' and spec.mount == 'chassis':
        mixed += ('F_M',)
    metrics = ('travel',) + (('tyre_load_ratio',) if spec.static_load is not None else ())
    control: tuple[str, ...] = ()
    if spec.control is not None:
        control = ('F_A', 'u_F', 'P_A', 'v_A')
        if spec.control.law == 'feedback':  # an open-loop control is in the timeseries already
            control += (spec.control.control,)
    return chassis + forces + mixed + metrics + (('a_w',) if spec.seats else ()) + control


def _kw(spec: VehicleSpec, nn: int) -> dict[str, int]:
    return {'num_nodes': nn, 'corners': spec.layout.n}


def _dofs(spec: VehicleSpec) -> dict[str, bool]:
    """The chassis' rotations, as the components' options."""
    return {'pitch': spec.layout.has_pitch, 'roll': spec.layout.has_roll}


def _accelerations(spec: VehicleSpec) -> tuple[str, ...]:
    """The chassis' accelerations: heave[, pitch][, roll]."""
    names = {'heave': 'zdd_C', 'pitch': 'thdd_C', 'roll': 'phidd_C'}
    return tuple(names[d] for d in spec.layout.dofs)


def integrand_signals(spec: VehicleSpec, wheel: str) -> tuple[tuple[str, str, int], ...]:
    """The metric signals whose squares are the objective's integrands, in the order of
    :func:`suspopt.models.metrics.objective_terms`: (vehicle signal, units, columns; 0 for
    one value per node)."""
    nc = spec.layout.n
    units = {'zdd_C': 'm/s**2', 'thdd_C': 'rad/s**2', 'phidd_C': 'rad/s**2'}
    out = [(a, units[a], 0) for a in _accelerations(spec)]
    out += [(wheel, 'm', nc), ('F_T', 'N', nc), ('travel', 'm', nc)]
    if spec.seats:
        out.append(('a_w', 'm/s**2', len(spec.seats)))
    if spec.control is not None:
        out.append(('u_F', 'N', len(spec.control.corners)))
    return tuple(out)


def _metrics(spec: VehicleSpec, wheel: str) -> list[Block]:
    """The ride metrics (:mod:`suspopt.models.metrics`) and the objective's integrands."""
    blocks = [
        Block(
            'travel',
            lambda nn: SuspensionTravelComp(**_kw(spec, nn)),
            inputs=(('wheel_z', wheel),),
        )
    ]
    static = spec.static_load
    if static is not None:
        blocks.append(
            Block('tyre_load_ratio', lambda nn: TyreLoadRatioComp(static=static, **_kw(spec, nn)))
        )
    if spec.seats:
        x = np.array([s[1] for s in spec.seats])
        y = np.array([s[2] for s in spec.seats])
        weightings = (WK_RIDE,) * len(spec.seats)
        blocks += [
            Block(
                'seats',
                lambda nn: SeatAccelerationComp(num_nodes=nn, x=x, y=y, **_dofs(spec)),
            ),
            Block(
                'comfort_filter',
                lambda nn: WeightingFilterComp(num_nodes=nn, weightings=weightings),
                inputs=(('signal', 'a_seat'), ('filter_x', 'x_w')),
                outputs=(('filter_x_dot', 'x_w_dot'), ('weighted', 'a_w')),
            ),
        ]
    signals = integrand_signals(spec, wheel)
    blocks.append(
        Block(
            'objective_integrand',
            lambda nn: SquaredSignalsComp(signals=signals, **_kw(spec, nn)),
            inputs=((wheel, wheel),),
        )
    )
    return blocks


def _common(spec: VehicleSpec) -> Iterator[Block]:
    lay = spec.layout
    yield Block(
        'road',
        lambda nn: RoadInputComp(
            num_nodes=nn,
            tracks=spec.tracks,
            speed=spec.speed,
            offsets=lay.offsets(),
            track_of=tuple(c.track for c in lay.corners),
        ),
    )
    yield Block(
        'settings',
        lambda nn: SuspensionSettingsComp(
            design=spec.design, labels=lay.labels, curve_defaults=spec.curve_defaults()
        ),
    )
    yield Block(
        'mount',
        lambda nn: MountMotionComp(a=lay.a, y=lay.y, **_dofs(spec), **_kw(spec, nn)),
    )


def _anti_roll(spec: VehicleSpec, wheel: str) -> Iterator[Block]:
    left, right, track = spec.bars
    if left:
        yield Block(
            'anti_roll',
            lambda nn: AntiRollBarComp(left=left, right=right, track=track, **_kw(spec, nn)),
            inputs=(('z_W', wheel),),
        )


def _forces(spec: VehicleSpec, *names: str) -> tuple[str, ...]:
    """The suspension's forces on the chassis per corner: ``names`` and the bars'."""
    return names + (('F_R',) if spec.bars[0] else ())


def _control(spec: VehicleSpec, wheel: str, wheel_v: str) -> Iterator[Block]:
    """The controlled suspension (:mod:`suspopt.models.control`): the feedback law, if any,
    then the actuator or variable damper. ``wheel``, ``wheel_v``: the signals of the
    wheel's displacement and velocity (the feedback's measurements)."""
    c = spec.control
    if c is None:
        return

    def kw(nn: int) -> dict[str, Any]:
        return {'controlled': c.corners, **_kw(spec, nn)}

    measured = (('wheel_z', wheel), ('wheel_v', wheel_v))
    if c.law == 'feedback' and c.kind == 'active':
        yield Block('feedback', lambda nn: LinearFeedbackComp(**kw(nn)), inputs=measured)
    elif c.law == 'feedback':
        yield Block(
            'feedback',
            lambda nn: SkyGroundhookComp(
                c_min=c.c_min,
                c_max=c.c_max,
                smoothing=c.smoothing,
                velocity_floor=c.velocity_floor,
                **kw(nn),
            ),
            inputs=measured[1:],
        )
    if c.kind == 'active':
        limits = (-c.force_max, c.force_max) if c.force_max else None
        yield Block('actuator', lambda nn: ActiveForceComp(limits=limits, **kw(nn)))
    else:
        yield Block('actuator', lambda nn: VariableDamperComp(limits=(c.c_min, c.c_max), **kw(nn)))


def _chassis(spec: VehicleSpec, forces: tuple[str, ...]) -> Iterator[Block]:
    lay = spec.layout
    yield Block(
        'chassis_heave', lambda nn: ChassisHeaveComp(M=spec.M, forces=forces, **_kw(spec, nn))
    )
    if lay.has_pitch:
        yield Block(
            'chassis_pitch',
            lambda nn: ChassisPitchComp(a=lay.a, I=spec.I, forces=forces, **_kw(spec, nn)),
        )
    if lay.has_roll:
        yield Block(
            'chassis_roll',
            lambda nn: ChassisRollComp(y=lay.y, I_x=spec.I_x, forces=forces, **_kw(spec, nn)),
        )


def _curve_inputs(spec: VehicleSpec) -> tuple[tuple[str, str], ...]:
    """The curve parameters' inputs under their signals' names (``curve_<parameter>``)."""
    return tuple((p, KINDS[p].setting) for p in spec.curve_settings)


def _suspension(spec: VehicleSpec) -> Block:
    """Eq. 9: the linear spring and damper, or, where a corner has curves, the curves
    (``docs/nonlinear_hardware.md``) with the design's parameters as inputs."""
    if not spec.has_curves:
        return Block('suspension', lambda nn: SuspensionForceComp(**_kw(spec, nn)))
    rates = tuple(
        n for n in ('k_S', 'c_S') if any(u is None or n in u.parameter_values() for u in spec.units)
    )
    settings = rates + spec.curve_settings
    return Block(
        'suspension',
        lambda nn: NonlinearSuspensionForceComp(
            units=spec.units, settings=settings, **_kw(spec, nn)
        ),
        inputs=_curve_inputs(spec),
    )


def _low_fidelity(spec: VehicleSpec) -> list[Block]:
    """The low-fidelity suspension and wheels: eqs. 9, 10, 7-8 (and the bars, and an
    actuator in parallel with the spring-damper)."""
    actuated = spec.control is not None
    forces = _forces(spec, 'F_S', *(('F_A',) if actuated else ()))
    return [
        _suspension(spec),
        *([Block('strut_rate', lambda nn: StrutRateComp(**_kw(spec, nn)))] if actuated else []),
        *_control(spec, 'z_W', 'v_W'),
        *_anti_roll(spec, 'z_W'),
        Block('tyre', lambda nn: TyreForceComp(k_T=spec.k_T, **_kw(spec, nn))),
        Block('wheel', lambda nn: WheelDynamicsComp(m=spec.m, forces=forces, **_kw(spec, nn))),
        *_chassis(spec, forces),
    ]


def _black_box(spec: VehicleSpec) -> dict[str, Any]:
    """The multibody modules' options: their finite differences and, for a controlled
    car, a Hessian without their own curvature (``docs/codesign.md``)."""
    return {
        'modules': spec.modules,
        'fd_form': spec.fd_form,
        'fd_step': spec.fd_step,
        **({'hessian_frozen': True} if spec.control is not None else {}),
    }


def _actuated(spec: VehicleSpec) -> dict[str, Any]:
    """The multibody queries' option: an actuator force along the spring-damper's line."""
    return {'actuator': True} if spec.control is not None else {}


def _black_box_settings(spec: VehicleSpec) -> dict[str, Any]:
    """The dynamic analysis' curve settings: the design's curve parameters (the others
    keep the modules' values; each one an input costs a batched call per Jacobian)."""
    return {'curve_settings': spec.curve_settings}


def _linkage_kinematics(spec: VehicleSpec) -> Iterator[Block]:
    """The multibody modules' position and velocity analysis (black box), the tyre
    (eq. 13) and the wheel load the linkage carries."""
    lay = spec.layout
    chassis = spec.mount == 'chassis'
    if chassis and lay.has_roll:
        yield Block('mount_rotation', lambda nn: MountRotationComp(side=spec.side, **_kw(spec, nn)))
    yield Block(
        'kinematics',
        lambda nn: SuspensionKinematicsComp(
            mount=spec.mount,
            roll=lay.has_roll,
            **_black_box(spec),
            **_kw(spec, nn),
            **({'strut_rate': True} if spec.control is not None else {}),
        ),
    )
    yield from _anti_roll(spec, 'q_W')
    yield Block(
        'tyre', lambda nn: TyreForceComp(k_T=spec.k_T, **_kw(spec, nn)), inputs=(('z_W', 'q_W'),)
    )
    if spec.bars[0]:
        yield Block('wheel_load', lambda nn: WheelLoadComp(**_kw(spec, nn)))
    # the actuator acts along the linkage's spring-damper (the black box's input F_A)
    yield from _control(spec, 'q_W', 'qd_W')


def _wheel_load(spec: VehicleSpec) -> tuple[tuple[str, str], ...]:
    return (('F_T', 'F_W'),) if spec.bars[0] else ()


def _ground_mounted(spec: VehicleSpec) -> list[Block]:
    """Mixed fidelity, the paper's coupling (frame on the ground): the dynamic analysis
    (eq. 11) gives the wheel travel's acceleration and the spring force of eq. 12."""
    return [
        *_linkage_kinematics(spec),
        Block(
            'dynamics',
            lambda nn: SuspensionDynamicsComp(
                **_black_box(spec), **_black_box_settings(spec), **_kw(spec, nn), **_actuated(spec)
            ),
            inputs=_wheel_load(spec) + _curve_inputs(spec),
        ),
        *_chassis(spec, _forces(spec, 'F_S')),
    ]


def _chassis_mounted(spec: VehicleSpec) -> list[Block]:
    """Mixed fidelity with every frame on the chassis: the modules' response at zero and
    per unit mount acceleration, the chassis solved with the linkage's reactions, then the
    modules' outputs at the solved accelerations (:mod:`suspopt.models.mount`)."""
    lay = spec.layout
    roll = lay.has_roll
    width = ChassisMountDynamicsComp(modules=spec.modules, num_nodes=1).width
    mount = {'a': lay.a, 'y': lay.y, 'side': spec.side, 'width': width, **_dofs(spec)}
    forces = _forces(spec)
    return [
        *_linkage_kinematics(spec),
        Block(
            'dynamics',
            lambda nn: ChassisMountDynamicsComp(
                roll=roll,
                **_black_box(spec),
                **_black_box_settings(spec),
                **_kw(spec, nn),
                **_actuated(spec),
            ),
            inputs=_wheel_load(spec) + _curve_inputs(spec),
        ),
        Block(
            'chassis',
            lambda nn: ChassisMountComp(
                M=spec.M, I=spec.I, I_x=spec.I_x, forces=forces, **mount, **_kw(spec, nn)
            ),
        ),
        Block('mount_response', lambda nn: MountResponseComp(**mount, **_kw(spec, nn))),
    ]


class _Signals(Mapping[str, Any]):
    """A block's view of the vehicle's signals, under the block's own input names."""

    def __init__(self, signals: Mapping[str, Any], names: Mapping[str, str]):
        self._signals, self._names = signals, names

    def __getitem__(self, key: str) -> Any:
        return self._signals[self._names.get(key, key)]

    def __iter__(self) -> Iterator[str]:
        return iter(self._signals)

    def __len__(self) -> int:
        return len(self._signals)


def constraint_residual(assembly: VehicleAssembly, values: Mapping[str, Any]) -> float:
    """Largest position-constraint violation [m] of the multibody modules along states
    ``values`` (the chassis' and the wheels'), their mounts' poses from the assembly's own
    blocks."""
    signals = dict(values)
    for block in assembly.blocks:
        if block.name in ('mount', 'mount_rotation', 'kinematics'):
            comp = block.make(1)
            view = _Signals(signals, dict(block.inputs))
            if block.name == 'kinematics':
                return float(comp.constraint_residual(view))
            signals.update(comp.evaluate(view))
    raise ValueError('the assembly has no multibody modules')


class AssemblyEvaluator:
    """The vehicle assembly as a function of its signals: given the states (chassis (N,),
    per corner (N, corners)), ``time`` (N,) and the design variables, every block's
    equation in order adds its outputs (the time marching's right-hand side). The blocks
    named in ``skip`` are left out (their outputs are then given, e.g. the road's)."""

    def __init__(self, assembly: VehicleAssembly, skip: tuple[str, ...] = ()):
        self.assembly = assembly
        self._steps = [
            (block.make(1), dict(block.inputs), dict(block.outputs))
            for block in assembly.blocks
            if block.name not in skip
        ]

    def __call__(self, signals: dict[str, Any]) -> dict[str, Any]:
        for comp, inputs, outputs in self._steps:
            for name, value in comp.evaluate(_Signals(signals, inputs)).items():
                signals[outputs.get(name, name)] = value
        return signals

    def components(self) -> Iterator[Any]:
        """The blocks' components (one instance each, shared by every call)."""
        return (comp for comp, _, _ in self._steps)
