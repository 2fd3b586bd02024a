"""Independent time-marching integration of both vehicle models (SciPy ``solve_ivp``).

This is the reference the collocation is checked against (paper §4.2, SPEC §5-§6) and
the source of the ``reference`` normalization. It integrates the same equations
(:mod:`suspopt.models.equations`, :class:`~suspopt.multibody.suspension.SuspensionModule`)
with an adaptive explicit Runge-Kutta method (DOP853), stopping at every time where the
road's second derivative jumps under a wheel so the high order is kept. The objective
integrals are integrated as extra states.

In the mixed-fidelity model the multibody constraints are kept exactly (coordinate
partitioning): at every right-hand-side evaluation the dependent coordinates are solved
by Newton's method from the wheel travel, then the augmented system gives the
accelerations. The largest constraint residual seen is reported.
"""

from __future__ import annotations

import time

import numpy as np
from scipy.integrate import solve_ivp

from suspopt.errors import ConfigError, ModelError
from suspopt.models import equations as eq
from suspopt.models.design import corner_of_design
from suspopt.multibody.suspension import RESPONSE
from suspopt.records.trajectory import Trajectory
from suspopt.road import road_tracks
from suspopt.spec.schema import Scenario, StudyConfig
from suspopt.transcription.problem import Scales, multibody_modules


