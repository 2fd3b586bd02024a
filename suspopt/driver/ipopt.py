"""IPOPT as an OpenMDAO driver, through cyipopt and OpenMDAO's public API (paper §3.6).

OpenMDAO 3.45 reaches IPOPT only through pyOptSparse, which is not available here, so
:class:`IpoptDriver` is an OpenMDAO ``Driver`` (``openmdao.core.driver.Driver``, the base
class of OpenMDAO's own drivers) around ``cyipopt``: ``problem.driver = IpoptDriver(...)``
and ``problem.run_driver()`` solve, the driver's case recorders record every accepted
IPOPT iteration, and OpenMDAO's ``debug_print`` applies. It reads the NLP the model
declares (design variables, constraints, objective, their ``ref``/``ref0`` scaling) from
public metadata and drives the model by public calls (``run_solve_nonlinear``, and
:mod:`suspopt.driver.totals` for the derivatives):

* design variables, bounds and constraints are passed to IPOPT in driver scaling;
* the constraint Jacobian is given to IPOPT as a sparse matrix whose structure is the
  exact sparsity computed from the model's declared partials
  (:mod:`suspopt.driver.sparsity`); its values come from one forward solve per color,
  gathered straight into IPOPT's nonzeros (no dense (m, n) array), driver-scaled there;
* the objective gradient comes from one reverse solve on the same linearization;
* the Hessian of the Lagrangian is approximated by IPOPT (limited-memory BFGS), its
  low-rank update kept in IPOPT's augmented system (``limited_memory_aug_solver =
  extended``, see :data:`LIMITED_MEMORY_OPTIONS`), or, with ``hessian = 'exact'``, given
  to IPOPT on a sparsity pattern derived from the model's structure, its values by
  second-order adjoints along a symmetric coloring (:mod:`suspopt.driver.hessian`);
* a model evaluation that fails (``AnalysisError``, non-finite values) is reported to IPOPT
  as an evaluation error, so IPOPT backtracks instead of aborting;
* every accepted iteration is recorded by the driver's recorders (``record_iteration``,
  the model run at that iterate), reported to the ``progress`` option's callable
  (iteration, objective, constraint violation, elapsed time) and kept in ``history``;
* design variables named in the ``pinned`` option are held at their current values
  (IPOPT bounds lower = upper);
* Ctrl-C (SIGINT) or SIGTERM stops IPOPT at once (:mod:`suspopt.interrupts`):
  every evaluation callback refuses to run after it and IPOPT ends at its next
  intermediate callback; an iterate that already meets IPOPT's tolerances may take its
  last iteration, so a solve converging as the signal comes is kept as converged; a
  second signal ends the process at once. :attr:`IpoptDriver.interrupted` tells the
  caller, which decides what to keep and then stops too. IPOPT's ``max_wall_time`` is
  :data:`MAX_WALL_TIME` unless the options say otherwise (a guard against a runaway
  solve);
* a case recorder that cannot be written (a full disk) stops IPOPT and is a
  :class:`~suspopt.errors.RunError` naming the file;
* the exit status is reported truthfully: :attr:`IpoptDriver.status_message` is IPOPT's
  own, and the run counts as a success (``run()`` returns OpenMDAO's failure flag False,
  ``run_driver()``'s ``DriverResult.success`` is True) only if IPOPT reports one of
  :data:`SUCCESS`.
"""

from __future__ import annotations

import ctypes
import os
import pprint
import sqlite3
import sys
import tempfile
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import cyipopt
import numpy as np
import openmdao.api as om
from openmdao.core.driver import Driver, DriverResult, RecordingDebugging

import suspopt.driver.structure as structure
from suspopt import interrupts
from suspopt.driver.dataflow import DataFlow, data_flow
from suspopt.driver.hessian import (
    HessianColoring,
    HessianStructure,
    PropagatedHessian,
    edge_values,
    fd_hessian,
    hessian_structure,
    varying_entries,
)
from suspopt.driver.propagation import TOTALS_METHODS, PropagatedTotals, make_totals
from suspopt.driver.propagation import supported as propagation_supported
from suspopt.driver.sparsity import Coloring, Variable, compute_coloring
from suspopt.driver.structure import driver_name
from suspopt.driver.totals import ColoredTotals, Layout, flat_positions, nlp_layout
from suspopt.errors import RunError

#: IPOPT's return statuses (IpReturnCodes.h).
IPOPT_STATUS = {
    0: 'Solve_Succeeded',
    1: 'Solved_To_Acceptable_Level',
    2: 'Infeasible_Problem_Detected',
    3: 'Search_Direction_Becomes_Too_Small',
    4: 'Diverging_Iterates',
    5: 'User_Requested_Stop',
    6: 'Feasible_Point_Found',
    -1: 'Maximum_Iterations_Exceeded',
    -2: 'Restoration_Failed',
    -3: 'Error_In_Step_Computation',
    -4: 'Maximum_CpuTime_Exceeded',
    -5: 'Maximum_WallTime_Exceeded',
    -10: 'Not_Enough_Degrees_Of_Freedom',
    -11: 'Invalid_Problem_Definition',
    -12: 'Invalid_Option',
    -13: 'Invalid_Number_Detected',
    -100: 'Unrecoverable_Exception',
    -101: 'NonIpopt_Exception_Thrown',
    -102: 'Insufficient_Memory',
    -199: 'Internal_Error',
}
#: the statuses of a solved problem: ``Solve_Succeeded``, ``Solved_To_Acceptable_Level``,
#: and ``Feasible_Point_Found``, IPOPT's verdict on a square problem (no degrees of
#: freedom: an evaluation, its design pinned) whose equations it solved, by way of its
#: restoration phase
SUCCESS = (0, 1, 6)
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


