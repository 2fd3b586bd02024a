"""The NLP of a study: every scenario's phase sharing one design (paper eq. 14; docs/model.md).

:class:`VehicleProblem` builds, from a :class:`~suspopt.spec.schema.StudyConfig`, one Dymos
trajectory with one Radau phase per scenario (:mod:`suspopt.transcription.phase`),

* the design variables as trajectory parameters scaled to [0, 1] by their bounds
  (ref0 = lower, ref = upper), shared by all phases;
* each scenario's objective terms ``J_k`` by its grid's own Radau quadrature of the
  integrands ``dJ_dt`` (:class:`~suspopt.models.objective.ObjectiveQuadratureComp`): the
  value integrated states would reach, without their variables and defects; and its
  normalized weighted sum ``f_s = Σ w_k J_k / s_k``;
* the objective ``Σ_s w_s f_s`` (``aggregate = "sum"``; IPOPT sees it divided by
  ``Σ_s w_s``) or the worst case ``t`` with ``f_s ≤ t`` (``"max"``, epigraph form);
* :class:`~suspopt.driver.IpoptDriver` as the problem's driver (``run_driver``), solving
  states and design together with the exact sparse constraint Jacobian; the coloring is
  cached by model structure (:mod:`suspopt.transcription.coloring_cache`).

With ``optimize_design=False`` the design is held fixed and IPOPT only solves the
collocation equations: this is how one design is *evaluated* by collocation.
"""

from __future__ import annotations

import shutil
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import dymos as dm
import numpy as np
import openmdao.api as om
from dymos.utils.lgr import lgr

import suspopt.transcription.coloring_cache as cache
from suspopt.driver import SUCCESS, IpoptDriver, IterationInfo
from suspopt.errors import ModelError
from suspopt.models.assembly import constraint_residual
from suspopt.models.design import DESIGN_UNITS, design_kind
from suspopt.models.objective import (
    ObjectiveQuadratureComp,
    ScenarioObjectiveComp,
    WeightedObjectiveComp,
    WorstCaseGapComp,
)
from suspopt.records.constraints import ConstraintValue
from suspopt.records.control import ControlHistory
from suspopt.records.solve import (
    Grid,
    Iterate,
    ScenarioResult,
    SolveRecord,
    SolveTimes,
    best_feasible,
)
from suspopt.records.trajectory import Trajectory
from suspopt.spec.schema import HESSIANS, StudyConfig
from suspopt.transcription.constraints import (
    GROUP,
    Worst,
    add_design_constraints,
    add_path_constraints,
    bounds,
    path_constraints,
    worst_on_path,
)
from suspopt.transcription.grid import radau_grid, radau_quadrature_weights
from suspopt.transcription.phase import build_phase
from suspopt.transcription.vehicle import multibody_modules, vehicle_assembly

#: scales of the objective terms, one table per scenario (term → s_k)
Scales = tuple[dict[str, float], ...]


#: what one IPOPT solve produced: the record of the solve (``mode`` ``optimize`` or
#: ``evaluate``; not yet verified)
SolveResult = SolveRecord


#: the Hessians of the Lagrangian a problem can give IPOPT


#: the fewest segments (over all scenarios) for which ``'auto'`` takes the exact Hessian
AUTO_EXACT_MIN_SEGMENTS = 200

#: IPOPT's acceptable level for an open-loop control in the mixed fidelity (the study's
#: ``optimizer.options`` override it): the gradient with respect to thousands of control
#: values carries the multibody black box's finite-difference error, about 1e-6 of the
#: dual infeasibility, which then stalls there at the optimum rather than reach ``tol``
#: (``docs/codesign.md``)
MIXED_CONTROL_SETTINGS = {'acceptable_tol': 1e-5, 'acceptable_iter': 5}


