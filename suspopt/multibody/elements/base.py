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

from suspopt.multibody.reading import GROUND

COORDINATES = ('x', 'z', 'phi')


def rot_apply(phi: np.ndarray, u: np.ndarray) -> np.ndarray:
    """``A(φ) u = cos φ u + sin φ perp(u)`` with broadcasting; ``u`` has a trailing axis of 2."""
    return np.cos(phi)[..., None] * u + np.sin(phi)[..., None] * (u[..., ::-1] * _FLIP)


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


def coincidence_jacobian(arm: np.ndarray, n_equations: int = 2) -> np.ndarray:
    """Jacobian blocks of ``r_i + A_i u_i - r_j - A_j u_j`` (the first two equations) for
    arms ``A u`` of both bodies (N, ne, 2, 2): (N, ne, 2, n_equations, 3), with
    ``∂/∂r = ±I`` and ``∂/∂φ = ±B u = ±perp(A u)``; further equations' rows are zero."""
    N, ne = arm.shape[:2]
    J = np.zeros((N, ne, 2, n_equations, 3))
    J[:, :, 0, 0, 0] = J[:, :, 0, 1, 1] = 1.0
    J[:, :, 1, 0, 0] = J[:, :, 1, 1, 1] = -1.0
    J[:, :, 0, 0, 2] = -arm[:, :, 0, 1]
    J[:, :, 0, 1, 2] = arm[:, :, 0, 0]
    J[:, :, 1, 0, 2] = arm[:, :, 1, 1]
    J[:, :, 1, 1, 2] = -arm[:, :, 1, 0]
    return J