@dataclass(frozen=True)
class _OptionDoc:
    """What IPOPT's documentation block of an option says (printed when it rejects a
    value): its type, its valid settings (a string option) or its range (a number)."""

    kind: str = ''
    settings: tuple[str, ...] = ()
    range: str = ''


def _option_doc(text: str) -> _OptionDoc:
    """The first documentation block (``### name (Type) ###``) in IPOPT's output."""
    lines = text.splitlines()
    for i, line in enumerate(lines):
        head = line.strip()
        if head.startswith('###') and head.endswith('###') and '(' in head:
            kind = head[head.index('(') + 1 : head.rindex(')')].strip()
            settings: list[str] = []
            rng = ''
            for ln in lines[i + 1 :]:
                if ln.strip().startswith('###') or ln.startswith('Tried to set'):
                    break
                if ln.startswith('\t') and ln.strip():
                    settings.append(ln.split()[0])
                elif '<' in ln and '(' in ln and ln.strip()[0] in '-+0123456789':
                    rng = ' '.join(ln.split())
            return _OptionDoc(kind, tuple(settings), rng)
    return _OptionDoc()


#: IPOPT's option types, as a user reads them
_KINDS = {'Real Number': 'a number', 'Integer': 'a whole number', 'String': 'a setting'}


def _ipopt_reason(text: str, value: Any) -> str:
    """Why IPOPT rejected ``value``, in one line: not an option, the wrong type, or a
    value outside its settings or range (from IPOPT's own documentation of it)."""
    first = next((' '.join(ln.split()) for ln in text.splitlines() if ln.strip()), '')
    if 'is not a valid option' in first:
        return 'not a valid option of IPOPT (its options: coin-or.github.io/Ipopt/OPTIONS.html)'
    doc = _option_doc(text)
    allowed = (
        f' (valid: {", ".join(doc.settings)})'
        if doc.settings
        else f' (range: {doc.range}; the default in brackets)'
        if doc.range
        else ''
    )
    if 'is of type' in first:
        return f'expects {_KINDS.get(doc.kind, doc.kind or "another type")}, got {value!r}{allowed}'
    if 'is not a valid setting' in first:
        return f'{value!r} is ' + ('out of range' if doc.range else 'not a valid setting') + allowed
    return (first or 'rejected by IPOPT') + allowed


def _option_value_problem(name: str, value: Any) -> str | None:
    """What is wrong with an option before IPOPT sees it (None: let IPOPT judge)."""
    if not isinstance(name, str) or not name.strip() or name != name.strip():
        return f': {name!r} is not an option name (empty, or spaces around it)'
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        return f'{name}: must be a number or a string, got {value!r}'
    if isinstance(value, int) and not -(2**31) <= value < 2**31:
        return f'{name}: {value} is too large for IPOPT (a whole number below 2^31)'
    if isinstance(value, float) and not np.isfinite(value):
        return f'{name}: must be a finite number (IPOPT reads 1e20 as none), got {value!r}'
    if isinstance(value, str) and '\x00' in value:
        return f'{name}: {value!r} contains a NUL byte'
    return None


def _add_option(nlp: cyipopt.Problem, name: str, value: Any) -> None:
    """``nlp.add_option``, taking an integer for a real-valued option too (TOML writes
    ``acceptable_tol = 1`` as an integer; IPOPT would reject it by type)."""
    try:
        nlp.add_option(name, value)
    except TypeError:
        if isinstance(value, bool) or not isinstance(value, int):
            raise
        nlp.add_option(name, float(value))


#: IPOPT options the driver sets from first-class study keys (the options table would
#: override them, and the command line's --max-iter with them)
DRIVER_OPTIONS = {
    'max_iter': 'optimizer.max_iter',
    'tol': 'optimizer.tol',
    'print_level': 'optimizer.print_level',
    'hessian_approximation': 'optimizer.hessian',
}


def ipopt_option_problems(options: dict[str, Any]) -> list[str]:
    """One ``name: reason`` line per option IPOPT would reject, before any work: unknown
    name, wrong type, value out of range (set on a throw-away IPOPT problem), an option
    that only fails when IPOPT starts (an unavailable ``linear_solver``: one tiny real
    solve with the options), an ``output_file`` that cannot be written, and options the
    driver sets itself (:data:`DRIVER_OPTIONS`)."""
    if not options:
        return []
    problems = []
    nlp = cyipopt.Problem(n=1, m=0, problem_obj=_OptionProbe(), lb=[0.0], ub=[1.0])
    accepted = {}
    try:
        for name, value in options.items():
            problem = _option_value_problem(name, value)
            if problem is not None:
                problems.append(problem)
                continue
            if name in DRIVER_OPTIONS:
                problems.append(
                    f'{name}: set {DRIVER_OPTIONS[name]} instead (the driver sets '
                    'this option from it)'
                )
                continue
            with tempfile.TemporaryFile(mode='w+') as out:
                try:
                    with _c_stdout_to(out):
                        _add_option(nlp, name, value)
                except TypeError:
                    out.seek(0)
                    problems.append(f'{name}: {_ipopt_reason(out.read(), value)}')
                    continue
            if name == 'output_file':
                problems.extend(_output_file_problems(name, value))
            else:
                accepted[name] = value
    finally:
        nlp.close()
    if accepted and _probe_solve(accepted)[0] in _OPTION_FAILURES:
        for name, value in accepted.items():  # which one: each alone
            status, text = _probe_solve({name: value})
            if status in _OPTION_FAILURES:
                problems.append(
                    f'{name}: IPOPT cannot run with {value!r}: '
                    f'{_solve_reason(text)}'
                    + (
                        " (this IPOPT's linear solver is 'mumps')"
                        if name == 'linear_solver'
                        else ''
                    )
                )
    return problems


