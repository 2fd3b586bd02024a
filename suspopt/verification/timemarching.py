"""Independent time-marching integration of both vehicle models.

This is the reference the collocation is checked against (``docs/model.md``,
"Verification") and the source of the ``reference`` normalization. It integrates the
same equations — the vehicle assembly of :mod:`suspopt.models.assembly`, from which the
collocation's ODE is built too — by a method independent of the collocation's
discretization and integrator, not of the equations:

* **Linear models (low fidelity), by default: exactly.** Their state-space matrices are
  read off the assembly (:mod:`suspopt.models.linear`) and marched exactly between road
  samples (:mod:`suspopt.verification.linear_march`): the road is its cubic Hermite
  interpolant between samples placed at its breakpoints, at its spline knots (the ISO
  8608 and measured roads, then represented exactly) and wherever else its own
  interpolation error demands (:func:`sample_grid`); the objective integrals are exact
  for that input. Before and after, the assembly itself is checked against the matrices
  (at random probe states and times, then at every state of the march): a nonlinear
  curve or a time-varying input makes the exact path inapplicable, and the marching
  falls back to the integrator below on its own.
* **Otherwise (the mixed model, or ``method='DOP853'``):** an adaptive explicit
  Runge-Kutta method (SciPy's DOP853) on the assembly's right-hand side, stopping at
  every time where the road's second derivative jumps under a wheel so the high order is
  kept; the objective integrals are integrated as extra states. In the mixed-fidelity
  model the multibody constraints are kept exactly (coordinate partitioning): at every
  right-hand-side evaluation the dependent coordinates are solved by Newton's method
  from the wheel travel, then the augmented system gives the accelerations. The largest
  constraint residual seen is reported.

An open-loop control (``docs/codesign.md``) is marched as the collocation represents it
(:class:`~suspopt.records.control.ControlHistory`: per segment the polynomial through its
values at the LGR points), piece by piece between the segment ends, where it may jump; a
feedback law is a block of the assembly. A controlled car is always marched by DOP853.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, fields, is_dataclass
from pathlib import Path
from typing import Any

import numpy as np
import scipy
from scipy.integrate import solve_ivp
from threadpoolctl import threadpool_limits

from suspopt.errors import ConfigError, ModelError
from suspopt.models.assembly import AssemblyEvaluator, integrand_signals
from suspopt.models.design import GAIN_KINDS, design_kind
from suspopt.models.linear import NonlinearModelError, check_linear, linearize
from suspopt.models.metrics import static_loads
from suspopt.multibody.components import SuspensionKinematicsComp
from suspopt.multibody.reduced import reduced_modules
from suspopt.records.control import ControlHistory
from suspopt.records.trajectory import Trajectory
from suspopt.road import RoadProfile
from suspopt.spec.schema import Scenario, StudyConfig
from suspopt.transcription import coloring_cache
from suspopt.transcription.problem import Scales
from suspopt.transcription.vehicle import multibody_modules, vehicle_assembly, vehicle_spec
from suspopt.verification import linear_march, relaxation
from suspopt.verification.road_sampling import (
    ROAD_TOLERANCE,
    breakpoint_times,
    refine_stretches,
    road_samples,
    sample_grid,
)

#: ``simulate``'s methods: ``auto`` (exact for a linear model, else by relaxation, else
#: DOP853), ``exact`` (a linear model only), ``relaxation``, ``DOP853``
METHODS = ('auto', 'exact', 'relaxation', 'DOP853')

#: at most this many radians of the fastest mode of the vehicle per step
STEP_PHASE = 1.0

#: the same for the relaxation of a nonlinear model at ``rtol = 1e-6``, as ``rtol^(1/4)``
#: otherwise (its remainder is interpolated between the steps' ends, with an O(h⁴) error)
RELAXATION_STEP_PHASE = 0.25

#: the path signals (``dense``): at least this many points per period of the fastest mode
#: they respond to (a sampled peak is then within 0.2 % of a sinusoid's)
DENSE_POINTS_PER_PERIOD = 48


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


@dataclass(frozen=True)
class DenseSignals:
    """Signals at dense points along a time-marched trajectory (the path constraints'
    check): times ``t`` (N,) and each signal (N[, corners]). The exact marching gives
    them at its own grid (the road's samples, refined to
    :data:`DENSE_POINTS_PER_PERIOD` points per period of the fastest mode they respond
    to); DOP853 at its steps and on a uniform grid as fine, by its dense output."""

    t: np.ndarray
    values: dict[str, np.ndarray]

    def __getitem__(self, name: str) -> np.ndarray:
        return self.values[name]


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
    method: str = 'auto',
    dense: Sequence[str] = (),
    controls: Sequence[ControlHistory] = (),
) -> Trajectory:
    """March a model from the zero initial state over a scenario's horizon (docs/model.md).

    ``design`` defaults to the configured initial design. Returns the trajectory at
    ``t_eval`` (default: 2001 points) with states, accelerations, forces and road inputs,
    and the objective integrals ``J`` at the final time (term order).

    ``method`` (module docstring): ``auto`` marches a linear model (the low fidelity
    without nonlinear curves or time-varying inputs) exactly between road samples, a
    nonlinear one (the mixed fidelity) by waveform relaxation around its linearization,
    and one on which the relaxation does not converge by DOP853 (``info['integrator']``
    says which, ``info['fallbacks']`` why not the others); ``exact`` and ``relaxation``
    refuse what they cannot do (:class:`ModelError`); ``DOP853`` always integrates
    adaptively. ``rtol``/``atol`` are DOP853's tolerances (the default gives the J_k to
    about 1e-8 relative); the relaxation's steps follow ``rtol`` (its J_k to about
    ``rtol``); the exact marching needs none. ``dense``: signals (e.g. ``travel``,
    ``tyre_load_ratio``) also returned at dense points along the whole trajectory, as
    ``info['dense']`` (:class:`DenseSignals`).

    ``controls``: the open-loop controls of a controlled car (``docs/codesign.md``), those
    of this scenario (by name; an open-loop car needs them). A controlled car is marched
    by DOP853, which then also stops at every segment end of the controls."""
    if method not in METHODS:
        raise ValueError(f'method must be one of {METHODS}, got {method!r}')
    design = dict(config.design.initial() if design is None else design)
    missing = set(config.design_names()) - set(design)
    if missing:
        raise ValueError(f'design is missing {sorted(missing)}')
    sc = _scenario(config, scenario)
    t_eval = (
        np.linspace(0.0, sc.horizon, 2001) if t_eval is None else np.asarray(t_eval, dtype=float)
    )
    fallbacks: dict[str, str] = {}
    if config.control.enabled and method == 'auto':  # time-varying inputs, nonlinear laws
        fallbacks['exact'] = fallbacks['relaxation'] = 'a controlled car'
        method = 'DOP853'
    if method in ('auto', 'exact'):
        try:
            if fidelity != 'low':
                raise NonlinearModelError(f'the {fidelity}-fidelity model is not linear')
            return _march_exact(config, sc, design, t_eval, tuple(dense))
        except NonlinearModelError as err:
            if method == 'exact':
                raise ModelError(f'exact time marching impossible: {err}') from err
            fallbacks['exact'] = str(err)
    if method in ('auto', 'relaxation'):
        try:
            tr = _march_relaxed(config, fidelity, design, sc, t_eval, rtol, modules, tuple(dense))
            tr.info['fallbacks'] = fallbacks
            return tr
        except relaxation.NotConverged as err:
            if method == 'relaxation':
                raise ModelError(f'time marching by relaxation failed: {err}') from err
            fallbacks['relaxation'] = str(err)
    tr = _march_dop853(
        config, fidelity, design, sc, t_eval, rtol, atol, modules, tuple(dense), controls
    )
    tr.info['fallbacks'] = fallbacks
    return tr


def _march_dop853(
    config: StudyConfig,
    fidelity: str,
    design: dict[str, float],
    sc: Scenario,
    t_eval: np.ndarray,
    rtol: float,
    atol: float,
    modules: dict | None,
    dense: tuple[str, ...],
    controls: Sequence[ControlHistory] = (),
) -> Trajectory:
    """DOP853 on the assembly's right-hand side, piece by piece between the road's
    breakpoints under the wheels and the controls' segment ends."""
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
    h_dense = _dense_step(config, sc, design, dense) if dense else math.inf
    y = np.zeros(rhs.n_states + rhs.nt)
    pieces_t, pieces_y, dense_t, dense_y = [], [], [np.zeros(1)], [y[: rhs.n_states, None]]
    t0 = time.perf_counter()
    for ta, tb in zip(breaks[:-1], breaks[1:]):
        mask = (t_eval >= ta) & ((t_eval < tb) | ((tb == breaks[-1]) & (t_eval <= tb)))
        # the interpolant costs 3 more RHS calls per step: only when asked inside a piece
        interior = bool(dense) or bool(np.any(mask & (t_eval > ta) & (t_eval < tb)))
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
        if dense:
            n_uniform = max(1, math.ceil((tb - ta) / h_dense))
            td = np.union1d(sol.t[1:], np.linspace(ta, tb, n_uniform + 1)[1:])
            dense_t.append(td)
            dense_y.append(sol.sol(td)[: rhs.n_states])
    ts = np.concatenate(pieces_t) if pieces_t else np.zeros(0)
    ys = np.concatenate(pieces_y, axis=1) if pieces_y else np.zeros((y.size, 0))
    wall = time.perf_counter() - t0
    rhs.segment = None  # every time by its own segment
    values = rhs.signals(ts, ys[: rhs.n_states])
    info: dict[str, Any] = {
        'rhs_evaluations': rhs.n_evals,
        'wall_time_s': wall,
        'fidelity': fidelity,
        'method': 'time-marching',
        'integrator': f'DOP853 (rtol {rtol:g}, atol {atol:g})',
        'scenario': sc.name,
    }
    if fidelity == 'mixed':
        info['max_constraint_residual_m'] = rhs.max_constraint_residual
    if dense:
        td = np.concatenate(dense_t)
        sig = rhs.signals(td, np.concatenate(dense_y, axis=1))
        info['dense'] = DenseSignals(t=td, values={n: sig[n] for n in dense})
    return Trajectory(t=ts, values=values, J=y[rhs.n_states :].copy(), info=info)


