"""Transcription of a vehicle model into one NLP (paper §3.4-3.6, eq. 14; SPEC §5-§6).

:class:`VehicleProblem` builds, from a :class:`~suspopt.config.StudyConfig`, a Dymos
Radau pseudospectral phase around :class:`~suspopt.models.vehicle.HalfCarODE` or
:class:`~suspopt.models.vehicle.MixedFidelityODE`, with

* states ``z_C, v_C, theta_C, omega_C, z_W1, v_W1, z_W2, v_W2`` from the zero initial
  state;
* the four objective integrals ``J_k`` by the grid's own Radau quadrature of the
  integrands ``dJ_dt`` (:class:`~suspopt.models.objective.ObjectiveQuadratureComp`):
  the value integrated states would reach, without their variables and defects;
* the design variables as Dymos parameters scaled to [0, 1] by their bounds
  (ref0 = lower, ref = upper), the car's constants as fixed parameters;
* the objective ``f = Σ w_k J_k(T) / s_k`` computed after the phase;
* :class:`~suspopt.driver.IpoptDriver` solving states and design together with the
  sparse constraint Jacobian (forward coloring) and the objective gradient (one reverse
  solve); the coloring is cached by model structure (:mod:`suspopt.cache`).

With ``optimize_design=False`` the design is held fixed and IPOPT only solves the
collocation equations: this is how one design is *evaluated* by collocation.
"""
from __future__ import annotations

import shutil
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import dymos as dm
import numpy as np
import openmdao.api as om
from dymos.utils.lgr import lgr

from suspopt import cache
from suspopt.config import DESIGN_NAMES, StudyConfig
from suspopt.driver import IpoptDriver, IterationInfo
from suspopt.errors import ModelError
from suspopt.models.objective import ObjectiveQuadratureComp, WeightedObjectiveComp
from suspopt.models.vehicle import HalfCarODE, MixedFidelityODE
from suspopt.multibody.suspension import SuspensionModule
from suspopt.timemarching import Trajectory

FIDELITIES = ('low', 'mixed')

#: (state, rate source, units, ref) of the transcription, paper eq. 2 and SPEC §5. ``ref``
#: is a typical magnitude over a road feature of a few centimetres; it scales the states
#: and defects for IPOPT (low fidelity: 16 -> 11 iterations) and changes no result.
STATE_DEFS = (
    ('z_C', 'v_C', 'm', 0.02), ('v_C', 'zdd_C', 'm/s', 0.2),
    ('theta_C', 'omega_C', 'rad', 0.01), ('omega_C', 'thdd_C', 'rad/s', 0.2),
    ('z_W1', 'v_W1', 'm', 0.05), ('v_W1', 'zdd_W1', 'm/s', 1.0),
    ('z_W2', 'v_W2', 'm', 0.05), ('v_W2', 'zdd_W2', 'm/s', 1.0),
)
DESIGN_UNITS = {'k_S1': 'N/m', 'k_S2': 'N/m', 'c_S1': 'N*s/m', 'c_S2': 'N*s/m'}
#: signals added to the timeseries (beyond the states), per fidelity
TIMESERIES = {
    'low': ('zdd_C', 'thdd_C', 'zdd_W1', 'zdd_W2', 'F_S1', 'F_S2', 'F_T1', 'F_T2',
            'delta_1', 'delta_2'),
    'mixed': ('zdd_C', 'thdd_C', 'zdd_W1', 'zdd_W2', 'F_S1', 'F_S2', 'F_T1', 'F_T2',
              'delta_1', 'delta_2', 'q_U1', 'q_U2', 'q_W1', 'q_W2',
              'reactions_1', 'reactions_2'),
}


