"""Independent time-marching integration of both vehicle models (SciPy ``solve_ivp``).

This is the reference the collocation is checked against (paper §4.2, SPEC §5-§6) and
the source of the ``reference`` normalization. It integrates the same equations
(:mod:`suspopt.models.equations`, :class:`~suspopt.multibody.suspension.SuspensionModule`)
with an adaptive explicit Runge-Kutta method (DOP853), stopping at every time where the
road's second derivative jumps under either wheel so the high order is kept. The
objective integrals are integrated as extra states, exactly as in the collocation.

In the mixed-fidelity model the multibody constraints are kept exactly (coordinate
partitioning): at every right-hand-side evaluation the dependent coordinates are solved
by Newton's method from the wheel travel, then the augmented system gives the
accelerations. The largest constraint residual seen is reported.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from suspopt.config import DESIGN_NAMES, StudyConfig
from suspopt.errors import ConfigError, ModelError
from suspopt.models import equations as eq
from suspopt.multibody.suspension import SuspensionModule
from suspopt.road import wheel_road_inputs

#: State vector of both models: chassis, front and rear wheel travel, objective integrals.
STATES = ('z_C', 'v_C', 'theta_C', 'omega_C', 'z_W1', 'v_W1', 'z_W2', 'v_W2',
          'J1', 'J2', 'J3', 'J4')


@dataclass
class Trajectory:
    """A time history: ``t`` [s] and named arrays of the same length, plus ``J`` at ``T``."""

    t: np.ndarray
    values: dict[str, np.ndarray]
    J: np.ndarray
    info: dict[str, Any] = field(default_factory=dict)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.values[name]


class VehicleRHS:
    """Right-hand side ``dy/dt`` of the half car (``fidelity='low'``) or the mixed-fidelity
    model (``'mixed'``), for one design. Also returns every intermediate signal."""

    def __init__(self, config: StudyConfig, fidelity: str, design: dict[str, float],
                 modules: tuple[SuspensionModule, SuspensionModule] | None = None):
        if fidelity not in ('low', 'mixed'):
            raise ValueError(f"fidelity must be 'low' or 'mixed', got {fidelity!r}")
        v = config.vehicle
        self.fidelity = fidelity
        self.road = config.road_profile()
        self.speed = config.maneuver.speed
        self.offsets = (0.0, v.wheelbase)
        self.M, self.I = v.chassis_mass, v.chassis_pitch_inertia
        self.a = (v.front.axle_position, v.rear.axle_position)
        self.m = (v.front.wheel_mass, v.rear.wheel_mass)
        self.k_T = (v.front.tyre_stiffness, v.rear.tyre_stiffness)
        self.k_S = (design['k_S1'], design['k_S2'])
        self.c_S = (design['c_S1'], design['c_S2'])
        if fidelity == 'mixed':
            self.modules = modules or (SuspensionModule(v.front.mechanism),
                                       SuspensionModule(v.rear.mechanism))
            # identical front and rear mechanisms: one batched solver call for both axles
            self._shared = self.modules[0].mechanism == self.modules[1].mechanism
            self._guess: dict[int, tuple[np.ndarray, ...]] = {}
        self.max_constraint_residual = 0.0
        self.n_evals = 0

    def _kinematics(self, z_W: list[np.ndarray], v_W: list[np.ndarray]):
        """Multibody position/velocity analysis of both axles (one batched call if shared)."""
        groups = [(0, [0, 1])] if self._shared else [(0, [0]), (1, [1])]
        out = {}
        for m, axles in groups:
            z = np.concatenate([z_W[i] for i in axles])
            guess = None
            if m in self._guess and self._guess[m][0].shape[0] == z.size:
                # Newton starts from the last pose moved along its tangent: the dependent
                # velocities per unit wheel-travel rate (where that rate is not ~0)
                q, qd, z_prev, v_prev = self._guess[m]
                safe = np.abs(v_prev) > 1e-9
                step = np.where(safe, (z - z_prev) / np.where(safe, v_prev, 1.0), 0.0)
                guess = q + qd * step[:, None]
            v = np.concatenate([v_W[i] for i in axles])
            kin = self.modules[m].kinematics(z, v, guess)
            self._guess[m] = (kin.state.q, kin.state.qd, z, v)
            self.max_constraint_residual = max(self.max_constraint_residual,
                                               self.modules[m].constraint_residual(kin.state))
            out[m] = (axles, kin)
        return out

    def signals(self, t: np.ndarray, y: np.ndarray) -> dict[str, np.ndarray]:
        """All model signals at times ``t`` (N,) for states ``y`` (12, N)."""
        z_C, v_C, th, om_ = y[:4]
        z_W, v_W = [y[4], y[6]], [y[5], y[7]]
        n = np.size(t)
        delta, _ = wheel_road_inputs(self.road, t, self.speed, self.offsets, rates=False)
        out = {'delta_1': delta[0], 'delta_2': delta[1]}
        if self.fidelity == 'low':
            spring, wheel = list(zip(z_W, v_W)), z_W
        else:
            kin = self._kinematics(z_W, v_W)
            spring, wheel = [None, None], [None, None]
            for axles, k in kin.values():
                for j, i in enumerate(axles):
                    sl = slice(j * n, (j + 1) * n)
                    spring[i] = (k.q_U[sl], k.qd_U[sl])
                    wheel[i] = k.q_W[sl]
                    out[f'q_U{i + 1}'] = k.q_U[sl]
        F_S = [eq.suspension_force(self.k_S[i], self.c_S[i], self.a[i], *spring[i],
                                   z_C, v_C, th, om_) for i in range(2)]
        F_T = [eq.tyre_force(self.k_T[i], delta[i], wheel[i]) for i in range(2)]
        for i in range(2):
            out[f'wheel_z{i + 1}'] = wheel[i]
            out[f'F_S{i + 1}'], out[f'F_T{i + 1}'] = F_S[i], F_T[i]
            if self.fidelity == 'low':
                out[f'zdd_W{i + 1}'] = eq.wheel_acceleration(F_S[i], F_T[i], self.m[i])
        if self.fidelity == 'mixed':
            for m, (axles, k) in kin.items():
                acc, _ = self.modules[m].dynamics(k.state, np.concatenate([F_S[i] for i in axles]),
                                                  np.concatenate([F_T[i] for i in axles]))
                for j, i in enumerate(axles):
                    out[f'zdd_W{i + 1}'] = acc[j * n:(j + 1) * n]
        out['zdd_C'] = eq.chassis_heave_acceleration(F_S[0], F_S[1], self.M)
        out['thdd_C'] = eq.chassis_pitch_acceleration(F_S[0], F_S[1], *self.a, self.I)
        out['dJ_dt'] = eq.objective_integrands(out['zdd_C'], out['thdd_C'],
                                               out['wheel_z1'], out['wheel_z2'])
        return out

    def __call__(self, t: float, y: np.ndarray) -> np.ndarray:
        self.n_evals += 1
        s = self.signals(np.atleast_1d(t), y[:, None])
        return np.concatenate([y[[1]], s['zdd_C'], y[[3]], s['thdd_C'],
                               y[[5]], s['zdd_W1'], y[[7]], s['zdd_W2'], s['dJ_dt'][0]])


def simulate(config: StudyConfig, fidelity: str, design: dict[str, float] | None = None,
             *, t_eval: np.ndarray | None = None, rtol: float = 1e-8,
             atol: float = 1e-11) -> Trajectory:
    """Integrate a model from the zero initial state over the horizon (SPEC §1).

    ``design`` defaults to the configured initial design. Returns the trajectory at
    ``t_eval`` (default: 2001 points) with states, accelerations, forces and road inputs,
    and the objective integrals ``J`` at the final time. The default tolerances give the
    ``J_k`` to about 1e-8 relative (checked against rtol = 1e-12).
    """
    design = dict(config.design.initial() if design is None else design)
    missing = set(DESIGN_NAMES) - set(design)
    if missing:
        raise ValueError(f'design is missing {sorted(missing)}')
    T = config.maneuver.horizon
    rhs = VehicleRHS(config, fidelity, design)
    road = rhs.road
    # times where the road's second derivative jumps under either wheel
    breaks = sorted({(s + off) / config.maneuver.speed for s in road.breakpoints()
                     for off in rhs.offsets} | {0.0, T})
    breaks = [b for b in breaks if 0.0 <= b <= T]
    t_eval = np.linspace(0.0, T, 2001) if t_eval is None else np.asarray(t_eval, dtype=float)
    y = np.zeros(len(STATES))
    pieces_t, pieces_y = [], []
    t0 = time.perf_counter()
    for ta, tb in zip(breaks[:-1], breaks[1:]):
        sol = solve_ivp(rhs, (ta, tb), y, method='DOP853', rtol=rtol, atol=atol,
                        dense_output=True)
        if sol.status != 0:
            raise ModelError(f'time marching ({fidelity} fidelity) failed at t = {sol.t[-1]:.4g} s:'
                             f' {sol.message}')
        y = sol.y[:, -1]
        if not np.all(np.isfinite(y)):
            raise ModelError(f'time marching ({fidelity} fidelity) produced NaN/inf')
        mask = (t_eval >= ta) & ((t_eval < tb) | ((tb == breaks[-1]) & (t_eval <= tb)))
        if np.any(mask):
            pieces_t.append(t_eval[mask])
            pieces_y.append(sol.sol(t_eval[mask]))
    ts = np.concatenate(pieces_t)
    ys = np.concatenate(pieces_y, axis=1)
    wall = time.perf_counter() - t0
    values = {name: ys[k] for k, name in enumerate(STATES)}
    values.update(rhs.signals(ts, ys))
    info = {'rhs_evaluations': rhs.n_evals, 'wall_time_s': wall, 'fidelity': fidelity}
    if fidelity == 'mixed':
        info['max_constraint_residual_m'] = rhs.max_constraint_residual
    return Trajectory(t=ts, values=values, J=y[8:12].copy(), info=info)


def reference_scales(config: StudyConfig) -> tuple[float, float, float, float]:
    """``s_k`` of the ``reference`` normalization: J_k of the low-fidelity model at the
    initial design by accurate time marching (SPEC §5)."""
    J = simulate(config, 'low', t_eval=np.array([0.0, config.maneuver.horizon])).J
    if not np.all(J > 0.0):
        raise ConfigError(f'objective.normalization: reference normalization impossible: '
                          f'J = {J.tolist()} at the initial design (the road does not excite '
                          "every term); use normalization = 'custom' with scales")
    return tuple(float(x) for x in J)
