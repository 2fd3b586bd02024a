"""Planar multibody dynamics in the augmented form (paper eq. 11, docs/model.md).

Body coordinates ``q = (x, z, φ)`` per body, CG-based, so the mass matrix
``M = diag(m, m, I)`` is constant and there are no quadratic-velocity inertia forces
(``F_v = 0``; Shabana, *Dynamics of Multibody Systems*, ch. 5). The constraint equations
``C(q, t) = 0`` are the joints' (one module per joint type in
:mod:`suspopt.multibody.elements`; a fixed body is a fixed joint to the ground), stacked
in the order of the mechanism's joints, each type evaluated for all its joints at once.
The accelerations and multipliers solve

    [ M   C_qᵀ ] [ q̈ ]   [ Q          ]
    [ C_q  0   ] [ λ ] = [ γ = F_c    ],   γ = -(C_q q̇)_q q̇ - C_tt,

and ``Q = F_e`` is gravity plus the force elements. Optionally Baumgarte stabilization
replaces ``γ`` by ``γ - 2α Ċ - β² C`` (used by the full-coordinate simulator only).

Every method works on a batch of N states at once (leading axis N): the collocation
nodes are evaluated in one vectorized call with batched LAPACK solves, never in a
Python loop over nodes.

Position analysis (coordinate partitioning, Wehage & Haug 1982): given the independent
coordinates, Newton's method on ``C(q) = 0`` gives the dependent ones; then
``C_q q̇ = ν`` (``ν = -C_t``, zero unless a body is prescribed) gives the dependent
velocities.

Run-time values: ``motion`` maps prescribed joints to their
:class:`~suspopt.multibody.elements.PrescribedMotion` (pose offsets, velocities and
accelerations per state); ``params`` maps force elements to values of their parameters
per state (``{'strut': {'stiffness': k, 'damping': c}}``, ``{'tyre': {'magnitude': F}}``),
which replace the file's values.

Queries for a vehicle coupling: :meth:`PlanarMultibodySolver.spring` (length,
deflection, rate, tension, line of action and force at each end of a spring element),
:meth:`~PlanarMultibodySolver.reactions` (every joint's force and torque on each of its
bodies) and :meth:`~PlanarMultibodySolver.body_reaction` (their sum on one body or the
ground, torque about a given point; for a prescribed frame, the force that drives it).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from suspopt.errors import ConfigError, MultibodyError
from suspopt.multibody.elements import FixedJoint, JointSpec, PointLoad, PrescribedMotion
from suspopt.multibody.elements.base import (
    COORDINATES,
    BodyPoints,
    CoincidenceJointGroup,
    CoincidenceSet,
    ForceGroup,
    JointGroup,
    Layout,
    ScalarSpringGroup,
    cross,
    gather,
    perp,
    rot_apply,
)
from suspopt.multibody.mechanism import GROUND, Mechanism
from suspopt.multibody.npfast import inv as _lapack_inv
from suspopt.multibody.npfast import solve as _lapack_solve

#: a state where the linkage moves this many times faster than at its reference pose is
#: a lock (toggle) position: the travel-range check of a suspension refuses it
TOGGLE_SENSITIVITY = 100.0
#: wheel-travel steps of the travel-range check (continuation, each half of the range)
TRAVEL_STEPS = 10
#: batches up to this many states iterate Newton's method as a whole (see _positions)
SMALL_BATCH = 16
#: spacing of the pose table over a suspension's travel range [m of wheel travel]
POSE_TABLE_SPACING = 1.25e-4
#: read-only constraint Jacobians whose partitioning is kept (PlanarMultibodySolver.partition):
#: the poses one finite-difference Jacobian visits (the base and one per position input:
#: wheel travel, and a chassis mount's height and rotation)
KEPT_POSES = 4

Motion = Mapping[str, PrescribedMotion]
Params = Mapping[str, Mapping[str, ArrayLike]]

__all__ = [
    'MultibodyState',
    'PlanarMultibodySolver',
    'PositionAnalysis',
    'SpringState',
    'ValueCache',
    'freeze',
    'frozen',
    'rotation',
]


def rotation(phi: np.ndarray) -> np.ndarray:
    """``A(φ)`` for an array of angles: shape ``phi.shape + (2, 2)``."""
    c, s = np.cos(phi), np.sin(phi)
    return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)


@dataclass
class MultibodyState:
    """Positions, velocities, accelerations and multipliers of a batch of N states."""

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray | None = None
    lam: np.ndarray | None = None
    Cq: np.ndarray | None = None  # constraint Jacobian at q, when already computed


@dataclass
class PositionAnalysis:
    """A position analysis of N states (:meth:`PlanarMultibodySolver.analyse_positions`):
    the coordinates ``q`` (N, n), the constraint Jacobian there ``Cq`` (N, m, n), each
    state's largest constraint violation ``residual`` (N,) and the coincidence joints'
    pool (N, width) or None (see :class:`~suspopt.multibody.elements.base.CoincidenceSet`)."""

    q: np.ndarray
    Cq: np.ndarray
    residual: np.ndarray
    pool: np.ndarray | None


@dataclass
class SpringState:
    """A spring element at N states: length ``ℓ``, deflection ``ℓ - ℓ0``, rate ``ℓ̇`` and
    ``ℓ̈`` (NaN when not computed), tension ``f = k (ℓ - ℓ0) + c ℓ̇`` (N,); the unit line of
    action at each end, pointing to the other end (N, 2, 2), and the force on each end,
    ``f`` times it (N, 2, 2); the bodies of the two ends."""

    length: np.ndarray
    deflection: np.ndarray
    rate: np.ndarray
    acceleration: np.ndarray
    force: np.ndarray
    direction: np.ndarray
    end_forces: np.ndarray
    bodies: tuple[str, str]


class PlanarMultibodySolver:
    """Batched planar multibody solver for one :class:`Mechanism`.

    Counts every batched evaluation in ``calls`` (position analyses, augmented solves) so
    that benchmarks can report solver calls. A mechanism with a travel range (a
    suspension file) is checked to pass it without locking.
    """

    def __init__(self, mechanism: Mechanism, newton_tol: float = 1e-12, newton_max_iter: int = 30):
        self.mechanism = mechanism
        self.newton_tol = newton_tol
        self.newton_max_iter = newton_max_iter
        #: analyses (batched): position, eq. 11; and factorizations: C_q,dep inverted (for
        #: the velocity analysis and eq. 11, once per pose)
        self.calls = {'positions': 0, 'augmented': 0, 'factorizations': 0}

        bodies = mechanism.bodies
        self.nb = nb = len(bodies)
        self.n = 3 * nb
        self.body_names = [b.name for b in bodies]
        idx = {name: i for i, name in enumerate(self.body_names)}
        idx[GROUND] = nb  # a virtual body with zero coordinates
        self.q0 = np.array([[*b.position, b.angle] for b in bodies], dtype=float).ravel()
        self.mass_diag = np.array([[b.mass, b.mass, b.inertia] for b in bodies]).ravel()
        self.M = np.diag(self.mass_diag)
        self._inv_mass = 1.0 / self.mass_diag
        #: the partitioning of the last read-only C_q's, by value (:meth:`partition`)
        self.partitions = ValueCache()
        q0e = np.concatenate([self.q0.reshape(nb, 3), np.zeros((1, 3))])

        # markers (on bodies or on the ground)
        self.marker_names = [mk.name for mk in mechanism.markers]
        self.mk_body = np.array([idx[mk.body] for mk in mechanism.markers], dtype=int)
        mk_pts = np.array([mk.point for mk in mechanism.markers], dtype=float).reshape(-1, 2)
        self.mk_u = rot_apply(-q0e[self.mk_body, 2], mk_pts - q0e[self.mk_body, :2])
        self._markers = BodyPoints(self.mk_body, self.mk_u)
        layout = Layout(
            index=idx,
            q0e=q0e,
            markers={
                name: (int(b), u) for name, b, u in zip(self.marker_names, self.mk_body, self.mk_u)
            },
        )

        self._setup_joints(layout)
        self._setup_forces(layout)
        self._setup_partitioning(idx)

        #: q_dep as a cubic spline of the single independent coordinate over the wheel
        #: travel range (a suspension's), the start of its position analyses there; made
        #: at the first analysis that needs it (False: none to make)
        self._pose_spline: Callable[[np.ndarray], np.ndarray] | Literal[False] | None = None
        self._travel_poses: dict[float, np.ndarray] | None = None
        if mechanism.travel is not None:
            self._travel_poses = self._check_travel(mechanism.travel)

    def _setup_joints(self, layout: Layout) -> None:
        """The joints: the mechanism's, then every fixed body welded to the ground at its
        CG, in one group per type, with where their rows and Jacobian entries go."""
        # joints: the mechanism's, then every fixed body welded to the ground at its CG
        mechanism, nb, q0e = self.mechanism, self.nb, layout.q0e
        specs: list[JointSpec] = list(mechanism.joints) + [
            FixedJoint(f'fixed {b.name}', (b.name, GROUND)) for b in mechanism.bodies if b.fixed
        ]
        self.nj = len(mechanism.joints)
        self.joint_names = [j.name for j in specs]
        self.joint_bodies = [tuple(j.bodies) for j in specs]
        first = np.cumsum([0] + [type(j).group.n_equations for j in specs])
        self.m = int(first[-1])
        self.joint_rows = [np.arange(first[k], first[k + 1]) for k in range(len(specs))]
        self.joint_groups: list[JointGroup] = []
        for typ in dict.fromkeys(j.type for j in specs):
            members = [k for k, j in enumerate(specs) if j.type == typ]
            g: JointGroup = type(specs[members[0]]).group([specs[k] for k in members], layout)
            g.members = np.array(members, dtype=int)
            g.rows = np.array([self.joint_rows[k] for k in members], dtype=int)
            r = g.rows.ravel()
            g.row_index = (
                slice(int(r[0]), int(r[-1]) + 1)
                if r.size and np.array_equal(r, np.arange(r[0], r[-1] + 1))
                else r
            )
            # where each entry of its Jacobian blocks (ne, S, k, 3) goes in the flattened
            # C_q of the bodies and the ground (m, 3 (nb + 1))
            g.flat = (
                g.rows[:, None, :, None] * 3 * (nb + 1)
                + 3 * g.bodies[:, :, None, None]
                + np.arange(3)
            ).ravel()
            self.joint_groups.append(g)
        self.prescribed = [name for g in self.joint_groups if g.rheonomic for name in g.names]
        # the coincidence joints (revolute, fixed) evaluated at once in the analyses: C_q is
        # their constant entries, then their arms, then the other groups' blocks
        coinc = [g for g in self.joint_groups if isinstance(g, CoincidenceJointGroup)]
        self._coincidences = (
            CoincidenceSet(coinc, [g.rows for g in coinc], nb, self.m) if coinc else None
        )
        self._others = [
            (gi, g)
            for gi, g in enumerate(self.joint_groups)
            if not isinstance(g, CoincidenceJointGroup)
        ]
        for _, g in self._others:  # g.flat in C_q (m, n), without the ground's columns
            row, col = np.divmod(g.flat, 3 * (nb + 1))
            g.flat_keep = np.flatnonzero(col < self.n)
            g.flat_mn = (row * self.n + col)[g.flat_keep]
        self._all_coincident = (
            not self._others
            and self.m > 0
            and self._coincidences is not None
            and np.array_equal(self._coincidences.rows, np.arange(self.m))
        )
        # joint_reactions without q: -λ_kᵀ ∂C_k/∂(x_i, z_i) of each joint's first body i, as
        # one matrix (2 nj, m), where that block does not depend on q
        self._first_force: np.ndarray = np.zeros((len(specs), 2, self.m))
        for g in self.joint_groups:
            J0 = g.jacobian(q0e[None])[0, :, 0, :, :2]  # (ne, k, 2)
            self._first_force[
                g.members[:, None, None], np.arange(2)[:, None], g.rows[:, None, :]
            ] = J0.transpose(0, 2, 1)
        self._first_force = self._first_force[: self.nj].reshape(2 * self.nj, self.m)
        self._first_force_T = np.ascontiguousarray(self._first_force.T)
        # the groups whose first-body force needs q: (group, its members among the joints)
        self._moving_force = [
            (g, g.members < self.nj)
            for g in self.joint_groups
            if not g.constant_force_jacobian and np.any(g.members < self.nj)
        ]

    def _setup_forces(self, layout: Layout) -> None:
        """The force elements: the loads, then ``[[forces]]``, one group per type; and
        gravity."""
        mechanism, nb = self.mechanism, self.nb
        fspecs = list(mechanism.loads) + list(mechanism.forces)
        self.force_names = [f.name for f in fspecs]
        self.load_names = [f.name for f in fspecs if isinstance(f, PointLoad)]
        self.force_groups: list[ForceGroup] = []
        for typ in dict.fromkeys(f.type for f in fspecs):
            fmembers = [f for f in fspecs if f.type == typ]
            self.force_groups.append(type(fmembers[0]).group(fmembers, layout))
        self._force_group = {
            name: (gi, k)
            for gi, g in enumerate(self.force_groups)
            for k, name in enumerate(g.names)
        }
        for fg in self.force_groups:  # generalized forces (ne, S, 3) -> the bodies' (n,)
            fg.all_zero = not any(np.any(v) for v in fg.defaults.values())
            fg.given = frozenset()  # parameters given at run time (see force_values)
            scatter = np.zeros((fg.bodies.size, 3, nb + 1, 3))
            scatter[np.arange(fg.bodies.size), :, fg.bodies.ravel()] = np.eye(3)
            fg.scatter = scatter.reshape(fg.bodies.size * 3, 3 * (nb + 1))[:, : self.n]
        # point-load groups: the columns of the ``loads`` array of their elements
        self._load_columns = {
            gi: np.array([self.load_names.index(n) for n in g.names])
            for gi, g in enumerate(self.force_groups)
            if isinstance(g.specs[0], PointLoad)
        }
        gravity = np.asarray(mechanism.gravity, dtype=float)
        self._gravity_force = None  # m g on every body (n,), None without gravity
        if np.any(gravity):
            Qg = np.zeros((nb, 3))
            Qg[:, :2] += self.mass_diag.reshape(nb, 3)[:, :1] * gravity
            self._gravity_force = Qg.ravel()

    def _setup_partitioning(self, idx: dict[str, int]) -> None:
        """Coordinate partitioning: the independent and dependent coordinates, checked at
        the reference pose, and the tangents that predict a position analysis's start."""
        mechanism = self.mechanism
        self.ind = np.array(
            [3 * idx[b] + COORDINATES.index(c) for b, c in mechanism.independent], dtype=int
        )
        self.dep = np.setdiff1d(np.arange(self.n), self.ind)
        self.dof = self.n - self.m
        if len(self.ind) != self.dof:
            raise ConfigError(
                f'{mechanism.name}: the mechanism has {self.dof} degrees of freedom '
                f'({self.n} coordinates, {self.m} constraint equations) but '
                f'{len(self.ind)} independent coordinates are given'
            )
        self._mass_dep = self.mass_diag[self.dep]
        self._ind0 = int(self.ind[0]) if self.dof else 0
        Cq = self.constraint_jacobian(self.q0[None])[0]
        sv = np.linalg.svd(Cq[:, self.dep], compute_uv=False)
        if sv[-1] < 1e-10 * max(sv[0], 1.0):
            raise ConfigError(
                f'{mechanism.name}: singular constraint Jacobian at the reference pose '
                '(redundant or locked joints, or the independent coordinates cannot drive '
                'the mechanism)'
            )
        # ∂q_dep/∂q_ind at the reference pose: the tangent that predicts a position
        # analysis's start, and the reference of the toggle check (see :meth:`velocities`)
        self._tangent0 = -np.linalg.solve(Cq[:, self.dep], Cq[:, self.ind])
        self.sensitivity0 = float(np.max(np.abs(self._tangent0))) or 1.0
        # C_q,dep⁻¹ on the rows of the rheonomic joints (predictor of a driven position)
        self._drive_rows = np.concatenate(
            [g.rows.ravel() for g in self.joint_groups if g.rheonomic] or [np.zeros(0, dtype=int)]
        )
        E = np.zeros((self.m, self._drive_rows.size))
        E[self._drive_rows, np.arange(self._drive_rows.size)] = 1.0
        self._drive_tangent0 = np.linalg.solve(Cq[:, self.dep], E)

    # ---------------------------------------------------------------- run-time values
    def extend(self, q: np.ndarray) -> np.ndarray:
        """Body coordinates or velocities ``q`` (N, n) with the ground's zeros appended,
        (N, nb + 1, 3): what the element groups (:attr:`joint_groups`,
        :attr:`force_groups`) take as ``qe`` and ``qde``."""
        N = q.shape[0]
        qe = np.zeros((N, self.n + 3))
        qe[:, : self.n] = q
        return qe.reshape(N, self.nb + 1, 3)

    _ext = extend

    def force_element(self, name: str) -> tuple[int, int]:
        """Where the force element (or load) ``name`` is: its group's index in
        :attr:`force_groups` and its index in that group (ValueError if there is none)."""
        where = self._force_group.get(name)
        if where is None:
            raise ValueError(
                f'{self.mechanism.name}: no force element {name!r} (force elements: '
                f'{self.force_names})'
            )
        return where

    def _drives(self, motion: Motion | None, N: int) -> list[np.ndarray | None]:
        """Per joint group: its run-time drive values (see ``JointGroup.drive``), or None
        (a rheonomic joint then holds its reference)."""
        out: list[np.ndarray | None] = [None] * len(self.joint_groups)
        if not motion:
            return out
        unknown = sorted(set(motion) - set(self.prescribed))
        if unknown:
            raise ValueError(
                f'{self.mechanism.name}: motion given for {unknown}, which are '
                f'not prescribed joints (prescribed: {self.prescribed})'
            )
        for gi, g in enumerate(self.joint_groups):
            if g.rheonomic and any(name in motion for name in g.names):
                out[gi] = g.drive([motion.get(name) for name in g.names], N)
        return out

    @staticmethod
    def _subset(drives: list[np.ndarray | None], rows: np.ndarray) -> list[np.ndarray | None]:
        return [None if d is None else d[:, rows] for d in drives]

    def _nu(self, drives: list[np.ndarray | None], N: int) -> np.ndarray | None:
        """``ν = -C_t`` (N, m), or None when nothing moves by prescription."""
        if all(d is None for d in drives):
            return None
        nu = np.zeros((N, self.m))
        for g, d in zip(self.joint_groups, drives):
            if d is not None:
                nu[:, g.rows] = g.velocity_term(d)
        return nu

    def force_values(
        self, N: int, loads: np.ndarray | None, params: Params | None, only: int | None = None
    ) -> list[dict[str, np.ndarray] | None]:
        """The run-time values of N states per force group (order :attr:`force_groups`):
        each parameter's values (N, ne), the file's unless given by the load magnitudes
        ``loads`` (N, n_loads) or ``params`` (see :meth:`generalized_forces`); None for a
        group whose values are all zero (it applies no force). ``only``: that group's
        entry alone (the others None). What :meth:`applied_forces` takes."""
        given: dict[int, dict[str, list]] = {}
        for name, vals in (params or {}).items():
            if name not in self._force_group:
                raise ValueError(
                    f'{self.mechanism.name}: params given for {name!r}, which is '
                    f'not a force element (force elements: {self.force_names})'
                )
            gi, k = self._force_group[name]
            for p, val in vals.items():
                if p not in self.force_groups[gi].parameters:
                    raise ValueError(
                        f'{self.mechanism.name}: force element {name!r} has no '
                        f'parameter {p!r} (parameters: '
                        f'{", ".join(self.force_groups[gi].parameters)})'
                    )
                given.setdefault(gi, {}).setdefault(p, []).append((k, val))
        out: list[dict[str, np.ndarray] | None] = [None] * len(self.force_groups)
        for gi, g in enumerate(self.force_groups):
            if only is not None and gi != only:
                continue
            from_loads = loads is not None and gi in self._load_columns
            if gi not in given and not from_loads and g.all_zero:
                continue
            values = {}
            mine = given.get(gi, {})
            for p, v in g.defaults.items():
                if from_loads and p == 'magnitude':
                    values[p] = np.asarray(loads, dtype=float)[:, self._load_columns[gi]]
                else:
                    values[p] = a = np.empty((N, v.size))
                    if len(mine.get(p, ())) < v.size:  # (all given: no defaults left)
                        a[...] = v
            for p, items in given.get(gi, {}).items():
                a = values[p]
                for k, val in items:
                    val = np.asarray(val, dtype=float)
                    a[:, k] = val if val.shape in ((), (N,)) else np.broadcast_to(val, (N,))
            out[gi] = values
        return out

    # ---------------------------------------------------------------- kinematics
    def constraints(self, q: np.ndarray, motion: Motion | None = None) -> np.ndarray:
        """Position constraints ``C(q, t)``, shape (N, m)."""
        return self._constraints(self._ext(q), self._drives(motion, q.shape[0]))

    def _constraints(self, qe: np.ndarray, drives: list[np.ndarray | None]) -> np.ndarray:
        C = np.empty((qe.shape[0], self.m))
        for g, d in zip(self.joint_groups, drives):
            C[:, g.rows] = g.residual(qe, d)
        return C

    def constraint_jacobian(self, q: np.ndarray) -> np.ndarray:
        """``C_q``, shape (N, m, n)."""
        return self._jacobian(self._ext(q))

    def _jacobian(self, qe: np.ndarray, blocks: list[np.ndarray] | None = None) -> np.ndarray:
        """Assemble ``C_q`` (N, m, n) from the groups' blocks (computed unless given)."""
        N = qe.shape[0]
        Cq = np.zeros((N, self.m * 3 * (self.nb + 1)))
        for i, g in enumerate(self.joint_groups):
            J = g.jacobian(qe) if blocks is None else blocks[i]
            Cq[:, g.flat] = J.reshape(N, -1)
        return Cq.reshape(N, self.m, -1)[:, :, : self.n]

    def _analysis(
        self, q: np.ndarray, drives: list[np.ndarray | None]
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """``C`` (N, m) and ``C_q`` (N, m, n) at ``q`` (N, n) at once (the position
        analysis' Newton iterations): what :meth:`constraints` and
        :meth:`constraint_jacobian` give, the coincidence joints evaluated together (and
        their pool, see :meth:`_gamma_all`)."""
        N = q.shape[0]
        co = self._coincidences
        if co is None:
            Cq = np.zeros((N, self.m * self.n))
            v = None
        else:
            v = co.pool(q)
            Cq = co.jacobian(v)
            if self._all_coincident:
                return co.residual(v), Cq.reshape(N, self.m, self.n), v
        C = np.empty((N, self.m))
        if co is not None and v is not None:
            C[:, co.rows] = co.residual(v)
        qe = self._ext(q)
        for gi, g in self._others:
            Cg, J = g.residual_jacobian(qe, drives[gi])
            C[:, g.row_index] = Cg.reshape(N, -1)
            Cq[:, g.flat_mn] = J.reshape(N, -1).take(g.flat_keep, axis=1)
        return C, Cq.reshape(N, self.m, self.n), v

    def _gamma_all(
        self,
        q: np.ndarray,
        qd: np.ndarray,
        drives: list[np.ndarray | None],
        qe: np.ndarray | None = None,
        qde: np.ndarray | None = None,
        pool: np.ndarray | None = None,
    ) -> np.ndarray:
        """:meth:`gamma` with the coincidence joints evaluated together (``qe``, ``qde``:
        :meth:`_ext` of ``q`` and ``qd``; ``pool``: the coincidence joints' at ``q``, if the
        caller has them)."""
        co = self._coincidences
        qde = self._ext(qd) if qde is None else qde
        if co is None:
            return self._gamma(self._ext(q) if qe is None else qe, qde, drives)
        gc = co.gamma(co.pool(q) if pool is None else pool, qde)
        if self._all_coincident:
            return gc
        qe = self._ext(q) if qe is None else qe
        N = q.shape[0]
        g = np.empty((N, self.m))
        g[:, co.rows] = gc
        for gi, grp in self._others:
            g[:, grp.row_index] = grp.gamma(qe, qde, drives[gi]).reshape(N, -1)
        return g

    def constraint_rate(
        self,
        q: np.ndarray,
        qd: np.ndarray,
        motion: Motion | None = None,
        Cq: np.ndarray | None = None,
    ) -> np.ndarray:
        """``Ċ = C_q q̇ - ν`` (N, m); zero at consistent velocities."""
        Cdot = np.einsum('nij,nj->ni', self.constraint_jacobian(q) if Cq is None else Cq, qd)
        nu = self._nu(self._drives(motion, q.shape[0]), q.shape[0])
        return Cdot if nu is None else Cdot - nu

    def gamma(
        self,
        q: np.ndarray,
        qd: np.ndarray,
        motion: Motion | None = None,
        *,
        qe: np.ndarray | None = None,
        qde: np.ndarray | None = None,
        pool: np.ndarray | None = None,
    ) -> np.ndarray:
        """Right-hand side of the acceleration constraints ``γ = -(C_q q̇)_q q̇ - C_tt``,
        (N, m). A caller that has them may pass :meth:`extend` of ``q`` and ``q̇`` and the
        coincidence joints' pool at ``q`` (:meth:`analyse_positions`): the coincidence
        joints are then evaluated together, with the same result bit for bit."""
        drives = self._drives(motion, q.shape[0])
        if qe is None and qde is None and pool is None:
            return self._gamma(self._ext(q), self._ext(qd), drives)
        return self._gamma_all(q, qd, drives, qe, qde, pool)

    def _gamma(
        self, qe: np.ndarray, qde: np.ndarray, drives: list[np.ndarray | None]
    ) -> np.ndarray:
        N = qe.shape[0]
        g = np.empty((N, self.m))
        for grp, d in zip(self.joint_groups, drives):
            g[:, grp.row_index] = grp.gamma(qe, qde, d).reshape(N, -1)
        return g

    def marker_positions(self, q: np.ndarray) -> np.ndarray:
        """Global positions of all markers, (N, n_markers, 2)."""
        qb, _, _, arm = self._markers.state(self._ext(q))
        return qb[..., :2] + arm

    def marker_velocities(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """Global velocities of all markers, (N, n_markers, 2)."""
        arm = perp(self._markers.arms(self._ext(q)))
        vb = gather(self._ext(qd), self._markers.coords)
        return vb[..., :2] + arm * vb[..., 2, None]

    def marker_accelerations(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """Global accelerations of all markers, ``r̈ + B u φ̈ - A u φ̇²``, (N, n_markers, 2)."""
        arm = self._markers.arms(self._ext(q))
        w = gather(self._ext(qd), self._markers.phi)
        ab = gather(self._ext(qdd), self._markers.coords)
        return ab[..., :2] + perp(arm) * ab[..., 2, None] - arm * w[..., None] ** 2

    def marker_reference(self) -> np.ndarray:
        """Marker positions at the reference pose, (n_markers, 2)."""
        return self.marker_positions(self.q0[None])[0]

    # ---------------------------------------------------------------- forces
    def point_force(self, q: np.ndarray, body: int, u: np.ndarray, force: np.ndarray) -> np.ndarray:
        """Generalized force of global ``force`` (N, 2) at body point ``u`` (body axes)."""
        N = q.shape[0]
        Q = np.zeros((N, self.n))
        phi = q[:, 3 * body + 2]
        arm = perp(rot_apply(phi, u))
        Q[:, 3 * body : 3 * body + 2] = force
        Q[:, 3 * body + 2] = np.sum(arm * force, axis=-1)
        return Q

    def generalized_forces(
        self,
        q: np.ndarray,
        loads: np.ndarray | None = None,
        qd: np.ndarray | None = None,
        params: Params | None = None,
    ) -> np.ndarray:
        """``Q = F_e`` (N, n): gravity plus every force element, with the point loads'
        magnitudes ``loads`` (N, n_loads; order :attr:`load_names`) and ``params``.
        ``qd`` is needed when a damper has non-zero damping. An element whose parameters
        are all zero contributes nothing and is skipped."""
        values = self.force_values(q.shape[0], loads, params)
        if all(v is None for v in values):
            return self.applied_forces(q, None, None, values)[0]
        return self.applied_forces(q, self._ext(q), None if qd is None else self._ext(qd), values)[
            0
        ]

    def applied_forces(
        self,
        q: np.ndarray,
        qe: np.ndarray | None,
        qde: np.ndarray | None,
        values: list[dict[str, np.ndarray] | None],
        geometry: dict | None = None,
    ) -> tuple[np.ndarray, list]:
        """:meth:`generalized_forces` ``Q`` (N, n) from the groups' :meth:`force_values`
        (``qe``, ``qde``: :meth:`extend` of ``q`` and ``q̇``), and what each group computed
        on the way (:meth:`~suspopt.multibody.elements.base.ForceGroup.forces`: a spring
        group's ``tension``; None for a group without force); ``geometry``: groups'
        ``geometry(qe)`` by group index, if the caller has them."""
        N = q.shape[0]
        Q = np.zeros((N, self.n))
        if self._gravity_force is not None:
            Q += self._gravity_force
        parts: list = [None] * len(self.force_groups)
        for gi, (grp, v) in enumerate(zip(self.force_groups, values)):
            if v is not None:
                assert qe is not None  # given whenever a group has values
                Qg, parts[gi] = grp.forces(
                    qe, qde, v, None if geometry is None else geometry.get(gi)
                )
                Q += Qg.reshape(N, -1) @ grp.scatter
        return Q, parts

    def spring(
        self,
        name: str,
        q: np.ndarray,
        qd: np.ndarray | None = None,
        params: Params | None = None,
        qdd: np.ndarray | None = None,
    ) -> SpringState:
        """The spring element ``name`` at N states (rate needs ``qd``, ``ℓ̈`` also ``qdd``)."""
        where = self._force_group.get(name)
        grp = None if where is None else self.force_groups[where[0]]
        if where is None or not isinstance(grp, ScalarSpringGroup):
            springs = [
                n for g in self.force_groups if isinstance(g, ScalarSpringGroup) for n in g.names
            ]
            raise ValueError(
                f'{self.mechanism.name}: {name!r} is not a spring element (springs: {springs})'
            )
        gi, k = where
        qe = self._ext(q)
        qde = None if qd is None else self._ext(qd)
        values = self.force_values(q.shape[0], None, params, only=gi)[gi]
        if values is None:  # all zero
            values = {p: np.zeros((q.shape[0], len(grp.names))) for p in grp.parameters}
        geo = grp.geometry(qe)
        return self._spring_state(
            gi,
            k,
            qe,
            qde,
            grp.tension(qe, qde, values, geo),
            grp.directions(qe, geo)[:, k],
            qdd,
            geo,
        )

    def _spring_state(
        self,
        gi: int,
        k: int,
        qe: np.ndarray,
        qde: np.ndarray | None,
        tension: tuple[np.ndarray, ...],
        direction: np.ndarray,
        qdd: np.ndarray | None = None,
        geometry=None,
    ) -> SpringState:
        """:meth:`spring` from its group's :meth:`~ScalarSpringGroup.tension` and the
        element's line of action (N, 2, 2)."""
        grp = self.force_groups[gi]
        assert isinstance(grp, ScalarSpringGroup)  # only springs have a spring state
        ell, ell_d, f, grad = tension
        acc = np.full(qe.shape[0], np.nan)
        if qdd is not None and qde is not None:
            acc = (grp.rate(grad, self._ext(qdd)) + grp.quadratic(qe, qde, geometry))[:, k]
        return SpringState(
            length=ell[:, k],
            deflection=ell[:, k] - grp.free_length[k],
            rate=ell_d[:, k],
            acceleration=acc,
            force=f[:, k],
            direction=direction,
            end_forces=f[:, k, None, None] * direction,
            bodies=(self._name(grp.bodies[k, 0]), self._name(grp.bodies[k, 1])),
        )

    def _name(self, index: int) -> str:
        return GROUND if index == self.nb else self.body_names[index]

    # ---------------------------------------------------------------- dynamics
    def solve_augmented(
        self,
        q: np.ndarray,
        qd: np.ndarray,
        Q: np.ndarray,
        baumgarte: tuple[float, float] | None = None,
        Cq: np.ndarray | None = None,
        method: str = 'partitioned',
        motion: Motion | None = None,
        *,
        gamma: np.ndarray | None = None,
        partition: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Solve eq. 11 for ``q̈`` (N, n) and ``λ`` (N, m), batched over N states
        (``Cq``: the constraint Jacobian at ``q``, ``gamma``: :meth:`gamma` there and
        ``partition``: :meth:`partition` of ``Cq``, if the caller already has them). The
        methods give the same solution of the same system, by different eliminations:

        ``'partitioned'`` (default): with ``C_q,dep⁻¹`` of the coordinate partitioning,
        ``q̈ = V q̈_ind + G`` satisfies the constraint rows for any ``q̈_ind`` (``V = [T; I]``,
        the tangent ``T = -C_q,dep⁻¹ C_q,ind``, ``G = [C_q,dep⁻¹ γ; 0]``); ``Vᵀ`` times
        the force rows (``Vᵀ C_qᵀ = 0``) gives ``(Vᵀ M V) q̈_ind = Vᵀ (Q - M G)``, a
        dof × dof system, and their dependent rows ``λ = C_q,dep⁻ᵀ (Q - M q̈)_dep``. One
        inversion per pose (shared with the velocity analysis, :meth:`partition`),
        then products only: the finite differences query each pose many times.
        ``'schur'``: ``(C_q M⁻¹ C_qᵀ) λ = C_q M⁻¹ Q - γ``, then ``q̈ = M⁻¹ (Q - C_qᵀ λ)``
        (an m × m factorization per query, M being diagonal).
        ``'dense'``: factorizes the assembled (n + m) × (n + m) matrix itself."""
        self.calls['augmented'] += 1
        if Cq is None:
            Cq = self.constraint_jacobian(q)
        rhs_c = self.gamma(q, qd, motion) if gamma is None else gamma
        return self._augmented(q, qd, Q, Cq, rhs_c, baumgarte, method, motion, partition)

    def _augmented(
        self, q, qd, Q, Cq, rhs_c, baumgarte=None, method='partitioned', motion=None, partition=None
    ):
        """:meth:`solve_augmented` given ``C_q`` and ``γ`` (and :meth:`partition` of
        ``C_q``, if the caller has it)."""
        N, n, m = q.shape[0], self.n, self.m
        if baumgarte is not None:
            alpha, beta = baumgarte
            rhs_c = (
                rhs_c
                - 2.0 * alpha * self.constraint_rate(q, qd, motion, Cq)
                - beta**2 * self.constraints(q, motion)
            )
        what = 'augmented system (eq. 11)'
        if method == 'partitioned':
            Cinv, T = self.partition(Cq) if partition is None else partition
            g = np.einsum('nij,nj->ni', Cinv, rhs_c)
            m_dep, Q_dep = self._mass_dep, Q[:, self.dep]
            f_dep = Q_dep - m_dep * g  # (Q - M G)_dep
            if self.dof == 1:
                t = T[:, :, 0]
                i = self._ind0
                qdd_ind = (
                    (Q[:, i] + np.einsum('ni,ni->n', t, f_dep))
                    / (self.mass_diag[i] + (t * t) @ m_dep)
                )[:, None]
                qdd_dep = t * qdd_ind + g
            else:
                Mr = np.einsum('nji,j,njk->nik', T, m_dep, T)
                Mr[:, np.arange(self.dof), np.arange(self.dof)] += self.mass_diag[self.ind]
                qdd_ind = _batched_solve(
                    Mr, Q[:, self.ind] + np.einsum('nji,nj->ni', T, f_dep), what
                )
                qdd_dep = np.einsum('nij,nj->ni', T, qdd_ind) + g
            qdd = np.empty((N, n))
            qdd[:, self.ind] = qdd_ind
            qdd[:, self.dep] = qdd_dep
            lam = np.einsum('nji,nj->ni', Cinv, Q_dep - m_dep * qdd_dep)
            if not np.isfinite(np.add.reduce(lam, axis=None)):
                _finite(Cq, np.concatenate([Q, rhs_c], axis=1), what)
            return qdd, lam
        if method == 'schur':
            CMi = Cq * self._inv_mass
            lam = _batched_solve(
                CMi @ Cq.transpose(0, 2, 1), np.einsum('nij,nj->ni', CMi, Q) - rhs_c, what
            )
            return (Q - np.einsum('nji,nj->ni', Cq, lam)) / self.mass_diag, lam
        if method != 'dense':
            raise ValueError(f"method must be 'partitioned', 'schur' or 'dense', got {method!r}")
        A = np.zeros((N, n + m, n + m))
        A[:, :n, :n] = self.M
        A[:, :n, n:] = Cq.transpose(0, 2, 1)
        A[:, n:, :n] = Cq
        b = np.concatenate([Q, rhs_c], axis=1)
        x = _batched_solve(A, b, what)
        return x[:, :n], x[:, n:]

    def partition(self, Cq: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``C_q,dep⁻¹`` (N, m, m) and the tangent ``T = ∂q_dep/∂q_ind = -C_q,dep⁻¹ C_q,ind``
        (N, m, dof) at a pose (``C_q`` (N, m, n)): the velocity analysis and eq. 11 as
        products (:meth:`velocities` and :meth:`solve_augmented` take it as
        ``partition``). One inversion per pose; a read-only ``C_q`` equal to one of the last
        :data:`KEPT_POSES` read-only ones gets theirs (:attr:`partitions`), bit for bit as
        computed afresh."""
        known = self.partitions.get(Cq)
        if known is not None:
            return known  # type: ignore[return-value]
        try:
            Cinv = _lapack_inv(Cq.take(self.dep, 2))
        except np.linalg.LinAlgError:
            _finite(Cq, Cq[:, :, 0], 'constraint Jacobian')
            raise MultibodyError(
                'singular constraint Jacobian C_q,dep: the mechanism is in a singular configuration'
            ) from None
        i = self._ind0
        C_ind = Cq[:, :, i : i + 1] if self.dof == 1 else Cq.take(self.ind, 2)
        T = -(Cinv @ C_ind)  # (a non-finite C_q: found by the users of T)
        self.calls['factorizations'] += 1
        return self.partitions.put(Cq, (Cinv, T))  # type: ignore[return-value]

    _partition = partition

    def reactions(
        self, q: np.ndarray, lam: np.ndarray, jacobians: tuple[np.ndarray, ...] | None = None
    ) -> np.ndarray:
        """What every joint (the mechanism's, then the fixed bodies' welds, order
        :attr:`joint_names`) applies on each of its bodies (:attr:`joint_bodies`; a
        prescribed joint has one): (N, n_joints, 2, 3) = force (x, z) and torque about
        that body's CG (about the origin for the ground), ``-(∂C_k/∂q_b)ᵀ λ_k``
        (``jacobians``: :meth:`joint_jacobians` at ``q``, if the caller has them)."""
        out = np.zeros((q.shape[0], len(self.joint_names), 2, 3))
        if jacobians is None:
            jacobians = self.joint_jacobians(q)
        for g, jac in zip(self.joint_groups, jacobians):
            out[:, g.members, : g.n_bodies] = g.reactions(None, lam[:, g.rows], jac)
        return out

    def joint_jacobians(self, q: np.ndarray) -> tuple[np.ndarray, ...]:
        """Each joint group's Jacobian blocks ``∂C/∂q_b`` at ``q`` (N, ne, S, k, 3), in the
        order of :attr:`joint_groups`: what :meth:`reactions` takes as ``jacobians`` (a
        caller querying one pose again keeps them)."""
        qe = self._ext(q)
        return tuple(g.jacobian(qe) for g in self.joint_groups)

    def joint_reactions(self, lam: np.ndarray, q: np.ndarray | None = None) -> np.ndarray:
        """Force each of the mechanism's joints applies on its first body, global axes,
        (N, n_joints, 2) (for a revolute joint ``-λ_k``; ``+λ_k`` acts on the second body).

        Joints whose force direction turns with the bodies (prismatic) need the positions
        ``q``; for the others the force follows from ``λ`` alone."""
        if q is None:
            moving = [
                n for g in self.joint_groups if not g.constant_force_jacobian for n in g.names
            ]
            if moving:
                raise ValueError(
                    f'{self.mechanism.name}: the reactions of {moving} depend on the pose: pass q'
                )
        out = -(lam @ self._first_force_T).reshape(lam.shape[0], self.nj, 2)
        if q is not None and self._moving_force:
            qe = self._ext(q)
            for g, mine in self._moving_force:
                out[:, g.members[mine]] = g.reactions(qe, lam[:, g.rows])[:, mine, 0, :2]
        return out

    def body_reaction(
        self,
        body: str,
        q: np.ndarray,
        lam: np.ndarray,
        point: ArrayLike | None = None,
        joints: list[str] | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Total force (N, 2) and torque (N,) that the joints attached to ``body`` (or the
        ground; only those in ``joints`` if given) apply on it, the torque about the
        global ``point`` ((2,) or (N, 2); default: the body's CG, the origin for the
        ground)."""
        if body not in self.body_names + [GROUND]:
            raise ValueError(f'{self.mechanism.name}: unknown body {body!r}')
        chosen = self.joint_names if joints is None else joints
        unknown = sorted(set(chosen) - set(self.joint_names))
        if unknown:
            raise ValueError(f'{self.mechanism.name}: unknown joints {unknown}')
        R = self.reactions(q, lam)
        F = np.zeros((q.shape[0], 2))
        M = np.zeros(q.shape[0])
        for k, name in enumerate(self.joint_names):
            for s, b in enumerate(self.joint_bodies[k]):
                if b == body and name in chosen:
                    F += R[:, k, s, :2]
                    M += R[:, k, s, 2]
        if point is not None:
            cg = self._ext(q)[:, self.nb if body == GROUND else self.body_names.index(body), :2]
            M = M + cross(cg - np.asarray(point, dtype=float), F)
        return F, M

    def kinetic_energy(self, qd: np.ndarray) -> np.ndarray:
        return 0.5 * np.sum(self.mass_diag * qd**2, axis=-1)

    def potential_energy(self, q: np.ndarray, params: Params | None = None) -> np.ndarray:
        """Gravity plus spring potential energy ``½ k (ℓ - ℓ0)²`` (N,)."""
        g = np.asarray(self.mechanism.gravity, dtype=float)
        q3 = q.reshape(q.shape[0], self.nb, 3)
        m = self.mass_diag.reshape(self.nb, 3)[:, 0]
        V = -np.sum(m * (q3[:, :, 0] * g[0] + q3[:, :, 1] * g[1]), axis=-1)
        qe = self._ext(q)
        for grp, v in zip(self.force_groups, self.force_values(q.shape[0], None, params)):
            if v is not None:
                V = V + np.sum(grp.potential(qe, v), axis=-1)
        return V

    # ---------------------------------------------------------------- partitioning
    def positions(
        self, q_ind: np.ndarray, guess: np.ndarray | None = None, motion: Motion | None = None
    ) -> np.ndarray:
        """All coordinates (N, n) consistent with the independent ones (N, dof): Newton on
        ``C(q) = 0`` for the dependent coordinates, from ``guess``, else from the pose table
        inside a suspension's travel range (:meth:`_pose_table`: converged already), else
        from the reference pose moved along its tangent (a first-order prediction).

        Each state iterates until its own ``max |C| < newton_tol`` and is then left alone,
        so a state's result depends on its own inputs and start only (a state that starts
        converged comes back bit for bit, whatever the others do)."""
        self.calls['positions'] += 1
        q_ind = np.asarray(q_ind, dtype=float)
        return self._positions(q_ind, guess, self._drives(motion, q_ind.shape[0]))

    def _analysed_positions(
        self, q_ind: np.ndarray, guess: np.ndarray | None = None, motion: Motion | None = None
    ):
        """:meth:`analyse_positions` as a tuple ``(q, C_q, max |C|, pool)``."""
        self.calls['positions'] += 1
        q_ind = np.asarray(q_ind, dtype=float)
        return self._positions(q_ind, guess, self._drives(motion, q_ind.shape[0]), full=True)

    def analyse_positions(
        self, q_ind: np.ndarray, guess: np.ndarray | None = None, motion: Motion | None = None
    ) -> PositionAnalysis:
        """:meth:`positions` and what its last Newton iteration found at the result: the
        constraint Jacobian (what :meth:`constraint_jacobian` gives), each state's
        ``max |C|`` (of :meth:`constraints`) and the coincidence joints' pool (what
        :meth:`gamma` may take)."""
        q, Cq, residual, pool = self._analysed_positions(q_ind, guess, motion)
        return PositionAnalysis(q=q, Cq=Cq, residual=residual, pool=pool)

    def _positions(
        self,
        q_ind: np.ndarray,
        guess: np.ndarray | None,
        drives: list[np.ndarray | None],
        full: bool = False,
    ):
        """:meth:`positions`; with ``full``, also ``C_q`` (N, m, n), ``max |C|`` (N,) and
        the coincidence joints' pool (or None) of each state at its result, from its last
        Newton iteration (what :meth:`constraint_jacobian` and :meth:`constraints` give
        there)."""
        if not np.logical_and.reduce(np.isfinite(q_ind), axis=None):
            raise MultibodyError(f'{self.mechanism.name}: non-finite independent coordinate')
        N = q_ind.shape[0]
        driven = any(d is not None for d in drives)
        if guess is None and not driven and self._pose_spline is None:
            travel = self.mechanism.travel
            self._pose_spline = (
                False
                if self._travel_poses is None or travel is None or self.dof != 1
                else self._pose_table(travel, self._travel_poses) or False
            )
        if guess is None and not driven and self._pose_spline is not False:
            assert self._pose_spline is not None  # made just above
            # the pose table where it has the pose, the reference's tangent elsewhere
            q = np.array(np.broadcast_to(self.q0, (N, self.n)))
            table = self._pose_spline(q_ind[:, 0])
            outside = np.isnan(table[:, 0])
            if outside.any():
                table[outside] = (
                    self.q0[self.dep] + (q_ind[outside] - self.q0[self.ind]) @ self._tangent0.T
                )
            q[:, self.dep] = table
        elif guess is None:  # the reference pose moved along its tangent
            q = np.array(np.broadcast_to(self.q0, (N, self.n)))
            q[:, self.dep] += (q_ind - self.q0[self.ind]) @ self._tangent0.T
            if driven:  # and along the drives' (-C_q,dep⁻¹ C)
                q0e = self._ext(self.q0[None].repeat(N, 0))
                C0 = [
                    g.residual(q0e, d).reshape(N, -1)
                    for g, d in zip(self.joint_groups, drives)
                    if g.rheonomic
                ]
                q[:, self.dep] -= np.concatenate(C0, axis=1) @ self._drive_tangent0.T
        else:
            q = guess.copy()
        q[:, self.ind] = q_ind
        # the states still iterating (None: all of them). A small batch iterates as a
        # whole, its converged states held where they are (a zero step); a large one
        # iterates only the states still open
        todo = None
        small = N <= SMALL_BATCH
        # (full) C_q, max |C| and pool of the states converged so far
        out: tuple[np.ndarray, np.ndarray, np.ndarray | None] | None = None

        def keep(done):  # (full) the states ``done`` of this iteration end here
            nonlocal out
            if out is None:
                out = (
                    np.empty((N, self.m, self.n)),
                    np.empty(N),
                    None if pool is None else np.empty((N, pool.shape[1])),
                )
            idx = np.flatnonzero(done) if todo is None else todo[done]
            out_Cq, out_err, out_pool = out
            out_Cq[idx] = Cq[done]
            out_err[idx] = err[done]
            if pool is not None and out_pool is not None:
                out_pool[idx] = pool[done]

        for it in range(self.newton_max_iter + 1):
            qa = q if todo is None else q[todo]
            C, Cq, pool = self._analysis(qa, drives if todo is None else self._subset(drives, todo))
            err = np.maximum.reduce(np.abs(C), axis=1, initial=0.0)
            open_ = err >= self.newton_tol
            n_open = np.count_nonzero(open_)
            if not n_open:
                if todo is None:
                    return (q, Cq, err, pool) if full else q
                if full:
                    keep(~open_)
                    assert out is not None  # kept just now
                    return (q, *out)
                return q
            if it == self.newton_max_iter:
                break
            step = None
            if n_open < qa.shape[0]:
                if small:
                    try:
                        step = _batched_solve(Cq.take(self.dep, 2), C, 'position analysis C(q) = 0')
                    except MultibodyError:  # singular at a converged state
                        small = False
                    else:
                        step[~open_] = 0.0
                if not small:
                    if full:
                        keep(~open_)
                    todo = np.flatnonzero(open_) if todo is None else todo[open_]
                    qa, C, Cq = qa[open_], C[open_], Cq[open_]
            if step is None:
                step = _batched_solve(Cq.take(self.dep, 2), C, 'position analysis C(q) = 0')
            if todo is None:
                q[:, self.dep] -= step
            else:
                q[np.ix_(todo, self.dep)] = qa[:, self.dep] - step
        worst = float(np.max(np.abs(self._constraints(self._ext(q), drives))))
        raise MultibodyError(
            f'{self.mechanism.name}: position analysis did not converge in '
            f'{self.newton_max_iter} Newton iterations (max |C| = {worst:.2e}); the '
            "independent coordinate is out of the mechanism's range"
        )

    def velocities(
        self,
        q: np.ndarray,
        qd_ind: np.ndarray,
        Cq: np.ndarray | None = None,
        max_sensitivity: float | None = None,
        motion: Motion | None = None,
        partition: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> np.ndarray:
        """All velocities (N, n) from the independent ones: ``C_q q̇ = ν``, as
        ``q̇_dep = T q̇_ind + C_q,dep⁻¹ ν`` with the tangent ``T = ∂q_dep/∂q_ind =
        -C_q,dep⁻¹ C_q,ind`` (:meth:`partition` of ``C_q``, computed unless given: a new
        rate at a known pose is products only).

        With ``max_sensitivity``, a state where some dependent coordinate moves more than
        that many times faster per unit of independent motion than at the reference pose
        (the largest ``|T|``) is a :class:`MultibodyError`: the mechanism is at or near a
        singular (toggle) position, the edge of its range of motion, where its dynamics
        have no finite solution."""
        N = q.shape[0]
        qd = np.zeros_like(q)  # q's memory order (what einsum on qd sums in)
        if Cq is None:
            Cq = self.constraint_jacobian(q)
        qd[:, self.ind] = qd_ind
        Cinv, T = self.partition(Cq) if partition is None else partition
        if max_sensitivity is not None:
            ratio = np.maximum.reduce(np.abs(T).reshape(N, -1), axis=1) / self.sensitivity0
            if np.maximum.reduce(ratio) > max_sensitivity:
                worst = int(ratio.argmax())
                raise MultibodyError(
                    f'{self.mechanism.name}: near a singular (toggle) position at independent '
                    f'coordinate(s) {np.round(q[worst, self.ind], 6).tolist()}: the linkage '
                    f'moves {ratio[worst]:.3g} times faster than at its reference pose; this '
                    'is the edge of its range of motion'
                )
        if self.dof == 1:
            qd_dep = T[:, :, 0] * qd[:, self._ind0, None]
        else:
            qd_dep = np.einsum('nij,nj->ni', T, qd[:, self.ind])
        nu = self._nu(self._drives(motion, N), N) if motion else None
        if nu is not None:
            qd_dep = qd_dep + np.einsum('nij,nj->ni', Cinv, nu)
        if not np.isfinite(np.add.reduce(qd_dep, axis=None)):  # T is finite
            raise MultibodyError('non-finite value in the velocity analysis')
        qd[:, self.dep] = qd_dep
        return qd

    def accelerations(
        self,
        q: np.ndarray,
        qd: np.ndarray,
        qdd_ind: np.ndarray,
        Cq: np.ndarray | None = None,
        motion: Motion | None = None,
    ) -> np.ndarray:
        """Acceleration analysis: all accelerations (N, n) from the independent ones,
        ``C_q q̈ = γ`` at consistent positions and velocities (no forces involved)."""
        qdd = np.zeros_like(q)
        qdd[:, self.ind] = qdd_ind
        if Cq is None:
            Cq = self.constraint_jacobian(q)
        rhs = self.gamma(q, qd, motion) - np.einsum(
            'nij,nj->ni', Cq[:, :, self.ind], qdd[:, self.ind]
        )
        qdd[:, self.dep] = _batched_solve(Cq[:, :, self.dep], rhs, 'acceleration analysis')
        return qdd

    def consistent_state(
        self,
        q_ind: np.ndarray,
        qd_ind: np.ndarray,
        guess: np.ndarray | None = None,
        motion: Motion | None = None,
    ) -> MultibodyState:
        """Consistent positions and velocities from the independent coordinates and rates."""
        q = self.positions(np.atleast_2d(q_ind), guess, motion)
        Cq = self.constraint_jacobian(q)
        return MultibodyState(
            q=q, qd=self.velocities(q, np.atleast_2d(qd_ind), Cq, motion=motion), Cq=Cq
        )

    def dynamics(
        self,
        q_ind: np.ndarray,
        qd_ind: np.ndarray,
        loads: np.ndarray | None,
        guess: np.ndarray | None = None,
        motion: Motion | None = None,
        params: Params | None = None,
    ) -> MultibodyState:
        """Everything at N states given by independent coordinates, rates, load magnitudes,
        prescribed motion and force parameters."""
        st = self.consistent_state(q_ind, qd_ind, guess, motion)
        Q = self.generalized_forces(st.q, loads, st.qd, params)
        st.qdd, st.lam = self.solve_augmented(st.q, st.qd, Q, Cq=st.Cq, motion=motion)
        return st

    # ---------------------------------------------------------------- checks
    def _check_travel(self, travel: tuple[float, float]) -> dict[float, np.ndarray]:
        """The linkage passes its wheel travel range (the single independent coordinate,
        from the reference pose) without locking: position analysis by continuation in
        :data:`TRAVEL_STEPS` steps each way, each started from the last pose moved along
        its tangent. It locks where Newton's method fails, where the linkage moves more
        than :data:`TOGGLE_SENSITIVITY` times faster than at its reference pose (a toggle,
        see :meth:`velocities`), or where the converged pose is farther from the
        prediction than the predicted step itself (no nearby pose: Newton found another
        assembly). A ConfigError names the travel step and the joints that lock. Returns
        the poses visited, by wheel travel."""
        none: list[np.ndarray | None] = [None] * len(self.joint_groups)
        ind0 = self.q0[self.ind]
        visited = {0.0: self.q0}
        for end in (travel[1], travel[0]):
            q, qd = self.q0[None], self.velocities(self.q0[None], np.ones((1, 1)))
            zs = np.linspace(0.0, end, TRAVEL_STEPS + 1)
            for z, dz in zip(zs[1:], np.diff(zs)):
                step = qd * dz
                try:
                    q_new = self._positions(np.array([ind0 + z]), q + step, none)
                    if np.max(np.abs(q_new - q - step)) > np.max(np.abs(step)):
                        raise MultibodyError(
                            'no pose near the last one: the end of its range of motion'
                        )
                    qd = self.velocities(q_new, np.ones((1, 1)), max_sensitivity=TOGGLE_SENSITIVITY)
                except MultibodyError as err:
                    raise ConfigError(
                        f'{self.mechanism.name}: suspension.travel: the linkage locks between '
                        f'wheel travel {z - dz:+.4g} and {z:+.4g} m, inside its travel range '
                        f'[{travel[0]:g}, {travel[1]:g}] m (joints {self._locking_joints(q)}): '
                        + str(err).removeprefix(f'{self.mechanism.name}: ')
                    ) from None
                q = q_new
                visited[float(z)] = q[0]
        return visited

    def _pose_table(
        self, travel: tuple[float, float], visited: dict[float, np.ndarray]
    ) -> Callable[[np.ndarray], np.ndarray] | None:
        """The converged poses every :data:`POSE_TABLE_SPACING` of the travel range
        (started from the travel check's poses, interpolated), as a cubic spline of the
        independent coordinate: it predicts a pose there within about the Newton tolerance,
        so a position analysis needs one Newton step fewer, or none. A function of the
        mechanism alone, so every analysis still depends on its own query only."""
        from scipy.interpolate import CubicSpline

        lo, hi = travel
        k = max(4, int(np.ceil((hi - lo) / POSE_TABLE_SPACING)) + 1)
        z = np.linspace(lo, hi, k)
        zv = np.array(sorted(visited))
        qv = np.array([visited[x] for x in zv])
        guess = np.stack([np.interp(z, zv, qv[:, j]) for j in range(self.n)], axis=1)
        ind0 = self.q0[self.ind]
        none: list[np.ndarray | None] = [None] * len(self.joint_groups)
        try:
            q = self._positions(ind0 + z[:, None], guess, none)
            C, Cq, _ = self._analysis(q, none)  # one Newton step more: to the rounding floor
            q[:, self.dep] -= _batched_solve(Cq.take(self.dep, 2), C, 'pose table')
        except MultibodyError:  # the travel check passed step by step; keep the tangent
            return None
        return CubicSpline(ind0[0] + z, q[:, self.dep], axis=0, extrapolate=False)

    def _locking_joints(self, q: np.ndarray) -> list[str]:
        """Joints carrying the left singular vector of ``C_q,dep`` at ``q`` (the
        constraints that become dependent: the loop that locks)."""
        Cd = self.constraint_jacobian(q)[0][:, self.dep]
        y = np.abs(np.linalg.svd(Cd)[0][:, -1])
        return [
            name
            for name, rows in zip(self.joint_names, self.joint_rows)
            if np.max(y[rows], initial=0.0) > 0.1 * np.max(y)
        ]


class ValueCache:
    """Results remembered by the value of the array they were computed from: :meth:`get`
    returns one only for an array equal to its key entry for entry (and in shape and
    dtype), of which the cache keeps its own copy; the :data:`KEPT_POSES` newest are kept.

    Only read-only arrays are remembered (:meth:`put`): those are the ones a caller may
    query again (the suspension module's remembered poses), whereas writable ones are
    scratch values (Newton iterates, a simulator's steps) that would cost a copy each for
    nothing. The answer never depends on the flag: it is the value that is compared, so
    an array changed in place, or a read-only view whose base changed, is computed
    afresh."""

    def __init__(self, size: int = KEPT_POSES):
        self.size = size
        self._entries: list[tuple[np.ndarray, tuple[np.ndarray, ...]]] = []

    def get(self, key: np.ndarray) -> tuple[np.ndarray, ...] | None:
        first = (0,) * (key.ndim - 1)  # its first row: most other keys differ there
        for k, value in self._entries:
            if (
                k.shape == key.shape
                and k.dtype == key.dtype
                and (key.size == 0 or np.array_equal(k[first], key[first]))
                and np.array_equal(k, key)
            ):
                return value
        return None

    def put(self, key: np.ndarray, value: tuple[np.ndarray, ...]) -> tuple[np.ndarray, ...]:
        """``value``, remembered (its arrays made read-only) if ``key`` is read-only."""
        if not key.flags.writeable:
            value = tuple(freeze(a) for a in value)
            self._entries = [(freeze(key.copy()), value), *self._entries[: self.size - 1]]
        return value

    def clear(self) -> None:
        self._entries = []


def freeze(a: np.ndarray) -> np.ndarray:
    """Make ``a`` and every array it is a view of read-only (remembered values, which
    nothing may change); ``a``."""
    b: np.ndarray | None = a
    while isinstance(b, np.ndarray):
        b.flags.writeable = False
        b = b.base
    return a


def frozen(a: np.ndarray) -> bool:
    """Whether ``a`` cannot change: read-only, and so is every array it is a view of."""
    b: np.ndarray | None = a
    while b is not None:
        if b.flags.writeable:
            return False
        b = b.base if isinstance(b.base, np.ndarray) else None
    return True


def _batched_solve(A: np.ndarray, b: np.ndarray, what: str) -> np.ndarray:
    """Solve a batch of small dense systems ``A`` (N, m, m) for right-hand sides ``b``
    (N, m) or (N, m, k); a singular or non-finite one is a MultibodyError."""
    vector = b.ndim != A.ndim
    rhs = b[..., None] if vector else b
    solve = (
        _lapack_solve
        if A.dtype == np.float64 and rhs.dtype == np.float64 and A.ndim == 3
        else np.linalg.solve
    )
    try:
        x = solve(A, rhs)
    except np.linalg.LinAlgError:
        _finite(A, b, what)
        raise MultibodyError(
            f'singular {what}: the mechanism is in a singular configuration'
        ) from None
    # a non-finite input gives a non-finite solution: check the inputs only then
    if not np.isfinite(np.add.reduce(x, axis=None)):
        _finite(A, b, what)
    return x[..., 0] if vector else x


def _finite(A: np.ndarray, b: np.ndarray, what: str) -> None:
    if not (np.isfinite(A).all() and np.isfinite(b).all()):
        raise MultibodyError(f'non-finite value in the {what}')