#: IPOPT statuses of a solve that an option stopped before it began
_OPTION_FAILURES = (-11, -12)


def _probe_solve(options: dict[str, Any]) -> tuple[int, str]:
    """Solve the smallest problem with ``options``: (IPOPT status, what IPOPT printed)."""
    nlp = cyipopt.Problem(n=1, m=0, problem_obj=_OptionProbe(), lb=[0.0], ub=[1.0])
    try:
        with tempfile.TemporaryFile(mode='w+') as out:
            with _c_stdout_to(out):
                nlp.add_option('hessian_approximation', 'limited-memory')
                nlp.add_option('sb', 'yes')
                for name, value in options.items():
                    _add_option(nlp, name, value)
                nlp.add_option('print_level', 1)
                _, info = nlp.solve(np.array([0.5]))
            out.seek(0)
            return int(info['status']), out.read()
    finally:
        nlp.close()


def _solve_reason(text: str) -> str:
    """IPOPT's explanation of a solve that did not start, in one line."""
    lines = [' '.join(ln.split()) for ln in text.splitlines() if ln.strip()]
    msg = [
        ln.split('Exception message:', 1)[1].strip() for ln in lines if 'Exception message:' in ln
    ]
    return (msg or lines or ['IPOPT stopped before the first iteration (Invalid_Option)'])[0]


def _output_file_problems(name: str, value: Any) -> list[str]:
    from pathlib import Path

    if not isinstance(value, str) or not value:
        return [f'{name}: must be a file name, got {value!r}']
    path = Path(value)
    parent = path.parent if str(path.parent) else Path('.')
    if path.is_dir():
        return [f'{name}: {value} is a directory']
    if not parent.is_dir():
        return [f'{name}: cannot write {value}: directory {parent} does not exist']
    if not os.access(parent, os.W_OK) or (path.exists() and not os.access(path, os.W_OK)):
        return [f'{name}: cannot write {value}: permission denied']
    return []


#: IPOPT options the driver sets with the limited-memory Hessian (a study's
#: ``optimizer.options`` override them). ``extended`` puts the quasi-Newton update's
#: low-rank terms into the augmented system that MUMPS factorizes; IPOPT's default
#: (``sherman-morrison``) keeps them out of it and pays extra back-solves with it instead,
#: whose cost grows faster than the NLP here. The same steps either way (the iterates
#: agree to rounding); ``benchmarks/ipopt_iterations.py --options sherman,extended``
#: measures both.
LIMITED_MEMORY_OPTIONS: dict[str, Any] = {'limited_memory_aug_solver': 'extended'}

#: IPOPT's ``max_wall_time`` [s] of every solve unless a study's ``optimizer.options``
#: sets it: a guard against a solve that runs away (IPOPT checks it once per iteration)
MAX_WALL_TIME = 3600.0

#: an iterate within this factor of IPOPT's tolerances may take one more iteration after
#: a signal (it is about to converge: its result is kept as converged)
NEAR_CONVERGED = 100.0


class _Stopped(Exception):
    """Raised in an evaluation callback after a signal: cyipopt keeps it, IPOPT ends at
    its next intermediate callback, and :meth:`IpoptDriver.run` catches it."""


#: the driver's ``hessian`` option: how IPOPT gets the Hessian of the Lagrangian
HESSIAN_METHODS = ('limited-memory', 'exact')

#: relative size of the random moves of the design at which the driver compares two
#: linearizations to find the model's nonlinear terms (:func:`hessian.varying_entries`)
PROBE_STEP = 1e-3

#: the Hessian's forward-difference step relative to max(1, |x_j|) (driver scaling)
FD_STEP = float(np.sqrt(np.finfo(float).eps))


@dataclass
class IterationInfo:
    """One accepted IPOPT iteration, as reported to the progress callback."""

    iteration: int
    objective: float
    constraint_violation: float
    dual_infeasibility: float
    elapsed_s: float
    design: dict[str, float] = field(default_factory=dict)


def _is_callable_or_none(name: str, value: Any) -> None:
    if value is not None and not callable(value):
        raise TypeError(f"option '{name}' must be callable or None, got {value!r}")


