"""Reduced-space optimization of a linear vehicle's stationary response on an ISO 8608
road, by IPOPT through ``cyipopt`` (docs/spectral.md).

The NLP has the design variables only; every evaluation solves the Lyapunov equation
for the covariance, so every iterate is a true stationary response:

    minimize    f(p) = Σ_k w_k m_k(p) / s_k        (m_k: RMS or variance of output k)
    subject to  Var y_j(p) / ℓ_j² <= 1              (RMS y_j <= ℓ_j)
                lower <= p <= upper.

Gradients by the adjoint Lyapunov equation (:meth:`StationaryModel.gradient`; the
gradient of the Lagrangian is one adjoint solve, its weights the multipliers). The
Hessian of the Lagrangian is exact: the complex-step derivative of that adjoint
gradient, one complex Lyapunov pair per design variable (``hessian = 'exact'``); or
IPOPT's limited-memory BFGS (``'limited-memory'``).
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, field

import cyipopt
import numpy as np
from numpy.typing import ArrayLike

from suspopt.errors import ConfigError, ModelError
from suspopt.spectral.accuracy import PADE_ORDERS, PadeChoice, choose_pade_order
from suspopt.spectral.lyapunov import StationaryModel
from suspopt.spectral.road import RandomRoad
from suspopt.spectral.system import AffineLinearSystem

#: IPOPT's return statuses (IpReturnCodes.h) this solver reports by name
_STATUS = {
    0: 'Solve_Succeeded',
    1: 'Solved_To_Acceptable_Level',
    2: 'Infeasible_Problem_Detected',
    3: 'Search_Direction_Becomes_Too_Small',
    4: 'Diverging_Iterates',
    5: 'User_Requested_Stop',
    -1: 'Maximum_Iterations_Exceeded',
    -2: 'Restoration_Failed',
    -3: 'Error_In_Step_Computation',
    -13: 'Invalid_Number_Detected',
}
#: complex step [in units of the scaled design, ~1]
_COMPLEX_STEP = 1e-30


@dataclass(frozen=True)
class SpectralOptimum:
    """The result of :func:`optimize_spectral`.

    ``design`` the optimum (by name, physical units); ``rms``/``rms_initial`` every
    output's RMS there and at the start; ``objective`` ``f`` there and at the start;
    ``success`` if IPOPT converged (``status``, ``status_message``); ``iterations``,
    ``evaluations`` (covariances solved for IPOPT, at distinct designs);
    ``constraint_multipliers`` of ``Var y_j/ℓ_j² <= 1`` by output; ``bound_multipliers``
    by design variable (``z_upper - z_lower`` per unit of the variable: positive at an
    active upper bound);
    the Padé order used and its estimated relative RMS error; wall time.
    """

    design: dict[str, float]
    rms: dict[str, float]
    rms_initial: dict[str, float]
    objective: float
    objective_initial: float
    success: bool
    status: int
    status_message: str
    iterations: int
    evaluations: int
    constraint_multipliers: dict[str, float]
    bound_multipliers: dict[str, float]
    pade: PadeChoice
    hessian: str
    solve_time_s: float
    history: list[float] = field(default_factory=list)


class _SpectralNLP:
    """cyipopt's problem object: IPOPT's ``x`` is the design over its scale."""

    def __init__(
        self,
        model: StationaryModel,
        x_scale: np.ndarray,
        weights: np.ndarray,
        scales: np.ndarray,
        measure: str,
        con_index: np.ndarray,
        limits: np.ndarray,
    ):
        self.model = model
        self.x_scale = x_scale
        self.weights, self.scales, self.measure = weights, scales, measure
        self.con_index, self.limits = con_index, limits
        self.n_y = len(model.system.outputs)
        self.history: list[float] = []
        self.iterations = 0
        self._solves0 = model.solves

    @property
    def evaluations(self) -> int:
        """Covariances solved at real designs during the solve."""
        return self.model.solves - self._solves0

    def _var(self, x: np.ndarray) -> np.ndarray:
        p = x * self.x_scale
        try:
            var = self.model.variances(p)
        except ModelError:
            raise cyipopt.CyIpoptEvaluationError() from None
        return var

    def f_of_var(self, var: np.ndarray) -> np.ndarray:
        m = np.sqrt(var) if self.measure == 'rms' else var
        return np.sum(self.weights * m / self.scales)

    def df_dvar(self, var: np.ndarray) -> np.ndarray:
        if self.measure == 'rms':
            return self.weights / (2.0 * self.scales * np.sqrt(var))
        return self.weights / self.scales

    # cyipopt callbacks
    def objective(self, x: np.ndarray) -> float:
        return float(self.f_of_var(self._var(x)))

    def gradient(self, x: np.ndarray) -> np.ndarray:
        var = self._var(x)
        return self.model.gradient(x * self.x_scale, self.df_dvar(var)) * self.x_scale

    def constraints(self, x: np.ndarray) -> np.ndarray:
        return self._var(x)[self.con_index] / self.limits**2

    def _con_weights(self) -> np.ndarray:
        W = np.zeros((self.con_index.size, self.n_y))
        W[np.arange(self.con_index.size), self.con_index] = 1.0 / self.limits**2
        return W

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        if not self.con_index.size:
            return np.zeros(0)
        self._var(x)
        J = self.model.gradient(x * self.x_scale, self._con_weights())
        return (J * self.x_scale).ravel()

    def jacobianstructure(self) -> tuple[np.ndarray, np.ndarray]:
        n = self.x_scale.size
        rows, cols = np.meshgrid(np.arange(self.con_index.size), np.arange(n), indexing='ij')
        return rows.ravel(), cols.ravel()

    def _lagrangian_gradient(
        self, x: np.ndarray, lagrange: np.ndarray, obj_factor: float
    ) -> np.ndarray:
        var = self._var(x)
        w = obj_factor * self.df_dvar(var)
        if self.con_index.size:
            w = w + lagrange @ self._con_weights()
        return self.model.gradient(x * self.x_scale, w) * self.x_scale

    def hessian(self, x: np.ndarray, lagrange: np.ndarray, obj_factor: float) -> np.ndarray:
        n = x.size
        H = np.empty((n, n))
        for j in range(n):
            xc = x.astype(complex)
            xc[j] += 1j * _COMPLEX_STEP
            H[:, j] = self._lagrangian_gradient(xc, lagrange, obj_factor).imag / _COMPLEX_STEP
        H = 0.5 * (H + H.T)
        return H[np.tril_indices(n)]

    def hessianstructure(self) -> tuple[np.ndarray, np.ndarray]:
        return np.tril_indices(self.x_scale.size)

    def intermediate(self, alg_mod, iter_count, obj_value, *args) -> bool:
        self.iterations = int(iter_count)
        self.history.append(float(obj_value))
        return True


def _from(order: int) -> tuple[int, ...]:
    """:data:`PADE_ORDERS` from ``order`` on (the check at the optimum starts there)."""
    return tuple(k for k in PADE_ORDERS if k >= order)


def _by_name(
    values: Mapping[str, float] | None, names: tuple[str, ...], where: str
) -> dict[str, float]:
    values = dict(values or {})
    for k in values:
        if k not in names:
            raise ConfigError(f'{where}.{k}: not one of {", ".join(names)}')
    return values


def optimize_spectral(
    system: AffineLinearSystem,
    road: RandomRoad,
    start: Mapping[str, float] | ArrayLike,
    *,
    objective: Mapping[str, float],
    lower: Mapping[str, float],
    upper: Mapping[str, float],
    rms_limits: Mapping[str, float] | None = None,
    measure: str = 'rms',
    scales: Mapping[str, float] | None = None,
    pade_order: int | str = 'auto',
    pade_rtol: float = 1e-4,
    hessian: str = 'exact',
    tol: float = 1e-8,
    max_iter: int = 200,
    print_level: int = 0,
    ipopt_options: Mapping[str, int | float | str] | None = None,
) -> SpectralOptimum:
    """Minimize ``Σ_k w_k m_k / s_k`` over the design (module docstring).

    ``start``, ``lower``, ``upper``: the design by name (or ``start`` as a vector in the
    system's ``design`` order); every variable needs finite bounds. ``objective``: output
    name → weight ``w_k``; ``measure``: ``'rms'`` (``m_k`` the RMS) or ``'variance'``;
    ``scales``: ``s_k`` by output (default ``m_k`` at the start). ``rms_limits``: output
    name → largest RMS ``ℓ_j``. ``pade_order``: states per delay, or ``'auto'``: chosen at
    the start by self-convergence to ``pade_rtol`` (:func:`choose_pade_order`) and checked
    again at the optimum (re-chosen and re-solved once if it drifted beyond).
    ``hessian``: ``'exact'`` or ``'limited-memory'``. ``ipopt_options``: further IPOPT
    options.
    """
    from threadpoolctl import threadpool_limits

    # the matrices are small (tens of states): BLAS threads only cost synchronization
    with threadpool_limits(limits=1, user_api='blas'):
        return _optimize(
            system,
            road,
            start,
            objective=objective,
            lower=lower,
            upper=upper,
            rms_limits=rms_limits,
            measure=measure,
            scales=scales,
            pade_order=pade_order,
            pade_rtol=pade_rtol,
            hessian=hessian,
            tol=tol,
            max_iter=max_iter,
            print_level=print_level,
            ipopt_options=ipopt_options,
        )


def _optimize(
    system: AffineLinearSystem,
    road: RandomRoad,
    start: Mapping[str, float] | ArrayLike,
    *,
    objective: Mapping[str, float],
    lower: Mapping[str, float],
    upper: Mapping[str, float],
    rms_limits: Mapping[str, float] | None,
    measure: str,
    scales: Mapping[str, float] | None,
    pade_order: int | str,
    pade_rtol: float,
    hessian: str,
    tol: float,
    max_iter: int,
    print_level: int,
    ipopt_options: Mapping[str, int | float | str] | None,
) -> SpectralOptimum:
    """:func:`optimize_spectral` (BLAS threads limited by the caller)."""
    t0 = time.perf_counter()
    names = system.design
    p0 = system.design_vector(start, 'start').astype(float)
    lo = system.design_vector(_by_name(lower, names, 'lower'), 'lower').astype(float)
    up = system.design_vector(_by_name(upper, names, 'upper'), 'upper').astype(float)
    for i, k in enumerate(names):
        if not (np.isfinite(lo[i]) and np.isfinite(up[i]) and lo[i] <= up[i]):
            raise ConfigError(
                f'lower.{k}/upper.{k}: need finite lower <= upper, got {lo[i]}, {up[i]}'
            )
        if not lo[i] <= p0[i] <= up[i]:
            raise ConfigError(f'start.{k}: {p0[i]} is outside [{lo[i]}, {up[i]}]')
    if measure not in ('rms', 'variance'):
        raise ConfigError(f"measure: must be 'rms' or 'variance', got {measure!r}")
    if hessian not in ('exact', 'limited-memory'):
        raise ConfigError(f"hessian: must be 'exact' or 'limited-memory', got {hessian!r}")
    outs = system.outputs
    obj = _by_name(objective, outs, 'objective')
    if not obj:
        raise ConfigError('objective: needs at least one output with a weight')
    for k, w in obj.items():
        if not (np.isfinite(w) and w >= 0.0):
            raise ConfigError(f'objective.{k}: weight must be >= 0, got {w}')
    lim = _by_name(rms_limits, outs, 'rms_limits')
    for k, v in lim.items():
        if not (np.isfinite(v) and v > 0.0):
            raise ConfigError(f'rms_limits.{k}: must be > 0, got {v}')
    weights = np.array([obj.get(k, 0.0) for k in outs])
    con_index = np.array([system.output_index(k) for k in lim], dtype=int)
    limits = np.array(list(lim.values()), dtype=float)

    if pade_order == 'auto':
        choice = choose_pade_order(system, road, p0, rtol=pade_rtol)
    elif isinstance(pade_order, int) and not isinstance(pade_order, bool):
        choice = PadeChoice(pade_order, float('nan'), 'given')
    else:
        raise ConfigError(f"pade_order: must be an integer or 'auto', got {pade_order!r}")

    model = StationaryModel(system, road, choice.order)
    var0 = model.variances(p0).copy()
    m0 = np.sqrt(var0) if measure == 'rms' else var0
    sc = _by_name(scales, outs, 'scales')
    s = np.array([sc.get(k, m0[i]) for i, k in enumerate(outs)])
    s = np.where(weights > 0.0, s, 1.0)
    if np.any(~np.isfinite(s) | (s <= 0.0)):
        raise ConfigError('scales: every weighted term needs a scale > 0')
    x_scale = np.where(np.abs(p0) > 0.0, np.abs(p0), np.maximum(np.abs(up - lo), 1.0))

    def solve(model: StationaryModel, x0: np.ndarray):
        nlp = _SpectralNLP(model, x_scale, weights, s, measure, con_index, limits)
        problem = cyipopt.Problem(
            n=x0.size,
            m=con_index.size,
            problem_obj=nlp,
            lb=lo / x_scale,
            ub=up / x_scale,
            cl=np.full(con_index.size, -1e20),
            cu=np.ones(con_index.size),
        )
        problem.add_option('sb', 'yes')
        problem.add_option('tol', tol)
        problem.add_option('max_iter', max_iter)
        problem.add_option('print_level', print_level)
        problem.add_option('hessian_approximation', hessian)
        for key, val in (ipopt_options or {}).items():
            problem.add_option(key, val)
        try:
            x, info = problem.solve(x0)
        finally:
            problem.close()
        return nlp, np.clip(np.asarray(x), lo / x_scale, up / x_scale), info

    nlp, x, info = solve(model, p0 / x_scale)
    iterations, evaluations, history = nlp.iterations, nlp.evaluations, list(nlp.history)
    if pade_order == 'auto' and choice.order > 0:
        again = choose_pade_order(
            system, road, x * x_scale, rtol=pade_rtol, orders=_from(choice.order)
        )
        if again.order > choice.order:
            choice = again
            model = StationaryModel(system, road, choice.order)
            nlp, x, info = solve(model, x)
            iterations += nlp.iterations
            evaluations += nlp.evaluations
            history += nlp.history
    p = x * x_scale
    var = model.variances(p)
    mult_g = np.asarray(info['mult_g'])
    z = (np.asarray(info['mult_x_U']) - np.asarray(info['mult_x_L'])) / x_scale
    status = int(info['status'])
    return SpectralOptimum(
        design={k: float(v) for k, v in zip(names, p)},
        rms={k: float(v) for k, v in zip(outs, np.sqrt(var))},
        rms_initial={k: float(v) for k, v in zip(outs, np.sqrt(var0))},
        objective=float(nlp.f_of_var(var)),
        objective_initial=float(nlp.f_of_var(var0)),
        success=status in (0, 1),
        status=status,
        status_message=_STATUS.get(status, info['status_msg'].decode(errors='replace')),
        iterations=iterations,
        evaluations=evaluations,
        constraint_multipliers={k: float(v) for k, v in zip(lim, mult_g)},
        bound_multipliers={k: float(v) for k, v in zip(names, z)},
        pade=choice,
        hessian=hessian,
        solve_time_s=time.perf_counter() - t0,
        history=history,
    )
