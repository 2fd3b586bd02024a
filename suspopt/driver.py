"""An OpenMDAO driver for IPOPT through cyipopt (paper §3.6).

OpenMDAO 3.45 reaches IPOPT only through pyOptSparse, which is not available here
(``../shared/FINDINGS.md``), so this small driver wraps ``cyipopt`` directly:

* design variables, bounds and constraints are passed in driver scaling (``ref``/``ref0``);
* the constraint Jacobian is given to IPOPT as a sparse matrix whose structure is the
  sparsity of a forward total-derivative coloring of the *constraints*; values come from
  one colored, unscaled total-derivative evaluation per iterate (always with the same
  ``of``/``wrt`` lists in the driver's order, so they line up with the coloring),
  scattered by color with one vectorized assignment straight into IPOPT's nonzeros (no
  dense (m, n) array is written), and driver-scaled there;
* the objective gradient comes from one reverse solve on the same linearization: an
  objective that depends on every node (a quadrature) would make a forward coloring of
  the whole Jacobian useless, and a bidirectional one costs far more to compute
  (needs the problem set up with ``mode='auto'``, which enables both directions);
* the Hessian is approximated by IPOPT (limited-memory BFGS);
* a model evaluation that fails (``AnalysisError``, non-finite values) is reported to IPOPT
  as an evaluation error, so IPOPT backtracks instead of aborting;
* every accepted iteration is reported to an optional ``progress`` callable
  (iteration, objective, constraint violation, elapsed time) and kept in ``history``;
* Ctrl-C (SIGINT) stops IPOPT at the end of the current iteration (a second Ctrl-C
  interrupts at once), keeping what was computed;
* the exit status is reported truthfully: ``run()`` returns ``fail=True`` unless IPOPT
  reports ``Solve_Succeeded`` (0) or ``Solved_To_Acceptable_Level`` (1).
"""
from __future__ import annotations

import ctypes
import os
import signal
import sys
import tempfile
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import cyipopt
import numpy as np
import openmdao.api as om
from openmdao.core.driver import Driver, RecordingDebugging
from openmdao.core.total_jac import _TotalJacInfo
from openmdao.utils import coloring as coloring_mod

#: IPOPT's return statuses (IpReturnCodes.h).
IPOPT_STATUS = {
    0: 'Solve_Succeeded', 1: 'Solved_To_Acceptable_Level', 2: 'Infeasible_Problem_Detected',
    3: 'Search_Direction_Becomes_Too_Small', 4: 'Diverging_Iterates',
    5: 'User_Requested_Stop', 6: 'Feasible_Point_Found',
    -1: 'Maximum_Iterations_Exceeded', -2: 'Restoration_Failed',
    -3: 'Error_In_Step_Computation', -4: 'Maximum_CpuTime_Exceeded',
    -5: 'Maximum_WallTime_Exceeded', -10: 'Not_Enough_Degrees_Of_Freedom',
    -11: 'Invalid_Problem_Definition', -12: 'Invalid_Option',
    -13: 'Invalid_Number_Detected', -100: 'Unrecoverable_Exception',
    -101: 'NonIpopt_Exception_Thrown', -102: 'Insufficient_Memory', -199: 'Internal_Error',
}
_INF = 1e20  # IPOPT's default nlp_upper_bound_inf is 1e19; anything above means "none"


class _OptionProbe:
    """The smallest problem object cyipopt accepts, to try options on."""

    def objective(self, x):
        return 0.0

    def gradient(self, x):
        return np.zeros(1)


@contextmanager
def _c_stdout_to(fh):
    """Send what C code prints on the process's standard output to ``fh``."""
    sys.stdout.flush()
    try:
        libc = ctypes.CDLL(None)
    except OSError:  # no C library to flush through: IPOPT's words go where they go
        yield
        return
    saved = os.dup(1)
    os.dup2(fh.fileno(), 1)
    try:
        yield
    finally:
        libc.fflush(None)
        os.dup2(saved, 1)
        os.close(saved)