class VehicleRHS:
    """Right-hand side ``dy/dt`` of the low- or mixed-fidelity model of one scenario, for
    one design; :meth:`signals` also returns every intermediate signal.

    State vector: the chassis states (``z_C, v_C, theta_C, omega_C`` [, ``phi_C, p_C``]),
    every wheel's travel ``z_W`` then its rate ``v_W``, then the objective integrals."""

    def __init__(
        self,
        config: StudyConfig,
        fidelity: str,
        design: dict[str, float],
        scenario: Scenario,
        modules: dict | None = None,
    ):
        if fidelity not in ('low', 'mixed'):
            raise ValueError(f"fidelity must be 'low' or 'mixed', got {fidelity!r}")
        v = config.vehicle
        lay = self.layout = v.layout()
        self.fidelity, self.scenario = fidelity, scenario
        self.nc, self.roll = lay.n, lay.has_roll
        self.nch = 6 if self.roll else 4
        self.nt = len(config.terms())
        self.a, self.y = lay.a, lay.y
        self.tracks = road_tracks(scenario.road, lay.n_tracks, lay.track_separation())
        self.offsets = np.array(lay.offsets())
        self.track_of = [c.track for c in lay.corners]
        self._track_cols = [
            (road, np.array([c for c, tr in enumerate(self.track_of) if tr == k]))
            for k, road in enumerate(self.tracks)
        ]
        self.M, self.I, self.I_x = v.chassis_mass, v.chassis_pitch_inertia, v.chassis_roll_inertia
        axles = v.axles
        self.m = np.array([axles[c.axle].wheel_mass for c in lay.corners])
        self.k_T = np.array([axles[c.axle].tyre_stiffness for c in lay.corners])
        settings = {'k_S': np.zeros(lay.n), 'c_S': np.zeros(lay.n), 'k_R': []}
        bars = sorted(n for n in design if n.startswith('k_R'))
        settings['k_R'] = np.zeros(len(bars))
        for name, targets in corner_of_design(config.design_names(), lay.labels).items():
            for kind, i in targets:
                settings[kind][i] = design[name]
        self.k_S, self.c_S, self.k_R = settings['k_S'], settings['c_S'], settings['k_R']
        pairs = lay.anti_roll_pairs(tuple(i for i, ax in enumerate(axles) if ax.anti_roll_bar))
        self.bar_left = [p[1] for p in pairs]
        self.bar_right = [p[2] for p in pairs]
        self.bar_track = np.array([axles[p[0]].track for p in pairs])
        if fidelity == 'mixed':
            mods = modules or multibody_modules(config)
            self.groups: list[tuple[object, list[int]]] = []
            for c, corner in enumerate(lay.corners):
                mod = mods[axles[corner.axle].mechanism]
                for m, cols in self.groups:
                    if m is mod:
                        cols.append(c)
                        break
                else:
                    self.groups.append((mod, [c]))
            self._guess: dict[int, tuple[np.ndarray, ...]] = {}
        self.mount = config.multibody.mount if fidelity == 'mixed' else 'ground'
        if self.mount == 'chassis':
            self.side = np.array([c.side for c in lay.corners], dtype=float)
            self.L = eq.mount_map(self.a, self.y, self.side, self.roll)
            self.inertia = [self.M, self.I] + ([self.I_x] if self.roll else [])
            self.width = len(RESPONSE) + 2 * max(m.n_joints for m, _ in self.groups)
        self.max_constraint_residual = 0.0
        self.n_evals = 0

    def road(self, t: np.ndarray) -> np.ndarray:
        """Road height under every wheel at times ``t`` (N,): (N, corners)."""
        s = self.scenario.speed * t[:, None] - self.offsets
        if len(self._track_cols) == 1:
            return self._track_cols[0][0].r(s)
        out = np.empty_like(s)
        for road, cols in self._track_cols:
            out[:, cols] = road.r(s[:, cols])
        return out

    def _kinematics(self, z_W: np.ndarray, v_W: np.ndarray, poses=None):
        """Multibody position/velocity analysis of every corner (one batch per mechanism),
        each Newton started from the last pose moved along its tangent; ``poses``: the
        chassis mounts' (z_M, v_M, ψ, ψ̇), each (N, corners)."""
        out = {}
        for g, (mod, cols) in enumerate(self.groups):
            z, v = z_W[:, cols].ravel(), v_W[:, cols].ravel()
            pose = None if poses is None else tuple(p[:, cols].ravel() for p in poses)
            guess = None
            if g in self._guess and self._guess[g][0].shape[0] == z.size:
                q, qd, z_prev, v_prev = self._guess[g]
                safe = np.abs(v_prev) > 1e-9
                step = np.where(safe, (z - z_prev) / np.where(safe, v_prev, 1.0), 0.0)
                guess = q + qd * step[:, None]
            kin = mod.kinematics(z, v, guess, pose=pose)
            self._guess[g] = (kin.state.q, kin.state.qd, z, v)
            self.max_constraint_residual = max(
                self.max_constraint_residual, mod.constraint_residual(kin.state, kin.pose)
            )
            out[g] = kin
        return out

    def signals(self, t: np.ndarray, y: np.ndarray) -> dict[str, np.ndarray]:
        """All model signals at times ``t`` (N,) for states ``y`` (n_states, N)."""
        N, nch, nc = np.size(t), self.nch, self.nc
        ch = y[:nch]
        z_C, v_C, th, om_ = ch[0], ch[1], ch[2], ch[3]
        phi, p = (ch[4], ch[5]) if self.roll else (0.0, 0.0)
        z_W, v_W = y[nch : nch + nc].T, y[nch + nc : nch + 2 * nc].T
        delta = self.road(np.atleast_1d(t))
        z_M = eq.mount_motion(z_C, th, phi, self.a, self.y)
        v_M = eq.mount_motion(v_C, om_, p, self.a, self.y)
        out = {'delta': delta, 'z_M': z_M}
        if self.fidelity == 'low':
            F_S = eq.suspension_force(self.k_S, self.c_S, z_W, v_W, z_M, v_M)
            F_R = eq.anti_roll_force(
                self.k_R, z_W, z_M, self.bar_track, self.bar_left, self.bar_right
            )
            F_T = eq.tyre_force(self.k_T, delta, z_W)
            F = F_S + F_R
            zdd_W = eq.wheel_acceleration(F_T, F, self.m)
            wheel = z_W
        else:
            poses = None
            if self.mount == 'chassis':
                side = self.side
                poses = (
                    z_M,
                    v_M,
                    eq.mount_rotation(np.broadcast_to(phi, (N,)), side),
                    eq.mount_rotation(np.broadcast_to(p, (N,)), side),
                )
            kin = self._kinematics(z_W, v_W, poses)
            wheel = np.empty((N, nc))
            for g, (_, cols) in enumerate(self.groups):
                wheel[:, cols] = kin[g].q_W.reshape(N, len(cols))
            F_R = eq.anti_roll_force(
                self.k_R, wheel, z_M, self.bar_track, self.bar_left, self.bar_right
            )
            F_T = eq.tyre_force(self.k_T, delta, wheel)
            F_S, zdd_W = np.empty((N, nc)), np.empty((N, nc))
            if self.mount == 'chassis':
                return self._chassis_mounted(out, kin, wheel, F_T, F_R)
            for g, (mod, cols) in enumerate(self.groups):
                acc, force, _ = mod.dynamics(
                    kin[g].state,
                    z_M[:, cols].ravel(),
                    v_M[:, cols].ravel(),
                    np.tile(self.k_S[cols], N),
                    np.tile(self.c_S[cols], N),
                    (F_T - F_R)[:, cols].ravel(),
                )
                zdd_W[:, cols] = acc.reshape(N, len(cols))
                F_S[:, cols] = force.reshape(N, len(cols))
            F = F_S + F_R
            out['q_W'] = wheel
        out.update(F_S=F_S, F_R=F_R, F_T=F_T, zdd_W=zdd_W, wheel_z=wheel)
        out['zdd_C'] = eq.chassis_heave_acceleration(F, self.M)
        out['thdd_C'] = eq.chassis_pitch_acceleration(F, self.a, self.I)
        chassis = [out['zdd_C'], out['thdd_C']]
        if self.roll:
            out['phidd_C'] = eq.chassis_roll_acceleration(F, self.y, self.I_x)
            chassis.append(out['phidd_C'])
        out['dJ_dt'] = eq.objective_integrands(chassis, wheel)
        return out

    def _chassis_mounted(self, out, kin, wheel, F_T, F_R) -> dict[str, np.ndarray]:
        """The chassis-mounted modules and the chassis, the loop through the mount
        acceleration solved per state (:func:`~suspopt.models.equations.
        chassis_mount_accelerations`), as :class:`~suspopt.models.mount.ChassisMountComp`."""
        N, nc, nu = wheel.shape[0], self.nc, self.L.shape[1]
        R = np.zeros((N, nc, 1 + nu, self.width))
        F_S = np.empty((N, nc))
        for g, (mod, cols) in enumerate(self.groups):
            resp, force = mod.mount_response(
                kin[g],
                np.tile(self.k_S[cols], N),
                np.tile(self.c_S[cols], N),
                (F_T - F_R)[:, cols].ravel(),
                rotation=self.roll,
            )
            R[:, cols, :, : resp.shape[2]] = resp.reshape(N, len(cols), 1 + nu, -1)
            F_S[:, cols] = force.reshape(N, len(cols))
        F0, G = eq.mount_forces(R, nu)
        acc = eq.chassis_mount_accelerations(F0, G, F_R, self.L, self.inertia)
        r = eq.mount_response(R, eq.mount_accelerations(acc, self.L))
        out.update(
            q_W=wheel,
            F_S=F_S,
            F_R=F_R,
            F_T=F_T,
            zdd_W=r[..., 0],
            F_M=r[..., 1],
            wheel_z=wheel,
            zdd_C=acc[:, 0],
            thdd_C=acc[:, 1],
        )
        chassis = [acc[:, 0], acc[:, 1]]
        if self.roll:
            out['phidd_C'] = acc[:, 2]
            chassis.append(acc[:, 2])
        out['dJ_dt'] = eq.objective_integrands(chassis, wheel)
        return out

    def __call__(self, t: float, y: np.ndarray) -> np.ndarray:
        self.n_evals += 1
        s = self.signals(np.atleast_1d(t), y[:, None])
        nch, nc = self.nch, self.nc
        rates = [y[1:2], s['zdd_C'], y[3:4], s['thdd_C']]
        if self.roll:
            rates += [y[5:6], s['phidd_C']]
        return np.concatenate(rates + [y[nch + nc : nch + 2 * nc], s['zdd_W'][0], s['dJ_dt'][0]])

    def state_names(self) -> list[str]:
        names = ['z_C', 'v_C', 'theta_C', 'omega_C'] + (['phi_C', 'p_C'] if self.roll else [])
        return names


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
) -> Trajectory:
    """Integrate a model from the zero initial state over a scenario's horizon (SPEC §1).

    ``design`` defaults to the configured initial design. Returns the trajectory at
    ``t_eval`` (default: 2001 points) with states, accelerations, forces and road inputs,
    and the objective integrals ``J`` at the final time (term order). The default
    tolerances give the J_k to about 1e-8 relative."""
    design = dict(config.design.initial() if design is None else design)
    missing = set(config.design_names()) - set(design)
    if missing:
        raise ValueError(f'design is missing {sorted(missing)}')
    sc = _scenario(config, scenario)
    T = sc.horizon
    rhs = VehicleRHS(config, fidelity, design, sc, modules)
    # times where the road's second derivative jumps under a wheel
    breaks = sorted(
        {
            (s + off) / sc.speed
            for road in rhs.tracks
            for s in road.breakpoints()
            for off in rhs.offsets
        }
        | {0.0, T}
    )
    breaks = [b for b in breaks if 0.0 <= b <= T]
    t_eval = np.linspace(0.0, T, 2001) if t_eval is None else np.asarray(t_eval, dtype=float)
    nch, nc = rhs.nch, rhs.nc
    y = np.zeros(nch + 2 * nc + rhs.nt)
    pieces_t, pieces_y = [], []
    t0 = time.perf_counter()
    for ta, tb in zip(breaks[:-1], breaks[1:]):
        mask = (t_eval >= ta) & ((t_eval < tb) | ((tb == breaks[-1]) & (t_eval <= tb)))
        # the interpolant costs 3 more RHS calls per step: only when asked inside a piece
        interior = bool(np.any(mask & (t_eval > ta) & (t_eval < tb)))
        y_a = y
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
    values = {name: ys[k] for k, name in enumerate(rhs.state_names())}
    values['z_W'], values['v_W'] = ys[nch : nch + nc].T, ys[nch + nc : nch + 2 * nc].T
    values.update(rhs.signals(ts, ys))
    info = {
        'rhs_evaluations': rhs.n_evals,
        'wall_time_s': wall,
        'fidelity': fidelity,
        'method': 'time-marching',
        'scenario': sc.name,
    }
    if fidelity == 'mixed':
        info['max_constraint_residual_m'] = rhs.max_constraint_residual
    return Trajectory(t=ts, values=values, J=y[nch + 2 * nc :].copy(), info=info)


def reference_scales(config: StudyConfig) -> Scales:
    """``s_k`` of the ``reference`` normalization, per scenario: J_k of the low-fidelity
    model at the initial design by accurate time marching (SPEC §5)."""
    out = []
    terms = config.terms()
    for i, sc in enumerate(config.scenarios()):
        J = simulate(config, 'low', scenario=sc, t_eval=np.array([0.0, sc.horizon])).J
        zero = [t for t, j in zip(terms, J) if not j > 0.0]
        if zero:
            where = f'scenario {sc.name!r}: ' if config.scenario else ''
            raise ConfigError(
                f'objective.normalization: {where}reference normalization '
                f'impossible: the road does not excite {", ".join(zero)} at '
                "the initial design; use normalization = 'custom' with scales"
            )
        out.append(dict(zip(terms, (float(x) for x in J))))
    return tuple(out)
