"""The half car's equations as plain NumPy functions (paper eqs. 5-10, 12-13).

This module is the single place where each equation is written. The OpenMDAO components
of :mod:`suspopt.models` wrap these functions and add their analytic partials; the
time-marching evaluator (:mod:`suspopt.timemarching`) calls them directly, so both
integrators integrate the same model.

Sign conventions (SPEC §2): ``z`` up, pitch ``theta`` positive nose down, axle position
``a_i`` measured forward from the chassis centre of gravity (``a2 < 0`` for the rear).
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def suspension_force(k_S: ArrayLike, c_S: ArrayLike, a: ArrayLike,
                     z_W: ArrayLike, v_W: ArrayLike,
                     z_C: ArrayLike, v_C: ArrayLike,
                     theta_C: ArrayLike, omega_C: ArrayLike) -> np.ndarray:
    """Suspension force, eq. 9 (eq. 12 with ``z_W = q^z_U``).

    ``F_S = k_S (z_W + a theta_C - z_C) + c_S (v_W + a omega_C - v_C)``.
    """
    return k_S * (z_W + a * theta_C - z_C) + c_S * (v_W + a * omega_C - v_C)


def tyre_force(k_T: ArrayLike, delta: ArrayLike, z_W: ArrayLike) -> np.ndarray:
    """Tyre force, eq. 10 (eq. 13 with ``z_W = q^z_W``): ``F_T = k_T (delta - z_W)``."""
    return k_T * (delta - z_W)


def chassis_heave_acceleration(F_S1: ArrayLike, F_S2: ArrayLike, M: ArrayLike) -> np.ndarray:
    """Chassis heave, eq. 5: ``M z''_C = F_S1 + F_S2``."""
    return (F_S1 + F_S2) / M


def chassis_pitch_acceleration(F_S1: ArrayLike, F_S2: ArrayLike,
                               a1: ArrayLike, a2: ArrayLike, I: ArrayLike) -> np.ndarray:
    """Chassis pitch, eq. 6: ``I theta''_C = -a1 F_S1 - a2 F_S2``."""
    return -(a1 * F_S1 + a2 * F_S2) / I


def wheel_acceleration(F_S: ArrayLike, F_T: ArrayLike, m: ArrayLike) -> np.ndarray:
    """Wheel hop, eqs. 7-8: ``m_i z''_Wi = -F_Si + F_Ti``."""
    return (F_T - F_S) / m


def objective_integrands(zdd_C: ArrayLike, thdd_C: ArrayLike,
                         z_W1: ArrayLike, z_W2: ArrayLike) -> np.ndarray:
    """Integrands of the objective terms ``J_1..J_4`` (eq. 4, SPEC §5), stacked on the last axis."""
    return np.stack([np.square(zdd_C), np.square(thdd_C), np.square(z_W1), np.square(z_W2)],
                    axis=-1)