# ------------------------------------------------------------------ exact (linear models)
def _fastest_mode(A: np.ndarray, rows: np.ndarray | None = None) -> float:
    """The largest |eigenvalue| of ``A`` [rad/s]; with ``rows`` (outputs, n) of an
    output matrix, of the states those outputs depend on (through ``A``) only."""
    keep = np.ones(A.shape[0], dtype=bool)
    if rows is not None:
        keep = np.any(rows != 0.0, axis=0)
        while True:
            more = keep | np.any(A[keep] != 0.0, axis=0)
            if np.array_equal(more, keep):
                break
            keep = more
    sub = A[np.ix_(keep, keep)]
    return float(np.max(np.abs(np.linalg.eigvals(sub)), initial=0.0)) if sub.size else 0.0


def _dense_step(
    config: StudyConfig, sc: Scenario, design: dict[str, float], names: Sequence[str]
) -> float:
    """The dense points' largest spacing: :data:`DENSE_POINTS_PER_PERIOD` per period of
    the fastest mode of the low-fidelity model that ``names`` respond to."""
    try:
        asm = vehicle_assembly(config, sc, 'low')
        lm = linearize(asm, design, names)
    # not linear, or signals only the mixed model has (KeyError from the probe): 1 kHz
    except (NonlinearModelError, KeyError):
        return 1e-3
    omega = _fastest_mode(lm.A, lm.C)
    return 2.0 * np.pi / (DENSE_POINTS_PER_PERIOD * omega) if omega > 0.0 else math.inf