def _ipopt_reason(text: str) -> str:
    """IPOPT's own explanation of a rejected option, in one line."""
    lines = [' '.join(ln.split()) for ln in text.splitlines() if ln.strip()]
    if not lines:
        return 'rejected by IPOPT'
    reason = lines[0].replace(' Please check the list of available options.', '') \
        .replace(' Check the option documentation.', '') \
        .replace(' Please check the documentation for options.', '')
    ranges = [ln for ln in lines if '<=' in ln or '<' in ln and '(' in ln]
    if 'Valid Settings:' in lines:
        i = lines.index('Valid Settings:')
        valid = [ln.split()[0] for ln in lines[i + 1:] if not ln.startswith('Default')]
        reason += f' (valid: {", ".join(valid)})'
    elif ranges:
        reason += f' (range: {ranges[0]})'
    return reason


def _add_option(nlp: cyipopt.Problem, name: str, value: Any) -> None:
    """``nlp.add_option``, taking an integer for a real-valued option too (TOML writes
    ``acceptable_tol = 1`` as an integer; IPOPT would reject it by type)."""
    try:
        nlp.add_option(name, value)
    except TypeError:
        if isinstance(value, bool) or not isinstance(value, int):
            raise
        nlp.add_option(name, float(value))


def ipopt_option_problems(options: dict[str, Any]) -> list[str]:
    """One ``name: reason`` line per option that IPOPT itself rejects (unknown name, wrong
    type, value out of range), found by setting each on a throw-away IPOPT problem."""
    if not options:
        return []
    problems = []
    nlp = cyipopt.Problem(n=1, m=0, problem_obj=_OptionProbe(), lb=[0.0], ub=[1.0])
    try:
        for name, value in options.items():
            if isinstance(value, bool) or not isinstance(value, (int, float, str)):
                problems.append(f'{name}: must be a number or a string, got {value!r}')
                continue
            with tempfile.TemporaryFile(mode='w+') as out:
                try:
                    with _c_stdout_to(out):
                        _add_option(nlp, name, value)
                except TypeError:
                    out.seek(0)
                    problems.append(f'{name}: IPOPT rejects {value!r}: '
                                    f'{_ipopt_reason(out.read())}')
    finally:
        nlp.close()
    return problems


class _IgnoreZeroing(np.ndarray):
    """The dense total Jacobian, minus OpenMDAO's ``J[:] = 0`` before every evaluation.

    Under :class:`_ColoredNonzerosTotalJac` the dense array is never written (the values go
    straight to the nonzeros), so it stays the untouched ``np.zeros`` it was allocated as;
    re-zeroing it (~50 ms at 80 x 5, 10^7 entries) would be the only touch.
    """

    def __setitem__(self, key, value):
        if type(key) is slice and key == slice(None) and np.isscalar(value) and value == 0:
            return
        super().__setitem__(key, value)


