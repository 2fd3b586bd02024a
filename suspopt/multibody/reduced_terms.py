"""The formulas of the reduced suspension model (:mod:`suspopt.multibody.reduced`) and
their compiled (Numba) kernels, in one file.

:func:`ground_terms` and :func:`chassis_terms` are the reduced model's physics (see
:mod:`~suspopt.multibody.reduced`), written with arithmetic only so that they run both on
NumPy columns (a batch of states at once) and, compiled, on one state's scalars.
:func:`compiled_kernels` compiles them with the batch kernels below (one call per query
instead of a few dozen NumPy calls on arrays of a few states, whose per-call overhead is
what the NumPy evaluation costs). The Chebyshev series are evaluated with the three-term
recurrence ``T_{k+1} = 2 x T_k - T_{k-1}`` (Trefethen, *Approximation Theory and
Approximation Practice*, ch. 3).

Numba is imported, and the kernels compiled, only by :func:`compiled_kernels`; they are
cached on disk (Numba's ``cache=True``). Numba invalidates a cached kernel when the file
of its source changes, not when a function it calls in another file does: the layout, the
formulas and the kernels are therefore all in this file.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

#: the tabulated functions of the wheel travel s (the linkage's frame at its reference
#: pose), in this order: 2-vectors (x, z) relative to the mount point P_0, the wheel marker
#: ρ_w, ρ_w'; the CG of the body of the independent coordinate ρ_b, ρ_b', ρ_b''; the tyre's
#: contact point ρ_c, ρ_c'; the spring's line of action at its linkage end; the first
#: moment p = Σ m ρ of the moving bodies and p', p''; that of the fixed bodies (a
#: constant); then scalars: the spring's length ℓ, ℓ'; the generalized mass
#: m = Σ m |ρ'|² + I φ'² and h = Σ m ρ' · ρ'' + I φ' φ''; the polar inertia about P_0,
#: J0 = Σ m |ρ|² + I; Hc = Σ m ρ × ρ' + I φ', Hq = Σ m ρ × ρ'' + I φ'', Hd = Σ m ρ · ρ'
#: (sums over the moving bodies); then the body coordinates q and q' (n each)
VECTORS = (
    'wheel',
    'dwheel',
    'body',
    'dbody',
    'ddbody',
    'contact',
    'dcontact',
    'direction',
    'p',
    'dp',
    'ddp',
    'pfixed',
)
SCALARS = ('length', 'dlength', 'mass', 'h', 'J0', 'Hc', 'Hq', 'Hd')
(
    V_WHEEL,
    V_DWHEEL,
    V_BODY,
    V_DBODY,
    V_DDBODY,
    V_CONTACT,
    V_DCONTACT,
    V_DIRECTION,
    V_P,
    V_DP,
    V_DDP,
    V_PFIXED,
) = range(len(VECTORS))
_S0 = 2 * len(VECTORS)
S_LENGTH, S_DLENGTH, S_MASS, S_H, S_J0, S_HC, S_HQ, S_HD = range(_S0, _S0 + len(SCALARS))
#: first column of q (then q')
Q0 = _S0 + len(SCALARS)
N_VECTORS = len(VECTORS)


def layout(n: int) -> dict[str, slice]:
    """The columns of each tabulated function for a linkage of ``n`` body coordinates."""
    cols = {name: slice(2 * i, 2 * i + 2) for i, name in enumerate(VECTORS)}
    cols.update({name: slice(_S0 + i, _S0 + i + 1) for i, name in enumerate(SCALARS)})
    cols['q'], cols['dq'] = slice(Q0, Q0 + n), slice(Q0 + n, Q0 + 2 * n)
    return cols


#: the constants the formulas take (``par``): the spring's free length and file preload,
#: the tyre load's direction, gravity, the moving bodies' and all bodies' mass
P_FREE, P_PRELOAD, P_DTX, P_DTZ, P_GX, P_GZ, P_MMOV, P_MALL = range(8)


def ground_terms(y, sd, z_M, v_M, k, c, F_T, par):
    """Ground mount: wheel-travel acceleration and ``F_S`` from the table's functions
    ``y`` (indexable by column; a column array (N,) each, or one state's scalars) and the
    query: Lagrange's equation in s (module docstring) with the spring's tension
    ``f = k (ℓ - ℓ0) + c ℓ' ṡ + e_z (k z_M + c v_M)`` (eq. 12 generalized)."""
    dell = y[S_DLENGTH]
    e_z = y[2 * V_DIRECTION + 1]
    f = k * (y[S_LENGTH] - par[P_FREE]) + c * (dell * sd) + e_z * (k * z_M + c * v_M)
    Qs = (
        F_T * (par[P_DTX] * y[2 * V_DCONTACT] + par[P_DTZ] * y[2 * V_DCONTACT + 1])
        - f * dell
        + (par[P_GX] * y[2 * V_DP] + par[P_GZ] * y[2 * V_DP + 1])
    )
    return (Qs - y[S_H] * (sd * sd)) / y[S_MASS], -f * e_z


def chassis_terms(y, X, Z, sd, w, k, c, F_T, par):
    """Chassis mount: the response (module docstring) from the table's functions ``y``,
    the global x and z of its 2-vectors turned with the frame, ``X``, ``Z`` (indexable by
    vector), the travel rate ``sd``, the frame's angular velocity ``w`` and the query:
    ``(zdd_W, F_z, M_P, F_x)`` at zero mount acceleration, per unit vertical acceleration
    of P, per unit angular acceleration of the frame (12 values), then ``F_S``."""
    dell = y[S_DLENGTH]
    f = k * (y[S_LENGTH] - par[P_FREE]) + c * (dell * sd) + par[P_PRELOAD]
    dTx, dTz, gx, gz = par[P_DTX], par[P_DTZ], par[P_GX], par[P_GZ]
    Xdp, Zdp = X[V_DP], Z[V_DP]
    # the tyre's and gravity's generalized forces on s: d · (A ρ'), g · (A p')
    Qs = F_T * (dTx * X[V_DCONTACT] + dTz * Z[V_DCONTACT]) - f * dell + (gx * Xdp + gz * Zdp)
    m, Hc, Hd = y[S_MASS], y[S_HC], y[S_HD]
    sd2, w2, ws = sd * sd, w * w, w * sd
    sdd0 = (Qs - y[S_H] * sd2 + Hd * w2) / m
    sdd_a = -Zdp / m
    sdd_r = -Hc / m
    # the independent body's height acceleration
    Zdb = Z[V_DBODY]
    zdd0 = -w2 * Z[V_BODY] + 2.0 * ws * X[V_DBODY] + sd2 * Z[V_DDBODY] + sdd0 * Zdb
    zdd_a = 1.0 + Zdb * sdd_a
    zdd_r = X[V_BODY] + Zdb * sdd_r
    # force on the frame: F_T d_T + Σ m g - Σ m r̈ over the moving bodies
    Xp, Zp = X[V_P], Z[V_P]
    mall = par[P_MALL]
    Fx0 = F_T * dTx + mall * gx - (-w2 * Xp - 2.0 * ws * Zdp + sd2 * X[V_DDP] + sdd0 * Xdp)
    Fz0 = F_T * dTz + mall * gz - (-w2 * Zp + 2.0 * ws * Xdp + sd2 * Z[V_DDP] + sdd0 * Zdp)
    Fx_a = -Xdp * sdd_a
    Fz_a = -par[P_MMOV] - Zdp * sdd_a
    Fx_r = Zp - Xdp * sdd_r
    Fz_r = -Xp - Zdp * sdd_r
    # moment about P: of the tyre force and gravity, less the rate of angular momentum
    Xpa, Zpa = Xp + X[V_PFIXED], Zp + Z[V_PFIXED]
    M0 = (
        F_T * (X[V_CONTACT] * dTz - Z[V_CONTACT] * dTx)
        + (Xpa * gz - Zpa * gx)
        - (2.0 * ws * Hd + sd2 * y[S_HQ] + sdd0 * Hc)
    )
    M_a = -Xp - Hc * sdd_a
    M_r = -y[S_J0] - Hc * sdd_r
    F_S = -f * Z[V_DIRECTION]
    return (zdd0, Fz0, M0, Fx0, zdd_a, Fz_a, M_a, Fx_a, zdd_r, Fz_r, M_r, Fx_r, F_S)


# the kernels call the formulas by these names: their compiled versions once
# compiled_kernels() has run (the plain functions before; the kernels are plain Python then)
_ground_terms_compiled = ground_terms
_chassis_terms_compiled = chassis_terms


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


def _two(coef, lo, hi, s, j0, j1):
    """Columns ``j0`` and ``j1`` of the series at one travel ``s`` (Clenshaw)."""
    K = coef.shape[0]
    x = (2.0 * s - (lo + hi)) / (hi - lo)
    a1 = a2 = b1 = b2 = 0.0
    for k in range(K - 1, 0, -1):
        a1, a2 = 2.0 * x * a1 - a2 + coef[k, j0], a1
        b1, b2 = 2.0 * x * b1 - b2 + coef[k, j1], b1
    return x * a1 - a2 + coef[0, j0], x * b1 - b2 + coef[0, j1]


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


def ground_dynamics(Y, rows, sd, z_M, v_M, k, c, F_T, par, sdd, F_S):
    """:func:`~suspopt.multibody.reduced.ground_terms` at the states ``rows``."""
    for r in range(rows.shape[0]):
        i = rows[r]
        sdd[i], F_S[i] = _ground_terms_compiled(
            Y[i], sd[i], z_M[i], v_M[i], k[i], c[i], F_T[i], par
        )


def chassis_response(Y, rows, sd, psi, w, k, c, F_T, par, acc, R, F_S):
    """:func:`~suspopt.multibody.reduced.chassis_terms` at the states ``rows``: the
    response blocks into ``R`` (N, B, 4) (B = 2 or 3), or with ``acc`` (N, 2) the response
    at those mount accelerations (B = 1)."""
    X = np.empty(N_VECTORS)
    Z = np.empty(N_VECTORS)
    blocks = R.shape[1]
    for r in range(rows.shape[0]):
        i = rows[r]
        y = Y[i]
        cp, sp = np.cos(psi[i]), np.sin(psi[i])
        for v in range(N_VECTORS):
            X[v] = cp * y[2 * v] - sp * y[2 * v + 1]
            Z[v] = sp * y[2 * v] + cp * y[2 * v + 1]
        t = _chassis_terms_compiled(y, X, Z, sd[i], w[i], k[i], c[i], F_T[i], par)
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


#: the compiled kernels, once made (:func:`compiled_kernels`)
_COMPILED: SimpleNamespace | None = None
#: compiled in this order (each calls only those before it)
_KERNELS = (
    '_row',
    '_two',
    'ground_kinematics',
    'chassis_kinematics',
    'ground_dynamics',
    'chassis_response',
)


def compiled_kernels() -> SimpleNamespace:
    """The batch kernels (``ground_kinematics``, ``chassis_kinematics``,
    ``ground_dynamics``, ``chassis_response``) compiled by Numba (an ImportError without
    it); compiled (or loaded from Numba's cache) at their first call."""
    global _COMPILED
    if _COMPILED is None:
        from numba import njit

        g = globals()
        g['_ground_terms_compiled'] = njit(cache=True)(ground_terms)
        g['_chassis_terms_compiled'] = njit(cache=True)(chassis_terms)
        out = {}
        for name in _KERNELS:
            out[name] = g[name] = njit(cache=True)(g[name])
        _COMPILED = SimpleNamespace(**out)
    return _COMPILED