def _departure(value: np.ndarray, linear: np.ndarray, scale: np.ndarray) -> float:
    """The largest departure of ``value`` from ``linear`` relative to ``scale``."""
    with np.errstate(divide='ignore', invalid='ignore'):
        d = np.abs(value - linear) / scale
    d = np.where(np.abs(value - linear) == 0.0, 0.0, d)
    return float(np.max(d, initial=0.0)) if np.all(np.isfinite(value)) else math.inf


def _march_exact(
    config: StudyConfig,
    sc: Scenario,
    design: dict[str, float],
    t_eval: np.ndarray,
    dense: tuple[str, ...],
) -> Trajectory:
    """The low-fidelity model marched exactly between road samples (module docstring);
    :class:`NonlinearModelError` if the model is not linear time-invariant."""
    t0 = time.perf_counter()
    T = sc.horizon
    rhs = VehicleRHS(config, 'low', design, sc)
    asm = rhs.assembly
    squared = [name for name, _, _ in integrand_signals(asm.spec, asm.wheel_signal)]
    outputs = squared + [n for n in dense if n not in squared]
    lm = linearize(asm, design, outputs)
    check_linear(asm, design, lm, outputs, horizon=T)
    rows = np.concatenate([np.arange(lm.C.shape[0])[lm.signals[n]] for n in squared])
    if rows.size != rhs.nt:
        raise NonlinearModelError(
            f'the objective has {rhs.nt} integrands, the squared signals {rows.size}'
        )
    max_step = STEP_PHASE / max(_fastest_mode(lm.A), 1e-12)
    if dense:
        dense_rows = np.concatenate([np.arange(lm.C.shape[0])[lm.signals[n]] for n in dense])
        omega = _fastest_mode(lm.A, lm.C[dense_rows])
        if omega > 0.0:
            max_step = min(max_step, 2.0 * np.pi / (DENSE_POINTS_PER_PERIOD * omega))
    # small matrices, one after another: a BLAS thread more only contends for the cores
    with threadpool_limits(1, user_api='blas'):
        grid, (u, start, end) = sample_grid(asm.spec, T, max_step)
        marched = linear_march.march(
            lm.A, lm.B, grid, linear_march.hermite_chain(grid, u, start, end)
        )
        nw = marched.F.shape[0]
        G = np.zeros((rows.size, nw))
        n, m = lm.B.shape
        G[:, :n], G[:, n : n + m] = lm.C[rows], lm.D[rows]
        J = marched.integrals(G)
        inside = t_eval[(t_eval >= 0.0) & (t_eval <= T)]
        x_eval = marched.states_at(inside)
    # the assembly itself along every state of the march: still its linearization?
    along = rhs.signals(grid, marched.x.T)
    x, d = marched.x, along['delta']
    rates = np.concatenate(
        [np.reshape(along[st.rate], (grid.size, -1)) for st in asm.states], axis=1
    )
    y = x @ lm.C[rows].T + d @ lm.D[rows].T
    y_scale = np.abs(x) @ np.abs(lm.C[rows].T) + np.abs(d) @ np.abs(lm.D[rows].T)
    worst = max(
        _departure(
            rates,
            x @ lm.A.T + d @ lm.B.T,
            np.abs(x) @ np.abs(lm.A.T) + np.abs(d) @ np.abs(lm.B.T),
        ),
        _departure(np.asarray(along['dJ_dt']), y**2, y_scale**2),
    )
    if not worst <= 1e-8:
        raise NonlinearModelError(
            f'the model departs from its linearization along the trajectory (relative {worst:.2g})'
        )
    values = rhs.signals(inside, x_eval.T)
    info: dict[str, Any] = {
        'rhs_evaluations': rhs.n_evals,
        'wall_time_s': time.perf_counter() - t0,
        'fidelity': 'low',
        'method': 'time-marching',
        'integrator': 'exact (linear model, cubic road between samples)',
        'steps': grid.size - 1,
        'step_lengths': int(marched.lengths.size),
        'scenario': sc.name,
    }
    if dense:
        info['dense'] = DenseSignals(t=grid, values={name: along[name] for name in dense})
    return Trajectory(t=inside, values=values, J=J, info=info)