def radau_grid(segments: int, order: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes (phase τ in [-1, 1]) and quadrature weights (in τ) of Dymos' compressed Radau
    grid of ``segments`` uniform segments: each segment has the ``order`` LGR points and
    its right end (weight zero: not a collocation point), which repeats the next segment's
    first node. ``weights @ g(nodes)`` is what Radau collocation integrates ``x' = g`` to."""
    x, w = lgr(order, include_endpoint=True)
    ends = np.linspace(-1.0, 1.0, segments + 1)
    half = 0.5 * np.diff(ends)[:, None]
    return (ends[:-1, None] + half * (x + 1.0)).ravel(), (half * w).ravel()


def radau_quadrature_weights(segments: int, order: int, duration: float) -> np.ndarray:
    """Quadrature weight [s] of every node of the compressed Radau grid over ``duration``
    (see :func:`radau_grid`)."""
    return radau_grid(segments, order)[1] * (0.5 * duration)


def vehicle_parameters(config: StudyConfig, fidelity: str) -> dict[str, tuple[float, str]]:
    """The car's constants as (value, units) by ODE input name (SPEC §2)."""
    v = config.vehicle
    params = {'M': (v.chassis_mass, 'kg'), 'I': (v.chassis_pitch_inertia, 'kg*m**2'),
              'a1': (v.front.axle_position, 'm'), 'a2': (v.rear.axle_position, 'm'),
              'k_T1': (v.front.tyre_stiffness, 'N/m'), 'k_T2': (v.rear.tyre_stiffness, 'N/m')}
    if fidelity == 'low':
        params.update(m1=(v.front.wheel_mass, 'kg'), m2=(v.rear.wheel_mass, 'kg'))
    return params


@dataclass
class SolveResult:
    """What one IPOPT solve produced."""

    fidelity: str
    design: dict[str, float]
    objective: float
    terms: list[float]
    scales: list[float]
    success: bool
    status: str
    iterations: int
    function_evaluations: int
    gradient_evaluations: int
    times: dict[str, float]
    multibody_calls: dict[str, int] = field(default_factory=dict)
    coloring_from_cache: bool = False
    history: list[IterationInfo] = field(default_factory=list)
    message: str = ''


class VehicleProblem:
    """A set-up Dymos problem of one fidelity for one study description.

    Parameters
    ----------
    config : the study description.
    fidelity : ``'low'`` (half car) or ``'mixed'`` (half car + multibody modules).
    scales : normalization ``s_k`` of the four objective terms.
    optimize_design : False holds every design variable fixed (a problem only for
        evaluations); otherwise those with ``optimize = true`` in the config are free.
    recorder : path of an SQLite case recorder, or None.
    progress : callable receiving an :class:`IterationInfo` after every IPOPT iteration.
    use_cache : reuse/save the total coloring in the coloring cache.
    """

    def __init__(self, config: StudyConfig, fidelity: str, scales: tuple[float, ...],
                 *, optimize_design: bool = True, recorder: str | Path | None = None,
                 progress: Callable[[IterationInfo], None] | None = None,
                 use_cache: bool = True):
        if fidelity not in FIDELITIES:
            raise ValueError(f"fidelity must be one of {FIDELITIES}, got {fidelity!r}")
        t0 = time.perf_counter()
        self.config, self.fidelity = config, fidelity
        self.scales = tuple(float(s) for s in scales)
        self.optimize_design = optimize_design
        self.opt_names = [n for n in DESIGN_NAMES
                          if optimize_design and getattr(config.design, n).optimize]
        # every design variable is an NLP variable (one structure, one coloring); those
        # not optimized are pinned by IPOPT bounds lower = upper = value
        self._work_dir = tempfile.mkdtemp(prefix='suspopt-om-')
        v, tr = config.vehicle, config.transcription
        self.modules: tuple[SuspensionModule, ...] = ()
        ode_kwargs: dict[str, Any] = {'road': config.road_profile(),
                                      'speed': float(config.maneuver.speed),
                                      'wheelbase': float(v.wheelbase)}
        if fidelity == 'mixed':
            self.modules = (SuspensionModule(v.front.mechanism),
                            SuspensionModule(v.rear.mechanism))
            ode_kwargs.update(modules=self.modules, fd_form=config.multibody.fd_form,
                              fd_step=config.multibody.fd_step)
        ode_class = HalfCarODE if fidelity == 'low' else MixedFidelityODE

        p = self.problem = om.Problem(reports=False, work_dir=self._work_dir)
        phase = self.phase = dm.Phase(
            ode_class=ode_class, ode_init_kwargs=ode_kwargs,
            transcription=dm.Radau(num_segments=tr.segments, order=tr.order, compressed=True))
        phase.set_time_options(fix_initial=True, fix_duration=True, units='s',
                               targets=['time'])
        for name, rate, units, ref in STATE_DEFS:
            phase.add_state(name, rate_source=rate, units=units, fix_initial=True,
                            targets=[name], ref=ref)
        for name in DESIGN_NAMES:
            dv = getattr(config.design, name)
            phase.add_parameter(name, val=dv.initial, units=DESIGN_UNITS[name], opt=True,
                                lower=dv.lower, upper=dv.upper, ref0=dv.lower, ref=dv.upper,
                                static_target=True, targets=[name])
        for name, (val, units) in vehicle_parameters(config, fidelity).items():
            phase.add_parameter(name, val=val, units=units, opt=False, static_target=True,
                                targets=[name])
        for name in TIMESERIES[fidelity] + ('dJ_dt',):
            phase.add_timeseries_output(name)
        p.model.add_subsystem('phase', phase)
        self._quadrature = radau_quadrature_weights(tr.segments, tr.order,
                                                    config.maneuver.horizon)
        p.model.add_subsystem('quadrature', ObjectiveQuadratureComp(weights=self._quadrature))
        p.model.add_subsystem('objective', WeightedObjectiveComp())
        # straight from the ODE: the timeseries then is on no derivative path
        p.model.connect('phase.rhs_all.dJ_dt', 'quadrature.dJ_dt')
        p.model.connect('quadrature.J', 'objective.J')
        p.model.add_objective('objective.f')

        self.cache_key = cache.coloring_key(config, fidelity)
        self.use_cache = use_cache
        cached = cache.load(self.cache_key) if use_cache else None
        self.coloring_from_cache = cached is not None
        opt = config.optimizer
        self.driver = IpoptDriver(p, max_iter=opt.max_iter, tol=opt.tol,
                                  print_level=opt.print_level, progress=progress,
                                  watch=[f'phase.parameters:{n}' for n in DESIGN_NAMES],
                                  coloring=cached, opt_settings=opt.options)

        self.recorder_path = None
        if recorder is not None:
            self.recorder_path = Path(recorder).resolve()
            rec = om.SqliteRecorder(str(self.recorder_path), record_viewer_data=False)
            p.add_recorder(rec)
            p.recording_options['includes'] = ['*']

        # 'auto' sets up both derivative directions: the driver colors the constraint
        # Jacobian forward and gets the objective gradient (dense in the states) by one
        # reverse solve
        p.setup(mode='auto', check=False)
        self.set_weights(config.objective.weights)
        p.set_val('objective.scales', np.asarray(self.scales))
        phase.set_time_val(initial=0.0, duration=config.maneuver.horizon)
        self.set_initial_guess(None)  # Dymos' default state value is 1, not SPEC's zero
        p.final_setup()
        grid = phase.options['transcription'].grid_data
        nodes = radau_grid(tr.segments, tr.order)[0]
        if grid.node_ptau.shape != nodes.shape or not np.allclose(grid.node_ptau, nodes):
            # the objective's quadrature must be the phase's own grid
            raise ModelError('internal error: objective quadrature does not match the grid')
        self.times = {'setup_s': time.perf_counter() - t0}

    # ---------------------------------------------------------------- values
    def set_weights(self, weights) -> None:
        """The objective weights w_k (inputs of the objective: a new weighting needs no new
        setup or coloring, e.g. along a Pareto front)."""
        self.problem.set_val('objective.weights', np.asarray(weights, dtype=float))

    def set_design(self, design: dict[str, float]) -> None:
        """Set the design (all four values) as the starting point / fixed design."""
        for name in DESIGN_NAMES:
            self.problem.set_val(f'phase.parameters:{name}', float(design[name]),
                                 units=DESIGN_UNITS[name])

    def design(self) -> dict[str, float]:
        return {n: float(self.problem.get_val(f'phase.parameters:{n}',
                                              units=DESIGN_UNITS[n])[0]) for n in DESIGN_NAMES}

    def set_initial_guess(self, traj: Trajectory | None) -> None:
        """Initialize the discretized states from a trajectory (or zeros).

        The first node is the fixed initial state and is always zero (SPEC §1), whatever
        the guess starts from.
        """
        if traj is None:
            t, keep = np.array([0.0, self.config.maneuver.horizon]), slice(None)
        else:  # collocation trajectories repeat the segment-boundary times
            t, keep = np.unique(traj.t, return_index=True)
        for name, *_ in STATE_DEFS:
            vals = np.zeros(2) if traj is None else np.array(traj[name][keep])
            self.phase.set_state_val(name, vals, time_vals=t)
        for name, *_ in STATE_DEFS:
            path = f'phase.states:{name}'
            vals = self.problem.get_val(path)
            vals[0] = 0.0
            self.problem.set_val(path, vals)

    def terms(self) -> np.ndarray:
        return np.array(self.problem.get_val('quadrature.J'))

    def objective(self) -> float:
        return float(self.problem.get_val('objective.f')[0])

    def timeseries(self) -> Trajectory:
        """The collocation solution at the nodes, with the time-marching signal names."""
        p = self.problem
        ts = 'phase.timeseries.'
        t = p.get_val(ts + 'time')[:, 0]
        values = {name: p.get_val(ts + name)[:, 0] for name, *_ in STATE_DEFS}
        for name in TIMESERIES[self.fidelity]:
            val = p.get_val(ts + name)
            values[name] = val[:, 0] if val.ndim == 2 and val.shape[1] == 1 else val
        wheel = 'z_W' if self.fidelity == 'low' else 'q_W'
        values['wheel_z1'], values['wheel_z2'] = values[wheel + '1'], values[wheel + '2']
        info = {'fidelity': self.fidelity, 'method': 'collocation'}
        if self.fidelity == 'mixed':
            info['max_constraint_residual_m'] = max(
                m.constraint_residual(m.kinematics(values[f'z_W{i + 1}'],
                                                   values[f'v_W{i + 1}']).state)
                for i, m in enumerate(self.modules))
        return Trajectory(t=t, values=values, J=self.terms(), info=info)

    def stats(self) -> dict[str, Any]:
        """Setup and coloring times, whether the coloring came from the cache, and all
        multibody solver calls so far (for the results files)."""
        return {'setup_s': self.times['setup_s'],
                'coloring_s': self.times.get('coloring_s', 0.0),
                'coloring_from_cache': self.coloring_from_cache,
                'multibody_calls_total': self.multibody_calls()}

    def multibody_calls(self) -> dict[str, int]:
        """Batched multibody solver calls so far (position analyses, augmented solves)."""
        out: dict[str, int] = {}
        for m in self.modules:
            for k, v in m.solver.calls.items():
                out[k] = out.get(k, 0) + v
        return out

    # ---------------------------------------------------------------- solve
    def solve(self, optimize: bool = True) -> SolveResult:
        """Run IPOPT: optimize the free design variables, or (``optimize=False``) only solve
        the collocation equations at the current design."""
        p, drv = self.problem, self.driver
        calls0 = self.multibody_calls()
        free = self.opt_names if optimize else []
        pinned = [f'phase.parameters:{n}' for n in DESIGN_NAMES if n not in free]
        t0 = time.perf_counter()
        try:
            p.run_model()
        except om.AnalysisError as err:
            raise ModelError(f'model evaluation failed at the starting point: {err}') from None
        t1 = time.perf_counter()
        computed = drv.coloring is None
        coloring = drv.total_coloring()
        t2 = time.perf_counter()
        if computed and coloring is not None and self.use_cache:
            cache.store(self.cache_key, coloring)  # for other problems of this structure
        drv.run(pinned=pinned)
        t3 = time.perf_counter()
        terms = self.terms()
        success = drv.status in (0, 1)
        self.times['coloring_s'] = self.times.get('coloring_s', 0.0) + (t2 - t1)
        times = {'coloring_s': t2 - t1, 'solve_s': t3 - t2 + (t1 - t0)}
        msg = drv.status_message
        if drv.last_error and not success:
            msg += f' (last model error: {drv.last_error})'
        return SolveResult(
            fidelity=self.fidelity, design=self.design(), objective=self.objective(),
            terms=terms.tolist(), scales=list(self.scales), success=success,
            status=drv.status_message, iterations=len(drv.history) - 1 if drv.history else 0,
            function_evaluations=drv.n_function_evals,
            gradient_evaluations=drv.n_gradient_evals, times=times,
            multibody_calls={k: v - calls0.get(k, 0) for k, v in self.multibody_calls().items()},
            coloring_from_cache=self.coloring_from_cache, history=list(drv.history), message=msg)

    def record(self, label: str) -> None:
        """Record every output (trajectories included) as case ``label`` in the recorder."""
        if self.recorder_path is not None:
            self.problem.record(label)

    def cleanup(self) -> None:
        """Close the recorder and remove OpenMDAO's scratch directory."""
        try:
            self.problem.cleanup()
        finally:
            shutil.rmtree(self._work_dir, ignore_errors=True)

    def __enter__(self) -> 'VehicleProblem':
        return self

    def __exit__(self, *exc) -> None:
        self.cleanup()
