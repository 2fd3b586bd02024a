"""The vehicle equations as plain NumPy functions (paper eqs. 5-10, 12-13), over corners.

This module is the single place where each equation is written. The OpenMDAO components
of :mod:`suspopt.models` wrap these functions and add their analytic partials; the
time-marching evaluator (:mod:`suspopt.timemarching`) calls them directly, so both
integrators integrate the same model. Per-wheel arrays have the corners on their last
axis (:mod:`suspopt.models.layout`); the half car is the two-corner case.

Sign conventions (SPEC §2): ``z`` up, pitch ``θ`` positive nose down, roll ``φ`` positive
left side up, ``a`` forward from the chassis CG, ``y`` to its left.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def mount_motion(z_C: ArrayLike, theta_C: ArrayLike, phi_C: ArrayLike | float,
                 a: ArrayLike, y: ArrayLike) -> np.ndarray:
    """Vertical motion of the chassis above each corner, ``z_C - a θ_C + y φ_C`` (the
    chassis side of eq. 9; the same expression maps rates to rates)."""
    z_C, theta_C, phi_C = (np.asarray(x)[..., None] for x in (z_C, theta_C, phi_C))
    return z_C - a * theta_C + y * phi_C


def suspension_force(k_S: ArrayLike, c_S: ArrayLike, z_W: ArrayLike, v_W: ArrayLike,
                     z_M: ArrayLike, v_M: ArrayLike) -> np.ndarray:
    """Suspension force on the chassis at each corner, eq. 9 (eq. 12 with ``z_W = q^z_U``):
    ``F_S = k_S (z_W - z_M) + c_S (v_W - v_M)``, with ``z_M`` the chassis above the corner."""
    return k_S * (z_W - z_M) + c_S * (v_W - v_M)


def anti_roll_force(k_R: ArrayLike, z_W: ArrayLike, z_M: ArrayLike, track: ArrayLike,
                    left: ArrayLike, right: ArrayLike) -> np.ndarray:
    """Force of the anti-roll bars on the chassis at each corner. A bar of torsional rate
    ``k_R`` [N m/rad] across track ``t`` twists by ``Δ = (s_L - s_R)/t``, ``s = z_W - z_M``
    the corner's suspension deflection, and pushes the chassis up by ``k_R Δ / t`` on the
    left and down by as much on the right (and the wheels the other way). ``left`` and
    ``right`` index the corners of each bar; ``k_R`` and ``track`` are per bar."""
    s = np.asarray(z_W) - np.asarray(z_M)
    F = np.zeros_like(s)
    left, right = np.asarray(left, dtype=int), np.asarray(right, dtype=int)
    if left.size:
        force = np.asarray(k_R) * (s[..., left] - s[..., right]) / np.asarray(track)**2
        F[..., left] = force
        F[..., right] = -force
    return F


def tyre_force(k_T: ArrayLike, delta: ArrayLike, z_W: ArrayLike) -> np.ndarray:
    """Tyre force on each wheel, eq. 10 (eq. 13 with ``z_W = q^z_W``): ``F_T = k_T (δ - z_W)``."""
    return k_T * (delta - z_W)


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


def objective_integrands(chassis_accelerations: list[ArrayLike], wheel_z: ArrayLike
                         ) -> np.ndarray:
    """Integrands of the objective terms (eq. 4, SPEC §5), stacked on the last axis: the
    squared chassis accelerations (heave, pitch[, roll]) then each wheel's squared travel."""
    chassis = np.stack([np.square(x) for x in chassis_accelerations], axis=-1)
    return np.concatenate([chassis, np.square(wheel_z)], axis=-1)