def auto_hessian(config: StudyConfig, fidelity: str, optimize_design: bool = True) -> str:
    """The Hessian ``hessian='auto'`` stands for: ``'exact'`` for optimizing the
    low-fidelity half car on at least :data:`AUTO_EXACT_MIN_SEGMENTS` segments in all
    (long roads, several scenarios), where its fewer iterations on a sparse KKT system
    beat L-BFGS's cheaper but more numerous ones; IPOPT's L-BFGS (``'limited-memory'``)
    otherwise: the full car (denser node blocks make each exact step dearer than the
    iterations it saves), the mixed fidelity (the multibody partials are finite
    differences already), short roads (about even), and evaluations (a fixed design:
    the collocation equations alone). ``benchmarks/ipopt_iterations.py --hessian
    limited-memory,exact,auto`` measures both on every case. A controlled car
    (``docs/codesign.md``) takes the exact Hessian where L-BFGS needs ten times the
    iterations or stalls: an open-loop control, in both fidelities (the linkages' own
    curvature left out, ``hessian_frozen``; its many values make the reduced Hessian
    ill-conditioned: the dynamics filter their fast components, only the effort term
    weighs them), and a feedback law in the low fidelity (its gains multiply the states);
    a feedback law in the mixed fidelity keeps L-BFGS (about as many iterations, each
    cheaper)."""
    segments = sum(sc.segments for sc in config.scenarios())
    control = config.control
    if optimize_design and control.enabled:
        if control.law == 'open_loop' or fidelity == 'low':
            return 'exact'
        return 'limited-memory'
    if (
        optimize_design
        and fidelity == 'low'
        and config.vehicle.model == 'half_car'
        and segments >= AUTO_EXACT_MIN_SEGMENTS
    ):
        return 'exact'
    return 'limited-memory'