def _state_refs(assembly: Any) -> np.ndarray:
    return np.concatenate([np.full(int(np.prod(st.shape)), st.ref) for st in assembly.states])


def _rates(assembly: Any, signals: dict[str, Any], points: int) -> np.ndarray:
    """The state rates (points, n) in the state vector's order."""
    return np.concatenate(
        [np.reshape(signals[st.rate], (points, -1)) for st in assembly.states], axis=1
    )


def _march_relaxed(
    config: StudyConfig,
    fidelity: str,
    design: dict[str, float],
    sc: Scenario,
    t_eval: np.ndarray,
    rtol: float,
    modules: dict | None,
    dense: tuple[str, ...],
) -> Trajectory:
    """A nonlinear model (the mixed fidelity) by waveform relaxation around its
    linearization at rest (:mod:`suspopt.verification.relaxation`);
    :class:`~suspopt.verification.relaxation.NotConverged` if it does not contract."""
    t0 = time.perf_counter()
    T = sc.horizon
    rhs = VehicleRHS(config, fidelity, design, sc, modules)
    asm = rhs.assembly
    nc = asm.spec.layout.n
    probe = AssemblyEvaluator(asm, skip=('road',))

    def at_rest(t: np.ndarray, X: np.ndarray, U: np.ndarray) -> np.ndarray:
        signals: dict[str, Any] = {'time': t, 'delta': U.T, **rhs.design}
        signals.update(rhs.unpack(X))
        return _rates(asm, probe(signals), X.shape[1]).T

    refs = _state_refs(asm)
    A, B = relaxation.jacobians(at_rest, refs, nc, 0.05)
    # the rates that can depart from A x + B δ, found at random states
    rng = np.random.default_rng(0)
    X = rng.standard_normal((refs.size, 8)) * refs[:, None] * 0.2
    U = rng.standard_normal((nc, 8)) * 0.01
    departs = np.max(np.abs(at_rest(np.zeros(8), X, U) - A @ X - B @ U), axis=1) > 0.0
    remainder_rows = np.flatnonzero(departs)
    phase = RELAXATION_STEP_PHASE * min(max(rtol / 1e-6, 1e-8), 1e4) ** 0.25
    max_step = phase / max(_fastest_mode(A), 1e-12)
    if dense:
        max_step = min(max_step, _dense_step(config, sc, design, dense))
    # the road as accurate as the remainder's interpolation (both errors O(h⁴)), and the
    # stretches between the road's breakpoints long enough for the remainder's slopes
    grid, road = sample_grid(asm.spec, T, max_step, max(ROAD_TOLERANCE, 1e-2 * rtol))
    breaks = breakpoint_times(asm.spec, T)
    refined = refine_stretches(grid, breaks, relaxation.STENCIL - 1)
    if refined.size > grid.size:
        grid, road = refined, road_samples(asm.spec, refined)

    def evaluate(t: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, dict[str, Any]]:
        signals = rhs.signals(t, x.T)
        return _rates(asm, signals, t.size), signals

    relaxed = relaxation.relax(
        A,
        B,
        grid,
        road,
        breaks,
        evaluate,
        remainder_rows,
        # the changes shrink geometrically (typically tenfold or more, at least by
        # CONTRACTION): stopped at 0.1 rtol, the states are within 0.1 rtol of the limit
        tolerance=min(relaxation.TOLERANCE * 1e4, 0.1 * rtol),
    )
    nodes, weights = relaxation.gauss_points(grid)
    at_nodes = rhs.signals(nodes, relaxed.marched.states_at(nodes).T)
    J = weights @ np.asarray(at_nodes['dJ_dt'])
    inside = t_eval[(t_eval >= 0.0) & (t_eval <= T)]
    values = rhs.signals(inside, relaxed.marched.states_at(inside).T)
    info: dict[str, Any] = {
        'rhs_evaluations': rhs.n_evals,
        'wall_time_s': time.perf_counter() - t0,
        'fidelity': fidelity,
        'method': 'time-marching',
        'integrator': (
            'waveform relaxation (exact linear part, cubic road and remainder between samples)'
        ),
        'steps': grid.size - 1,
        'iterations': relaxed.iterations,
        'scenario': sc.name,
    }
    if fidelity == 'mixed':
        info['max_constraint_residual_m'] = rhs.max_constraint_residual
    if dense:
        info['dense'] = DenseSignals(t=grid, values={name: relaxed.signals[name] for name in dense})
    return Trajectory(t=inside, values=values, J=J, info=info)


