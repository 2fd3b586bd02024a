"""The fastest mode of a study's vehicle, and the plausibility and cost checks on it
(``docs/commands.md``, "What is refused before any work").

A road vehicle's fastest motion is the wheel hop (the unsprung mass on the tyre and the
suspension): the automatic grid is sized on it (:mod:`suspopt.spec.resolve`) and the
time marching's explicit integrator steps at its pace. A parameter that makes another
mode much faster — a roll inertia typed in the wrong unit, a damping bound far above the
wheel's mass — makes the model stiff: the verification's integrator then needs millions
of steps and IPOPT's factorizations grow, long before anything is wrong in the result.

:func:`mode_problems` reads the low-fidelity vehicle's tangent state matrix off the
vehicle assembly (:mod:`suspopt.models.assembly`, the equations the collocation and the
time marching solve) at the stiffest corner of the design box (every design variable at
its upper bound) and at the initial design, takes its eigenvalues (NumPy's ``eig``),
and refuses the car as described (the initial design) if its fastest mode is more than
:data:`MAX_MODE_RATIO` times the stiffest wheel hop
(:func:`~suspopt.spec.resolve.wheel_hop_frequency`), and a design box whose stiffest
corner would take the time marching more than :data:`MAX_MARCHING_STEPS` steps. The
message names the parameters that make the mode fast: those whose 1 % change moves it
most (its elasticities).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from suspopt.models.assembly import AssemblyEvaluator, VehicleSpec, assemble
from suspopt.models.metrics import static_loads
from suspopt.road import road_tracks
from suspopt.spec.resolve import Scenario, wheel_hop_frequency
from suspopt.spec.schema import AxleConfig, StudyConfig, VehicleConfig

#: the car's fastest mode may be this many times the stiffest wheel hop (the default
#: cars': about 1)
MAX_MODE_RATIO = 3.0
#: the verification's explicit integrator (DOP853) is stable for steps h |λ| below about
#: this (its stability region on the negative real axis)
DOP853_STABILITY = 6.0
#: the most steps the time marching of one scenario may need at the fastest mode
MAX_MARCHING_STEPS = 1_000_000
#: relative change of a parameter to find its effect on the fastest mode
ELASTICITY_STEP = 0.01
#: the positions of the chassis and what each one's mode is called
CHASSIS = {'z_C': 'heave', 'theta_C': 'pitch', 'phi_C': 'roll'}


@dataclass(frozen=True)
class Mode:
    """One eigenvalue ``lam`` [1/s] of the vehicle, and the motion it mostly is
    (``heave``, ``pitch``, ``roll`` or ``wheel <corner>``)."""

    lam: complex
    motion: str

    @property
    def rate(self) -> float:
        """|λ| [1/s]: how fast the mode is (its frequency times 2π if undamped)."""
        return abs(self.lam)

    def describe(self) -> str:
        kind = (
            f'oscillating at {abs(self.lam.imag) / (2 * math.pi):.3g} Hz'
            if abs(self.lam.imag) > 1e-9 * abs(self.lam)
            else 'overdamped'
        )
        return f'a {self.motion} mode, |λ| = {self.rate:.3g} 1/s, {kind}'


def passive_vehicle_spec(config: StudyConfig, scenario: Scenario) -> VehicleSpec:
    """The passive, linear low-fidelity vehicle of ``config`` in ``scenario``: its masses,
    tyres, bars, roads and static loads (:func:`suspopt.transcription.vehicle.vehicle_spec`
    adds the multibody modules, the seats, the hardware curves and a control)."""
    v = config.vehicle
    lay = v.layout()
    axles = v.axles
    pairs = lay.anti_roll_pairs(tuple(i for i, ax in enumerate(axles) if ax.anti_roll_bar))
    wheel_mass = np.array([axles[c.axle].wheel_mass for c in lay.corners])
    return VehicleSpec(
        layout=lay,
        M=v.chassis_mass,
        I=v.chassis_pitch_inertia,
        I_x=v.chassis_roll_inertia,
        m=wheel_mass,
        k_T=np.array([axles[c.axle].tyre_stiffness for c in lay.corners]),
        design=config.design_names(),
        bars=(
            tuple(p[1] for p in pairs),
            tuple(p[2] for p in pairs),
            tuple(axles[p[0]].track for p in pairs),
        ),
        tracks=road_tracks(scenario.road, lay.n_tracks, lay.track_separation()),
        speed=float(scenario.speed),
        static_load=static_loads(lay, v.chassis_mass, wheel_mass),
    )


def modes(config: StudyConfig, design: dict[str, float]) -> list[Mode]:
    """The eigenvalues of the low-fidelity vehicle (its chassis and wheels) linearized at
    the static position at ``design``, fastest first."""
    spec = passive_vehicle_spec(config, config.scenarios()[0])
    assembly = assemble(spec, 'low')
    evaluate = AssemblyEvaluator(assembly, skip=('road',))
    sizes = [int(np.prod(s.shape)) for s in assembly.states]
    refs = np.concatenate([np.full(n, s.ref) for s, n in zip(assembly.states, sizes)])
    n, nc = len(refs), spec.layout.n
    h = 1e-6 * refs
    X = np.concatenate([np.zeros((n, 1)), np.diag(h)], axis=1)
    K = n + 1
    signals: dict[str, Any] = {
        'time': np.zeros(K),
        'delta': np.zeros((K, nc)),
        **{name: np.array([float(design[name])]) for name in spec.design},
    }
    k = 0
    for st, size in zip(assembly.states, sizes):
        block = X[k : k + size]
        signals[st.name] = block[0] if st.scalar else block.T
        k += size
    evaluate(signals)
    rates = np.concatenate(
        [np.reshape(signals[st.rate], (K, -1)) for st in assembly.states], axis=1
    ).T
    A = (rates[:, 1:] - rates[:, :1]) / h
    labels: list[str] = []
    for st in assembly.states:
        labels += [st.name] if st.scalar else [f'{st.name}[{c}]' for c in spec.layout.labels]
    inertia = {'z_C': spec.M, 'theta_C': spec.I, 'phi_C': spec.I_x}
    positions = [
        (i, inertia[lab], CHASSIS[lab])
        if lab in inertia
        else (i, float(spec.m[spec.layout.labels.index(lab[4:-1])]), f'wheel {lab[4:-1]}')
        for i, lab in enumerate(labels)
        if lab in inertia or lab.startswith('z_W[')
    ]
    lam, vectors = np.linalg.eig(A)
    out = []
    for j in np.argsort(-np.abs(lam)):
        energy = [m * abs(vectors[i, j]) ** 2 for i, m, _ in positions]
        out.append(Mode(complex(lam[j]), positions[int(np.argmax(energy))][2]))
    return out


def _parameters(config: StudyConfig) -> dict[str, tuple[str, float]]:
    """The vehicle's and the design box's parameters a mode depends on: key → (unit,
    value) (the design variables at their upper bounds)."""
    v = config.vehicle
    out = {
        'vehicle.chassis_mass': ('kg', v.chassis_mass),
        'vehicle.chassis_pitch_inertia': ('kg m^2', v.chassis_pitch_inertia),
        'vehicle.chassis_roll_inertia': ('kg m^2', v.chassis_roll_inertia),
    }
    axles = ('front',) if v.model == 'quarter_car' else ('front', 'rear')
    for axle in axles:
        ax = getattr(v, axle)
        out[f'vehicle.{axle}.wheel_mass'] = ('kg', ax.wheel_mass)
        out[f'vehicle.{axle}.tyre_stiffness'] = ('N/m', ax.tyre_stiffness)
    for name, dv in config.design.variables.items():
        out[f'design.{name}.upper'] = ('', dv.upper)
    return {k: (u, x) for k, (u, x) in out.items() if x > 0.0}


def _scaled(config: StudyConfig, key: str, factor: float) -> StudyConfig:
    """``config`` with the parameter ``key`` (of :func:`_parameters`) times ``factor``."""
    parts = key.split('.')
    if parts[0] == 'design':
        dv = config.design[parts[1]]
        variables = {
            **config.design.variables,
            parts[1]: dataclasses.replace(dv, upper=dv.upper * factor),
        }
        return config.replace(design=dataclasses.replace(config.design, variables=variables))
    v: VehicleConfig = config.vehicle
    if len(parts) == 2:
        return config.replace(
            vehicle=dataclasses.replace(v, **{parts[1]: getattr(v, parts[1]) * factor})
        )
    ax: AxleConfig = getattr(v, parts[1])
    ax = dataclasses.replace(ax, **{parts[2]: getattr(ax, parts[2]) * factor})
    axle: dict[str, Any] = {parts[1]: ax}
    return config.replace(vehicle=dataclasses.replace(v, **axle))


def _stiffest(config: StudyConfig) -> dict[str, float]:
    return {n: dv.upper for n, dv in config.design.variables.items()}


def responsible(
    config: StudyConfig, rate: float, upper: bool, keys: tuple[str, ...] | None = None
) -> list[tuple[str, float]]:
    """The parameters that make the fastest mode (|λ| = ``rate`` at the initial design,
    or with ``upper`` at the design upper bounds) fast, most first: (key, elasticity
    d ln|λ| / d ln p), those above 0.2 in size."""
    out = []
    for key in keys or tuple(_parameters(config)):
        other = _scaled(config, key, 1.0 + ELASTICITY_STEP)
        design = _stiffest(other) if upper else other.design.initial()
        faster = modes(other, design)[0].rate
        e = math.log(faster / rate) / math.log1p(ELASTICITY_STEP)
        if abs(e) > 0.2:
            out.append((key, e))
    return sorted(out, key=lambda ke: -abs(ke[1]))


def mode_problems(config: StudyConfig) -> list[str]:
    """Why the vehicle's fastest mode is implausible (at the initial design: the car as
    described) or too costly to integrate (at the design upper bounds, where IPOPT may
    go); empty if it is neither. One line naming the parameter most responsible."""
    params = _parameters(config)
    hop = 2.0 * math.pi * wheel_hop_frequency(config)
    car = modes(config, config.design.initial())[0]
    if car.rate > MAX_MODE_RATIO * hop:
        vehicle = tuple(k for k in params if k.startswith('vehicle.'))
        blamed = responsible(config, car.rate, False, vehicle)[:1] or [(vehicle[0], 0.0)]
        key = blamed[0][0]
        unit, value = params[key]
        return [
            f"{key}: {value:g} {unit} is implausible: it makes the car's fastest mode "
            f'({car.describe()}, at the initial design) {car.rate / hop:.3g} times the '
            f"stiffest wheel hop ({hop:.3g} 1/s), which is a road vehicle's fastest "
            f'motion (at most {MAX_MODE_RATIO:g} times it); the model would be stiff: check '
            'the value and its unit'
        ]
    fastest = modes(config, _stiffest(config))[0]
    horizon = max(sc.horizon for sc in config.scenarios())
    steps = fastest.rate * horizon / DOP853_STABILITY
    if steps <= MAX_MARCHING_STEPS:
        return []
    blamed = responsible(config, fastest.rate, True)[:2] or [(next(iter(params)), 0.0)]

    def shown(k: str) -> str:
        unit, value = params[k]
        return f'{k} = {value:g}' + (f' {unit}' if unit else '')

    return [
        f'{blamed[0][0]}: the model is too stiff to integrate: its fastest mode at the '
        f'design upper bounds ({fastest.describe()}) needs about {steps:.2g} time-marching '
        f'steps over {horizon:g} s (at most {MAX_MARCHING_STEPS:.2g}); it comes from '
        + ' and '.join(shown(k) for k, _ in blamed)
        + ': check the value and its unit'
    ]