class _ColoredNonzerosTotalJac(_TotalJacInfo):
    """OpenMDAO's forward-colored total Jacobian, gathered straight into its nonzeros.

    OpenMDAO writes each column of a colored solve into a dense (m, n) array in a Python
    loop over columns, and the driver would then gather the nonzeros from it again. Here
    each color's solution is scattered with one vectorized assignment into
    :attr:`nonzeros`, ordered as the coloring's ``(_nzrows, _nzcols)`` (the IPOPT
    structure); the dense array is neither written nor re-zeroed. Only for unscaled totals
    in forward mode on one process, without unit conversions or coloring subtractions.
    """

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        col = self.simul_coloring
        if (col is None or self.jac_scratch is not None or self.comm.size > 1
                or col._subtractions or self.has_scaling
                or self._desvar_unit_scalers or self._resp_unit_scalers):
            raise RuntimeError('internal error: colored nonzero gathering does not apply')
        self.J = self.J.view(_IgnoreZeroing)
        self.nonzeros = np.zeros(col._nzrows.size)
        self._positions: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]] = {}
        # (row, col) of every nonzero as one sortable key, to find a color's positions
        self._nz_keys = col._nzrows.astype(np.int64) * col._shape[1] + col._nzcols
        self._nz_order = np.argsort(self._nz_keys, kind='stable')

    def _color_positions(self, inds) -> tuple[np.ndarray, np.ndarray]:
        """(rows of the solution vector, positions in :attr:`nonzeros`) of one color."""
        key = (inds[0], len(inds))
        if key not in self._positions:
            col = self.simul_coloring
            row_col_map = col.get_row_col_map('fwd')
            rows = [np.asarray(row_col_map[i], dtype=int) for i in inds]
            cols = np.repeat(np.asarray(inds, dtype=int), [r.size for r in rows])
            rows = np.concatenate(rows)
            keys = rows.astype(np.int64) * col._shape[1] + cols
            order = self._nz_order
            self._positions[key] = (rows, order[np.searchsorted(self._nz_keys[order], keys)])
        return self._positions[key]

    def simul_coloring_jac_setter(self, inds, mode, meta):
        rows, pos = self._color_positions(inds)
        deriv_idxs, _, _ = self.sol2jac_map[mode]
        self.nonzeros[pos] = self.output_vec[mode].asarray()[deriv_idxs][rows]


@contextmanager
def _linearized(model):
    """Skip the next linearization: the model was just linearized at this point."""
    model._linearize = lambda *args, **kwargs: None
    try:
        yield
    finally:
        del model._linearize


@contextmanager
def _solving_in(problem, mode: str):
    """Let OpenMDAO compute a coloring in ``mode`` on a problem set up with mode='auto'."""
    meta = problem._metadata
    saved = meta['mode']
    meta['mode'] = mode
    try:
        yield
    finally:
        meta['mode'] = saved


@dataclass
class IterationInfo:
    """One accepted IPOPT iteration, as reported to the progress callback."""

    iteration: int
    objective: float
    constraint_violation: float
    dual_infeasibility: float
    elapsed_s: float
    design: dict[str, float] = field(default_factory=dict)