#: suspopt's sources the reference scales depend on (a change recomputes them)
SCALE_SOURCES = (
    'models',
    'road',
    'curves.py',
    'transcription/vehicle.py',
    'verification/timemarching.py',
    'verification/linear_march.py',
)


def _canonical(obj: Any) -> Any:
    """``obj`` as plain JSON data, every float exactly (a cache key); a road read from a
    file carries the file's digest."""
    if is_dataclass(obj) and not isinstance(obj, type):
        out: dict[str, Any] = {'type': type(obj).__qualname__}
        out.update({f.name: _canonical(getattr(obj, f.name)) for f in fields(obj)})
        file = getattr(obj, 'file', None) if isinstance(obj, RoadProfile) else None
        if file:
            path = Path(file)
            out['file_sha256'] = (
                hashlib.sha256(path.read_bytes()).hexdigest() if path.is_file() else None
            )
        return out
    if isinstance(obj, np.ndarray):
        return {'shape': list(obj.shape), 'values': _canonical(obj.ravel().tolist())}
    if isinstance(obj, (list, tuple)):
        return [_canonical(x) for x in obj]
    if isinstance(obj, dict):
        return {str(k): _canonical(v) for k, v in obj.items()}
    if isinstance(obj, (np.floating, np.integer, np.bool_)):
        return obj.item()
    if obj is None or isinstance(obj, (str, int, float, bool)):
        return obj
    raise TypeError(f'reference scales key: no plain form for {type(obj).__name__}')


