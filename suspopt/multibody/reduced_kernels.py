"""Compiled (Numba) evaluation of the reduced suspension model
(:mod:`suspopt.multibody.reduced`): one kernel call per query instead of a few dozen NumPy
calls on arrays of a few states, whose per-call overhead is what the reduced model's
NumPy evaluation costs. The physics is not repeated here: the kernels call the same
formulas (:func:`~suspopt.multibody.reduced.ground_terms`,
:func:`~suspopt.multibody.reduced.chassis_terms`), compiled, state by state. The Chebyshev
series are evaluated with the three-term recurrence ``T_{k+1} = 2 x T_k - T_{k-1}``
(Trefethen, *Approximation Theory and Approximation Practice*, ch. 3).

Importing this module needs Numba; the kernels compile at their first call and are cached
on disk (``cache=True``, Numba's cache directory rules).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from suspopt.multibody.reduced import (
    Q0,
    V_BODY,
    V_DBODY,
    V_DWHEEL,
    V_WHEEL,
    VECTORS,
    chassis_terms,
    ground_terms,
)

_ground_terms = njit(cache=True)(ground_terms)
_chassis_terms = njit(cache=True)(chassis_terms)
_NV = len(VECTORS)


@njit(cache=True)
def _row(coef, lo, hi, s, T, out):
    """The series at one travel ``s`` into ``out`` (M,), the basis in ``T`` (K,)."""
    K, M = coef.shape
    x = (2.0 * s - (lo + hi)) / (hi - lo)
    T[0] = 1.0
    if K > 1:
        T[1] = x
    for k in range(2, K):
        T[k] = 2.0 * x * T[k - 1] - T[k - 2]
    for j in range(M):
        out[j] = 0.0
    for k in range(K):
        t = T[k]
        for j in range(M):
            out[j] += t * coef[k, j]


@njit(cache=True)
def _two(coef, lo, hi, s, j0, j1):
    """Columns ``j0`` and ``j1`` of the series at one travel ``s`` (Clenshaw)."""
    K = coef.shape[0]
    x = (2.0 * s - (lo + hi)) / (hi - lo)
    a1 = a2 = b1 = b2 = 0.0
    for k in range(K - 1, 0, -1):
        a1, a2 = 2.0 * x * a1 - a2 + coef[k, j0], a1
        b1, b2 = 2.0 * x * b1 - b2 + coef[k, j1], b1
    return x * a1 - a2 + coef[0, j0], x * b1 - b2 + coef[0, j1]


@njit(cache=True)
def ground_kinematics(coef, lo, hi, z_W, v_W, n, Y, qd, q_W, qd_W, inside):
    """Ground mount: the table at ``s = z_W`` (``Y``), the body velocities ``q' ṡ``, the
    wheel marker's height and rate, for the states inside the table (``inside``)."""
    T = np.empty(coef.shape[0])
    for i in range(z_W.shape[0]):
        s = z_W[i]
        inside[i] = lo <= s <= hi
        if not inside[i]:
            continue
        y = Y[i]
        _row(coef, lo, hi, s, T, y)
        sd = v_W[i]
        q_W[i] = y[2 * V_WHEEL + 1]
        qd_W[i] = y[2 * V_DWHEEL + 1] * sd
        for j in range(n):
            qd[i, j] = y[Q0 + n + j] * sd