class IpoptDriver(Driver):
    """Solve the NLP declared on the problem's model with IPOPT (an OpenMDAO driver).

    ``problem.driver = IpoptDriver(max_iter=..., ...)`` and ``problem.run_driver()``
    (which returns OpenMDAO's ``DriverResult``). Options (``driver.options``, or keyword
    arguments):

    * ``max_iter``, ``tol``, ``print_level``: IPOPT's options of the same names;
    * ``hessian``: the Hessian of the Lagrangian: ``'limited-memory'`` (IPOPT's L-BFGS
      approximation) or ``'exact'`` (:mod:`suspopt.driver.hessian`: its pattern from the
      model's structure, its values by second-order adjoints along Hessian colors; L-BFGS
      with a warning where the model's data flow cannot be read);
    * ``totals``: how the total derivatives are computed
      (:data:`~suspopt.driver.propagation.TOTALS_METHODS`; ``'auto'`` propagates every
      color at once where the model allows it);
    * ``coloring``: the constraint Jacobian's sparsity and coloring in this layout
      (:func:`~suspopt.driver.sparsity.compute_coloring`), e.g. from a cache; computed
      from the model's declared structure on the first run if None, and kept here;
    * ``progress``: a callable receiving an :class:`IterationInfo` after every iteration;
      ``watch`` names design variables whose physical values it carries;
    * ``pinned``: design variables held at their current values (IPOPT bounds
      lower = upper), e.g. to evaluate one design by solving only the collocation.

    ``opt_settings`` (a dict, as on OpenMDAO's other drivers) holds further raw IPOPT
    options. After a run: :attr:`status`, :attr:`status_message`, :attr:`history`,
    :attr:`interrupted`, :attr:`last_error`, :attr:`n_function_evals`,
    :attr:`n_gradient_evals`, :attr:`n_hessian_evals`.
    """

    def __init__(self, **kwargs: Any):
        super().__init__(**kwargs)
        self.supports['optimization'] = True
        self.supports['inequality_constraints'] = True
        self.supports['equality_constraints'] = True
        self.supports['two_sided_constraints'] = True
        self.supports['linear_constraints'] = False
        self.supports['gradients'] = True
        self.supports['multiple_objectives'] = False
        self.supports['integer_design_vars'] = False
        self.supports['distributed_design_vars'] = False
        self.supports._read_only = True
        self.opt_settings: dict[str, Any] = {}
        self._has_recorders = False
        self.history: list[IterationInfo] = []
        self.status: int | None = None
        self.status_message = ''
        self.n_function_evals = self.n_gradient_evals = 0
        self.last_error: str | None = None
        self.interrupted = False
        self._layout: Layout | None = None
        self._hess: HessianColoring | None = None
        self._phess: PropagatedHessian | None = None
        self._exact = False
        self.n_hessian_evals = 0
        self._totals: ColoredTotals | PropagatedTotals | None = None
        self._nlp: cyipopt.Problem | None = None
        self._x_run: np.ndarray | None = None
        self._x_jac: np.ndarray | None = None
        self._x_lin: np.ndarray | None = None
        self._eval_failed = False
        self._near_converged = False
        self._x_accepted: np.ndarray | None = None
        self._failure: BaseException | None = None
        self._t0 = time.perf_counter()

    def _declare_options(self) -> None:
        self.options.declare('max_iter', default=3000, types=int, lower=0, desc='IPOPT max_iter')
        self.options.declare('tol', default=1e-8, types=(int, float), lower=0.0, desc='IPOPT tol')
        self.options.declare('print_level', default=0, types=int, desc='IPOPT print_level')
        self.options.declare(
            'hessian',
            default='limited-memory',
            values=HESSIAN_METHODS,
            desc="the Hessian of the Lagrangian: IPOPT's L-BFGS approximation, or 'exact' "
            '(second-order adjoints along Hessian colors, suspopt.driver.hessian)',
        )
        self.options.declare(
            'totals',
            default='auto',
            values=TOTALS_METHODS,
            desc='how the total derivatives are computed',
        )
        self.options.declare(
            'coloring',
            default=None,
            types=Coloring,
            allow_none=True,
            recordable=False,
            desc='the constraint Jacobian coloring (None: computed on the first run)',
        )
        self.options.declare(
            'hessian_structure',
            default=None,
            types=HessianStructure,
            allow_none=True,
            recordable=False,
            desc="with hessian='exact': its nonlinear terms and coloring (None: computed "
            'on the first run)',
        )
        self.options.declare(
            'progress',
            default=None,
            allow_none=True,
            check_valid=_is_callable_or_none,
            recordable=False,
            desc='called with an IterationInfo after every IPOPT iteration',
        )
        self.options.declare(
            'watch', default=[], types=(list, tuple), desc='design variables in IterationInfo'
        )
        self.options.declare(
            'pinned', default=[], types=(list, tuple), desc='design variables held fixed'
        )
        self.options.declare(
            'released',
            default=[],
            types=(list, tuple),
            desc='constraints whose bounds this run drops (an evaluation reports them)',
        )

    def _get_name(self) -> str:
        return 'IpoptDriver'

    def add_recorder(self, recorder: Any) -> None:
        """Add a case recorder: it records every accepted IPOPT iteration."""
        super().add_recorder(recorder)
        self._has_recorders = True

    def _setup_driver(self, problem: om.Problem) -> None:
        super()._setup_driver(problem)
        n_obj = len(problem.model.get_objectives())
        if n_obj != 1:
            raise RuntimeError(f'{self.msginfo}: needs exactly one objective, has {n_obj}')
        if (
            self._layout is not None
            and problem.model.get_nonlinear_vectors()[1] is not self._outputs
        ):
            self._layout = self._totals = self._hess = self._phess = None  # new vectors

    @property
    def problem(self) -> om.Problem:
        """The problem this driver is attached to."""
        if self._problem is None:
            raise RuntimeError(f'{self.msginfo}: not attached to a problem (problem.driver = ...)')
        return self._problem()

    @property
    def coloring(self) -> Coloring | None:
        """The constraint Jacobian's coloring in use (the ``coloring`` option)."""
        return self.options['coloring']

    # ------------------------------------------------------------------ layout
    def layout(self) -> Layout:
        """The NLP as declared on the model (read once per setup)."""
        if self._layout is None:
            lay = nlp_layout(self.problem)
            meta = [lay.dv_meta[v.name] for v in lay.design_vars]
            self._dv_scaler = _cat(meta, lay.design_vars, 'total_scaler', 1.0)
            self._dv_adder = _cat(meta, lay.design_vars, 'total_adder', 0.0)
            cmeta = [lay.con_meta[v.name] for v in lay.constraints]
            self._con_scaler = _cat(cmeta, lay.constraints, 'total_scaler', 1.0)
            self._con_adder = _cat(cmeta, lay.constraints, 'total_adder', 0.0)
            self._obj_scaler = float(_vec(lay.obj_meta.get('total_scaler'), 1.0, 1)[0])
            self._obj_adder = float(_vec(lay.obj_meta.get('total_adder'), 0.0, 1)[0])
            self._lb = self._scaled_x(_cat(meta, lay.design_vars, 'lower', -np.inf))
            self._ub = self._scaled_x(_cat(meta, lay.design_vars, 'upper', np.inf))
            cl, cu = [], []
            for m, v in zip(cmeta, lay.constraints):
                if m.get('equals') is not None:
                    cl.append(_vec(m['equals'], 0.0, v.size))
                    cu.append(_vec(m['equals'], 0.0, v.size))
                else:
                    cl.append(_vec(m.get('lower'), -np.inf, v.size))
                    cu.append(_vec(m.get('upper'), np.inf, v.size))
            self._cl = self._scaled_con(np.concatenate(cl)) if cl else np.zeros(0)
            self._cu = self._scaled_con(np.concatenate(cu)) if cu else np.zeros(0)
            _, outputs, _ = self.problem.model.get_nonlinear_vectors()
            self._outputs = outputs
            self._dv_pos = flat_positions(outputs, lay.design_vars)
            self._con_pos = flat_positions(outputs, lay.constraints)
            self._obj_pos = flat_positions(outputs, [lay.objective])
            starts = np.cumsum([0] + [v.size for v in lay.design_vars])
            self._dv_slices = {
                v.name: slice(a, b) for v, a, b in zip(lay.design_vars, starts[:-1], starts[1:])
            }
            self._layout = lay
        return self._layout

    def _scaled_x(self, phys: np.ndarray) -> np.ndarray:
        with np.errstate(invalid='ignore', over='ignore'):
            return np.clip((phys + self._dv_adder) * self._dv_scaler, -_INF, _INF)

    def _scaled_con(self, phys: np.ndarray) -> np.ndarray:
        with np.errstate(invalid='ignore', over='ignore'):
            return np.clip((phys + self._con_adder) * self._con_scaler, -_INF, _INF)

    def design_values(self) -> np.ndarray:
        """Physical values of all design-variable entries, in the layout's order."""
        self.layout()
        return self._outputs.asarray()[self._dv_pos].copy()

    def scaled_design(self) -> np.ndarray:
        """The model's current design in driver scaling (IPOPT's x)."""
        return self._scaled_x(self.design_values())

    def total_coloring(self) -> Coloring | None:
        """The constraint Jacobian's coloring: the given one, or computed from the model's
        declared structure (once, and kept in the ``coloring`` option)."""
        lay = self.layout()
        if self.options['coloring'] is None and lay.m:
            self.options['coloring'] = compute_coloring(
                self.problem, lay.constraints, lay.design_vars
            )
        c = self.options['coloring']
        if c is not None and tuple(c.shape) != (lay.m, lay.n):
            raise ValueError(
                f'total coloring shape {c.shape} does not match the constraint '
                f'Jacobian ({lay.m}, {lay.n}); the cached coloring is stale'
            )
        return c

    # ------------------------------------------------------------------ evaluations
    @DriverResult.track_stats(kind='model')
    def _run_model_at(self, x: np.ndarray) -> None:
        """Set the design (driver-scaled ``x``) into the model and run it."""
        self._outputs.asarray()[self._dv_pos] = x / self._dv_scaler - self._dv_adder
        self.n_function_evals += 1
        self.problem.model.run_solve_nonlinear()

    def _stop_check(self) -> None:
        """After a signal, an evaluation does not run (unless the last iterate was about
        to converge: it may finish that iteration): IPOPT stops at its next callback."""
        if self._nlp is not None and interrupts.requested() and not self._near_converged:
            raise _Stopped

    def _evaluate(self, x: np.ndarray) -> None:
        """Run the model at x (driver-scaled) unless it was the last point run."""
        self._stop_check()
        if self._x_run is not None and np.array_equal(x, self._x_run):
            if self._eval_failed:
                raise cyipopt.CyIpoptEvaluationError()
            return
        self._x_run = x.copy()
        self._eval_failed = False
        try:
            self._run_model_at(x)
        except om.AnalysisError as err:
            self.last_error = str(err)
            self._eval_failed = True
            raise cyipopt.CyIpoptEvaluationError() from None
        data = self._outputs.asarray()
        obj = (data[self._obj_pos] + self._obj_adder) * self._obj_scaler
        con = (data[self._con_pos] + self._con_adder) * self._con_scaler
        if not (np.all(np.isfinite(obj)) and np.all(np.isfinite(con))):
            self.last_error = 'the model returned NaN or inf'
            self._eval_failed = True
            raise cyipopt.CyIpoptEvaluationError()
        self._f, self._g = float(obj[0]), con

    @DriverResult.track_stats(kind='deriv')
    def _compute_derivatives(self) -> tuple[np.ndarray, np.ndarray]:
        self.n_gradient_evals += 1
        assert self._totals is not None
        return self._totals.compute()

    def _jacobian_values(self, x: np.ndarray) -> None:
        self._stop_check()
        if self._x_jac is not None and np.array_equal(x, self._x_jac):
            return
        self._evaluate(x)
        self._x_lin = None
        try:
            g, jac = self._compute_derivatives()
        except om.AnalysisError as err:
            self.last_error = str(err)
            raise cyipopt.CyIpoptEvaluationError() from None
        grad = g * (self._obj_scaler / self._dv_scaler)
        jac = jac * self._jac_scaler
        if not (np.all(np.isfinite(grad)) and np.all(np.isfinite(jac))):
            self.last_error = 'the total derivatives contain NaN or inf'
            raise cyipopt.CyIpoptEvaluationError()
        self._grad, self._jac = grad, jac
        self._x_jac = x.copy()
        self._x_lin = x.copy()  # where the totals' linearization is
        if 'totals' in self.options['debug_print']:
            self._print_totals()

    def _print_totals(self) -> None:
        """OpenMDAO's ``debug_print = ['totals']``: the driver-scaled derivatives."""
        lay = self.layout()
        header = f'Driver total derivatives for iteration: {self.iter_count}'
        print(f'{header}\n{"-" * len(header)}\n')
        grad = {v.name: self._grad[self._dv_slices[v.name]] for v in lay.design_vars}
        print(f'objective gradient ({lay.objective.name}):')
        pprint.pprint(grad)
        print(
            f'constraint Jacobian: {lay.m} x {lay.n}, {self._jac.size} nonzeros, '
            f'largest |value| {np.abs(self._jac).max(initial=0.0):.6g}\n'
        )
        sys.stdout.flush()

    # cyipopt callbacks (also callable directly after :meth:`prepare`)
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

    def intermediate(
        self,
        alg_mod,
        iter_count,
        obj_value,
        inf_pr,
        inf_du,
        mu,
        d_norm,
        regularization_size,
        alpha_du,
        alpha_pr,
        ls_trials,
    ) -> bool:
        info = IterationInfo(
            iteration=int(iter_count),
            objective=float(obj_value) / self._obj_scaler - self._obj_adder,
            constraint_violation=float(inf_pr),
            dual_infeasibility=float(inf_du),
            elapsed_s=time.perf_counter() - self._t0,
        )
        x = self._current_iterate()
        if self.options['watch'] and x is not None:
            phys = x / self._dv_scaler - self._dv_adder
            info.design = {n: float(phys[self._dv_slices[n]][0]) for n in self.options['watch']}
        self.history.append(info)
        self._x_accepted = None if x is None else np.array(x, dtype=float)
        try:
            self._record(x)
        except RunError as err:  # the recorder's disk is full: stop, raise it after IPOPT
            self._failure = err
            return False
        interrupts.stage('ipopt:iteration')
        progress = self.options['progress']
        if progress is not None:
            progress(info)
        if interrupts.requested():
            self.interrupted = True
            if self._near_converged:  # the one extra iteration was taken
                return False
            tol = float(self.options['tol'])
            self._near_converged = (
                info.dual_infeasibility <= NEAR_CONVERGED * tol
                and info.constraint_violation <= NEAR_CONVERGED * tol
                and float(mu) <= NEAR_CONVERGED * tol
            )
            return self._near_converged
        return True

    def _current_iterate(self) -> np.ndarray | None:
        """IPOPT's current iterate (driver-scaled), or the last point run where IPOPT does
        not tell it (restoration phase)."""
        try:
            return np.asarray(self._nlp.get_current_iterate(scaled=False)['x'])  # type: ignore[union-attr]
        except Exception:
            return self._x_run

    def _record(self, x: np.ndarray | None) -> None:
        """Record the accepted iterate ``x`` with the driver's recorders (and OpenMDAO's
        ``debug_print``), the model run there if it was last run elsewhere."""
        if not (self._has_recorders or self.options['debug_print']):
            self.iter_count += 1
            return
        try:
            with RecordingDebugging(driver_name(self), self.iter_count, self):
                if x is not None and (self._x_run is None or not np.array_equal(x, self._x_run)):
                    try:
                        self._evaluate(np.asarray(x, dtype=float))
                    except (cyipopt.CyIpoptEvaluationError, _Stopped):
                        pass
        except sqlite3.Error as err:
            names = [getattr(r, '_filepath', '') for r in self._rec_mgr._recorders]
            raise RunError(
                f'cannot write the case recorder {", ".join(map(str, names))}: {err}'
            ) from None
        self.iter_count += 1

    # ------------------------------------------------------------------ Hessian
    def _flow(self) -> DataFlow | None:
        """The model's data flow to the responses, where the driver can read it."""
        if isinstance(self._totals, PropagatedTotals):
            return self._totals.flow
        if not structure.supported():
            return None
        lay = self.layout()
        flow = data_flow(self.problem, [v.source for v in lay.constraints] + [lay.objective.source])
        return flow if propagation_supported(flow) else None

    def hessian_structure(self) -> HessianStructure | None:
        """The Hessian of the Lagrangian's nonlinear terms and coloring
        (:mod:`suspopt.driver.hessian`): the ``hessian_structure`` option if it fits the
        model, else computed (once, and kept there); None where the model's data flow is
        not available (implicit components, cycles, an untested OpenMDAO version)."""
        self._set_up_totals()
        flow = self._flow()
        if flow is None:
            return None
        hs = self.options['hessian_structure']
        if hs is None or not hs.matches(flow, self.layout().n):
            varying = self._varying_entries(flow)
            hs = hessian_structure(flow, self.layout().design_vars, varying)
            self.options['hessian_structure'] = hs
        return hs

    def _without_frozen(self, flow: DataFlow, varying: dict) -> dict:
        """``varying`` less the partials of components whose curvature the Hessian leaves
        out (``hessian_frozen``: a black box known only through finite differences, whose
        differenced partials would be differenced again; its partials then count as
        constant at each point, a Gauss-Newton treatment of it)."""
        frozen = {
            c.pathname
            for c in self.problem.model.system_iter(recurse=True, typ=om.ExplicitComponent)
            if getattr(c, 'hessian_frozen', False)
        }
        if not frozen:
            return varying
        return {k: m for k, m in varying.items() if flow.deps[k[0]][k[1]].component not in frozen}

    def _varying_entries(self, flow: DataFlow) -> dict | None:
        """The declared partial entries that differ between linearizations at two random
        points near the current design (None if the model fails there); the model is left
        as it was."""
        data = self._outputs.asarray()
        saved = data[self._dv_pos].copy()
        x0 = self.scaled_design()
        rng = np.random.default_rng(20120301)
        snapshots = []
        try:
            for step in (PROBE_STEP, PROBE_STEP, PROBE_STEP / 10, PROBE_STEP / 10):
                interrupts.checkpoint()
                x = x0 + step * np.maximum(1.0, np.abs(x0)) * rng.standard_normal(x0.size)
                try:
                    self._run_model_at(x)
                    self.problem.model.run_linearize()
                except om.AnalysisError:
                    continue
                snapshots.append(edge_values(flow))
                if len(snapshots) == 2:
                    return self._without_frozen(flow, varying_entries(*snapshots))
            return None
        finally:
            data[self._dv_pos] = saved
            self.problem.model.run_solve_nonlinear()
            self._x_run = None

    def hessian(self, x: np.ndarray, lam: np.ndarray, obj_factor: float) -> np.ndarray:
        """IPOPT's Hessian of the Lagrangian ``σ ∇²f + Σ λ_i ∇²c_i`` (driver scaling) at the
        nonzeros of :meth:`hessianstructure`: its products with each Hessian color's
        forward-difference steps, by second-order adjoints
        (:class:`~suspopt.driver.hessian.PropagatedHessian`) where the totals are
        propagated, else by differences of the gradient of the whole model."""
        assert self._hess is not None and self._totals is not None
        self._evaluate(x)  # after a signal: _Stopped
        w_obj = float(obj_factor) * self._obj_scaler
        w_con = np.asarray(lam) * self._con_scaler
        self.n_hessian_evals += 1
        if self._phess is not None:
            h = FD_STEP * np.maximum(1.0, np.abs(x))
            try:
                at_x = self._x_lin is not None and np.array_equal(x, self._x_lin)
                products = self._phess.compute(h / self._dv_scaler, w_obj, w_con, at_x)
                self._x_lin = x.copy()
            except om.AnalysisError as err:
                self.last_error = str(err)
                self._x_run = self._x_lin = None
                raise cyipopt.CyIpoptEvaluationError() from None
            products /= self._dv_scaler
            if not np.all(np.isfinite(products)):
                self.last_error = 'the Hessian contains NaN or inf'
                raise cyipopt.CyIpoptEvaluationError()
            return self._hess.recover(products, h)
        return self._fd_hessian(x, w_obj, w_con)

    def _fd_hessian(self, x: np.ndarray, w_obj: float, w_con: np.ndarray) -> np.ndarray:
        """The Hessian by forward differences of the Lagrangian gradient of the whole model
        (run, linearized and differentiated again at each color's step)."""
        assert self._hess is not None and self._totals is not None
        totals = self._totals
        self._x_lin = None

        def gradient(xp: np.ndarray) -> np.ndarray:
            if xp is not x:
                self._x_run = None  # the model moves off x
                try:
                    self._run_model_at(xp)
                except om.AnalysisError as err:
                    self.last_error = str(err)
                    raise cyipopt.CyIpoptEvaluationError() from None
            g = totals.lagrangian_gradient(w_obj, w_con) / self._dv_scaler
            if not np.all(np.isfinite(g)):
                self.last_error = 'the Lagrangian gradient contains NaN or inf'
                raise cyipopt.CyIpoptEvaluationError()
            return g

        return fd_hessian(gradient, x, self._hess, rel_step=FD_STEP)

    def hessianstructure(self) -> tuple[np.ndarray, np.ndarray]:
        assert self._hess is not None
        return self._hess.rows, self._hess.cols

    # ------------------------------------------------------------------ run
    def prepare(self) -> None:
        """Read the layout, get the coloring and set up the colored totals (done by
        :meth:`run`; after it the cyipopt callbacks can be called directly)."""
        self.layout()
        self.history = []
        self.status, self.status_message, self.last_error = None, '', None
        self.interrupted = False
        self._near_converged = False
        self._x_accepted = None
        self._failure = None
        self._x_run = self._x_jac = None
        self._eval_failed = False
        self._t0 = time.perf_counter()
        interrupts.checkpoint()  # preparing: a signal stops here at once
        coloring = self._set_up_totals()
        interrupts.checkpoint()
        self._exact = self.options['hessian'] == 'exact'
        hs = self.hessian_structure() if self._exact else None
        if self._exact and hs is None:
            om.issue_warning(
                f"{self.msginfo}: hessian='exact' needs the model's data flow (explicit "
                'components, no cycle, a tested OpenMDAO version); using limited-memory',
                category=om.DriverWarning,
            )
            self._exact = False
        self._hess = None if hs is None else hs.coloring
        if hs is None or not isinstance(self._totals, PropagatedTotals):
            self._phess = None
        elif (
            self._phess is None
            or self._phess.coloring is not hs.coloring
            or self._phess.totals is not self._totals
        ):
            self._phess = PropagatedHessian(self.problem, self._totals, hs.coloring, hs.varying)
        self.n_hessian_evals = 0
        if coloring is not None:
            self._jrows, self._jcols = coloring.rows, coloring.cols
        else:  # no constraints
            self._jrows = self._jcols = np.zeros(0, dtype=np.int64)
        self._jac_scaler = self._con_scaler[self._jrows] / self._dv_scaler[self._jcols]
        self.n_function_evals = self.n_gradient_evals = 0
        self._x_run = self._x_jac = self._x_lin = None

    def _set_up_totals(self) -> Coloring | None:
        """The coloring and the total-derivative engine for it (once)."""
        coloring = self.total_coloring()
        if self._totals is None or self._totals.coloring is not coloring:
            self._totals = make_totals(
                self.problem, self.layout(), coloring, self.options['totals']
            )
        return coloring

    def _ipopt_options(self) -> dict[str, Any]:
        opts: dict[str, Any] = {
            'max_iter': self.options['max_iter'],
            'tol': self.options['tol'],
            'print_level': self.options['print_level'],
            'hessian_approximation': 'exact' if self._exact else 'limited-memory',
            'max_wall_time': MAX_WALL_TIME,
        }
        if not self._exact:
            opts.update(LIMITED_MEMORY_OPTIONS)
        return opts

    def _check_desvar_bounds(self, x0: np.ndarray, pinned: list[str]) -> None:
        """OpenMDAO's ``invalid_desvar_behavior`` for the free design variables."""
        behavior = self.options['invalid_desvar_behavior']
        if behavior == 'ignore':
            return
        bad = []
        for v in self.layout().design_vars:
            sl = self._dv_slices[v.name]
            if v.name not in pinned and np.any((x0[sl] < self._lb[sl]) | (x0[sl] > self._ub[sl])):
                bad.append(v.name)
        if bad:
            msg = (
                f'{self.msginfo}: the initial values of {", ".join(bad)} are out of their '
                'bounds (IPOPT moves them inside)'
            )
            if behavior == 'raise':
                raise ValueError(msg)
            om.issue_warning(msg, category=om.DriverWarning)

    def run(self) -> bool:
        """Solve with IPOPT from the model's current design (``pinned`` design variables
        held at their current values). Leaves the model at IPOPT's final point. Returns
        OpenMDAO's failure flag: False if IPOPT converged (``Solve_Succeeded`` or
        ``Solved_To_Acceptable_Level``), True otherwise."""
        self.result.reset()
        self.iter_count = 0
        self.prepare()
        lay = self.layout()
        pinned = list(self.options['pinned'])
        unknown = [n for n in pinned if n not in self._dv_slices]
        if unknown:
            raise ValueError(f'{self.msginfo}: pinned {unknown} are not design variables')
        x0 = self.scaled_design()
        self._check_desvar_bounds(x0, pinned)
        lb, ub = self._lb.copy(), self._ub.copy()
        for name in pinned:
            sl = self._dv_slices[name]
            lb[sl] = ub[sl] = x0[sl]
        cl, cu = self._cl.copy(), self._cu.copy()
        released = set(self.options['released'])
        start = 0
        for con in lay.constraints:
            if con.name in released:
                cl[start : start + con.size], cu[start : start + con.size] = -np.inf, np.inf
            start += con.size

        self._nlp = nlp = cyipopt.Problem(
            n=lay.n, m=lay.m, problem_obj=self._callbacks(), lb=lb, ub=ub, cl=cl, cu=cu
        )
        for key, val in self._ipopt_options().items():
            nlp.add_option(key, val)
        nlp.add_option('sb', 'yes')
        for key, val in self.opt_settings.items():
            _add_option(nlp, key, val)

        # the solve and the final model run inside a hold: a first signal stops IPOPT
        # at its next callback (see the module docstring), never between a converged
        # solve and the caller's record of it; the caller learns it from `interrupted`
        with interrupts.hold(raise_on_exit=False):
            interrupts.stage('ipopt:start')
            try:
                x, info = nlp.solve(x0)
            except _Stopped:  # cyipopt re-raises the evaluation refused after a signal
                x = self._x_accepted if self._x_accepted is not None else x0
                info = {'status': 5, 'status_msg': b'User_Requested_Stop'}
            finally:
                nlp.close()
                self._nlp = None
            if self._failure is not None:
                raise self._failure
            self.interrupted = self.interrupted or interrupts.requested()
            self.status = int(info['status'])
            self.status_message = IPOPT_STATUS.get(
                self.status, info['status_msg'].decode(errors='replace')
            )
            # leave the model at IPOPT's final point (inside the bounds: IPOPT relaxes them
            # by its bound_relax_factor internally)
            self._x_run = None
            try:  # outside the solve (no stop check): the record needs this point
                self._evaluate(np.clip(np.asarray(x), lb, ub))
            except cyipopt.CyIpoptEvaluationError:
                pass
            interrupts.stage('ipopt:end', status=self.status)
        return self.status not in SUCCESS

    def _callbacks(self) -> _Callbacks:
        return _CallbacksWithHessian(self) if self._exact else _Callbacks(self)

    def get_exit_status(self) -> str:
        """IPOPT's status name (e.g. ``Solve_Succeeded``), or ``NOT_RUN``."""
        return self.status_message or 'NOT_RUN'

    def _update_result(self, result: DriverResult) -> None:
        result.iter_count = self.history[-1].iteration if self.history else 0


