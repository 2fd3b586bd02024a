"""What every element type implements, and the planar geometry they share.

Body coordinates ``q = (x, z, φ)`` per body (CG position and angle, paper eq. 11);
``A(φ)`` rotates body axes to global axes. Every method works on a batch of N states and
on all elements of its type at once: coordinates come as ``qe`` (N, nb + 1, 3), the
bodies with the ground appended as a virtual body of zero coordinates, so a point "on the
ground" is simply its global position. Element types never loop over states or elements.

A joint type (:class:`JointGroup`) supplies, for its ``ne`` elements of ``k`` equations:
the residual ``C`` (N, ne, k), the Jacobian blocks ``∂C/∂q_b`` of each connected body
(N, ne, S, k, 3), ``γ = -(C_q q̇)_q q̇ - C_tt`` (N, ne, k) and, if rheonomic,
``ν = -C_t`` (N, ne, k) for the velocity equations ``C_q q̇ = ν``. Reactions need no code
of their own: the generalized constraint force on body b is ``-(∂C/∂q_b)ᵀ λ`` (force and
torque about its CG), see :meth:`JointGroup.reactions`.

A force type (:class:`ForceGroup`) supplies the generalized force on each connected body
(N, ne, S, 3) from ``q``, ``q̇`` and its run-time parameter values (N, ne) per parameter.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from suspopt.curves import SLOTS, SpringDamperUnit
from suspopt.errors import ConfigError
from suspopt.multibody.reading import GROUND

COORDINATES = ('x', 'z', 'phi')


def rot_apply(phi: np.ndarray, u: np.ndarray, u_perp: np.ndarray | None = None) -> np.ndarray:
    """``A(φ) u = cos φ u + sin φ perp(u)`` with broadcasting; ``u`` has a trailing axis of 2
    (``u_perp``: ``perp(u)``, if the caller has it)."""
    if u_perp is None:
        u_perp = u[..., ::-1] * _FLIP
    return np.cos(phi)[..., None] * u + np.sin(phi)[..., None] * u_perp


_FLIP = np.array([-1.0, 1.0])


def perp(v: np.ndarray) -> np.ndarray:
    """``v`` turned by +90°, (x, z) -> (-z, x): ``B(φ) u = dA/dφ u = perp(A(φ) u)``."""
    out = np.empty_like(v)
    out[..., 0] = -v[..., 1]
    out[..., 1] = v[..., 0]
    return out


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Planar cross product ``a_x b_z - a_z b_x`` (a moment about the out-of-plane axis)."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1]


@dataclass(frozen=True)
class Layout:
    """The mechanism as element groups see it: body indices (the ground is index ``nb``),
    reference coordinates ``q0e`` (nb + 1, 3) and markers (body index, point in body axes)."""

    index: dict[str, int]
    q0e: np.ndarray
    markers: dict[str, tuple[int, np.ndarray]]

    def local(self, bodies: np.ndarray, points: np.ndarray) -> np.ndarray:
        """Global reference points (…, 2) on ``bodies`` (…) in body axes."""
        ref = self.q0e[bodies]
        return rot_apply(-ref[..., 2], np.asarray(points, dtype=float) - ref[..., :2])

    def angle0(self, bodies: np.ndarray) -> np.ndarray:
        return self.q0e[bodies, 2]


def flat_index(bodies: np.ndarray, coordinates=(0, 1, 2)) -> np.ndarray:
    """Where ``coordinates`` (0: x, 1: z, 2: φ) of ``bodies`` (…) are in a state's ``qe``
    flattened: (…, len(coordinates))."""
    return 3 * np.asarray(bodies, dtype=int)[..., None] + np.asarray(coordinates, dtype=int)


def gather(qe: np.ndarray, index: np.ndarray) -> np.ndarray:
    """``qe`` (N, nb + 1, 3) flattened per state, at ``index`` (any shape; see
    :func:`flat_index`): (N, *index.shape) in one call."""
    return qe.reshape(qe.shape[0], -1).take(index, axis=1)


class BodyPoints:
    """Points fixed in bodies: ``bodies`` (ne, S) and the points ``u`` (ne, S, 2) in body
    axes, with the index arrays that gather their bodies' coordinates from ``qe`` at once."""

    def __init__(self, bodies: np.ndarray, u: np.ndarray):
        self.bodies = np.asarray(bodies, dtype=int)
        self.u = np.asarray(u, dtype=float)
        self.u_perp = perp(self.u)
        self.phi = 3 * self.bodies + 2  # (ne, S)
        self.coords = flat_index(self.bodies)  # (ne, S, 3)

    def arms(self, qe: np.ndarray) -> np.ndarray:
        """``A(φ) u`` (N, ne, S, 2)."""
        return rot_apply(gather(qe, self.phi), self.u, self.u_perp)

    def state(self, qe: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The bodies' coordinates (N, ne, S, 3), ``cos φ`` and ``sin φ`` (N, ne, S) and the
        arms ``A(φ) u`` (N, ne, S, 2)."""
        qb = gather(qe, self.coords)
        c, s = np.cos(qb[..., 2]), np.sin(qb[..., 2])
        return qb, c, s, c[..., None] * self.u + s[..., None] * self.u_perp


#: ``coincidence_jacobian``: ∂/∂r of both bodies (+I, -I) and the sign of each ∂/∂φ entry
_PM_I = np.array([np.eye(2), -np.eye(2)])
_ARM_SIGN = np.array([[-1.0, 1.0], [1.0, -1.0]])


def coincidence_jacobian(arm: np.ndarray, n_equations: int = 2) -> np.ndarray:
    """Jacobian blocks of ``r_i + A_i u_i - r_j - A_j u_j`` (the first two equations) for
    arms ``A u`` of both bodies (N, ne, 2, 2): (N, ne, 2, n_equations, 3), with
    ``∂/∂r = ±I`` and ``∂/∂φ = ±B u = ±perp(A u)``; further equations' rows are zero."""
    N, ne = arm.shape[:2]
    J = np.zeros((N, ne, 2, n_equations, 3))
    J[:, :, :, :2, :2] = _PM_I
    J[:, :, :, :2, 2] = arm[..., ::-1] * _ARM_SIGN
    return J


class AxisProjection:
    """``ℓ = (A(φ_a) ā)ᵀ (p_b - p_a)``: the distance along a unit axis ``ā`` fixed in body
    a (body axes, (ne, 2)) from point ``u_a`` on a to point ``u_b`` on b, for elements on
    ``bodies`` (ne, 2) = (a, b) with points ``u`` (ne, 2, 2). Its gradient:

        ∂ℓ/∂r_a = -nᵀ,  ∂ℓ/∂φ_a = (B n̄)ᵀ (p_b - r_a),  ∂ℓ/∂r_b = nᵀ,  ∂ℓ/∂φ_b = nᵀ B_b u_b
    """

    def __init__(self, bodies: np.ndarray, u: np.ndarray, axis: np.ndarray):
        self.points = BodyPoints(bodies, u)
        self.axis = np.asarray(axis, dtype=float)
        self.axis_perp = perp(self.axis)

    def geometry(self, qe: np.ndarray):
        """Coordinates of both bodies (N, ne, 2, 3), arms and points of both ends
        (N, ne, 2, 2) and the axis ``n = A(φ_a) ā`` (N, ne, 2)."""
        qb, c, s, arm = self.points.state(qe)
        n = c[:, :, 0, None] * self.axis + s[:, :, 0, None] * self.axis_perp
        return qb, arm, qb[..., :2] + arm, n

    def normal(self, qe: np.ndarray) -> np.ndarray:
        """``n = A(φ_a) ā`` (N, ne, 2)."""
        return rot_apply(gather(qe, self.points.phi[:, 0]), self.axis, self.axis_perp)

    def measure(self, qe: np.ndarray, geometry=None) -> tuple[np.ndarray, np.ndarray]:
        """``ℓ`` (N, ne) and ``∂ℓ/∂q`` of a and b (N, ne, 2, 3) (``geometry``:
        :meth:`geometry` at ``qe``, if the caller has it)."""
        qb, arm, p, n = self.geometry(qe) if geometry is None else geometry
        G = np.empty(arm.shape[:2] + (2, 3))
        G[:, :, 0, :2] = -n
        G[:, :, 0, 2] = cross(n, p[:, :, 1] - qb[:, :, 0, :2])  # (B n̄)ᵀ (p_b - r_a)
        G[:, :, 1, :2] = n
        G[:, :, 1, 2] = cross(arm[:, :, 1], n)  # nᵀ perp(A_b u_b)
        return dot(n, p[:, :, 1] - p[:, :, 0]), G

    def quadratic(self, qe: np.ndarray, qde: np.ndarray, geometry=None) -> np.ndarray:
        """``(ℓ_q q̇)_q q̇`` (so ``ℓ̈ = ℓ_q q̈ +`` this), (N, ne):
        ``-nᵀd ω_a² + 2 ω_a (B n)ᵀ ḋ - nᵀ(A_b u_b ω_b² - A_a u_a ω_a²)``, ``d = p_b - p_a``."""
        qb, arm, p, n = self.geometry(qe) if geometry is None else geometry
        vb = gather(qde, self.points.coords)
        w = vb[..., 2]
        v = vb[..., :2] + perp(arm) * w[..., None]
        wa, wb = w[:, :, 0], w[:, :, 1]
        return (
            -dot(n, p[:, :, 1] - p[:, :, 0]) * wa**2
            + 2.0 * wa * dot(perp(n), v[:, :, 1] - v[:, :, 0])
            - dot(n, arm[:, :, 1]) * wb**2
            + dot(n, arm[:, :, 0]) * wa**2
        )


def axis_projection(
    qe: np.ndarray, bodies: np.ndarray, u: np.ndarray, axis: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`AxisProjection.measure` of the elements on ``bodies`` (ne, 2) with points
    ``u`` (ne, 2, 2) and axis ``axis`` (ne, 2) in body a's axes: ``ℓ`` (N, ne) and
    ``∂ℓ/∂q`` of a and b (N, ne, 2, 3)."""
    return AxisProjection(bodies, u, axis).measure(qe)


def axis_projection_quadratic(
    qe: np.ndarray, qde: np.ndarray, bodies: np.ndarray, u: np.ndarray, axis: np.ndarray
) -> np.ndarray:
    """:meth:`AxisProjection.quadratic` of the elements (see :func:`axis_projection`)."""
    return AxisProjection(bodies, u, axis).quadratic(qe, qde)


class JointGroup:
    """All joints of one type in a mechanism (subclasses: one per joint type)."""

    #: equations per element
    n_equations: ClassVar[int]
    #: bodies per element (slots): the Jacobian has one block per slot
    n_bodies: ClassVar[int] = 2
    #: depends on time through run-time drive values (``prescribed``)
    rheonomic: ClassVar[bool] = False
    #: ``∂C/∂(x, z)`` does not depend on q, so reaction forces follow from λ alone
    constant_force_jacobian: ClassVar[bool] = True

    # set by the solver (:class:`~suspopt.multibody.solver.PlanarMultibodySolver`): the
    # group's joints among the mechanism's, where its rows are in ``C`` (a slice when
    # contiguous) and where its Jacobian entries go in the flattened ``C_q``
    members: np.ndarray
    row_index: slice | np.ndarray
    flat: np.ndarray
    flat_keep: np.ndarray
    flat_mn: np.ndarray

    def __init__(self, specs: list[Any], layout: Layout):
        self.specs = specs
        self.names = [s.name for s in specs]
        self.bodies = np.array(
            [[layout.index[b] for b in s.bodies] for s in specs], dtype=int
        ).reshape(len(specs), self.n_bodies)
        self.rows = np.zeros((len(specs), self.n_equations), dtype=int)  # set by the solver

    def residual(self, qe: np.ndarray, drive: np.ndarray | None = None) -> np.ndarray:
        raise NotImplementedError

    def jacobian(self, qe: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def gamma(self, qe: np.ndarray, qde: np.ndarray, drive: np.ndarray | None = None) -> np.ndarray:
        raise NotImplementedError

    def residual_jacobian(
        self, qe: np.ndarray, drive: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Both at once (Newton's method); a type may share intermediate results."""
        return self.residual(qe, drive), self.jacobian(qe)

    def velocity_term(self, drive: np.ndarray) -> np.ndarray:
        """``ν = -∂C/∂t`` (rheonomic types only)."""
        raise NotImplementedError

    def drive(self, values: list[Any], N: int) -> np.ndarray:
        """The run-time values of a rheonomic type's elements (None: at rest at the
        reference) as one array with a state axis second, passed back to its methods."""
        raise NotImplementedError

    def reactions(
        self, qe: np.ndarray | None, lam: np.ndarray, jacobian: np.ndarray | None = None
    ) -> np.ndarray:
        """Generalized constraint force ``-(∂C/∂q_b)ᵀ λ`` on each connected body b:
        (N, ne, S, 3) = force (x, z) and torque about the body's CG (for the ground: about
        the origin). ``lam`` (N, ne, k) are this group's multipliers; ``jacobian``: this
        group's :meth:`jacobian` at ``qe``, if the caller has it."""
        if jacobian is None:
            assert qe is not None, 'reactions: give qe or its jacobian'
            jacobian = self.jacobian(qe)
        J = jacobian  # (N, ne, S, k, 3)
        out = J[:, :, :, 0, :] * lam[:, :, None, 0, None]  # the sum over k, as einsum's
        for i in range(1, J.shape[3]):
            out = out + J[:, :, :, i, :] * lam[:, :, None, i, None]
        return -out


class CoincidenceJointGroup(JointGroup):
    """Joints that make a point on each of two bodies coincide, ``r_i + A_i u_i`` with
    ``r_j + A_j u_j`` (x and z), and with ``angle_equation`` also hold their relative angle
    ``φ_i - φ_j`` at its reference value (a weld). The equations, in this order of
    operations (the solver evaluates all such joints of a mechanism at once by them):

        C_c = ((r_ic + a_ic) - r_jc) - a_jc,    C_φ = (φ_i - φ_j) - (φ_i0 - φ_j0)

    with the arms ``a = A u``; ``C_q = [ I  B_i u_i  -I  -B_j u_j ]`` (and ``±1`` on the
    angles), ``γ = a_i φ̇_i² - a_j φ̇_j²`` (0 for the angle). A type gives its joint
    points ``u`` (ne, 2, 2) in body axes (:meth:`joint_points`)."""

    #: a weld: the relative angle is held too (a third equation)
    angle_equation: ClassVar[bool] = False

    def __init__(self, specs: list[Any], layout: Layout):
        super().__init__(specs, layout)
        self.u = np.asarray(self.joint_points(specs, layout), dtype=float).reshape(-1, 2, 2)
        self.points = BodyPoints(self.bodies, self.u)
        ang = layout.angle0(self.bodies)
        self.angle = (ang[:, 0] - ang[:, 1]).reshape(-1)

    def joint_points(self, specs: list[Any], layout: Layout) -> np.ndarray:
        """The joint point in both bodies' axes (ne, 2, 2)."""
        raise NotImplementedError

    def arms(self, qe: np.ndarray) -> np.ndarray:
        return self.points.arms(qe)  # (N, ne, 2, 2)

    def _residual(self, qb, arm):
        C = qb[:, :, 0, :2] + arm[:, :, 0] - qb[:, :, 1, :2] - arm[:, :, 1]
        if not self.angle_equation:
            return C
        out = np.empty(C.shape[:2] + (3,))
        out[..., :2] = C
        out[..., 2] = qb[:, :, 0, 2] - qb[:, :, 1, 2] - self.angle
        return out

    def _jacobian(self, arm):
        J = coincidence_jacobian(arm, self.n_equations)
        if self.angle_equation:
            J[:, :, 0, 2, 2] = 1.0
            J[:, :, 1, 2, 2] = -1.0
        return J

    def residual(self, qe, drive=None):
        qb, _, _, arm = self.points.state(qe)
        return self._residual(qb, arm)

    def jacobian(self, qe):
        return self._jacobian(self.arms(qe))

    def residual_jacobian(self, qe, drive=None):
        qb, _, _, arm = self.points.state(qe)
        return self._residual(qb, arm), self._jacobian(arm)

    def gamma(self, qe, qde, drive=None):
        g = self.arms(qe) * gather(qde, self.points.phi)[..., None] ** 2
        if not self.angle_equation:
            return g[:, :, 0] - g[:, :, 1]
        out = np.zeros(g.shape[:2] + (3,))
        out[..., :2] = g[:, :, 0] - g[:, :, 1]
        return out


class CoincidenceSet:
    """All :class:`CoincidenceJointGroup` joints of a mechanism evaluated at once, by the
    same operations in the same order as their groups' methods (the same results bit for
    bit), with a few NumPy calls per batch whatever the number of joints.

    Per state, a pool holds the bodies' coordinates (the ground's zero), the arms ``A u``
    of every joint point and their negatives, the weld angles and the constants
    ``-0, 0, 1, -1``; each equation is ``((v_1 + v_2) - v_3) - v_4`` of four pool
    entries, ``C_q`` (m, n) is pool entries (``±1``, ``±`` arm components and zeros; the
    rows of other joints zero) and each ``γ`` the difference of two ``a φ̇²`` entries.
    ``rows``: the constraint row of each group's equations (ne, k)."""

    def __init__(
        self, groups: list[CoincidenceJointGroup], rows: list[np.ndarray], nb: int, m: int
    ):
        ncoord = 3 * (nb + 1)
        n = 3 * nb
        bodies = np.concatenate([g.bodies.ravel() for g in groups])  # (P,) per point
        u = np.concatenate([g.u.reshape(-1, 2) for g in groups])
        self.n_points = P = bodies.size
        self.phi = np.repeat(3 * bodies + 2, 2)  # per arm component
        self.u, self.u_perp = u.ravel(), perp(u).ravel()
        self.arms = slice(ncoord, ncoord + 2 * P)
        self.negative_arms = slice(ncoord + 2 * P, ncoord + 4 * P)
        angles = [a for g in groups if g.angle_equation for a in g.angle]
        start = ncoord + 4 * P
        ANGLE, NEGZERO, ZERO, ONE, MINUS = (
            start,
            start + len(angles),
            start + len(angles) + 1,
            start + len(angles) + 2,
            start + len(angles) + 3,
        )
        self.width = start + len(angles) + 4
        self.template = np.zeros(self.width)
        self.template[ANGLE:NEGZERO] = angles
        self.template[NEGZERO:] = (-0.0, 0.0, 1.0, -1.0)  # v + (-0.0) == v
        eq, gam = [], []
        cq = np.full(m * n, ZERO)  # C_q from the pool

        def put(r, b, c, src):
            if b < nb:
                cq[r * n + 3 * b + c] = src

        first = angle = 0
        for g, r in zip(groups, rows):
            for e in range(len(g.names)):
                bi, bj = g.bodies[e]
                pi, pj = first, first + 1  # points of both slots
                first += 2
                ai, aj = ncoord + 2 * pi, ncoord + 2 * pj  # their arms (x, z)
                for k in range(2):
                    eq.append((r[e, k], (3 * bi + k, ai + k, 3 * bj + k, aj + k)))
                    gam.append((r[e, k], (2 * pi + k, 2 * pj + k)))
                    put(r[e, k], bi, k, ONE)
                    put(r[e, k], bj, k, MINUS)
                # ∂C_x/∂φ = -a_z (i), +a_z (j); ∂C_z/∂φ = +a_x (i), -a_x (j)
                put(r[e, 0], bi, 2, ai + 1 + 2 * P)
                put(r[e, 0], bj, 2, aj + 1)
                put(r[e, 1], bi, 2, ai)
                put(r[e, 1], bj, 2, aj + 2 * P)
                if g.angle_equation:
                    eq.append((r[e, 2], (3 * bi + 2, NEGZERO, 3 * bj + 2, ANGLE + angle)))
                    gam.append((r[e, 2], (2 * P, 2 * P)))
                    put(r[e, 2], bi, 2, ONE)
                    put(r[e, 2], bj, 2, MINUS)
                    angle += 1
        order = np.argsort([row for row, _ in eq], kind='stable')
        self.rows = np.array([eq[o][0] for o in order], dtype=int)
        self.terms = np.array([eq[o][1] for o in order], dtype=int).T
        # γ: entries of [a φ̇² of every point (2P), 0]
        self.gamma_terms = np.array([gam[o][1] for o in order], dtype=int).T
        self.jacobian_source = cq
        self._ncoord = ncoord

    def pool(self, q: np.ndarray) -> np.ndarray:
        """The pool (N, width) at body coordinates ``q`` (N, n) (the ground's may follow)."""
        N = q.shape[0]
        v = np.empty((N, self.width))
        v[...] = self.template
        v[:, : q.shape[1]] = q
        phi = v.take(self.phi, axis=1)
        arm = v[:, self.arms]
        np.multiply(np.cos(phi), self.u, out=arm)  # A u = cos φ u + sin φ perp(u)
        arm += np.sin(phi) * self.u_perp
        np.negative(arm, out=v[:, self.negative_arms])
        return v

    def residual(self, v: np.ndarray) -> np.ndarray:
        """The equations (N, len(rows)) from the pool."""
        t = v.take(self.terms, axis=1)
        return ((t[:, 0] + t[:, 1]) - t[:, 2]) - t[:, 3]

    def jacobian(self, v: np.ndarray) -> np.ndarray:
        """``C_q`` (N, m · n) flattened from the pool: these joints' rows, zeros elsewhere."""
        return v.take(self.jacobian_source, axis=1)

    def gamma(self, v: np.ndarray, qde: np.ndarray) -> np.ndarray:
        """``γ`` of the equations (N, len(rows)), from the pool at q and the velocities
        ``qde`` (N, nb + 1, 3)."""
        N = v.shape[0]
        w = qde.reshape(N, -1).take(self.phi, axis=1)
        g = np.empty((N, 2 * self.n_points + 1))
        np.multiply(v[:, self.arms], w**2, out=g[:, :-1])
        g[:, -1] = 0.0
        t = g.take(self.gamma_terms, axis=1)
        return t[:, 0] - t[:, 1]


class ForceGroup:
    """All force elements of one type in a mechanism (subclasses: one per force type)."""

    #: names of the run-time parameters (each (N, ne); defaults from the file)
    parameters: tuple[str, ...] = ()
    n_bodies: ClassVar[int] = 2
    #: the connected bodies' indices (ne, S), set by each type
    bodies: np.ndarray

    # set by the solver (:class:`~suspopt.multibody.solver.PlanarMultibodySolver`): all
    # parameter defaults zero, the parameters given at run time and the map of the
    # generalized forces (ne S 3) to the bodies' coordinates (n)
    all_zero: bool
    given: frozenset[str]
    scatter: np.ndarray

    def __init__(self, specs: list[Any], layout: Layout):
        self.specs = specs
        self.names = [s.name for s in specs]
        self.defaults = {
            p: np.array([self.default(s, p) for s in specs], dtype=float) for p in self.parameters
        }

    def default(self, spec: Any, parameter: str) -> float:
        """The file's value of a run-time parameter of element ``spec``."""
        return getattr(spec, parameter)

    def generalized_force(
        self, qe: np.ndarray, qde: np.ndarray | None, values: dict[str, np.ndarray]
    ) -> np.ndarray:
        """Generalized force on each connected body (``self.bodies``), (N, ne, S, 3)."""
        raise NotImplementedError

    def forces(
        self,
        qe: np.ndarray,
        qde: np.ndarray | None,
        values: dict[str, np.ndarray],
        geometry: Any = None,
    ) -> tuple[np.ndarray, Any]:
        """:meth:`generalized_force` and what the type computed on the way that a query
        may reuse (a spring's :meth:`ScalarSpringGroup.tension`; None here); ``geometry``:
        a spring's :meth:`ScalarSpringGroup.geometry` at ``qe``, if the caller has it."""
        return self.generalized_force(qe, qde, values), None

    def potential(self, qe: np.ndarray, values: dict[str, np.ndarray]) -> np.ndarray:
        """Potential energy per element (N, ne); zero for non-conservative forces."""
        return np.zeros((qe.shape[0], len(self.names)))


class ScalarSpringGroup(ForceGroup):
    """A spring-damper acting on one scalar length ``ℓ(q)`` between two markers:
    tension ``f = k (ℓ - ℓ0) + c ℓ̇ + f_p`` (``f_p``: a preload, 0 unless given) and
    generalized force ``Q = -f (∂ℓ/∂q)ᵀ``, which is ``-∂V/∂q`` of
    ``V = ½ k (ℓ - ℓ0)² + f_p (ℓ - ℓ0)`` plus the damper. Subclasses define ``ℓ``, its
    gradient, ``(ℓ_q q̇)_q q̇`` (so that ``ℓ̈ = ℓ_q q̈ + that``) and the line of action.

    An element with curves (``spec.curves``, a
    :class:`~suspopt.curves.SpringDamperUnit`: spring, damper, bump and rebound
    stops) has instead the tension

        f = f_p - F(x, v),   x = -(ℓ - ℓ0 + δ),   v = -(ℓ̇ + δ̇)

    ``F`` the unit's force with compression ``x`` and compression rate ``v`` positive
    (bump, the curves' convention), ``V = E(x) + f_p (ℓ - ℓ0)``, ``E = ∫_0^x (S + B + R)``.
    ``δ``, ``δ̇`` (run-time parameters ``offset``, ``offset_rate``, default 0) lengthen the
    element, e.g. by a chassis mount's motion along it. Every curve parameter is a
    run-time parameter of its scalar name
    (:meth:`~suspopt.curves.SpringDamperUnit.scalar_parameters`: ``k_S``,
    ``c_bump_low``, ``damper_forces_3`` ...). The elements of a group evaluate their
    curves in one call per distinct curve structure."""

    parameters: tuple[str, ...] = ('stiffness', 'damping', 'preload')

    def __init__(self, specs: list[Any], layout: Layout):
        units = [getattr(s, 'curves', None) for s in specs]
        #: (unit, element indices, its scalar parameter names) per distinct curve structure
        self.curve_batches: list[tuple[Any, np.ndarray, list[str]]] = []
        if any(u is not None for u in units):
            by: dict[tuple, list[int]] = {}
            for i, u in enumerate(units):
                if u is not None:
                    by.setdefault(u.structure(), []).append(i)
            for idx in by.values():
                unit = units[idx[0]]
                assert unit is not None
                self.curve_batches.append((unit, np.array(idx), list(unit.scalar_parameters())))
            curve_names = [n for _, _, names in self.curve_batches for n in names]
            self.parameters = (
                ScalarSpringGroup.parameters
                + ('offset', 'offset_rate')
                + tuple(dict.fromkeys(curve_names))
            )
        super().__init__(specs, layout)
        ends = [[layout.markers[m] for m in s.markers] for s in specs]
        self.bodies = np.array([[e[0] for e in pair] for pair in ends], dtype=int).reshape(-1, 2)
        self.u = np.array([[e[1] for e in pair] for pair in ends], dtype=float).reshape(-1, 2, 2)
        self.points = BodyPoints(self.bodies, self.u)
        self.setup(specs, layout)
        ref = self.length(layout.q0e[None])[0]
        self.free_length = np.array(
            [ref[i] if s.free_length is None else s.free_length for i, s in enumerate(specs)],
            dtype=float,
        )

    def default(self, spec: Any, parameter: str) -> float:
        if parameter in ScalarSpringGroup.parameters:
            return getattr(spec, parameter)
        unit = getattr(spec, 'curves', None)
        if unit is None:
            return 0.0  # offsets, and curve parameters of an element without curves
        return unit.scalar_parameters().get(parameter, 0.0)

    def setup(self, specs: list[Any], layout: Layout) -> None:
        """Type-specific constant data (called before the reference length is taken)."""

    def ends(self, qe: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Arms ``A u`` (N, ne, 2, 2) and global positions (N, ne, 2, 2) of both ends."""
        qb, _, _, arm = self.points.state(qe)
        return arm, qb[..., :2] + arm

    def length(self, qe: np.ndarray) -> np.ndarray:
        return self.measure(qe)[0]

    def geometry(self, qe: np.ndarray) -> Any:
        """What :meth:`measure`, :meth:`quadratic` and :meth:`directions` share at ``qe``,
        for a caller that needs several of them at one pose (they take it as
        ``geometry``); None if nothing."""
        return None

    def measure(self, qe: np.ndarray, geometry: Any = None) -> tuple[np.ndarray, np.ndarray]:
        """``ℓ`` (N, ne) and ``∂ℓ/∂q_b`` of both end bodies (N, ne, 2, 3)."""
        raise NotImplementedError

    def quadratic(self, qe: np.ndarray, qde: np.ndarray, geometry: Any = None) -> np.ndarray:
        """``(ℓ_q q̇)_q q̇`` (N, ne)."""
        raise NotImplementedError

    def directions(self, qe: np.ndarray, geometry: Any = None) -> np.ndarray:
        """Unit line of action at each end, pointing to the other end (N, ne, 2, 2): a
        positive tension pulls end e along ``directions[..., e, :]``."""
        raise NotImplementedError

    def rate(self, grad: np.ndarray, qde: np.ndarray) -> np.ndarray:
        return np.einsum('nesc,nesc->ne', grad, qde[:, self.bodies])

    def tension(
        self,
        qe: np.ndarray,
        qde: np.ndarray | None,
        values: dict[str, np.ndarray],
        geometry: Any = None,
    ) -> tuple[np.ndarray, ...]:
        """``ℓ``, ``ℓ̇``, ``f`` (N, ne each) and the gradient (N, ne, 2, 3)."""
        ell, grad = self.measure(qe, geometry)
        if self.curve_batches:
            return self._curve_tension(ell, grad, qde, values)
        f = values['stiffness'] * (ell - self.free_length) + values['preload']
        if qde is None:
            if np.any(values['damping'] != 0.0):
                raise ValueError(
                    f'force elements {self.names} have damping: the velocities qd are needed'
                )
            ell_d = np.full_like(ell, np.nan)
        else:
            ell_d = self.rate(grad, qde)
            f = f + values['damping'] * ell_d
        return ell, ell_d, f, grad

    def _curve_tension(self, ell, grad, qde, values):
        """:meth:`tension` of a group with curve elements (see the class docstring);
        without velocities the tension of a damped element is NaN (the spring queries of
        a pose; the generalized forces refuse it, :meth:`forces`)."""
        e = ell - self.free_length + values['offset']
        f = values['stiffness'] * e + values['preload']
        if qde is None:
            ell_d = np.full_like(ell, np.nan)
            f = np.where(values['damping'] != 0.0, np.nan, f)
        else:
            ell_d = self.rate(grad, qde)
            f = f + values['damping'] * (ell_d + values['offset_rate'])
        for unit, idx, names in self.curve_batches:
            params = unit.gather({n: values[n][:, idx] for n in names})
            x = -e[:, idx]
            if qde is None:
                F = unit.elastic_force(x, params)[0]
                if not _no_damper(unit, values, idx):
                    F = F + np.nan
            else:
                v = -(ell_d[:, idx] + values['offset_rate'][:, idx])
                F = unit.force(x, v, params, partials=False).value
            f[:, idx] -= F
        return ell, ell_d, f, grad

    def _check_velocities(self, qde, values) -> None:
        if (
            qde is None
            and self.curve_batches
            and (
                np.any(values['damping'] != 0.0)
                or any(not _no_damper(u, values, idx) for u, idx, _ in self.curve_batches)
            )
        ):
            raise ValueError(
                f'force elements {self.names} have damping: the velocities qd are needed'
            )

    def generalized_force(self, qe, qde, values):
        self._check_velocities(qde, values)
        _, _, f, grad = self.tension(qe, qde, values)
        return -f[..., None, None] * grad

    def forces(self, qe, qde, values, geometry=None):
        self._check_velocities(qde, values)
        if type(self).generalized_force is not ScalarSpringGroup.generalized_force:
            return self.generalized_force(qe, qde, values), None
        t = self.tension(qe, qde, values, geometry)
        return -t[2][..., None, None] * t[3], t

    def potential(self, qe, values):
        s = self.length(qe) - self.free_length
        if not self.curve_batches:
            return 0.5 * values['stiffness'] * s**2 + values['preload'] * s
        e = s + values['offset']
        V = 0.5 * values['stiffness'] * e**2 + values['preload'] * s
        for unit, idx, names in self.curve_batches:
            params = unit.gather({n: values[n][:, idx] for n in names})
            V[:, idx] += unit.elastic_energy(-e[:, idx], params)
        return V


def _no_damper(unit: Any, values: dict[str, np.ndarray], idx: np.ndarray) -> bool:
    """The unit's damper gives no force at these values (its slopes and table forces are
    all zero), so the velocities are not needed."""
    names = [
        n
        for p in unit.damper.parameters()
        if not p.name.startswith('v_')  # knee velocities
        for n in p.scalar_names()
    ]
    return all(np.all(values[n][:, idx] == 0.0) for n in names)


def spring_spec_keys() -> dict[str, bool]:
    """TOML keys shared by the spring-damper types (True: required); the curve subtables
    (:data:`~suspopt.curves.SLOTS`) are optional."""
    return {
        'name': True,
        'type': True,
        'markers': True,
        'stiffness': False,
        'damping': False,
        'preload': False,
        'free_length': False,
        **dict.fromkeys(SLOTS, False),
    }


def read_spring_common(rd, data: dict, where: str) -> dict[str, Any]:
    """Markers on two different bodies, stiffness and damping >= 0, free length > 0."""
    pair = data.get('markers')
    if not isinstance(pair, list) or len(pair) != 2:
        rd.err(f'{where}.markers', f'must be two marker names, got {pair!r}')
        pair = ['?', '?']
    else:
        pair = [rd.marker(m, f'{where}.markers') for m in pair]
        bodies = [rd.markers[m][0] for m in pair if m in rd.markers]
        if len(bodies) == 2 and bodies[0] == bodies[1]:
            rd.err(
                f'{where}.markers',
                f'both ends are on body {bodies[0]!r}: a spring '
                'needs its ends on two different bodies',
            )
    free = data.get('free_length')
    common = {
        'markers': (pair[0], pair[1]),
        'stiffness': rd.number(data, 'stiffness', where, nonnegative=True, default=0.0),
        'damping': rd.number(data, 'damping', where, nonnegative=True, default=0.0),
        'preload': rd.number(data, 'preload', where, default=0.0),
        'free_length': None
        if free is None
        else rd.number(data, 'free_length', where, positive=True),
    }
    common['curves'] = read_curves(rd, data, where, common)
    return common


def read_curves(rd, data: dict, where: str, common: dict[str, Any]) -> SpringDamperUnit | None:
    """The element's curve subtables as a :class:`~suspopt.curves.SpringDamperUnit`
    (None without any): a spring curve replaces ``stiffness``, a damper curve ``damping``
    (each pair is exclusive); without them the unit's spring and damper are the linear
    ones of ``stiffness`` and ``damping``. The file gives no travel, so a polynomial spring
    must have a non-negative rate at every deflection (odd powers, say)."""
    if not any(slot in data for slot in SLOTS):
        return None
    for key, slot in (('stiffness', 'spring_curve'), ('damping', 'damper_curve')):
        if key in data and slot in data:
            rd.err(f'{where}.{key}', f'give {key} or {slot}, not both')
    try:
        unit = SpringDamperUnit.from_dict(
            data, where, stiffness=common['stiffness'], damping=common['damping']
        )
    except ConfigError as err:
        for line in err.problems:
            key, _, msg = line.partition(': ')
            rd.err(key, msg)
        return None
    common['stiffness'] = common['damping'] = 0.0  # in the unit
    return unit


__all__ = [
    'COORDINATES',
    'GROUND',
    'AxisProjection',
    'BodyPoints',
    'CoincidenceJointGroup',
    'CoincidenceSet',
    'ForceGroup',
    'JointGroup',
    'Layout',
    'ScalarSpringGroup',
    'axis_projection',
    'axis_projection_quadratic',
    'coincidence_jacobian',
    'cross',
    'dot',
    'flat_index',
    'gather',
    'perp',
    'rot_apply',
]
