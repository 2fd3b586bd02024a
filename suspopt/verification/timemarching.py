"""Independent time-marching integration of both vehicle models (SciPy ``solve_ivp``).

This is the reference the collocation is checked against (``docs/model.md``,
"Verification") and the source of the ``reference`` normalization. It integrates the
same equations — the vehicle assembly of :mod:`suspopt.models.assembly`, from which the
collocation's ODE is built too — with an adaptive explicit Runge-Kutta method (DOP853),
stopping at every time where the road's second derivative jumps under a wheel so the high
order is kept: it is independent of the collocation's discretization and integrator, not
of the equations. The objective integrals are integrated as extra states.

In the mixed-fidelity model the multibody constraints are kept exactly (coordinate
partitioning): at every right-hand-side evaluation the dependent coordinates are solved
by Newton's method from the wheel travel, then the augmented system gives the
accelerations. The largest constraint residual seen is reported.

An open-loop control (``docs/codesign.md``) is marched as the collocation represents it
(:class:`~suspopt.records.control.ControlHistory`: per segment the polynomial through its
values at the LGR points), piece by piece between the segment ends, where it may jump; a
feedback law is a block of the assembly and is marched with the rest of the model.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence

import numpy as np
from scipy.integrate import solve_ivp

from suspopt.errors import ConfigError, ModelError
from suspopt.models.assembly import AssemblyEvaluator
from suspopt.models.design import GAIN_KINDS, design_kind
from suspopt.models.metrics import static_loads
from suspopt.multibody.components import SuspensionKinematicsComp
from suspopt.multibody.reduced import reduced_modules
from suspopt.records.control import ControlHistory
from suspopt.records.trajectory import Trajectory
from suspopt.spec.schema import Scenario, StudyConfig
from suspopt.transcription.problem import Scales
from suspopt.transcription.vehicle import multibody_modules, vehicle_assembly


class VehicleRHS:
    """Right-hand side ``dy/dt`` of the low- or mixed-fidelity model of one scenario, for
    one design, evaluated by the vehicle assembly (:class:`~suspopt.models.assembly.
    AssemblyEvaluator`): the same equations as the collocation's ODE; :meth:`signals`
    also returns every intermediate signal.

    State vector: the assembly's states in order (the chassis' ``z_C, v_C, theta_C,
    omega_C`` [, ``phi_C, p_C``], every wheel's travel ``z_W`` then its rate ``v_W``), then
    the objective integrals."""

    def __init__(
        self,
        config: StudyConfig,
        fidelity: str,
        design: dict[str, float],
        scenario: Scenario,
        modules: dict | None = None,
    ):
        self.scenario = scenario
        if fidelity == 'mixed':  # each linkage reduced to its travel, exact to ~1e-12
            modules = reduced_modules(modules or multibody_modules(config))
        self.assembly = vehicle_assembly(config, scenario, fidelity, modules)
        self.evaluator = AssemblyEvaluator(self.assembly)
        spec = self.assembly.spec
        self.tracks = spec.tracks
        self.offsets = np.array(spec.layout.offsets())
        self.design = {n: np.array([float(design[n])]) for n in spec.design}
        self.sizes = [int(np.prod(st.shape)) for st in self.assembly.states]
        self.n_states = sum(self.sizes)
        self.nt = len(config.terms())
        self._kinematics = [
            c for c in self.evaluator.components() if isinstance(c, SuspensionKinematicsComp)
        ]
        for comp in self._kinematics:  # the largest constraint residual seen is reported
            comp.residual_seen = 0.0
        self.n_evals = 0
        #: the open-loop controls, and the segment whose polynomial applies (None: by time)
        self.controls: tuple[ControlHistory, ...] = ()
        self.segment: int | None = None

    @property
    def max_constraint_residual(self) -> float:
        return max((c.residual_seen or 0.0 for c in self._kinematics), default=0.0)

    def unpack(self, y: np.ndarray) -> dict[str, np.ndarray]:
        """The states by name from state vectors ``y`` (n, N): chassis states (N,), per
        corner (N, corners)."""
        out, k = {}, 0
        for st, size in zip(self.assembly.states, self.sizes):
            block = y[k : k + size]
            out[st.name] = block[0] if st.scalar else block.T
            k += size
        return out

    def signals(self, t: np.ndarray, y: np.ndarray) -> dict[str, np.ndarray]:
        """All model signals at times ``t`` (N,) for states ``y`` (n_states, N)."""
        signals: dict[str, np.ndarray] = {'time': np.atleast_1d(t), **self.design}
        signals.update(self.unpack(y))
        for control in self.controls:
            signals[control.name] = control(t, self.segment)
        self.evaluator(signals)
        signals['wheel_z'] = signals[self.assembly.wheel_signal]
        return signals

    def __call__(self, t: float, y: np.ndarray) -> np.ndarray:
        self.n_evals += 1
        s = self.signals(np.atleast_1d(t), y[:, None])
        rates = [np.ravel(s[st.rate]) for st in self.assembly.states]
        return np.concatenate(rates + [s['dJ_dt'][0]])


def _scenario(config: StudyConfig, scenario: int | Scenario) -> Scenario:
    return config.scenarios()[scenario] if isinstance(scenario, int) else scenario


def simulate(
    config: StudyConfig,
    fidelity: str,
    design: dict[str, float] | None = None,
    *,
    scenario: int | Scenario = 0,
    t_eval: np.ndarray | None = None,
    rtol: float = 1e-8,
    atol: float = 1e-11,
    modules: dict | None = None,
    controls: Sequence[ControlHistory] = (),
) -> Trajectory:
    """Integrate a model from the zero initial state over a scenario's horizon (SPEC §1).

    ``design`` defaults to the configured initial design. Returns the trajectory at
    ``t_eval`` (default: 2001 points) with states, accelerations, forces and road inputs,
    and the objective integrals ``J`` at the final time (term order). The default
    tolerances give the J_k to about 1e-8 relative.

    ``controls``: the open-loop controls of a controlled car (``docs/codesign.md``), those
    of this scenario (by name; an open-loop car needs them). The integration then also
    stops at every segment end of theirs, where they may jump."""
    design = dict(config.design.initial() if design is None else design)
    missing = set(config.design_names()) - set(design)
    if missing:
        raise ValueError(f'design is missing {sorted(missing)}')
    sc = _scenario(config, scenario)
    T = sc.horizon
    rhs = VehicleRHS(config, fidelity, design, sc, modules)
    rhs.controls = _scenario_controls(rhs, controls, sc)
    # times where the road's second derivative jumps under a wheel, and the controls' jumps
    breaks = sorted(
        {
            (s + off) / sc.speed
            for road in rhs.tracks
            for s in road.breakpoints()
            for off in rhs.offsets
        }
        | {float(b) for c in rhs.controls for b in c.breakpoints()}
        | {0.0, T}
    )
    breaks = [b for b in breaks if 0.0 <= b <= T]
    t_eval = np.linspace(0.0, T, 2001) if t_eval is None else np.asarray(t_eval, dtype=float)
    y = np.zeros(rhs.n_states + rhs.nt)
    pieces_t, pieces_y = [], []
    t0 = time.perf_counter()
    for ta, tb in zip(breaks[:-1], breaks[1:]):
        mask = (t_eval >= ta) & ((t_eval < tb) | ((tb == breaks[-1]) & (t_eval <= tb)))
        # the interpolant costs 3 more RHS calls per step: only when asked inside a piece
        interior = bool(np.any(mask & (t_eval > ta) & (t_eval < tb)))
        y_a = y
        if rhs.controls:  # the segment of the controls' polynomials on this piece
            rhs.segment = int(rhs.controls[0].segment_of(0.5 * (ta + tb)))
        sol = solve_ivp(
            rhs, (ta, tb), y, method='DOP853', rtol=rtol, atol=atol, dense_output=interior
        )
        if sol.status != 0:
            raise ModelError(
                f'time marching ({fidelity} fidelity) failed at t = '
                f'{sol.t[-1]:.4g} s: {sol.message}'
            )
        y = sol.y[:, -1]
        if not np.all(np.isfinite(y)):
            raise ModelError(f'time marching ({fidelity} fidelity) produced NaN/inf')
        if np.any(mask):
            pieces_t.append(t_eval[mask])
            pieces_y.append(
                sol.sol(t_eval[mask])
                if interior
                else np.stack([y_a if t == ta else y for t in t_eval[mask]], axis=1)
            )
    ts = np.concatenate(pieces_t)
    ys = np.concatenate(pieces_y, axis=1)
    wall = time.perf_counter() - t0
    rhs.segment = None  # every time by its own segment
    values = rhs.signals(ts, ys[: rhs.n_states])
    info = {
        'rhs_evaluations': rhs.n_evals,
        'wall_time_s': wall,
        'fidelity': fidelity,
        'method': 'time-marching',
        'scenario': sc.name,
    }
    if fidelity == 'mixed':
        info['max_constraint_residual_m'] = rhs.max_constraint_residual
    return Trajectory(t=ts, values=values, J=y[rhs.n_states :].copy(), info=info)


def starting_controls(
    config: StudyConfig, scenario: int | Scenario = 0
) -> tuple[ControlHistory, ...]:
    """The open-loop controls of ``config``'s model held at their starting values
    (:attr:`~suspopt.models.assembly.Control.initial`: no force, the softest damping):
    what the collocation starts from."""
    sc = _scenario(config, scenario)
    assembly = vehicle_assembly(config, sc, 'low')
    labels = assembly.spec.layout.labels
    spec = assembly.spec.control
    return tuple(
        ControlHistory.constant(
            name=c.name,
            units=c.units,
            corners=tuple(labels[k] for k in spec.corners) if spec else (),
            scenario=sc.name,
            horizon=sc.horizon,
            value=c.initial,
        )
        for c in assembly.controls
    )


def _scenario_controls(
    rhs: VehicleRHS, controls: Sequence[ControlHistory], sc: Scenario
) -> tuple[ControlHistory, ...]:
    """The open-loop controls ``rhs``'s model needs, from ``controls`` (those of scenario
    ``sc``, by name); a missing one is an error, not a zero control."""
    out = []
    for c in rhs.assembly.controls:
        mine = [h for h in controls if h.name == c.name and h.scenario in (sc.name, '')]
        if not mine:
            raise ValueError(
                f'the model has the open-loop control {c.name!r}: give its history '
                f'(scenario {sc.name!r}) to march it'
            )
        out.append(mine[0])
    if len({(c.segment_ends, c.tau) for c in out}) > 1:
        raise ValueError('the open-loop controls of one scenario must share their grid')
    return tuple(out)


def reference_scales(config: StudyConfig) -> Scales:
    """``s_k`` of the ``reference`` normalization, per scenario: J_k of the low-fidelity
    model at the initial design by accurate time marching (SPEC §5). A controlled car
    (``docs/codesign.md``) is normalized as its passive car (the initial design without
    the control), and each actuator's effort ``control_<c>`` by ``F_c² T``, the squared
    static load of its corner over the horizon: an actuator holding the corner's static
    load throughout scores 1."""
    if config.control.enabled:
        return _controlled_reference_scales(config)
    out = []
    terms = config.terms()
    weights = config.objective.weights
    for sc in config.scenarios():
        J = simulate(config, 'low', scenario=sc, t_eval=np.array([0.0, sc.horizon])).J
        zero = [t for t, j in zip(terms, J) if not j > 0.0 and weights.get(t, 0.0) > 0.0]
        if zero:
            where = f'scenario {sc.name!r}: ' if config.scenario else ''
            raise ConfigError(
                f'objective.normalization: {where}reference normalization '
                f'impossible: the road does not excite {", ".join(zero)} at '
                "the initial design; use normalization = 'custom' with scales"
            )
        out.append({t: float(x) if x > 0.0 else 1.0 for t, x in zip(terms, J)})
    return tuple(out)


def _controlled_reference_scales(config: StudyConfig) -> Scales:
    """:func:`reference_scales` of a controlled car: its passive car's, and ``F_c² T``
    for each actuator's effort."""
    passive = dataclasses.replace(
        config,
        control=dataclasses.replace(config.control, kind='none', law='open_loop', corners=()),
        design=dataclasses.replace(
            config.design,
            variables={
                n: v for n, v in config.design.variables.items() if design_kind(n) not in GAIN_KINDS
            },
        ),
        objective=dataclasses.replace(
            config.objective,
            weights={
                t: w for t, w in config.objective.weights.items() if not t.startswith('control_')
            },
        ),
    )
    lay = config.layout()
    static = static_loads(
        lay,
        config.vehicle.chassis_mass,
        np.array([config.vehicle.axles[c.axle].wheel_mass for c in lay.corners]),
    )
    out = []
    for sc, base in zip(config.scenarios(), reference_scales(passive)):
        scales = dict(base)
        for label in config.controlled():
            scales[f'control_{label}'] = float(static[lay.labels.index(label)] ** 2 * sc.horizon)
        out.append({t: scales[t] for t in config.terms()})
    return tuple(out)