class _Callbacks:
    """What cyipopt calls: the driver's evaluations (a separate object so that IPOPT sees a
    ``hessian`` callback only when the driver computes one)."""

    def __init__(self, driver: IpoptDriver):
        self.objective = driver.objective
        self.constraints = driver.constraints
        self.gradient = driver.gradient
        self.jacobian = driver.jacobian
        self.jacobianstructure = driver.jacobianstructure
        self.intermediate = driver.intermediate


class _CallbacksWithHessian(_Callbacks):
    def __init__(self, driver: IpoptDriver):
        super().__init__(driver)
        self.hessian = driver.hessian
        self.hessianstructure = driver.hessianstructure


def _cat(metas: list[dict], variables: list[Variable], key: str, default: float) -> np.ndarray:
    """Metadata ``key`` of every entry of ``variables``, one flat vector."""
    if not variables:
        return np.zeros(0)
    return np.concatenate([_vec(m.get(key), default, v.size) for m, v in zip(metas, variables)])


def _vec(value: Any, default: float, size: int) -> np.ndarray:
    """``value`` (None, scalar or array) as a float vector of ``size``."""
    if value is None:
        return np.full(size, default)
    return (
        np.broadcast_to(np.asarray(value, dtype=float).ravel(), (size,)).copy()
        if np.size(value) in (1, size)
        else np.asarray(value, dtype=float).ravel()
    )
