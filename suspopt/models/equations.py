"""The vehicle equations as plain NumPy functions (paper eqs. 5-10, 12-13), over corners.

This module is the single place where each equation is written. The OpenMDAO components
of :mod:`suspopt.models` wrap these functions and add their analytic partials; the
time-marching evaluator (:mod:`suspopt.verification.timemarching`) calls them directly, so both
integrators integrate the same model. Per-wheel arrays have the corners on their last
axis (:mod:`suspopt.models.layout`); the half car is the two-corner case.

Sign conventions (docs/model.md): ``z`` up, pitch ``θ`` positive nose down, roll ``φ`` positive
left side up, ``a`` forward from the chassis CG, ``y`` to its left.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def mount_motion(
    z_C: ArrayLike, theta_C: ArrayLike, phi_C: ArrayLike | float, a: ArrayLike, y: ArrayLike
) -> np.ndarray:
    """Vertical motion of the chassis above each corner, ``z_C - a θ_C + y φ_C`` (the
    chassis side of eq. 9; the same expression maps rates to rates)."""
    z, theta, phi = (np.asarray(v)[..., None] for v in (z_C, theta_C, phi_C))
    return z - np.asarray(a) * theta + np.asarray(y) * phi


def seat_acceleration(
    zdd_C: ArrayLike, thdd_C: ArrayLike, phidd_C: ArrayLike | float, x: ArrayLike, y: ArrayLike
) -> np.ndarray:
    """Vertical acceleration at points of the rigid chassis (seats) ``x`` forward of and
    ``y`` left of its CG, ``z''_C - x θ''_C + y φ''_C`` (the linear kinematics of
    :func:`mount_motion`, twice differentiated), one column per point: the input of the
    ISO 2631-1 Wk weighting (:mod:`suspopt.models.iso2631`)."""
    zdd: np.ndarray = np.asarray(zdd_C)[..., None]
    thdd: np.ndarray = np.asarray(thdd_C)[..., None]
    phidd: np.ndarray = np.asarray(phidd_C)[..., None]
    return zdd - np.asarray(x, dtype=float) * thdd + np.asarray(y, dtype=float) * phidd


def suspension_force(
    k_S: ArrayLike, c_S: ArrayLike, z_W: ArrayLike, v_W: ArrayLike, z_M: ArrayLike, v_M: ArrayLike
) -> np.ndarray:
    """Suspension force on the chassis at each corner, eq. 9 (eq. 12 with ``z_W = q^z_U``):
    ``F_S = k_S (z_W - z_M) + c_S (v_W - v_M)``, with ``z_M`` the chassis above the corner."""
    k, c = np.asarray(k_S), np.asarray(c_S)
    return k * (np.asarray(z_W) - np.asarray(z_M)) + c * (np.asarray(v_W) - np.asarray(v_M))


def anti_roll_force(
    k_R: ArrayLike,
    z_W: ArrayLike,
    z_M: ArrayLike,
    track: ArrayLike,
    left: ArrayLike,
    right: ArrayLike,
) -> np.ndarray:
    """Force of the anti-roll bars on the chassis at each corner. A bar of torsional rate
    ``k_R`` [N m/rad] across track ``t`` twists by ``Δ = (s_L - s_R)/t``, ``s = z_W - z_M``
    the corner's suspension deflection, and pushes the chassis up by ``k_R Δ / t`` on the
    left and down by as much on the right (and the wheels the other way). ``left`` and
    ``right`` index the corners of each bar; ``k_R`` and ``track`` are per bar."""
    s = np.asarray(z_W) - np.asarray(z_M)
    F = np.zeros_like(s)
    left, right = np.asarray(left, dtype=int), np.asarray(right, dtype=int)
    if left.size:
        force = np.asarray(k_R) * (s[..., left] - s[..., right]) / np.asarray(track) ** 2
        F[..., left] = force
        F[..., right] = -force
    return F


def tyre_force(k_T: ArrayLike, delta: ArrayLike, z_W: ArrayLike) -> np.ndarray:
    """Tyre force on each wheel, eq. 10 (eq. 13 with ``z_W = q^z_W``): ``F_T = k_T (δ - z_W)``."""
    return np.asarray(k_T) * (np.asarray(delta) - np.asarray(z_W))


def chassis_heave_acceleration(F: ArrayLike, M: float) -> np.ndarray:
    """Chassis heave, eq. 5: ``M z''_C = Σ_c F_c`` (F: the forces on the chassis per corner)."""
    return np.sum(F, axis=-1) / M


def chassis_pitch_acceleration(F: ArrayLike, a: ArrayLike, I: float) -> np.ndarray:
    """Chassis pitch, eq. 6: ``I θ''_C = -Σ_c a_c F_c``."""
    return -(np.asarray(F) @ np.asarray(a)) / I


def chassis_roll_acceleration(F: ArrayLike, y: ArrayLike, I_x: float) -> np.ndarray:
    """Chassis roll (full car): ``I_x φ''_C = Σ_c y_c F_c``."""
    return (np.asarray(F) @ np.asarray(y)) / I_x


def wheel_acceleration(F_T: ArrayLike, F: ArrayLike, m: ArrayLike) -> np.ndarray:
    """Wheel hop at each corner, eqs. 7-8: ``m z''_W = F_T - F`` (F: the suspension's
    forces on the chassis, which act on the wheel with the opposite sign)."""
    return (np.asarray(F_T) - np.asarray(F)) / m


def suspension_travel(z_W: ArrayLike, z_M: ArrayLike) -> np.ndarray:
    """Suspension travel at each corner, the wheel relative to the chassis above it,
    positive in bump: ``s = z_W - z_M`` (the deflection of eq. 9)."""
    return np.asarray(z_W) - np.asarray(z_M)


def tyre_load_ratio(F_T: ArrayLike, static: ArrayLike) -> np.ndarray:
    """The dynamic tyre load relative to the static load, ``F_T / F_static``; the tyre
    lifts off where it reaches -1."""
    return np.asarray(F_T) / np.asarray(static)


def squared_signals(signals: list[ArrayLike]) -> np.ndarray:
    """The objective's integrands (eq. 4, extended; ``docs/metrics.md``): the squares of
    the metric signals, each (N,) or (N, width), stacked as columns (N, terms)."""
    cols = [np.square(np.asarray(s)) for s in signals]
    return np.concatenate([c[..., None] if c.ndim == 1 else c for c in cols], axis=-1)


# ---------------------------------------------------------------- chassis-mounted modules
def mount_rotation(phi_C: ArrayLike, side: ArrayLike) -> np.ndarray:
    """Rotation of each corner's suspension frame in its planar front view: ``side · φ_C``
    (the planar x axis points outboard, so a left corner (side +1) turns with the roll and
    a right one (side -1) against it; 0 on the half car's centre line)."""
    return np.asarray(phi_C)[..., None] * np.asarray(side, dtype=float)


def mount_map(
    a: ArrayLike, y: ArrayLike, side: ArrayLike, roll: bool, pitch: bool = True
) -> np.ndarray:
    """``L`` (corners, mount coordinates, chassis coordinates): the mount's accelerations
    (vertical of P; the frame's rotation with ``roll``) from the chassis accelerations
    (heave[, pitch][, roll]), ``z_M = z_C - a θ_C + y φ_C``, ``ψ = side φ_C``. Its transpose
    maps the mount's generalized forces (F_z, M_P) to the chassis' (power balance)."""
    a, y, side = (np.asarray(v, dtype=float) for v in (a, y, side))
    nc = a.size
    L = np.zeros((nc, 2 if roll else 1, 1 + int(pitch) + int(roll)))
    L[:, 0, 0] = 1.0
    if pitch:
        L[:, 0, 1] = -a
    if roll:
        L[:, 0, -1], L[:, 1, -1] = y, side
    return L


def chassis_mount_accelerations(
    F0: ArrayLike, G: ArrayLike, F_R: ArrayLike, L: np.ndarray, inertia: ArrayLike
) -> np.ndarray:
    """Chassis accelerations (N, heave, pitch[, roll]) with chassis-mounted modules: eqs.
    5-6 (and roll) with the linkage's reactions instead of ``F_S``, solved for the loop
    they close. A module's generalized mount forces are affine in its mount's
    acceleration, ``F0 + G L a`` (F0 (N, corners, u), G (N, corners, u, u)), so

        (diag(M, I[, I_x]) - Σ_c L_cᵀ G_c L_c) a = Σ_c L_cᵀ (F0_c + F_R,c e_z),

    one small system per node. ``F_R`` (N, corners): further vertical forces on the
    chassis (anti-roll bars)."""
    F0, G = np.asarray(F0), np.asarray(G)
    A = np.diag(np.asarray(inertia, dtype=float)) - np.einsum('cuk,ncuv,cvl->nkl', L, G, L)
    b = np.einsum('cuk,ncu->nk', L, F0) + np.asarray(F_R) @ L[:, 0, :]
    return np.linalg.solve(A, b[..., None])[..., 0]


def mount_accelerations(acc_C: ArrayLike, L: np.ndarray) -> np.ndarray:
    """The mounts' accelerations (N, corners, u) from the chassis' (N, heave, pitch[, roll])."""
    return np.einsum('cuk,nk->ncu', L, np.asarray(acc_C))


def mount_response(R: ArrayLike, a_M: ArrayLike) -> np.ndarray:
    """A chassis-mounted module's response at its mount's accelerations: ``R_0 + Σ_u a_u
    R_u`` (R (N, corners, 1 + u, n) blocks: at zero mount acceleration, per unit of each
    mount coordinate; a_M (N, corners, u)) → (N, corners, n)."""
    R = np.asarray(R)
    return R[:, :, 0] + np.einsum('ncu,ncur->ncr', np.asarray(a_M), R[:, :, 1:])


def mount_forces(R: ArrayLike, n_mount: int) -> tuple[np.ndarray, np.ndarray]:
    """``F0`` (N, corners, u) and ``G`` (N, corners, u, u) of module responses ``R`` (N,
    corners, 1 + u, n): the generalized mount forces (entries 1 .. u: F_z, M_P) at zero
    mount acceleration and per unit mount acceleration, ``G[u, v]`` = force u per unit v."""
    R = np.asarray(R)
    return R[:, :, 0, 1 : 1 + n_mount], R[:, :, 1:, 1 : 1 + n_mount].transpose(0, 1, 3, 2)