@njit(cache=True)
def chassis_kinematics(
    coef, lo, hi, z_W, v_W, z_M, v_M, psi, w, P0x, P0z, rise0, n, Y, q, qd, q_W, qd_W, s, sd, inside
):
    """Chassis mount: the travel ``s`` (Newton's method on the independent body's height
    when the frame is turned), the table there, ``ṡ``, the wheel marker's height and rate,
    and the body coordinates and velocities moved with the frame (as
    :meth:`~suspopt.multibody.reduced.ReducedSuspensionModule.kinematics`)."""
    T = np.empty(coef.shape[0])
    jx, jdx = 2 * V_BODY, 2 * V_DBODY
    for i in range(z_W.shape[0]):
        c, sn = np.cos(psi[i]), np.sin(psi[i])
        si = z_W[i] - z_M[i]
        if sn != 0.0:
            rhs = si + (1.0 - c) * rise0
            ok = False
            for _ in range(12):
                xs = min(max(si, lo), hi)
                bx, bdx = _two(coef, lo, hi, xs, jx, jdx)
                step = (c * si + sn * bx - rhs) / (c + sn * bdx)
                si -= step
                if not abs(step) > 1e-15:
                    ok = True
                    break
            if not ok:
                si = np.nan
        s[i] = si
        inside[i] = lo <= si <= hi
        if not inside[i]:
            continue
        y = Y[i]
        _row(coef, lo, hi, si, T, y)
        rbx, rbz = y[2 * V_BODY], y[2 * V_BODY + 1]
        sdi = (v_W[i] - v_M[i] - w[i] * (c * rbx - sn * rbz)) / (
            sn * y[2 * V_DBODY] + c * y[2 * V_DBODY + 1]
        )
        sd[i] = sdi
        rwx, rwz = y[2 * V_WHEEL], y[2 * V_WHEEL + 1]
        q_W[i] = z_M[i] + (sn * rwx + c * rwz)
        qd_W[i] = (
            v_M[i]
            + w[i] * (c * rwx - sn * rwz)
            + sdi * (sn * y[2 * V_DWHEEL] + c * y[2 * V_DWHEEL + 1])
        )
        for b in range(n // 3):
            rx, rz = y[Q0 + 3 * b] - P0x, y[Q0 + 3 * b + 1] - P0z
            vx, vz, vp = y[Q0 + n + 3 * b], y[Q0 + n + 3 * b + 1], y[Q0 + n + 3 * b + 2]
            ax, az = c * rx - sn * rz, sn * rx + c * rz
            q[i, 3 * b] = P0x + ax
            q[i, 3 * b + 1] = (P0z + z_M[i]) + az
            q[i, 3 * b + 2] = y[Q0 + 3 * b + 2] + psi[i]
            qd[i, 3 * b] = -w[i] * az + sdi * (c * vx - sn * vz)
            qd[i, 3 * b + 1] = v_M[i] + w[i] * ax + sdi * (sn * vx + c * vz)
            qd[i, 3 * b + 2] = w[i] + sdi * vp


@njit(cache=True)
def ground_dynamics(Y, rows, sd, z_M, v_M, k, c, F_T, par, sdd, F_S):
    """:func:`~suspopt.multibody.reduced.ground_terms` at the states ``rows``."""
    for r in range(rows.shape[0]):
        i = rows[r]
        sdd[i], F_S[i] = _ground_terms(Y[i], sd[i], z_M[i], v_M[i], k[i], c[i], F_T[i], par)


@njit(cache=True)
def chassis_response(Y, rows, sd, psi, w, k, c, F_T, par, acc, R, F_S):
    """:func:`~suspopt.multibody.reduced.chassis_terms` at the states ``rows``: the
    response blocks into ``R`` (N, B, 4) (B = 2 or 3), or with ``acc`` (N, 2) the response
    at those mount accelerations (B = 1)."""
    X = np.empty(_NV)
    Z = np.empty(_NV)
    blocks = R.shape[1]
    for r in range(rows.shape[0]):
        i = rows[r]
        y = Y[i]
        cp, sp = np.cos(psi[i]), np.sin(psi[i])
        for v in range(_NV):
            X[v] = cp * y[2 * v] - sp * y[2 * v + 1]
            Z[v] = sp * y[2 * v] + cp * y[2 * v + 1]
        t = _chassis_terms(y, X, Z, sd[i], w[i], k[i], c[i], F_T[i], par)
        F_S[i] = t[12]
        if acc.shape[0]:
            a, b = acc[i, 0], acc[i, 1]
            R[i, 0, 0] = t[0] + a * t[4] + b * t[8]
            R[i, 0, 1] = t[1] + a * t[5] + b * t[9]
            R[i, 0, 2] = t[2] + a * t[6] + b * t[10]
            R[i, 0, 3] = t[3] + a * t[7] + b * t[11]
        else:
            for bl in range(blocks):
                R[i, bl, 0] = t[4 * bl]
                R[i, bl, 1] = t[4 * bl + 1]
                R[i, bl, 2] = t[4 * bl + 2]
                R[i, bl, 3] = t[4 * bl + 3]