def axis_projection(qe: np.ndarray, bodies: np.ndarray, u: np.ndarray,
                    axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``ℓ = (A(φ_a) ā)ᵀ (p_b - p_a)``: the distance along a unit axis ``ā`` fixed in body
    a (body axes, (ne, 2)) from point ``u_a`` on a to point ``u_b`` on b (``u`` (ne, 2, 2)).
    Returns ``ℓ`` (N, ne) and ``∂ℓ/∂q`` of a and b (N, ne, 2, 3):

        ∂ℓ/∂r_a = -nᵀ,  ∂ℓ/∂φ_a = (B n̄)ᵀ (p_b - r_a),  ∂ℓ/∂r_b = nᵀ,  ∂ℓ/∂φ_b = nᵀ B_b u_b
    """
    arm = rot_apply(qe[:, bodies, 2], u)
    p = qe[:, bodies, :2] + arm
    n = rot_apply(qe[:, bodies[:, 0], 2], axis)
    G = np.empty(arm.shape[:2] + (2, 3))
    G[:, :, 0, :2] = -n
    G[:, :, 0, 2] = dot(perp(n), p[:, :, 1] - qe[:, bodies[:, 0], :2])
    G[:, :, 1, :2] = n
    G[:, :, 1, 2] = dot(n, perp(arm[:, :, 1]))
    return dot(n, p[:, :, 1] - p[:, :, 0]), G


def axis_projection_quadratic(qe: np.ndarray, qde: np.ndarray, bodies: np.ndarray,
                              u: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """``(ℓ_q q̇)_q q̇`` of :func:`axis_projection` (so ``ℓ̈ = ℓ_q q̈ +`` this), (N, ne):
    ``-nᵀd ω_a² + 2 ω_a (B n)ᵀ ḋ - nᵀ(A_b u_b ω_b² - A_a u_a ω_a²)``, ``d = p_b - p_a``."""
    arm = rot_apply(qe[:, bodies, 2], u)
    p = qe[:, bodies, :2] + arm
    n = rot_apply(qe[:, bodies[:, 0], 2], axis)
    w = qde[:, bodies, 2]
    v = qde[:, bodies, :2] + perp(arm) * w[..., None]
    wa, wb = w[:, :, 0], w[:, :, 1]
    return (-dot(n, p[:, :, 1] - p[:, :, 0]) * wa**2
            + 2.0 * wa * dot(perp(n), v[:, :, 1] - v[:, :, 0])
            - dot(n, arm[:, :, 1]) * wb**2 + dot(n, arm[:, :, 0]) * wa**2)


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

    def __init__(self, specs: list[Any], layout: Layout):
        self.specs = specs
        self.names = [s.name for s in specs]
        self.bodies = np.array([[layout.index[b] for b in s.bodies] for s in specs],
                               dtype=int).reshape(len(specs), self.n_bodies)
        self.rows = np.zeros((len(specs), self.n_equations), dtype=int)  # set by the solver

    def residual(self, qe: np.ndarray, drive: np.ndarray | None = None) -> np.ndarray:
        raise NotImplementedError

    def jacobian(self, qe: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def gamma(self, qe: np.ndarray, qde: np.ndarray,
              drive: np.ndarray | None = None) -> np.ndarray:
        raise NotImplementedError

    def residual_jacobian(self, qe: np.ndarray,
                          drive: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Both at once (Newton's method); a type may share intermediate results."""
        return self.residual(qe, drive), self.jacobian(qe)

    def velocity_term(self, drive: np.ndarray) -> np.ndarray:
        """``ν = -∂C/∂t`` (rheonomic types only)."""
        raise NotImplementedError

    def drive(self, values: list[Any], N: int) -> np.ndarray:
        """The run-time values of a rheonomic type's elements (None: at rest at the
        reference) as one array with a state axis second, passed back to its methods."""
        raise NotImplementedError

    def reactions(self, qe: np.ndarray, lam: np.ndarray) -> np.ndarray:
        """Generalized constraint force ``-(∂C/∂q_b)ᵀ λ`` on each connected body b:
        (N, ne, S, 3) = force (x, z) and torque about the body's CG (for the ground: about
        the origin). ``lam`` (N, ne, k) are this group's multipliers."""
        return -np.einsum('neskc,nek->nesc', self.jacobian(qe), lam)


class ForceGroup:
    """All force elements of one type in a mechanism (subclasses: one per force type)."""

    #: names of the run-time parameters (each (N, ne); defaults from the file)
    parameters: ClassVar[tuple[str, ...]] = ()
    n_bodies: ClassVar[int] = 2

    def __init__(self, specs: list[Any], layout: Layout):
        self.specs = specs
        self.names = [s.name for s in specs]
        self.defaults = {p: np.array([getattr(s, p) for s in specs], dtype=float)
                         for p in self.parameters}

    def generalized_force(self, qe: np.ndarray, qde: np.ndarray | None,
                          values: dict[str, np.ndarray]) -> np.ndarray:
        """Generalized force on each connected body (``self.bodies``), (N, ne, S, 3)."""
        raise NotImplementedError

    def potential(self, qe: np.ndarray, values: dict[str, np.ndarray]) -> np.ndarray:
        """Potential energy per element (N, ne); zero for non-conservative forces."""
        return np.zeros((qe.shape[0], len(self.names)))


class ScalarSpringGroup(ForceGroup):
    """A spring-damper acting on one scalar length ``ℓ(q)`` between two markers:
    tension ``f = k (ℓ - ℓ0) + c ℓ̇ + f_p`` (``f_p``: a preload, 0 unless given) and
    generalized force ``Q = -f (∂ℓ/∂q)ᵀ``, which is ``-∂V/∂q`` of
    ``V = ½ k (ℓ - ℓ0)² + f_p (ℓ - ℓ0)`` plus the damper. Subclasses define ``ℓ``, its
    gradient, ``(ℓ_q q̇)_q q̇`` (so that ``ℓ̈ = ℓ_q q̈ + that``) and the line of action."""

    parameters = ('stiffness', 'damping', 'preload')

    def __init__(self, specs: list[Any], layout: Layout):
        super().__init__(specs, layout)
        ends = [[layout.markers[m] for m in s.markers] for s in specs]
        self.bodies = np.array([[e[0] for e in pair] for pair in ends], dtype=int).reshape(-1, 2)
        self.u = np.array([[e[1] for e in pair] for pair in ends], dtype=float).reshape(-1, 2, 2)
        self.setup(specs, layout)
        ref = self.length(layout.q0e[None])[0]
        self.free_length = np.array([ref[i] if s.free_length is None else s.free_length
                                     for i, s in enumerate(specs)], dtype=float)

    def setup(self, specs: list[Any], layout: Layout) -> None:
        """Type-specific constant data (called before the reference length is taken)."""

    def ends(self, qe: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Arms ``A u`` (N, ne, 2, 2) and global positions (N, ne, 2, 2) of both ends."""
        arm = rot_apply(qe[:, self.bodies, 2], self.u)
        return arm, qe[:, self.bodies, :2] + arm

    def length(self, qe: np.ndarray) -> np.ndarray:
        return self.measure(qe)[0]

    def measure(self, qe: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``ℓ`` (N, ne) and ``∂ℓ/∂q_b`` of both end bodies (N, ne, 2, 3)."""
        raise NotImplementedError

    def quadratic(self, qe: np.ndarray, qde: np.ndarray) -> np.ndarray:
        """``(ℓ_q q̇)_q q̇`` (N, ne)."""
        raise NotImplementedError

    def directions(self, qe: np.ndarray) -> np.ndarray:
        """Unit line of action at each end, pointing to the other end (N, ne, 2, 2): a
        positive tension pulls end e along ``directions[..., e, :]``."""
        raise NotImplementedError

    def rate(self, grad: np.ndarray, qde: np.ndarray) -> np.ndarray:
        return np.einsum('nesc,nesc->ne', grad, qde[:, self.bodies])

    def tension(self, qe: np.ndarray, qde: np.ndarray | None,
                values: dict[str, np.ndarray]) -> tuple[np.ndarray, ...]:
        """``ℓ``, ``ℓ̇``, ``f`` (N, ne each) and the gradient (N, ne, 2, 3)."""
        ell, grad = self.measure(qe)
        f = values['stiffness'] * (ell - self.free_length) + values['preload']
        if qde is None:
            if np.any(values['damping'] != 0.0):
                raise ValueError(f'force elements {self.names} have damping: the '
                                 'velocities qd are needed')
            ell_d = np.full_like(ell, np.nan)
        else:
            ell_d = self.rate(grad, qde)
            f = f + values['damping'] * ell_d
        return ell, ell_d, f, grad

    def generalized_force(self, qe, qde, values):
        _, _, f, grad = self.tension(qe, qde, values)
        return -f[..., None, None] * grad

    def potential(self, qe, values):
        s = self.length(qe) - self.free_length
        return 0.5 * values['stiffness'] * s ** 2 + values['preload'] * s


def spring_spec_keys() -> dict[str, bool]:
    """TOML keys shared by the spring-damper types (True: required)."""
    return {'name': True, 'type': True, 'markers': True, 'stiffness': False,
            'damping': False, 'preload': False, 'free_length': False}


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
            rd.err(f'{where}.markers', f'both ends are on body {bodies[0]!r}: a spring '
                   'needs its ends on two different bodies')
    free = data.get('free_length')
    return {'markers': (pair[0], pair[1]),
            'stiffness': rd.number(data, 'stiffness', where, nonnegative=True, default=0.0),
            'damping': rd.number(data, 'damping', where, nonnegative=True, default=0.0),
            'preload': rd.number(data, 'preload', where, default=0.0),
            'free_length': None if free is None else rd.number(data, 'free_length', where,
                                                               positive=True)}


__all__ = ['COORDINATES', 'GROUND', 'ForceGroup', 'JointGroup', 'Layout', 'ScalarSpringGroup',
           'axis_projection', 'axis_projection_quadratic', 'coincidence_jacobian', 'cross',
           'dot', 'perp', 'rot_apply']