class IpoptDriver(Driver):
    """Drive an OpenMDAO problem with IPOPT (cyipopt), using the sparse colored total Jacobian.

    Options: ``max_iter``, ``tol``, ``print_level`` (IPOPT's own output, 0 = silent),
    ``hessian_approximation``, ``progress`` (callable receiving :class:`IterationInfo`),
    ``watch`` (design-variable names whose values are put in each :class:`IterationInfo`),
    ``pinned`` (design variables held fixed by bounds lower = upper, so that evaluating a
    fixed design keeps the optimization's structure and coloring).
    Further raw IPOPT options go in ``opt_settings``.
    """

    def __init__(self, **kwargs: Any):
        super().__init__(**kwargs)
        self.supports['optimization'] = True
        self.supports['inequality_constraints'] = True
        self.supports['equality_constraints'] = True
        self.supports['two_sided_constraints'] = True
        self.supports['linear_constraints'] = False
        # colorings are handled here (constraints only), not by OpenMDAO's driver
        self.supports['simultaneous_derivatives'] = False
        self.supports['total_jac_sparsity'] = False
        self.supports['multiple_objectives'] = False
        self.supports['active_set'] = False
        self.supports['integer_design_vars'] = False
        self.supports['distributed_design_vars'] = False
        self.supports._read_only = True
        self.opt_settings: dict[str, Any] = {}
        self.history: list[IterationInfo] = []
        self.status: int | None = None
        self.status_message = ''
        self.n_function_evals = 0
        self.n_gradient_evals = 0
        self.last_error: str | None = None
        self._stop_requested = False
        self._con_coloring: coloring_mod.Coloring | None = None
        self._coloring_request: dict[str, int] | None = None

    def _declare_options(self) -> None:
        self.options.declare('max_iter', default=3000, types=int, lower=0)
        self.options.declare('tol', default=1e-8, types=float, lower=0.0)
        self.options.declare('print_level', default=0, types=int, lower=0, upper=12)
        self.options.declare('hessian_approximation', default='limited-memory',
                             values=('limited-memory', 'exact'))
        self.options.declare('progress', default=None, allow_none=True,
                             desc='callable(IterationInfo) called after every iteration')
        self.options.declare('watch', default=(), types=(list, tuple),
                             desc='design variables reported in IterationInfo.design')
        self.options.declare('pinned', default=(), types=(list, tuple),
                             desc='design variables held at their current value '
                                  '(IPOPT bounds lower = upper)')

    def _get_name(self) -> str:
        return 'IPOPT'

    # ------------------------------------------------------------------ layout
    def _layout(self) -> None:
        self._of = self._get_ordered_nl_responses()
        self._wrt = list(self._designvars)
        if any(meta.get('linear') for meta in self._cons.values()):
            raise RuntimeError(f'{self.msginfo}: linear constraints are not supported')
        obj_vals = self.get_objective_values()
        con_vals = self.get_constraint_values(lintype='nonlinear')
        sizes = {**{k: np.size(v) for k, v in obj_vals.items()},
                 **{k: np.size(v) for k, v in con_vals.items()}}
        self._con_names = [n for n in self._of if n in self._cons]
        self._con_sizes = [sizes[n] for n in self._con_names]
        self._n_obj = sizes[self._of[0]]
        dv = self.get_design_var_values()
        self._dv_sizes = [np.size(dv[n]) for n in self._wrt]
        self.n = int(sum(self._dv_sizes))
        self.m = int(sum(self._con_sizes))
        # driver scaling of the Jacobian, applied to its nonzeros only:
        # J_scaled[i, j] = J[i, j] * row_scaler[i] / col_scaler[j]
        self._row_scaler = np.concatenate(
            [self._scaler_vector(self._responses[n], s) for n, s in
             zip(self._of, [self._n_obj] + self._con_sizes)])
        self._col_scaler = np.concatenate(
            [self._scaler_vector(self._designvars[n], s) for n, s in
             zip(self._wrt, self._dv_sizes)])

        bounds = self._autoscaler.get_bounds_scaling('design_var')
        lb, ub = [], []
        for name, size in zip(self._wrt, self._dv_sizes):
            lo, up = bounds[name].lower, bounds[name].upper
            lb.append(np.broadcast_to(-_INF if lo is None else lo, (size,)))
            ub.append(np.broadcast_to(_INF if up is None else up, (size,)))
        self._lb = np.clip(np.concatenate(lb), -_INF, _INF)
        self._ub = np.clip(np.concatenate(ub), -_INF, _INF)
        x = self._x()
        start = 0
        for name, size in zip(self._wrt, self._dv_sizes):
            if name in self.options['pinned']:
                self._lb[start:start + size] = self._ub[start:start + size] = \
                    x[start:start + size]
            start += size

        cbounds = self._autoscaler.get_bounds_scaling('constraint')
        cl, cu = [], []
        for name, size in zip(self._con_names, self._con_sizes):
            b = cbounds[name]
            if b.equals is not None:
                cl.append(np.broadcast_to(b.equals, (size,)))
                cu.append(np.broadcast_to(b.equals, (size,)))
            else:
                cl.append(np.broadcast_to(-_INF if b.lower is None else b.lower, (size,)))
                cu.append(np.broadcast_to(_INF if b.upper is None else b.upper, (size,)))
        self._cl = np.clip(np.concatenate(cl), -_INF, _INF) if cl else np.zeros(0)
        self._cu = np.clip(np.concatenate(cu), -_INF, _INF) if cu else np.zeros(0)

    @staticmethod
    def _scaler_vector(meta: dict, size: int) -> np.ndarray:
        scaler = meta.get('total_scaler')
        return np.broadcast_to(1.0 if scaler is None else np.asarray(scaler, dtype=float),
                               (size,)).copy()

    def use_constraint_coloring(self, coloring: coloring_mod.Coloring | None) -> None:
        """Use this forward coloring of the constraint Jacobian (e.g. from a cache)."""
        self._con_coloring = coloring

    def declare_constraint_coloring(self, num_full_jacs: int = 1) -> None:
        """Compute a forward coloring of the constraint Jacobian on the first solve, with
        randomized partials on their declared sparsity (``num_full_jacs`` Jacobians)."""
        self._coloring_request = {'num_full_jacs': num_full_jacs}

    def total_coloring(self) -> coloring_mod.Coloring | None:
        """The forward coloring of the constraint Jacobian: the one given to
        :meth:`use_constraint_coloring`, or computed once here after
        :meth:`declare_constraint_coloring`; None without either (dense Jacobian)."""
        self._layout()
        if self._con_coloring is None and self._coloring_request and self._con_names:
            problem = self._problem()
            info = self._coloring_info
            with _solving_in(problem, 'fwd'):
                self._con_coloring = coloring_mod.compute_total_coloring(
                    problem, mode='fwd', of=self._con_names, wrt=self._wrt,
                    num_full_jacs=self._coloring_request['num_full_jacs'], tol=info['tol'],
                    orders=info['orders'], driver=self)
        coloring = self._con_coloring
        if coloring is not None and tuple(coloring._shape) != (self.m, self.n):
            raise RuntimeError(f'{self.msginfo}: total coloring shape {coloring._shape} does '
                               f'not match the constraint Jacobian ({self.m}, {self.n}); the '
                               'cached coloring is stale')
        return coloring

    def _sparsity(self, coloring) -> tuple[np.ndarray, np.ndarray]:
        """Constraint-Jacobian structure (rows, cols) in IPOPT's layout."""
        if coloring is not None:
            return coloring._nzrows, coloring._nzcols
        return np.nonzero(np.ones((self.m, self.n), dtype=bool))

    # ------------------------------------------------------------------ evaluations
    def _x(self) -> np.ndarray:
        dv = self.get_design_var_values()
        return np.concatenate([np.ravel(dv[n]) for n in self._wrt])

    def _evaluate(self, x: np.ndarray) -> None:
        """Run the model at x (driver-scaled) unless it was the last point run."""
        if self._x_run is not None and np.array_equal(x, self._x_run):
            if self._eval_failed:
                raise cyipopt.CyIpoptEvaluationError()
            return
        self._x_run = x.copy()
        self._x_jac = None
        self._eval_failed = False
        model = self._problem().model
        self._vectors['design_var'].set_data(x, driver_scaling=True)
        self._set_design_vars(driver_scaling=True)
        self.n_function_evals += 1
        with RecordingDebugging(self._get_name(), self.iter_count, self):
            self.iter_count += 1
            try:
                with model._relevance.nonlinear_active('iter'):
                    self._run_solve_nonlinear()
            except om.AnalysisError as err:
                self.last_error = str(err)
                self._eval_failed = True
        if not self._eval_failed:
            obj = np.concatenate([np.ravel(v) for v in
                                  self.get_objective_values(driver_scaling=True).values()])
            cons = self.get_constraint_values(lintype='nonlinear', driver_scaling=True)
            con = (np.concatenate([np.ravel(cons[n]) for n in self._con_names])
                   if self._con_names else np.zeros(0))
            if not (np.all(np.isfinite(obj)) and np.all(np.isfinite(con))):
                self.last_error = 'the model returned NaN or inf'
                self._eval_failed = True
            else:
                self._f, self._g = float(obj[0]), con
        if self._eval_failed:
            raise cyipopt.CyIpoptEvaluationError()

    def _jacobian_values(self, x: np.ndarray) -> None:
        self._evaluate(x)
        if self._x_jac is not None and np.array_equal(x, self._x_jac):
            return
        self.n_gradient_evals += 1
        try:
            g, jac = self._totals()
        except om.AnalysisError as err:
            self.last_error = str(err)
            raise cyipopt.CyIpoptEvaluationError() from None
        grad = g * (self._row_scaler[0] / self._col_scaler)
        jac = jac * self._jac_scaler
        if not (np.all(np.isfinite(grad)) and np.all(np.isfinite(jac))):
            self.last_error = 'the total derivatives contain NaN or inf'
            raise cyipopt.CyIpoptEvaluationError()
        self._grad, self._jac = grad, jac
        self._x_jac = x.copy()

    def _totals(self) -> tuple[np.ndarray, np.ndarray]:
        """Unscaled objective gradient (n,) and the constraint Jacobian's values at the
        IPOPT structure ``(_jrows, _jcols)``: one linearization, then the colored forward
        solves of the constraints (always in the driver's of/wrt order, so that they line
        up with the coloring), then one reverse solve for the objective."""
        problem = self._problem()
        if self._ojac is None:
            self._alljac = _TotalJacInfo(problem, self._of, self._wrt, 'array',
                                         driver_scaling=False)
            coloring = self.total_coloring()
            self._tjac = None
            if self._con_names and coloring is not None:
                meta = coloring_mod.ColoringMeta()
                meta.coloring = coloring
                self._tjac = _ColoredNonzerosTotalJac(
                    problem, self._con_names, self._wrt, 'array', driver_scaling=False,
                    coloring_info=meta)
            elif self._con_names:  # no coloring: dense
                self._tjac = _TotalJacInfo(problem, self._con_names, self._wrt, 'array',
                                           driver_scaling=False)
            self._ojac = _TotalJacInfo(problem, self._of[:1], self._wrt, 'array',
                                       driver_scaling=False)
        self._linearize_model()
        with _linearized(problem.model):
            if self._tjac is None:
                jac = np.zeros(0)
            elif isinstance(self._tjac, _ColoredNonzerosTotalJac):
                self._tjac.compute_totals()
                jac = self._tjac.nonzeros
            else:
                jac = self._tjac.compute_totals()[self._jrows, self._jcols]
            g = self._ojac.compute_totals()[0].copy()
        return g, jac

    def _linearize_model(self) -> None:
        """Linearize every system that the objective or a constraint depends on, once per
        iterate. (Each OpenMDAO total-derivative computation linearizes only the systems
        relevant to its own of/wrt, so the constraint Jacobian's would miss the objective's
        path, and a second linearization would repeat every black-box FD.)"""
        model = self._problem().model
        tj = self._alljac
        model._dinputs.set_val(0.0)
        model._doutputs.set_val(0.0)
        model._dresiduals.set_val(0.0)
        model._tot_jac = tj
        try:
            with tj._totjac_context(), tj.relevance.active(model.linear_solver.use_relevance()):
                with tj.relevance.all_seeds_active():
                    solver = model._linear_solver
                    with model._scaled_context_all():
                        model._linearize(sub_do_ln=solver._linearize_children())
                    solver._linearize()
        finally:
            model._tot_jac = None

    # cyipopt callbacks
    def objective(self, x: np.ndarray) -> float:
        self._evaluate(x)
        return self._f

    def constraints(self, x: np.ndarray) -> np.ndarray:
        self._evaluate(x)
        return self._g

    def gradient(self, x: np.ndarray) -> np.ndarray:
        self._jacobian_values(x)
        return self._grad

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        self._jacobian_values(x)
        return self._jac

    def jacobianstructure(self) -> tuple[np.ndarray, np.ndarray]:
        return self._jrows, self._jcols

    def intermediate(self, alg_mod, iter_count, obj_value, inf_pr, inf_du, mu, d_norm,
                     regularization_size, alpha_du, alpha_pr, ls_trials) -> bool:
        info = IterationInfo(iteration=int(iter_count), objective=float(obj_value),
                             constraint_violation=float(inf_pr),
                             dual_infeasibility=float(inf_du),
                             elapsed_s=time.perf_counter() - self._t0)
        watch = self.options['watch']
        if watch:
            try:
                it = self._nlp.get_current_iterate(scaled=False)
                x = np.asarray(it['x'])
            except Exception:  # not available during restoration
                x = self._x_run
            if x is not None:
                info.design = self._unscaled_design(x, watch)
        self.history.append(info)
        if self.options['progress'] is not None:
            self.options['progress'](info)
        return not self._stop_requested

    def _unscaled_design(self, x: np.ndarray, names) -> dict[str, float]:
        """Physical values of the watched (scalar) design variables at driver-scaled x."""
        out, start = {}, 0
        for name, size in zip(self._wrt, self._dv_sizes):
            if name in names:
                meta = self._designvars[name]
                scaler = 1.0 if meta['total_scaler'] is None else meta['total_scaler']
                adder = 0.0 if meta['total_adder'] is None else meta['total_adder']
                out[name] = float(np.ravel(x[start:start + size] / scaler - adder)[0])
            start += size
        return out

    # ------------------------------------------------------------------ run
    def run(self) -> bool:
        """Solve with IPOPT. Returns the failure flag (OpenMDAO's convention)."""
        self.result.reset()
        problem = self._problem()
        self.iter_count = 0
        self._total_jac = None
        self._tjac = self._ojac = self._alljac = None
        self._x_run = self._x_jac = None
        self._eval_failed = False
        self.history = []
        self.status, self.status_message, self.last_error = None, '', None
        self.n_function_evals = self.n_gradient_evals = 0
        self._stop_requested = False
        self._check_for_missing_objective()
        self._t0 = time.perf_counter()

        with RecordingDebugging(self._get_name(), self.iter_count, self):
            self._run_solve_nonlinear()
        self.iter_count += 1
        self._layout()
        self._jrows, self._jcols = self._sparsity(self.total_coloring())
        # driver scaling of the constraint Jacobian, on its nonzeros
        self._jac_scaler = (self._row_scaler[self._n_obj + self._jrows]
                            / self._col_scaler[self._jcols])

        self._nlp = nlp = cyipopt.Problem(n=self.n, m=self.m, problem_obj=self,
                                          lb=self._lb, ub=self._ub, cl=self._cl, cu=self._cu)
        nlp.add_option('hessian_approximation', self.options['hessian_approximation'])
        nlp.add_option('max_iter', self.options['max_iter'])
        nlp.add_option('tol', self.options['tol'])
        nlp.add_option('print_level', self.options['print_level'])
        nlp.add_option('sb', 'yes')
        for key, val in self.opt_settings.items():
            _add_option(nlp, key, val)

        previous = signal.getsignal(signal.SIGINT)

        def on_sigint(signum, frame):
            if self._stop_requested:
                raise KeyboardInterrupt
            self._stop_requested = True
            print('\nInterrupt: stopping IPOPT after this iteration (Ctrl-C again to abort).',
                  file=sys.stderr)

        try:
            signal.signal(signal.SIGINT, on_sigint)
        except ValueError:  # not in the main thread
            previous = None
        x0 = self._x()
        try:
            x, info = nlp.solve(x0)
        finally:
            if previous is not None:
                signal.signal(signal.SIGINT, previous)
            nlp.close()
            self._nlp = None
        self.status = int(info['status'])
        self.status_message = IPOPT_STATUS.get(self.status,
                                               info['status_msg'].decode(errors='replace'))

        # leave the model at IPOPT's final point and record it
        self._x_run = None
        try:
            self._evaluate(np.asarray(x))
        except cyipopt.CyIpoptEvaluationError:
            pass
        return self.status not in (0, 1)

    def _update_result(self, result) -> None:
        result.exit_status = self.status_message
        result.success = self.status in (0, 1)
