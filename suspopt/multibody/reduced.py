"""Reduced model of a one-degree-of-freedom suspension linkage in its wheel travel.

A suspension module (:class:`~suspopt.multibody.suspension.SuspensionModule`) answers
every query by a position analysis (Newton's method on ``C(q) = 0``), a velocity analysis
and the augmented solve of paper eq. 11. For a linkage with one degree of freedom all of
that is a function of one variable: with the frame at its reference pose, the body
coordinates ``q(s)``, the tangent ``q'(s)`` (the constraint Jacobian's null-space
direction, ``C_q q' = 0``) and ``q''(s)`` (the quadratic velocity term, ``C_q q'' = γ``
at ``q̇ = q'``) depend on the wheel travel ``s`` alone (coordinate partitioning, Wehage &
Haug 1982; the reduced equations of motion of a one-degree-of-freedom system, Shabana,
*Dynamics of Multibody Systems*, ch. 5). Everything eq. 11 gives for the vehicle follows
from a few sums over the bodies of these functions:

* ground mount: Lagrange's equation in ``s``,
  ``m(s) s̈ + h(s) ṡ² = F_T (d_T · r_c') + g · p' - f ℓ'`` with the generalized mass
  ``m = Σ m_i |r_i'|² + I_i φ_i'²``, ``h = Σ m_i r_i' · r_i'' + I_i φ_i' φ_i''``, the
  first moment ``p = Σ m_i r_i``, the contact patch ``r_c`` (load direction ``d_T``) and
  the spring's length ``ℓ(s)`` and tension ``f = k (ℓ - ℓ0) + c ℓ̇ + f_p``
  (the coupling of :mod:`~suspopt.multibody.suspension`, eq. 12 generalized);
* chassis mount: the linkage is the same linkage moved rigidly with its frame (turned by
  ``ψ`` about the mount point ``P``, which rises by ``z_M``), so each body is
  ``r_i = P + A(ψ) ρ_i(s)``, ``φ_i = φ_i(s) + ψ`` with ``ρ_i = r_i(s) - P_0``; the
  equation in ``s`` gains the frame's inertial terms, and the force and moment on the
  frame follow from Newton-Euler on the moving bodies, exactly as the module defines them
  (the tyre force and gravity minus ``Σ m_i r̈_i``, their moments about ``P`` minus the
  rate of angular momentum).

:class:`TravelTable` holds these functions of ``s`` as Chebyshev series over the linkage's
travel range (interpolation at Chebyshev points, Trefethen, *Approximation Theory and
Approximation Practice*, ch. 3-8), the degree raised until the series meet the tolerance
on a separate check grid. :class:`ReducedSuspensionModule` evaluates them (one small
matrix product per call) and answers the queries the time marching makes
(:meth:`~ReducedSuspensionModule.kinematics`, :meth:`~ReducedSuspensionModule.dynamics`,
:meth:`~ReducedSuspensionModule.mount_response`); states outside the table (wheel travel
outside the travel range) are answered by the full module. Nothing of the physics is
approximated: the reduced model differs from the augmented solve by the series'
interpolation error only. A linkage's table is made once per process (by the value of
the mechanism, its roles and travel range) and shared by its modules.
"""

from __future__ import annotations

import dataclasses
import time
from collections import OrderedDict
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np
from numpy.polynomial import chebyshev as cheb

from suspopt.errors import MultibodyError
from suspopt.multibody.elements import is_spring
from suspopt.multibody.elements.base import ScalarSpringGroup, cross
from suspopt.multibody.mechanism import Mechanism
from suspopt.multibody.reduced_terms import (
    P_DTX,
    P_DTZ,
    P_FREE,
    P_GX,
    P_GZ,
    P_MALL,
    P_MMOV,
    P_PRELOAD,
    Q0,
    S_DLENGTH,
    S_HC,
    S_MASS,
    V_BODY,
    V_DBODY,
    V_DIRECTION,
    V_DP,
    V_DWHEEL,
    V_WHEEL,
    VECTORS,
    chassis_terms,
    compiled_kernels,
    ground_terms,
    layout,
)
from suspopt.multibody.solver import MultibodyState, PlanarMultibodySolver, freeze
from suspopt.multibody.suspension import RESPONSE, ModuleKinematics, SuspensionModule

__all__ = [
    'ReducedState',
    'clear_tables',
    'ReducedSuspensionModule',
    'TravelTable',
    'reducible',
    'reduced_modules',
]