def reference_scales_key(config: StudyConfig, scenario: int | Scenario) -> str:
    """The cache key of one scenario's reference scales: a digest of the low-fidelity
    vehicle in the scenario (every value of its description, its roads, a road file's
    contents), the horizon, the initial design, the terms, the sources of suspopt that
    compute them and the NumPy and SciPy versions."""
    sc = _scenario(config, scenario)
    blob = {
        'kind': 'reference scales',
        'vehicle': _canonical(vehicle_spec(config, sc, 'low')),
        'horizon': sc.horizon,
        'design': {n: float(v) for n, v in config.design.initial().items()},
        'terms': list(config.terms()),
        'method': 'auto',
        'source': coloring_cache.source_digest(SCALE_SOURCES),
        'versions': [np.__version__, scipy.__version__],
    }
    text = json.dumps(blob, sort_keys=True, allow_nan=True)
    return hashlib.sha256(text.encode()).hexdigest()[:32]


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


def reference_scales(config: StudyConfig, *, cache: bool = True) -> Scales:
    """``s_k`` of the ``reference`` normalization, per scenario: J_k of the low-fidelity
    model at the initial design by time marching (docs/model.md) — exactly where the model is
    linear. Each scenario's values are cached (:mod:`suspopt.transcription.coloring_cache`,
    :func:`reference_scales_key`): a second run of the same study reuses them, a changed
    input computes them again; ``cache=False`` neither reads nor writes the cache. A
    controlled car (``docs/codesign.md``) is normalized as its passive car (the initial
    design without the control), and each actuator's effort ``control_<c>`` by ``F_c² T``,
    the squared static load of its corner over the horizon: an actuator holding the
    corner's static load throughout scores 1."""
    if config.control.enabled:
        return _controlled_reference_scales(config)
    out = []
    terms = config.terms()
    weights = config.objective.weights
    for sc in config.scenarios():
        key = reference_scales_key(config, sc) if cache else None
        J = coloring_cache.load_scales(key) if key else None
        if J is None or set(J) != set(terms):
            tr = simulate(config, 'low', scenario=sc, t_eval=np.array([0.0, sc.horizon]))
            J = {t: float(j) for t, j in zip(terms, tr.J)}
            if key:
                coloring_cache.store_scales(key, J)
        zero = [t for t in terms if not J[t] > 0.0 and weights.get(t, 0.0) > 0.0]
        if zero:
            where = f'scenario {sc.name!r}: ' if config.scenario else ''
            raise ConfigError(
                f'objective.normalization: {where}reference normalization '
                f'impossible: the road does not excite {", ".join(zero)} at '
                "the initial design; use normalization = 'custom' with scales"
            )
        out.append({t: J[t] if J[t] > 0.0 else 1.0 for t in terms})
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