class VehicleProblem:
    """A set-up problem of one fidelity for one study description (all its scenarios).

    Parameters
    ----------
    config : the study description.
    fidelity : ``'low'`` or ``'mixed'`` (multibody modules at the corners).
    scales : normalization ``s_k`` of the objective terms, one table per scenario.
    optimize_design : False holds every design variable fixed (a problem only for
        evaluations); otherwise those with ``optimize = true`` in the config are free.
    recorder : path of an SQLite case recorder, or None.
    progress : callable receiving an :class:`IterationInfo` after every IPOPT iteration.
    use_cache : reuse/save the total coloring in the coloring cache.
    totals : how the driver computes total derivatives
        (:data:`suspopt.driver.propagation.TOTALS_METHODS`).
    hessian : the Hessian of the Lagrangian IPOPT uses (:data:`HESSIANS`):
        ``'limited-memory'`` (IPOPT's L-BFGS), ``'exact'`` (second-order adjoints of the
        model's nonlinear components, :mod:`suspopt.driver.hessian`), or ``'auto'``
        (:func:`auto_hessian`); None: the study's ``optimizer.hessian``.
    """

    def __init__(
        self,
        config: StudyConfig,
        fidelity: str,
        scales: Scales,
        *,
        optimize_design: bool = True,
        recorder: str | Path | None = None,
        progress: Callable[[IterationInfo], None] | None = None,
        use_cache: bool = True,
        totals: str = 'auto',
        hessian: str | None = None,
    ):
        t0 = time.perf_counter()
        self.config, self.fidelity = config, fidelity
        self.scenarios = config.scenarios()
        if len(scales) != len(self.scenarios):
            raise ValueError(
                f'scales for {len(scales)} scenarios, the study has {len(self.scenarios)}'
            )
        self.scales = tuple(dict(s) for s in scales)
        self.terms_names = config.terms()
        self.design_names = config.design_names()
        self.optimize_design = optimize_design
        self.opt_names = [
            n for n in self.design_names if optimize_design and config.design[n].optimize
        ]
        self._work_dir = tempfile.mkdtemp(prefix='suspopt-om-')
        try:  # an interrupt or a failure while building leaves no scratch directory
            self.modules = multibody_modules(config) if fidelity == 'mixed' else {}
            nt = len(self.terms_names)

            p = self.problem = om.Problem(reports=False, work_dir=self._work_dir)
            traj = self.traj = p.model.add_subsystem('traj', dm.Trajectory())
            self.phases, self.assemblies, self._quadrature = [], [], []
            path = path_constraints(config)
            for i, sc in enumerate(self.scenarios):
                assembly = vehicle_assembly(config, sc, fidelity, self.modules)
                phase = traj.add_phase(f's{i}', build_phase(assembly, sc))
                self.phases.append(phase)
                self.assemblies.append(assembly)
                self._quadrature.append(radau_quadrature_weights(sc.segments, sc.order, sc.horizon))
            for name in self.design_names:
                dv = config.design[name]
                span = dv.upper - dv.lower if dv.upper > dv.lower else max(abs(dv.lower), 1.0)
                traj.add_parameter(
                    name,
                    val=dv.initial,
                    units=DESIGN_UNITS[design_kind(name)],
                    opt=True,
                    lower=dv.lower,
                    upper=dv.upper,
                    ref0=dv.lower,
                    ref=dv.lower + span,
                    static_target=True,
                )
            for i, sc in enumerate(self.scenarios):
                add_path_constraints(p.model, f'traj.s{i}.rhs_all', path, sc, config.layout().n)
            add_design_constraints(p.model, config, fidelity, self.modules)
            self.bounds = bounds(config)
            for i in range(len(self.scenarios)):
                p.model.add_subsystem(
                    f'quadrature_{i}',
                    ObjectiveQuadratureComp(weights=self._quadrature[i], terms=nt),
                )
                p.model.add_subsystem(f'objective_{i}', WeightedObjectiveComp(terms=nt))
                # straight from the ODE: the timeseries then is on no derivative path
                p.model.connect(f'traj.s{i}.rhs_all.dJ_dt', f'quadrature_{i}.dJ_dt')
                p.model.connect(f'quadrature_{i}.J', f'objective_{i}.J')
            n_sc = len(self.scenarios)
            self.aggregate = config.objective.aggregate if n_sc > 1 else 'sum'
            if self.aggregate == 'max':
                ivc = p.model.add_subsystem('bound', om.IndepVarComp())
                ivc.add_output('t', val=1.0)
                p.model.add_subsystem('worst', WorstCaseGapComp(n=n_sc))
                for i in range(n_sc):
                    p.model.connect(f'objective_{i}.f', f'worst.f{i}')
                p.model.connect('bound.t', 'worst.t')
                p.model.add_design_var('bound.t', lower=0.0, ref=1.0)
                p.model.add_constraint('worst.gap', upper=0.0, ref=1.0)
                p.model.add_objective('bound.t')
            else:
                p.model.add_subsystem(
                    'objective',
                    ScenarioObjectiveComp(weights=tuple(sc.weight for sc in self.scenarios)),
                )
                for i in range(n_sc):
                    p.model.connect(f'objective_{i}.f', f'objective.f{i}')
                # IPOPT sees the weighted mean (driver scaling only; f stays Σ w_s f_s):
                # one scenario's magnitude, which IPOPT's default barrier settings suit as
                # they suit a single scenario (bench_robust.py: fewer iterations)
                p.model.add_objective('objective.f', ref=sum(sc.weight for sc in self.scenarios))

            self.cache_key = cache.coloring_key(config, fidelity)
            self.use_cache = use_cache
            cached = cache.load(self.cache_key) if use_cache else None
            self.coloring_from_cache = cached is not None
            opt = config.optimizer
            if hessian is None:
                hessian = config.optimizer.hessian
            if hessian not in HESSIANS:
                raise ValueError(f'hessian must be one of {HESSIANS}, got {hessian!r}')
            if hessian == 'auto':
                hessian = auto_hessian(config, fidelity, optimize_design)
            self.hessian = hessian
            self.driver = p.driver = IpoptDriver(
                max_iter=opt.max_iter,
                tol=opt.tol,
                print_level=opt.print_level,
                progress=progress,
                watch=[self.design_var(n) for n in self.design_names],
                coloring=cached,
                totals=totals,
                hessian=hessian,
                hessian_structure=(
                    cache.load_hessian(self.cache_key) if use_cache and hessian == 'exact' else None
                ),
            )
            if fidelity == 'mixed' and any(a.controls for a in self.assemblies):
                self.driver.opt_settings.update(MIXED_CONTROL_SETTINGS)
            self.driver.opt_settings.update(opt.options)

            self.recorder_path = None
            if recorder is not None:
                self.recorder_path = Path(recorder).resolve()
                rec = om.SqliteRecorder(str(self.recorder_path), record_viewer_data=False)
                p.add_recorder(rec)
                p.recording_options['includes'] = ['*']

            # 'auto' sets up both derivative directions: the driver colors the constraint
            # Jacobian forward and gets the objective gradient by one reverse solve
            p.setup(mode='auto', check=False)
            self.set_weights(config.objective.weights)
            for i, s in enumerate(self.scales):
                p.set_val(f'objective_{i}.scales', np.array([s[t] for t in self.terms_names]))
            for phase, sc in zip(self.phases, self.scenarios):
                phase.set_time_val(initial=0.0, duration=sc.horizon)
            self.set_initial_guess(None)  # Dymos' default state value is 1, not the zero state
            self.set_controls(None)
            p.final_setup()
            for phase, sc in zip(self.phases, self.scenarios):
                grid = phase.options['transcription'].grid_data
                nodes = radau_grid(sc.segments, sc.order)[0]
                if grid.node_ptau.shape != nodes.shape or not np.allclose(grid.node_ptau, nodes):
                    # the objective's quadrature must be the phase's own grid
                    raise ModelError('internal error: objective quadrature does not match the grid')
            self.times = {'setup_s': time.perf_counter() - t0}
        except BaseException:
            shutil.rmtree(self._work_dir, ignore_errors=True)
            raise

    # ---------------------------------------------------------------- names and values
    @staticmethod
    def design_var(name: str) -> str:
        """The NLP's name of a design variable."""
        return f'traj.parameters:{name}'

    def set_weights(self, weights: dict[str, float]) -> None:
        """The objective weights w_k by term (inputs of the objective: a new weighting
        needs no new setup or coloring, e.g. along a Pareto front)."""
        self.weights = {t: float(weights.get(t, 0.0)) for t in self.terms_names}
        w = np.array(list(self.weights.values()))
        for i in range(len(self.scenarios)):
            self.problem.set_val(f'objective_{i}.weights', w)

    def set_design(self, design: dict[str, float]) -> None:
        """Set the design (every variable) as the starting point / fixed design."""
        for name in self.design_names:
            self.problem.set_val(
                self.design_var(name), float(design[name]), units=DESIGN_UNITS[design_kind(name)]
            )

    def design(self) -> dict[str, float]:
        return {
            n: float(
                self.problem.get_val(self.design_var(n), units=DESIGN_UNITS[design_kind(n)])[0]
            )
            for n in self.design_names
        }

    def set_initial_guess(self, trajs: list[Trajectory | None] | Trajectory | None) -> None:
        """Initialize the discretized states of every scenario from a trajectory (or zeros).

        The first node is the fixed initial state and is always zero (docs/model.md), whatever
        the guess starts from."""
        if not isinstance(trajs, (list, tuple)):
            trajs = [trajs] * len(self.scenarios)
        for i, (phase, assembly, sc, traj) in enumerate(
            zip(self.phases, self.assemblies, self.scenarios, trajs)
        ):
            for state in assembly.states:
                name, shape = state.name, state.shape
                if traj is None:
                    t, vals = np.array([0.0, sc.horizon]), np.zeros((2,) + shape)
                else:  # collocation trajectories repeat the segment-boundary times
                    t, keep = np.unique(traj.t, return_index=True)
                    vals = np.asarray(traj[name])[keep].reshape((t.size,) + shape)
                phase.set_state_val(name, vals, time_vals=t)
                path = f'traj.s{i}.states:{name}'
                arr = self.problem.get_val(path)
                arr[0] = 0.0
                self.problem.set_val(path, arr)

    def control_var(self, scenario: int, name: str) -> str:
        """The NLP's name of an open-loop control of a scenario."""
        return f'traj.s{scenario}.controls:{name}'

    def control_vars(self) -> list[str]:
        """Every scenario's open-loop controls (the NLP's names)."""
        return [
            self.control_var(i, c.name) for i, a in enumerate(self.assemblies) for c in a.controls
        ]

    def set_controls(self, histories: list[ControlHistory | None] | None) -> None:
        """Set every scenario's open-loop control (its values at the LGR points) from a
        history on the same grid, or (None) to its starting value (``Control.initial``)."""
        if histories is None:
            histories = [None] * len(self.scenarios)
        for i, (assembly, hist) in enumerate(zip(self.assemblies, histories)):
            for c in assembly.controls:
                path = self.control_var(i, c.name)
                arr = self.problem.get_val(path)
                if hist is None:
                    arr[...] = c.initial
                else:
                    arr[...] = hist.values_at_points().reshape(arr.shape)
                self.problem.set_val(path, arr)

    def control_histories(self) -> tuple[ControlHistory, ...]:
        """Every scenario's open-loop control as solved (none for a passive car or a
        feedback law): the values at the LGR points of each segment."""
        out = []
        for i, (assembly, sc) in enumerate(zip(self.assemblies, self.scenarios)):
            ctrl = assembly.spec.control
            for c in assembly.controls:
                assert ctrl is not None  # an assembly with controls has a control
                values = self.problem.get_val(self.control_var(i, c.name), units=c.units)
                out.append(
                    ControlHistory.radau(
                        name=c.name,
                        units=c.units,
                        corners=tuple(assembly.spec.layout.labels[k] for k in ctrl.corners),
                        scenario=sc.name,
                        segment_ends=np.linspace(0.0, sc.horizon, sc.segments + 1),
                        tau=lgr(sc.order)[0],
                        values=np.asarray(values),
                    )
                )
        return tuple(out)

    def terms(self, scenario: int = 0) -> dict[str, float]:
        J = self.problem.get_val(f'quadrature_{scenario}.J')
        return {t: float(v) for t, v in zip(self.terms_names, J)}

    def scenario_objective(self, scenario: int = 0) -> float:
        return float(self.problem.get_val(f'objective_{scenario}.f')[0])

    def objective(self) -> float:
        """The NLP's objective: Σ w_s f_s, or the worst case max_s f_s."""
        f = [self.scenario_objective(i) for i in range(len(self.scenarios))]
        if self.aggregate == 'max':
            return max(f)
        return float(sum(sc.weight * fi for sc, fi in zip(self.scenarios, f)))

    def engineering_constraints(self) -> list[str]:
        """The NLP's constraints that are engineering constraints (``docs/metrics.md``):
        the path constraints on the ODE's signals and the design metrics'."""
        return [
            c.name
            for c in self.driver.layout().constraints
            if c.name.startswith(f'{GROUP}.') or '.rhs_all.' in c.name
        ]

    def constraint_values(self) -> tuple[ConstraintValue, ...]:
        """Every side of every engineering constraint at the current solution: a path
        constraint at its worst over the nodes, corners and scenarios, a design-only one
        at its value."""
        p = self.problem
        labels = self.config.layout().labels
        out = []
        for b in self.bounds:
            if b.kind == 'path':
                ts = [
                    (
                        sc.name,
                        p.get_val(f'traj.s{i}.timeseries.time')[:, 0],
                        p.get_val(f'traj.s{i}.timeseries.{b.signal}'),
                    )
                    for i, sc in enumerate(self.scenarios)
                ]
                worst = worst_on_path(b, ts, labels)
                assert worst is not None
            else:
                worst = Worst(float(b.quantity(p.get_val(f'{GROUP}.{b.signal}'))[0]))
            out.append(
                ConstraintValue(
                    name=b.name,
                    kind=b.kind,
                    units=b.units,
                    upper=b.upper,
                    bound=b.bound,
                    value=worst.value,
                    active=b.active(worst.value),
                    where=worst.where,
                )
            )
        return tuple(out)

    def timeseries(self, scenario: int = 0) -> Trajectory:
        """The collocation solution of one scenario at its nodes."""
        p, assembly = self.problem, self.assemblies[scenario]
        ts = f'traj.s{scenario}.timeseries.'
        t = p.get_val(ts + 'time')[:, 0]
        values = {}
        for state in assembly.states:
            val = p.get_val(ts + state.name)
            values[state.name] = val[:, 0] if state.scalar else val
        for name in assembly.timeseries:
            val = p.get_val(ts + name)
            values[name] = val[:, 0] if val.ndim == 2 and val.shape[1] == 1 else val
        values['wheel_z'] = values[assembly.wheel_signal]
        info: dict[str, Any] = {
            'fidelity': self.fidelity,
            'method': 'collocation',
            'scenario': self.scenarios[scenario].name,
        }
        if self.fidelity == 'mixed':
            info['max_constraint_residual_m'] = constraint_residual(assembly, values)
        J = np.array([self.terms(scenario)[k] for k in self.terms_names])
        return Trajectory(t=t, values=values, J=J, info=info)

    def stats(self) -> dict[str, Any]:
        """Setup and coloring times, whether the coloring came from the cache, and all
        multibody solver calls so far (for the results files)."""
        c = self.driver.coloring
        return {
            'setup_s': self.times['setup_s'],
            'coloring_s': self.times.get('coloring_s', 0.0),
            'coloring_from_cache': self.coloring_from_cache,
            'nlp': {
                'variables': self.driver.layout().n,
                'constraints': self.driver.layout().m,
                'jacobian_nonzeros': c.nnz if c else 0,
                'colors': c.n_colors if c else 0,
            },
            'multibody_calls_total': self.multibody_calls(),
        }

    def multibody_calls(self) -> dict[str, int]:
        """Batched multibody solver calls so far (position analyses, augmented solves)."""
        out: dict[str, int] = {}
        for m in self.modules.values():
            for k, v in m.solver.calls.items():
                out[k] = out.get(k, 0) + v
        return out

    # ---------------------------------------------------------------- solve
    def solve(self, optimize: bool = True) -> SolveResult:
        """Run IPOPT: optimize the free design variables, or (``optimize=False``) only solve
        the collocation equations at the current design. The record's verification is
        pending and its wall time is the solve's own."""
        p, drv = self.problem, self.driver
        start = self.design()
        calls0 = self.multibody_calls()
        free = self.opt_names if optimize else []
        pinned = [self.design_var(n) for n in self.design_names if n not in free]
        if not optimize:  # an evaluation holds the open-loop control too
            pinned += self.control_vars()
        if self.aggregate == 'max' and not free:
            pinned.append('bound.t')
        t0 = time.perf_counter()
        try:
            p.run_model()
        except om.AnalysisError as err:
            raise ModelError(f'model evaluation failed at the starting point: {err}') from None
        if self.aggregate == 'max':  # start the bound on the worst case
            p.set_val(
                'bound.t', max(self.scenario_objective(i) for i in range(len(self.scenarios)))
            )
        t1 = time.perf_counter()
        c1 = time.process_time()
        computed = drv.coloring is None
        coloring = drv.total_coloring()
        if computed and coloring is not None and self.use_cache:
            cache.store(self.cache_key, coloring)  # for other problems of this structure
        if self.hessian == 'exact':
            given = drv.options['hessian_structure']
            hs = drv.hessian_structure()
            if hs is not None and hs is not given and self.use_cache:
                cache.store(self.cache_key, hs)
        t2 = time.perf_counter()
        c2 = time.process_time()
        drv.options['pinned'] = pinned
        # an evaluation of a fixed design reports the engineering constraints: it cannot
        # move to meet them (an optimization keeps them)
        drv.options['released'] = [] if optimize else self.engineering_constraints()
        p.run_driver()
        t3 = time.perf_counter()
        success = drv.status in SUCCESS
        self.times['coloring_s'] = self.times.get('coloring_s', 0.0) + (t2 - t1)
        msg = drv.status_message
        if drv.last_error and not success:
            msg += f' (last model error: {drv.last_error})'
        history = tuple(
            Iterate(h.iteration, h.objective, h.constraint_violation, h.elapsed_s)
            for h in drv.history
        )
        designs = [{k.rsplit(':', 1)[-1]: v for k, v in h.design.items()} for h in drv.history]
        f = self.objective()
        return SolveRecord(
            fidelity=self.fidelity,
            mode='optimize' if optimize else 'evaluate',
            method='collocation',
            start=start,
            design=self.design(),
            success=success,
            status=drv.status_message,
            objective=f if success else None,
            objective_at_stop=None if success else f,
            scenarios=tuple(self._scenario_result(i, success) for i in range(len(self.scenarios))),
            aggregate=self.aggregate,
            normalization=self.config.objective.normalization,
            weights=dict(self.weights),
            message=msg,
            interrupted=drv.interrupted,
            iterations=len(drv.history) - 1 if drv.history else 0,
            function_evaluations=drv.n_function_evals,
            gradient_evaluations=drv.n_gradient_evals,
            times=SolveTimes(
                coloring_s=t2 - t1, coloring_cpu_s=c2 - c1, solve_s=t3 - t2 + (t1 - t0)
            ),
            wall_time_s=t3 - t0,
            coloring_from_cache=self.coloring_from_cache,
            multibody_calls={k: v - calls0.get(k, 0) for k, v in self.multibody_calls().items()},
            history=history,
            best_feasible_iterate=best_feasible(history, designs),
            controls=self.control_histories(),
            constraints=self.constraint_values(),
        )

    def _scenario_result(self, i: int, success: bool) -> ScenarioResult:
        """Scenario ``i`` at the current solution (its values a result only if ``success``)."""
        sc = self.scenarios[i]
        f, J = self.scenario_objective(i), self.terms(i)
        return ScenarioResult(
            name=sc.name,
            weight=sc.weight,
            scales=dict(self.scales[i]),
            objective=f if success else None,
            terms=J if success else None,
            objective_at_stop=None if success else f,
            terms_at_stop=None if success else J,
            grid=Grid(sc.segments, sc.order),
        )

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

    def __enter__(self) -> VehicleProblem:
        return self

    def __exit__(self, *exc) -> None:
        self.cleanup()