@dataclass(frozen=True)
class TravelTable:
    """Functions of the wheel travel ``s`` on ``[lo, hi]`` as Chebyshev series:
    ``coefficients`` (K, columns), the columns named by ``columns`` (name -> slice).

    ``error`` is the largest interpolation error found on the check grid, per name,
    relative to the name's scale (its largest magnitude over the range)."""

    lo: float
    hi: float
    coefficients: np.ndarray
    columns: Mapping[str, slice]
    scale: Mapping[str, float]
    error: Mapping[str, float]

    @property
    def degree(self) -> int:
        return self.coefficients.shape[0] - 1

    def basis(self, s: np.ndarray) -> np.ndarray:
        """``T_k(x(s))`` (N, K) as ``cos(k arccos x)``, ``x = (2 s - lo - hi) / (hi - lo)``
        (``s`` inside the range: NaN outside)."""
        x = (2.0 * s - (self.lo + self.hi)) / (self.hi - self.lo)
        return np.cos(np.arccos(x)[:, None] * np.arange(self.coefficients.shape[0]))

    def __call__(self, s: np.ndarray, columns: slice | None = None) -> np.ndarray:
        """The functions at travels ``s`` (N,): (N, columns)."""
        c = self.coefficients if columns is None else self.coefficients[:, columns]
        return self.basis(s) @ c

    @classmethod
    def fit(
        cls,
        values: Callable[[np.ndarray], np.ndarray],
        lo: float,
        hi: float,
        columns: Mapping[str, slice],
        tolerance: float,
        degrees: tuple[int, ...] = (16, 24, 32, 48, 64, 96, 128),
        check: int = 201,
    ) -> TravelTable:
        """Interpolate ``values(s)`` (N, columns) at Chebyshev points of increasing degree
        until, on ``check`` equispaced travels, every name's error is at most
        ``tolerance`` times its scale (:class:`MultibodyError` if no degree does)."""
        s_check = np.linspace(lo, hi, check)
        y_check = values(s_check)
        scale = {n: float(np.max(np.abs(y_check[:, sl]), initial=0.0)) for n, sl in columns.items()}
        table = None
        for deg in degrees:
            x = cheb.chebpts1(deg + 1)
            y = values(0.5 * (lo + hi) + 0.5 * (hi - lo) * x)
            coef = cheb.chebvander(x, deg).T @ y * (2.0 / (deg + 1))
            coef[0] *= 0.5
            table = cls(lo, hi, freeze(coef), dict(columns), scale, {})
            err = table.errors(s_check, y_check)
            table = dataclasses.replace(table, error=err)
            if max(err.values()) <= tolerance:
                return table
        assert table is not None
        errors = table.error
        worst = max(errors, key=lambda name: errors[name])
        raise MultibodyError(
            f'travel table: the {worst!r} series misses the tolerance {tolerance:g} '
            f'at degree {degrees[-1]} (relative error {errors[worst]:.2g})'
        )

    def errors(self, s: np.ndarray, exact: np.ndarray) -> dict[str, float]:
        """The series' largest error at travels ``s`` against ``exact`` (N, columns),
        per name relative to its scale (absolute where the scale is zero)."""
        diff = np.abs(self(s) - exact)
        return {
            n: float(np.max(diff[:, sl], initial=0.0)) / (self.scale[n] or 1.0)
            for n, sl in self.columns.items()
        }


@dataclass
class ReducedState(MultibodyState):
    """A batch of states of a reduced module: the body coordinates and velocities
    (``q``, ``qd``, as :class:`~suspopt.multibody.solver.MultibodyState`), the wheel travel
    ``s`` in the linkage's frame and its rate ``sd`` and the table's functions there
    (``values``; rows of states outside the table undefined); the rows of the states
    inside the table (``inside``, None: all) and the full module's analysis of the others
    (``fallback``)."""

    s: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))
    sd: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))
    values: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 0)))
    inside: np.ndarray | None = None
    fallback: ModuleKinematics | None = None


def reducible(mechanism: Mechanism) -> str | None:
    """Why ``mechanism`` (a suspension file, ground-mounted form) has no reduced model,
    or None if it has one: one degree of freedom driven by the vertical position of a
    moving body, a travel range, a spring-type suspension spring, and no other force
    element with a nonzero value in the file (the tyre is the only load the module
    applies)."""
    if len(mechanism.independent) != 1:
        return f'{len(mechanism.independent)} independent coordinates (one needed)'
    body, coord = mechanism.independent[0]
    fixed = {b.name for b in mechanism.bodies if b.fixed}
    if coord != 'z' or body in fixed:
        return f'independent coordinate {body}.{coord} (the z of a moving body needed)'
    if mechanism.travel is None:
        return 'no travel range'
    spring = mechanism.roles.get('spring')
    for f in mechanism.forces:
        name = getattr(f, 'name', None)
        if name == spring:
            if not is_spring(f):
                return f'the suspension spring {spring!r} is not a spring type'
            if getattr(f, 'curves', None) is not None:
                return f'the suspension spring {spring!r} has curves (a linear one needed)'
            continue
        values = [getattr(f, p, 0.0) for p in ('stiffness', 'damping', 'preload', 'magnitude')]
        if any(v for v in values):
            return f'force element {name!r} has nonzero values in the file'
    return None


def _no_curves(settings: dict[str, np.ndarray] | None) -> None:
    if settings:
        raise ValueError(
            f'a reduced module has a linear spring, no curve settings {sorted(settings)}'
        )


class ReducedSuspensionModule:
    """The reduced model of a :class:`SuspensionModule` (same mechanism and mount): the
    same queries, by Chebyshev series in the wheel travel (see the module docstring).

    Its :meth:`kinematics`, :meth:`dynamics`, :meth:`mount_response` and
    :meth:`constraint_residual` take and return what the full module's do, except that
    the joint reactions are not modelled: :meth:`dynamics` returns None in their place and
    :meth:`mount_response` only the :data:`~suspopt.multibody.suspension.RESPONSE`
    entries. States whose wheel travel (in the linkage's frame) is outside the table
    are answered by ``full``.

    ``tolerance``: the series' largest interpolation error relative to each quantity's
    scale (checked when built, and again by :meth:`verify_table`). ``compiled``: evaluate
    by the Numba kernels of :mod:`~suspopt.multibody.reduced_terms` (Numba needed; they
    compile at the first query and are cached on disk) instead of NumPy on the batch."""

    def __init__(self, full: SuspensionModule, tolerance: float = 1e-12, compiled: bool = False):
        mech = full.base_mechanism
        why = reducible(mech)
        if why is not None:
            raise MultibodyError(f'{mech.name}: no reduced model: {why}')
        self.full = full
        #: what the vehicle's components read of a module (the full module's)
        self.solver, self.settings = full.solver, full.settings
        self.setting_units, self.unit = full.setting_units, full.unit
        self.mechanism = full.mechanism
        self.mount = full.mount
        self.n_joints = full.n_joints
        self.tolerance = tolerance
        self.time_s = 0.0  # wall time spent inside this module (benchmarks)
        self.fallbacks = 0  # states answered by the full module
        # a table of the same linkage made before (by value: mechanism, roles, travel)
        key = (mech, tuple(sorted(mech.roles.items())), mech.travel, tolerance)
        made = _MADE.get(key)
        # the ground-mounted linkage, analysed to the rounding floor
        self._solver = s = (
            PlanarMultibodySolver(mech, newton_tol=4e-15) if made is None else made[0]
        )
        self.n = s.n
        roles = mech.roles
        #: the mount point P_0: the wheel marker's reference position (as the full module's)
        self.mount_point = full.marker_ref[full.wheel].copy()
        self._wheel = s.marker_names.index(roles['wheel_marker'])
        load = next(ld for ld in mech.loads if ld.name == roles['tyre_load'])
        self._contact = s.marker_names.index(load.marker)
        self._spring = spring = roles['spring']
        self._linkage_end = 1 - full.chassis_end
        grp = next(
            g for g in s.force_groups if isinstance(g, ScalarSpringGroup) and spring in g.names
        )
        masses = s.mass_diag.reshape(s.nb, 3)
        moving = np.array([not body.fixed for body in mech.bodies])
        self._m = np.where(moving, masses[:, 0], 0.0)
        self._I = np.where(moving, masses[:, 2], 0.0)
        self._body = int(s.ind[0]) // 3
        q0 = s.q0.reshape(s.nb, 3)
        self._p_fixed = np.sum(
            (masses[:, 0] * ~moving)[:, None] * (q0[:, :2] - self.mount_point), axis=0
        )
        par = np.zeros(8)
        par[P_FREE] = grp.free_length[grp.names.index(spring)]
        par[P_PRELOAD] = getattr(mech.force(spring), 'preload', 0.0)
        par[P_DTX], par[P_DTZ] = load.direction
        par[P_GX], par[P_GZ] = mech.gravity
        par[P_MMOV], par[P_MALL] = np.sum(self._m), np.sum(masses[:, 0])
        self.par = freeze(par)
        #: height of the independent body's CG above P_0 at the reference pose
        self._rise0 = float(s.q0[s.ind[0]] - self.mount_point[1])
        self.columns = layout(s.n)
        if made is None:
            lo, hi = mech.travel  # type: ignore[misc]
            table = TravelTable.fit(self._exact, lo, hi, self.columns, tolerance)
            # the largest constraint violation of the tabulated positions (check grid)
            q = table(np.linspace(lo, hi, 201), self.columns['q'])
            made = (s, table, float(np.max(np.abs(s.constraints(q)))))
            _MADE[key] = made
            while len(_MADE) > _MADE_SIZE:
                _MADE.popitem(last=False)
        self.table: TravelTable = made[1]
        #: the largest constraint violation of the tabulated positions (found on the
        #: fit's check grid)
        self.table_residual: float = made[2]
        self._kernels: SimpleNamespace | None = compiled_kernels() if compiled else None
        self.compiled = compiled

    @classmethod
    def from_mechanism(
        cls,
        mechanism: Mechanism | str,
        mount: str = 'ground',
        tolerance: float = 1e-12,
        compiled: bool = False,
    ) -> ReducedSuspensionModule:
        return cls(SuspensionModule(mechanism, mount=mount), tolerance, compiled)

    # ------------------------------------------------------------------ the table
    def _exact(self, s: np.ndarray) -> np.ndarray:
        """The tabulated functions at travels ``s`` (N,) by the ground-mounted linkage's
        position, velocity and acceleration analyses (q, q' and q'' at ṡ = 1, s̈ = 0)."""
        sv = self._solver
        N = s.shape[0]
        q = sv.positions(sv.q0[sv.ind] + s[:, None])
        Cq = sv.constraint_jacobian(q)
        dq = sv.velocities(q, np.ones((N, 1)), Cq)
        ddq = sv.accelerations(q, dq, np.zeros((N, 1)), Cq)
        P0 = self.mount_point
        pos = sv.marker_positions(q) - P0
        vel = sv.marker_velocities(q, dq)
        sp = sv.spring(self._spring, q, dq)
        q3, v3, a3 = (a.reshape(N, sv.nb, 3) for a in (q, dq, ddq))
        rho, drho, ddrho = q3[..., :2] - P0, v3[..., :2], a3[..., :2]
        dphi, ddphi = v3[..., 2], a3[..., 2]
        m, I, b = self._m, self._I, self._body
        parts = {
            'wheel': pos[:, self._wheel],
            'dwheel': vel[:, self._wheel],
            'body': rho[:, b],
            'dbody': drho[:, b],
            'ddbody': ddrho[:, b],
            'contact': pos[:, self._contact],
            'dcontact': vel[:, self._contact],
            'direction': sp.direction[:, self._linkage_end],
            'p': np.einsum('i,nij->nj', m, rho),
            'dp': np.einsum('i,nij->nj', m, drho),
            'ddp': np.einsum('i,nij->nj', m, ddrho),
            'pfixed': np.broadcast_to(self._p_fixed, (N, 2)),
            'length': sp.length,
            'dlength': sp.rate,
            'mass': np.sum(m * np.sum(drho**2, -1) + I * dphi**2, -1),
            'h': np.sum(m * np.sum(drho * ddrho, -1) + I * dphi * ddphi, -1),
            'J0': np.sum(m * np.sum(rho**2, -1) + I, -1),
            'Hc': np.sum(m * cross(rho, drho) + I * dphi, -1),
            'Hq': np.sum(m * cross(rho, ddrho) + I * ddphi, -1),
            'Hd': np.sum(m * np.sum(rho * drho, -1), -1),
            'q': q,
            'dq': dq,
        }
        out = np.empty((N, Q0 + 2 * sv.n))
        for name, sl in self.columns.items():
            out[:, sl] = parts[name].reshape(N, -1)
        return out

    def verify_table(self, points: int = 401) -> dict[str, float]:
        """The table's error against the linkage's analyses on ``points`` equispaced
        travels (other than the fit's check grid), per name relative to its scale; a
        :class:`MultibodyError` if any exceeds the tolerance (a damaged table)."""
        t = self.table
        s = np.linspace(t.lo, t.hi, points)
        err = t.errors(s, self._exact(s))
        bad = {n: e for n, e in err.items() if not e <= self.tolerance}
        if bad:
            raise MultibodyError(
                f'{self.mechanism.name}: the travel table disagrees with the linkage '
                f'(relative errors {bad}, tolerance {self.tolerance:g})'
            )
        return err

    # ------------------------------------------------------------------ queries
    def kinematics(
        self,
        z_W: np.ndarray,
        v_W: np.ndarray,
        guess: np.ndarray | None = None,
        pose: tuple[np.ndarray, ...] | None = None,
    ) -> ModuleKinematics:
        """:meth:`SuspensionModule.kinematics` (``guess`` is used for the states outside the
        table only); the state is a :class:`ReducedState`."""
        t0 = time.perf_counter()
        try:
            z_W = _vector(z_W)
            N = z_W.shape[0]
            v_W = _vector(v_W, N)
            if (pose is not None) != (self.mount == 'chassis'):
                raise ValueError(
                    f'{self.mechanism.name}: a {self.mount}-mounted module '
                    + ('needs the mount pose' if pose is None else 'takes no mount pose')
                )
            if pose is not None:
                pose = tuple(_vector(p, N) for p in pose)
            if self._kernels is not None:
                Y, q, qd, q_W, qd_W, s, sd, inside = self._compiled_kinematics(z_W, v_W, pose)
            else:
                Y, q, qd, q_W, qd_W, s, sd, inside = self._numpy_kinematics(z_W, v_W, pose)
            fallback, rows = None, None
            if inside is not None:
                out = ~inside
                self.fallbacks += int(np.count_nonzero(out))
                sub = None if pose is None else tuple(p[out] for p in pose)
                fallback = self.full.kinematics(
                    z_W[out], v_W[out], None if guess is None else guess[out], pose=sub
                )
                q = np.array(q)  # (a view of the table's values in the ground mount)
                q[out], qd[out] = fallback.state.q, fallback.state.qd
                q_W[out], qd_W[out] = fallback.q_W, fallback.qd_W
                rows = np.flatnonzero(inside)
            state = ReducedState(q=q, qd=qd, s=s, sd=sd, values=Y, inside=rows, fallback=fallback)
            return ModuleKinematics(q_W=q_W, qd_W=qd_W, state=state, pose=pose)
        finally:
            self.time_s += time.perf_counter() - t0

    def _compiled_kinematics(self, z_W, v_W, pose):
        """:meth:`kinematics` by the compiled kernels: the table's values ``Y`` (N, columns),
        ``q``, ``q̇``, ``q_W``, ``q̇_W``, ``s``, ``ṡ`` of every state (the rows of states
        outside the table undefined) and the states inside (None: all)."""
        kern, t = self._kernels, self.table
        assert kern is not None
        N, n = z_W.shape[0], self.n
        Y = np.empty((N, t.coefficients.shape[1]))
        qd, q_W, qd_W = np.empty((N, n)), np.empty(N), np.empty(N)
        inside = np.empty(N, dtype=bool)
        if pose is None:
            kern.ground_kinematics(
                t.coefficients, t.lo, t.hi, z_W, v_W, n, Y, qd, q_W, qd_W, inside
            )
            q, s, sd = Y[:, Q0 : Q0 + n], z_W, v_W
        else:
            q, s, sd = np.empty((N, n)), np.empty(N), np.empty(N)
            P0 = self.mount_point
            kern.chassis_kinematics(
                t.coefficients, t.lo, t.hi, z_W, v_W, *pose, P0[0], P0[1], self._rise0, n,
                Y, q, qd, q_W, qd_W, s, sd, inside,
            )  # fmt: skip
        return Y, q, qd, q_W, qd_W, s, sd, None if inside.all() else inside

    def _numpy_kinematics(self, z_W, v_W, pose):
        """:meth:`_compiled_kinematics` by NumPy on the batch."""
        s = z_W if pose is None else self._travel(z_W, pose)
        t = self.table
        inside = (s >= t.lo) & (s <= t.hi)
        if inside.all():
            return (*self._inside_kinematics(s, v_W, pose), None)
        N = s.shape[0]
        Y = np.full((N, t.coefficients.shape[1]), np.nan)
        q, qd = np.full((N, self.n), np.nan), np.full((N, self.n), np.nan)
        q_W, qd_W, sd = np.full(N, np.nan), np.full(N, np.nan), np.full(N, np.nan)
        if inside.any():
            sub = None if pose is None else tuple(p[inside] for p in pose)
            values = self._inside_kinematics(s[inside], v_W[inside], sub)
            for a, v in zip((Y, q, qd, q_W, qd_W, sd), values[:5] + values[6:]):
                a[inside] = v
        return Y, q, qd, q_W, qd_W, s, sd, inside

    def _travel(self, z_W: np.ndarray, pose: tuple[np.ndarray, ...]) -> np.ndarray:
        """Chassis mount: the travel ``s`` at which the independent body's global height is
        the query's: ``z_M + sin ψ ρ_x(s) + cos ψ ρ_z(s) = z_W + ρ_z(0)`` with
        ``ρ_z(s) = ρ_z(0) + s``, by Newton's method when the frame is turned (NaN where it
        does not converge, left to the full module)."""
        z_M, _, psi, _ = pose
        s = z_W - z_M
        if not psi.any():
            return s
        c, sn = np.cos(psi), np.sin(psi)
        rhs = s + (1.0 - c) * self._rise0
        cx = self.table.coefficients[:, 2 * V_BODY : 2 * V_BODY + 1]
        cdx = self.table.coefficients[:, 2 * V_DBODY : 2 * V_DBODY + 1]
        lo, hi = self.table.lo, self.table.hi
        for _ in range(12):
            B = self.table.basis(np.minimum(np.maximum(s, lo), hi))
            step = (c * s + sn * (B @ cx)[:, 0] - rhs) / (c + sn * (B @ cdx)[:, 0])
            s = s - step
            if not np.max(np.abs(step), initial=0.0) > 1e-15:
                return s
        return s + np.nan

    def _inside_kinematics(self, s, v_W, pose):
        """The table's values, ``q``, ``q̇``, ``q_W``, ``q̇_W``, ``s`` placeholder and ``ṡ``
        at travels ``s`` inside the table (NumPy)."""
        Y = self.table(s)
        n = self.n
        q, dq = Y[:, Q0 : Q0 + n], Y[:, Q0 + n : Q0 + 2 * n]
        if pose is None:
            sd = v_W
            q_W = Y[:, 2 * V_WHEEL + 1]
            qd_W = Y[:, 2 * V_DWHEEL + 1] * sd
            qd = dq * sd[:, None]
        else:
            z_M, v_M, psi, w = pose
            c, sn = np.cos(psi), np.sin(psi)
            rb, drb = Y[:, 2 * V_BODY : 2 * V_BODY + 2], Y[:, 2 * V_DBODY : 2 * V_DBODY + 2]
            # the independent body's height rate v_M + ψ̇ X(ρ_b) + Z(ρ_b') ṡ is the query's
            sd = (v_W - v_M - w * (c * rb[:, 0] - sn * rb[:, 1])) / (sn * drb[:, 0] + c * drb[:, 1])
            rw = Y[:, 2 * V_WHEEL : 2 * V_WHEEL + 2]
            drw = Y[:, 2 * V_DWHEEL : 2 * V_DWHEEL + 2]
            q_W = z_M + (sn * rw[:, 0] + c * rw[:, 1])
            qd_W = v_M + w * (c * rw[:, 0] - sn * rw[:, 1]) + sd * (sn * drw[:, 0] + c * drw[:, 1])
            q, qd = self._moved(q, dq, sd, pose, c, sn)
        return Y, q, qd, q_W, qd_W, s, sd

    def _moved(self, q, dq, sd, pose, c, sn):
        """Body coordinates and velocities with the frame moved: ``r = P + A(ψ) ρ``,
        ``φ + ψ``; ``ṙ = (0, v_M) + ψ̇ perp(A ρ) + A ρ' ṡ``, ``φ̇ = ψ̇ + φ' ṡ``."""
        z_M, v_M, psi, w = pose
        N = q.shape[0]
        q3, v3 = q.reshape(N, -1, 3), dq.reshape(N, -1, 3)
        P0 = self.mount_point
        rx, rz = q3[..., 0] - P0[0], q3[..., 1] - P0[1]
        cc, ss, ww, sdd = c[:, None], sn[:, None], w[:, None], sd[:, None]
        ax, az = cc * rx - ss * rz, ss * rx + cc * rz
        qg = np.empty((N, self.n))
        qg[:, 0::3] = P0[0] + ax
        qg[:, 1::3] = (P0[1] + z_M[:, None]) + az
        qg[:, 2::3] = q3[..., 2] + psi[:, None]
        qdg = np.empty((N, self.n))
        qdg[:, 0::3] = -ww * az + sdd * (cc * v3[..., 0] - ss * v3[..., 1])
        qdg[:, 1::3] = v_M[:, None] + ww * ax + sdd * (ss * v3[..., 0] + cc * v3[..., 1])
        qdg[:, 2::3] = ww + sdd * v3[..., 2]
        return qg, qdg

    def dynamics(
        self,
        state: MultibodyState,
        z_M: np.ndarray,
        v_M: np.ndarray,
        k_S: np.ndarray,
        c_S: np.ndarray,
        F_T: np.ndarray,
        settings: dict[str, np.ndarray] | None = None,
        actuator: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray, None]:
        """:meth:`SuspensionModule.dynamics` at a :meth:`kinematics` state: wheel-travel
        acceleration (N,) and ``F_S`` (N,); no joint reactions (None). Its spring is linear:
        it has no curve ``settings``. An ``actuator`` force along the spring's line enters
        linearly (:meth:`_actuated`)."""
        _no_curves(settings)
        if self.mount != 'ground':
            raise ValueError(
                f"{self.mechanism.name}: dynamics() is the ground mount's "
                'query; a chassis-mounted module answers mount_response()'
            )
        st = self._own(state)
        t0 = time.perf_counter()
        try:
            N = st.q.shape[0]
            zM, vM, k, c, F = (_vector(a, N) for a in (z_M, v_M, k_S, c_S, F_T))
            rows = st.inside
            act = None if actuator is None else _vector(actuator, N)
            if rows is None and self._kernels is None:
                sdd, F_S = ground_terms(st.values.T, st.sd, zM, vM, k, c, F, self.par)
                if act is not None:
                    self._actuated(st.values, act, F_S, sdd)
                return sdd, F_S, None
            sdd, F_S = np.empty(N), np.empty(N)
            every = np.arange(N) if rows is None else rows
            if self._kernels is not None:
                self._kernels.ground_dynamics(
                    st.values, every, st.sd, zM, vM, k, c, F, self.par, sdd, F_S
                )
            elif every.size:
                sdd[every], F_S[every] = ground_terms(
                    st.values[every].T,
                    st.sd[every],
                    zM[every],
                    vM[every],
                    k[every],
                    c[every],
                    F[every],
                    self.par,
                )
            if act is not None and every.size:
                d_sdd, d_F = np.zeros(every.size), np.zeros(every.size)
                self._actuated(st.values[every], act[every], d_F, d_sdd)
                sdd[every] += d_sdd
                F_S[every] += d_F
            if st.fallback is not None:
                out = np.ones(N, dtype=bool)
                out[every] = False
                a, f, _ = self.full.dynamics(
                    st.fallback.state,
                    zM[out],
                    vM[out],
                    k[out],
                    c[out],
                    F[out],
                    actuator=None if act is None else act[out],
                )
                sdd[out], F_S[out] = a, f
            return sdd, F_S, None
        finally:
            self.time_s += time.perf_counter() - t0

    @staticmethod
    def _actuated(
        Y: np.ndarray,
        actuator: np.ndarray,
        F_S: np.ndarray,
        sdd: np.ndarray | None = None,
        psi: np.ndarray | None = None,
        R: np.ndarray | None = None,
    ) -> None:
        """Add an actuator force ``u`` along the spring's line (pushing its ends apart) to
        the answers at states ``Y``: the spring's tension is lower by ``u``, and both
        answers are affine in the tension (:func:`ground_terms`, :func:`chassis_terms`):
        ``Δs̈ = u ℓ' / m`` and ``ΔF_S = u e_z`` (ground mount, ``sdd``, ``F_S`` in place);
        the chassis mount's zero-acceleration response block ``R[:, 0]`` by the same
        ``Δs̈`` through the independent body's and the frame's terms (``psi``: the
        frame's turn)."""
        d = actuator * Y[:, S_DLENGTH] / Y[:, S_MASS]
        if R is None:
            assert sdd is not None
            sdd += d
            F_S += actuator * Y[:, 2 * V_DIRECTION + 1]
            return
        assert psi is not None
        cp, sp = np.cos(psi), np.sin(psi)

        def turned(v: int) -> tuple[np.ndarray, np.ndarray]:
            x, z = Y[:, 2 * v], Y[:, 2 * v + 1]
            return cp * x - sp * z, sp * x + cp * z

        Xdp, Zdp = turned(V_DP)
        R[:, 0, 0] += turned(V_DBODY)[1] * d
        R[:, 0, 1] -= Zdp * d
        R[:, 0, 2] -= Y[:, S_HC] * d
        R[:, 0, 3] -= Xdp * d
        F_S += actuator * turned(V_DIRECTION)[1]

    def strut_rate(self, kin: ModuleKinematics, v_M: np.ndarray | None = None) -> np.ndarray:
        """:meth:`SuspensionModule.strut_rate` at a :meth:`kinematics` state: ``-ℓ' ṡ``
        (less ``e_z v_M`` on the ground mount)."""
        st = self._own(kin.state)
        N = st.sd.shape[0]
        ground = self.mount == 'ground'
        vM = _vector(np.zeros(N) if v_M is None else v_M, N)
        every = np.arange(N) if st.inside is None else st.inside
        out = np.empty(N)
        Y = st.values[every]
        rate = -Y[:, S_DLENGTH] * st.sd[every]
        if ground:
            rate = rate - Y[:, 2 * V_DIRECTION + 1] * vM[every]
        out[every] = rate
        if st.fallback is not None:
            rest = np.ones(N, dtype=bool)
            rest[every] = False
            out[rest] = self.full.strut_rate(st.fallback, vM[rest] if ground else None)
        return out

    @staticmethod
    def _own(state: MultibodyState) -> ReducedState:
        if not isinstance(state, ReducedState):
            raise TypeError('a reduced module takes the states of its own kinematics()')
        return state

    def mount_response(
        self,
        kin: ModuleKinematics,
        k_S: np.ndarray,
        c_S: np.ndarray,
        F_T: np.ndarray,
        rotation: bool = False,
        acceleration: np.ndarray | None = None,
        settings: dict[str, np.ndarray] | None = None,
        actuator: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`SuspensionModule.mount_response` at a :meth:`kinematics` state, the
        :data:`~suspopt.multibody.suspension.RESPONSE` entries only: ``R`` (N, B, 4) and
        ``F_S`` (N,); an ``actuator`` force along the spring's line as in
        :meth:`dynamics`."""
        _no_curves(settings)
        if self.mount != 'chassis':
            raise ValueError(
                f"{self.mechanism.name}: mount_response() is the chassis mount's query"
            )
        st = self._own(kin.state)
        pose = kin.pose
        if pose is None:
            raise ValueError('mount_response() takes the kinematics of a chassis-mounted state')
        t0 = time.perf_counter()
        try:
            N = st.q.shape[0]
            k, c, F = (_vector(a, N) for a in (k_S, c_S, F_T))
            acc = None if acceleration is None else np.asarray(acceleration, float).reshape(N, 2)
            blocks = 1 if acc is not None else (3 if rotation else 2)
            R, F_S = np.empty((N, blocks, len(RESPONSE))), np.empty(N)
            rows = st.inside
            every = np.arange(N) if rows is None else rows
            if self._kernels is not None:
                self._kernels.chassis_response(
                    st.values, every, st.sd, pose[2], pose[3], k, c, F, self.par,
                    _NO_ACC if acc is None else np.ascontiguousarray(acc), R, F_S,
                )  # fmt: skip
            elif rows is None:
                self._response(st.values, st.sd, pose, k, c, F, acc, R, F_S)
            elif rows.size:
                Ri, Fi = R[rows], F_S[rows]
                self._response(
                    st.values[rows],
                    st.sd[rows],
                    tuple(p[rows] for p in pose),
                    k[rows],
                    c[rows],
                    F[rows],
                    None if acc is None else acc[rows],
                    Ri,
                    Fi,
                )
                R[rows], F_S[rows] = Ri, Fi
            act = None if actuator is None else _vector(actuator, N)
            if act is not None and every.size:
                Ri, Fi = R[every], F_S[every]
                self._actuated(st.values[every], act[every], Fi, psi=pose[2][every], R=Ri)
                R[every], F_S[every] = Ri, Fi
            if st.fallback is not None:
                out = np.ones(N, dtype=bool)
                out[every] = False
                Rf, Ff = self.full.mount_response(
                    st.fallback,
                    k[out],
                    c[out],
                    F[out],
                    rotation=rotation,
                    acceleration=None if acc is None else acc[out],
                    actuator=None if act is None else act[out],
                )
                R[out], F_S[out] = Rf[:, :, : len(RESPONSE)], Ff
            return R, F_S
        finally:
            self.time_s += time.perf_counter() - t0

    def _response(self, Y, sd, pose, k, c, F_T, acc, R, F_S) -> None:
        """:func:`chassis_terms` (NumPy) into the response blocks ``R`` (N, B, 4), or with
        ``acc`` the response at those mount accelerations (B = 1), and ``F_S``."""
        _, _, psi, w = pose
        V = Y[:, : 2 * len(VECTORS)]
        if psi.any():
            cp, sp = np.cos(psi)[:, None], np.sin(psi)[:, None]
            Vx, Vz = V[:, 0::2], V[:, 1::2]
            X, Z = (cp * Vx - sp * Vz).T, (sp * Vx + cp * Vz).T
        else:
            X, Z = V[:, 0::2].T, V[:, 1::2].T
        t = chassis_terms(Y.T, X, Z, sd, w, k, c, F_T, self.par)
        if acc is not None:
            a, r = acc[:, 0], acc[:, 1]
            for j in range(4):
                R[:, 0, j] = t[j] + a * t[4 + j] + r * t[8 + j]
        else:
            for b in range(R.shape[1]):
                for j in range(4):
                    R[:, b, j] = t[4 * b + j]
        F_S[...] = t[12]

    def constraint_residual(
        self, state: MultibodyState, pose: tuple[np.ndarray, ...] | None = None
    ) -> float:
        """The largest constraint violation of the states' positions [m]: the table's
        (found on its check grid) and the full module's for the states outside it."""
        if not isinstance(state, ReducedState):
            return self.full.constraint_residual(state, pose)
        res = self.table_residual if state.values is not None else 0.0
        if state.fallback is not None:
            fb = state.fallback
            res = max(res, self.full.constraint_residual(fb.state, fb.pose))
        return res


_NO_ACC = np.zeros((0, 2))
#: tables made, by the value of what they depend on: (the ground-mounted mechanism, its
#: roles, its travel range, the tolerance) -> (its solver, the table, the table's residual)
_MADE: OrderedDict[tuple, tuple[PlanarMultibodySolver, TravelTable, float]] = OrderedDict()
_MADE_SIZE = 16


def _vector(a, N: int | None = None) -> np.ndarray:
    """``a`` as a contiguous float array (N,) (broadcast if it is not one already)."""
    a = np.ascontiguousarray(a, dtype=float)
    if a.ndim != 1 or (N is not None and a.shape[0] != N):
        a = np.ascontiguousarray(np.broadcast_to(a, (a.size if N is None else N,)))
    return a


def clear_tables() -> None:
    """Forget the tables made so far (the next module of each linkage makes its own)."""
    _MADE.clear()


def reduced_modules(
    modules: Mapping[str, object], tolerance: float = 1e-12, compiled: bool = False
) -> dict[str, object]:
    """The reduced model of each :class:`SuspensionModule` of ``modules`` (by mechanism
    name, as ``transcription.problem.multibody_modules`` builds them), sharing it as the
    fallback; a module whose mechanism has no reduced model (:func:`reducible`, or no
    series meeting ``tolerance``) is kept. ``compiled``: see :class:`ReducedSuspensionModule`."""
    out: dict[str, object] = {}
    for name, mod in modules.items():
        out[name] = mod
        if isinstance(mod, SuspensionModule) and reducible(mod.base_mechanism) is None:
            try:
                out[name] = ReducedSuspensionModule(mod, tolerance, compiled)
            except MultibodyError:  # no series meets the tolerance: the full module answers
                pass
    return out
