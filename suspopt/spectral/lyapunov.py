"""Stationary variances of a linear vehicle on an ISO 8608 road by a Lyapunov equation,
and their design derivatives by the adjoint Lyapunov equation (docs/spectral.md).

The road heights under the wheels are integrals of white noise (random walks), not
stationary; only their velocities are. The vehicle is therefore written relative to its
static response to the road: with ``r`` the non-stationary reference heights (the front
of each independent track; one reference for identical or isotropic tracks) and the
corner heights ``δ = E r + M z`` (``z``: the stationary states of the road model, the
delays' and the coherence filters'), the coordinates ``x̃ = x + K r``, ``K = A⁻¹ B E``,
obey

    x̃' = A x̃ + (B M + K C_r) z + K D_r w,    z' = A_z z + B_z w,
    y  = C x̃ + D M z + (D - C A⁻¹ B) E r,

where ``u_r = C_r z + D_r w`` are the references' velocities and ``w`` white noise of
intensity ``q I`` (:meth:`RandomRoad.velocity_intensity`). An output has a finite
stationary variance iff ``A`` is stable and its static gain to the references vanishes,
``(D - C A⁻¹ B) E = 0``: it does not follow the road at low frequency (accelerations,
suspension travel, tyre deflection and load, pitch and roll relative to the road do; body
or wheel displacement does not). Then ``y = 𝒞 ζ`` with ``ζ = (x̃, z)`` and

    𝒜 P + P 𝒜ᵀ + ℬ Q ℬᵀ = 0,    Var y_k = 𝒞_k P 𝒞_kᵀ.

The delay of the rear wheels is a Padé approximation on the white road velocity
(:func:`suspopt.spectral.shaping.pade_delay`), whose states give the height lag
``δ(t - τ) - δ(t)``; the isotropic coherence a rational approximation
(:func:`suspopt.spectral.shaping.isotropic_filters`).

Gradient of ``J = Σ_k w_k Var y_k``: with ``Λ`` from ``𝒜ᵀ Λ + Λ 𝒜 + 𝒞ᵀ W 𝒞 = 0``,

    dJ = 2⟨d𝒞, W 𝒞 P⟩ + 2⟨d𝒜, Λ P⟩ + 2⟨dℬ, Λ ℬ Q⟩,

gathered into the gradients ``Ā, B̄, C̄, D̄`` of ``J`` with respect to the vehicle's
matrices (:meth:`StationaryModel.matrix_gradients`) and contracted with the affine terms.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
from numpy.typing import ArrayLike

from suspopt.errors import ConfigError, ModelError
from suspopt.spectral.road import RandomRoad
from suspopt.spectral.shaping import isotropic_filters, lag_map, pade_delay
from suspopt.spectral.system import AffineLinearSystem, RoadCorner

#: an output's static gain to the road counts as zero below this fraction of its ``|D|``
#: and ``|C|`` times the largest static response ``|A⁻¹ B|``
STATIC_GAIN_RTOL = 1e-8


@dataclass(frozen=True, eq=False)
class RoadModel:
    """The road under the corners as a linear system driven by white noise ``w``
    (``n_w`` channels of intensity ``intensity``, two-sided per Hz):

    ``z' = A_z z + B_z w``, corner heights ``δ = E r + M z``, reference velocities
    ``dr/dt = C_r z + D_r w``. ``tracks``: the model actually used (``identical`` when
    every corner is on track 0); ``delays`` [s] of the Padé groups."""

    A_z: np.ndarray
    B_z: np.ndarray
    M: np.ndarray
    E: np.ndarray
    C_r: np.ndarray
    D_r: np.ndarray
    intensity: float
    pade_order: int
    tracks: str
    delays: tuple[float, ...]

    @property
    def n_states(self) -> int:
        return self.A_z.shape[0]

    @property
    def n_noise(self) -> int:
        return self.B_z.shape[1]


def road_model(corners: Sequence[RoadCorner], road: RandomRoad, pade_order: int) -> RoadModel:
    """The :class:`RoadModel` of ``corners`` on ``road``, delays by Padé approximations of
    ``pade_order`` states (one per distinct track and delay > 0)."""
    m = len(corners)
    used = {c.track for c in corners}
    tracks = road.tracks if 1 in used else 'identical'
    # white noise channels and the two tracks' velocities u_k = C_trk[k] ξ_c + D_trk[k] w
    if tracks == 'isotropic':
        coh = isotropic_filters(road.speed, road.separation)
        A_c, B_c, C_trk, D_trk = coh.A, coh.B, coh.C_u, coh.D_u
        H_trk = np.vstack([np.zeros(coh.order), coh.C_d])  # track height - reference
    else:
        n_w = 2 if tracks == 'independent' else 1
        A_c, B_c = np.zeros((0, 0)), np.zeros((0, n_w))
        C_trk = np.zeros((2, 0))
        D_trk = np.eye(2) if n_w == 2 else np.ones((2, 1))
        H_trk = np.zeros((2, 0))
    n_c, n_w = A_c.shape[0], B_c.shape[1]

    # one Padé group per (track, delay): identical tracks share one for both sides
    def key(c: RoadCorner) -> tuple[int, float]:
        return (c.track if tracks != 'identical' else 0, round(c.delay(road.speed), 12))

    groups = sorted({key(c) for c in corners if c.offset > 0.0})
    if groups and pade_order < 1:
        raise ConfigError(f'pade_order: must be >= 1 for delayed corners, got {pade_order}')
    delays = [pade_delay(tau, pade_order) for _, tau in groups]
    n_z = n_c + sum(d.order for d in delays)
    A_z = np.zeros((n_z, n_z))
    B_z = np.zeros((n_z, n_w))
    A_z[:n_c, :n_c], B_z[:n_c] = A_c, B_c
    lag_rows: dict[tuple[int, float], np.ndarray] = {}
    j = n_c
    for (k, tau), d in zip(groups, delays):
        sl = slice(j, j + d.order)
        A_z[sl, sl] = d.A
        A_z[sl, :n_c] = np.outer(d.B, C_trk[k])
        B_z[sl] = np.outer(d.B, D_trk[k])
        row = np.zeros(n_z)
        row[sl] = lag_map(d)
        lag_rows[(k, tau)] = row
        j += d.order

    M = np.zeros((m, n_z))
    if tracks == 'independent':
        E = np.zeros((m, 2))
        for i, c in enumerate(corners):
            E[i, c.track] = 1.0
        C_r, D_r = np.zeros((2, n_z)), np.eye(2)
    else:
        E = np.ones((m, 1))
        C_r = np.zeros((1, n_z))
        C_r[0, :n_c] = C_trk[0]
        D_r = D_trk[:1].copy()
    for i, c in enumerate(corners):
        if tracks == 'isotropic':
            M[i, :n_c] = H_trk[c.track]
        if c.offset > 0.0:
            M[i] += lag_rows[key(c)]
    return RoadModel(
        A_z,
        B_z,
        M,
        E,
        C_r,
        D_r,
        road.velocity_intensity(),
        pade_order,
        tracks,
        tuple(tau for _, tau in groups),
    )


class LyapunovSolver:
    """Bartels-Stewart for ``A X + X Aᵀ + F = 0`` and the adjoint ``Aᵀ X + X A + G = 0``
    with one real Schur form ``A = U T Uᵀ`` (``scipy.linalg.schur``) shared by every
    right-hand side; each solve is one LAPACK ``dtrsyl`` on ``T`` (the method of
    ``scipy.linalg.solve_continuous_lyapunov``, without its two Schur forms per call).

    A complex right-hand side is solved by its real and imaginary parts; a complex step
    ``A + i A_i`` (``A_i`` of the order of the step) by :meth:`solve_step`, to first order
    in it (a complex Schur form would bury the step under the rounding of the real part).
    """

    def __init__(self, A: np.ndarray):
        self.T, self.U = sla.schur(np.asarray(A, dtype=float), output='real')

    def _trsyl(self, C: np.ndarray, adjoint: bool) -> np.ndarray:
        T, U = self.T, self.U
        Ct = U.T @ C @ U
        Y, scale, info = sla.lapack.dtrsyl(
            T, T, Ct, trana='T' if adjoint else 'N', tranb='N' if adjoint else 'T'
        )
        if info < 0:
            raise ModelError(f'dtrsyl: argument {-info} is invalid')
        return U @ (Y / scale) @ U.T

    def solve(self, F: np.ndarray, adjoint: bool = False) -> np.ndarray:
        """``X`` with ``A X + X Aᵀ + F = 0`` (``adjoint``: ``Aᵀ X + X A + F = 0``)."""
        if np.iscomplexobj(F):
            return self._trsyl(-F.real, adjoint) + 1j * self._trsyl(-F.imag, adjoint)
        return self._trsyl(-F, adjoint)

    def solve_step(
        self, A_i: np.ndarray, F: np.ndarray, adjoint: bool = False, X_r: np.ndarray | None = None
    ) -> np.ndarray:
        """``X`` with ``(A + i A_i) X + X (A + i A_i)ᵀ + F = 0`` to first order in the
        complex step (``X_r``: the real part if known)."""
        if X_r is None:
            X_r = self.solve(F.real, adjoint)
        Ai = A_i.T if adjoint else A_i
        X_i = self.solve(F.imag + Ai @ X_r + X_r @ Ai.T, adjoint)
        return X_r + 1j * X_i


@dataclass(frozen=True, eq=False)
class StationaryResponse:
    """Stationary statistics of the outputs at one design: ``variance`` (n_y,) in the
    outputs' units squared, ``covariance`` of the augmented state ``ζ = (x̃, z)``."""

    outputs: tuple[str, ...]
    design: np.ndarray
    variance: np.ndarray
    covariance: np.ndarray

    @property
    def rms(self) -> np.ndarray:
        return np.sqrt(self.variance)

    def rms_by_name(self) -> dict[str, float]:
        return {k: float(v) for k, v in zip(self.outputs, np.sqrt(self.variance.real))}


@dataclass(eq=False)
class _State:
    """Everything of one evaluation the gradients reuse."""

    p: np.ndarray
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    K: np.ndarray
    Acal: np.ndarray
    Bcal: np.ndarray
    Ccal: np.ndarray
    P: np.ndarray
    variance: np.ndarray
    solver: LyapunovSolver
    #: of a complex step: the state at its real part; of a real state: its adjoint
    #: solutions by weights (the complex steps of a Hessian share them)
    real: _State | None = None
    adjoints: dict[bytes, np.ndarray] = field(default_factory=dict)


class StationaryModel:
    """Stationary variances of ``system``'s outputs on ``road`` and their design
    derivatives, by Lyapunov equations (module docstring). ``pade_order``: states of each
    delay's Padé approximation (:func:`suspopt.spectral.accuracy.choose_pade_order`
    chooses it from the spectral integral).

    The road model is built once; each design costs one real Schur form of the augmented
    matrix and one triangular Sylvester solve (:class:`LyapunovSolver`), each gradient one
    more triangular solve.
    """

    def __init__(self, system: AffineLinearSystem, road: RandomRoad, pade_order: int = 8):
        self.system = system
        self.road = road
        self.road_model = road_model(system.corners, road, pade_order)
        self._last: _State | None = None
        self._last_step: _State | None = None
        #: covariances solved at real designs (cache misses), for reports
        self.solves = 0

    @property
    def pade_order(self) -> int:
        return self.road_model.pade_order

    @property
    def n_states(self) -> int:
        """Size of the augmented state ``ζ = (x̃, z)``."""
        return self.system.n_states + self.road_model.n_states

    # ------------------------------------------------------------------ evaluation
    def static_gain(self, p: ArrayLike) -> np.ndarray:
        """``(D - C A⁻¹ B) E`` (n_y, references): each output's static gain to the
        non-stationary reference heights; the variance is finite where it is zero."""
        A, B, C, D = self.system.matrices(np.asarray(p, dtype=float))
        E = self.road_model.E
        K = np.linalg.solve(A, B @ E)
        return D @ E - C @ K

    def infinite_outputs(self, p: ArrayLike) -> list[str]:
        """Problems (one line per output) of outputs whose variance is infinite at ``p``."""
        A, B, C, D = self.system.matrices(np.asarray(p, dtype=float))
        return self._infinite(C, D, np.linalg.solve(A, B))

    def infinite_output_names(self, p: ArrayLike) -> tuple[str, ...]:
        """The outputs whose variance is infinite at ``p`` (:meth:`infinite_outputs`)."""
        A, B, C, D = self.system.matrices(np.asarray(p, dtype=float))
        bad, _ = self._static_gain_nonzero(C, D, np.linalg.solve(A, B))
        rows = np.flatnonzero(bad.any(axis=1))
        return tuple(self.system.outputs[i] for i in rows)

    def _static_gain_nonzero(
        self, C: np.ndarray, D: np.ndarray, X: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Which static gains to the references are not zero (n_y, references), and the
        gains, with ``X = A⁻¹ B``."""
        gain = (D - C @ X) @ self.road_model.E
        # what rounding leaves of a gain that is zero in exact arithmetic: relative to
        # the output's D and to its C times the largest static response
        scale = np.abs(D).max(axis=1) + np.abs(C).sum(axis=1) * np.abs(X).max()
        return np.abs(gain) > STATIC_GAIN_RTOL * scale[:, None] + 1e-300, gain

    def _infinite(self, C: np.ndarray, D: np.ndarray, X: np.ndarray) -> list[str]:
        """:meth:`infinite_outputs` with ``X = A⁻¹ B``."""
        bad, gain = self._static_gain_nonzero(C, D, X)
        out = []
        for i, name in enumerate(self.system.outputs):
            if bad[i].any():
                k = int(np.argmax(bad[i]))
                which = f' to track {k}' if self.road_model.tracks == 'independent' else ''
                out.append(
                    f'outputs.{name}: its variance on a random road is infinite: its '
                    f'static gain to the road height{which} is {gain[i, k]:.6g}, not 0 '
                    '(it follows the road at low frequency; use a quantity relative to '
                    'the road or to another body, or an acceleration)'
                )
        return out

    def _evaluate(self, p: np.ndarray, check: bool = True) -> _State:
        for last in (self._last, self._last_step):
            if last is not None and last.p.dtype == p.dtype and np.array_equal(last.p, p):
                return last
        rm, sysm = self.road_model, self.system
        A, B, C, D = sysm.matrices(p)
        X = np.linalg.solve(A, B)
        if check and not np.iscomplexobj(p):
            eig = np.linalg.eigvals(A)
            if not np.all(eig.real < 0.0):
                raise ModelError(
                    'A(p) is not stable (eigenvalue with real part '
                    f'{eig.real.max():.3g} >= 0): the response has no stationary state'
                )
            problems = self._infinite(C, D, X)
            if problems:
                raise ConfigError(problems)
        K = X @ rm.E
        n, nz = sysm.n_states, rm.n_states
        dtype = np.result_type(A, float)
        Acal = np.zeros((n + nz, n + nz), dtype=dtype)
        Acal[:n, :n] = A
        Acal[:n, n:] = B @ rm.M + K @ rm.C_r
        Acal[n:, n:] = rm.A_z
        Bcal = np.vstack([K @ rm.D_r, rm.B_z.astype(dtype)])
        Ccal = np.hstack([C, D @ rm.M])
        F = rm.intensity * (Bcal @ Bcal.T)
        real = None
        if np.iscomplexobj(p):  # a complex step from the real design p.real
            real = self._evaluate(p.real, check=False)
            solver = real.solver
            P = solver.solve_step(Acal.imag, F, X_r=real.P)
        else:
            solver = LyapunovSolver(Acal)
            P = solver.solve(F)
            self.solves += 1
        P = 0.5 * (P + P.T)
        var = np.einsum('ij,jk,ik->i', Ccal, P, Ccal)
        state = _State(p.copy(), A, B, C, D, K, Acal, Bcal, Ccal, P, var, solver, real)
        if np.iscomplexobj(p):
            self._last_step = state
        else:
            self._last = state
        return state

    def response(self, p: ArrayLike) -> StationaryResponse:
        """The outputs' stationary variances at design ``p`` (vector in the system's
        ``design`` order, or a mapping by name)."""
        pv = self.system.design_vector(p) if isinstance(p, Mapping) else np.asarray(p)
        s = self._evaluate(pv.astype(np.result_type(pv, float)))
        return StationaryResponse(self.system.outputs, s.p, s.variance, s.P)

    def variances(self, p: ArrayLike) -> np.ndarray:
        """``Var y`` (n_y,) at ``p``."""
        pv = np.asarray(p)
        return self._evaluate(pv.astype(np.result_type(pv, float))).variance

    def rms(self, p: ArrayLike) -> np.ndarray:
        """RMS of every output (n_y,) at ``p`` (a variance below its rounding level,
        :meth:`variance_rounding`, is zero)."""
        var = self.variances(np.asarray(p, dtype=float))
        return np.sqrt(np.where(var > self.variance_rounding(p), var, 0.0))

    def variance_rounding(self, p: ArrayLike) -> np.ndarray:
        """The rounding level of each variance at ``p`` (n_y,): ``10³ ε ‖𝒞_k‖² ‖P‖₂``,
        the backward error of the Lyapunov solve carried to the output. An output with
        zero variance (one the road does not excite, e.g. roll on identical tracks)
        comes out within it of zero."""
        s = self._evaluate(np.asarray(p, dtype=float))
        return 1e3 * np.finfo(float).eps * np.sum(s.Ccal**2, axis=1) * np.linalg.norm(s.P, 2)

    # ------------------------------------------------------------------ derivatives
    def matrix_gradients(
        self, p: ArrayLike, weights: ArrayLike
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Gradients ``Ā, B̄, C̄, D̄`` of ``J = Σ_k w_k Var y_k`` with respect to the
        matrices ``A, B, C, D`` of the vehicle at ``p`` (one adjoint Lyapunov solve): for
        any parametrization, ``dJ = ⟨dA, Ā⟩ + ⟨dB, B̄⟩ + ⟨dC, C̄⟩ + ⟨dD, D̄⟩``."""
        pv = np.asarray(p)
        s = self._evaluate(pv.astype(np.result_type(pv, float)))
        rm = self.road_model
        n = self.system.n_states
        w = np.asarray(weights)
        G = (s.Ccal.T * w) @ s.Ccal
        if s.real is not None:  # a complex step: the real part is the real state's
            key = np.ascontiguousarray(w.real, dtype=float).tobytes()
            Lam_r = s.real.adjoints.get(key)
            if Lam_r is None:
                Lam_r = s.real.adjoints[key] = s.solver.solve(G.real, adjoint=True)
            Lam = s.solver.solve_step(s.Acal.imag, G, adjoint=True, X_r=Lam_r)
        else:
            Lam = s.solver.solve(G, adjoint=True)
        Lam = 0.5 * (Lam + Lam.T)
        S = Lam @ s.P
        T = rm.intensity * (Lam @ s.Bcal)
        U = (w[:, None] * s.Ccal) @ s.P
        Y = 2.0 * (S[:n, n:] @ rm.C_r.T + T[:n] @ rm.D_r.T)
        AinvT_Y = np.linalg.solve(s.A.T, Y)
        Abar = 2.0 * S[:n, :n] - AinvT_Y @ s.K.T
        Bbar = 2.0 * S[:n, n:] @ rm.M.T + AinvT_Y @ rm.E.T
        Cbar = 2.0 * U[:, :n]
        Dbar = 2.0 * U[:, n:] @ rm.M.T
        return Abar, Bbar, Cbar, Dbar

    def gradient(self, p: ArrayLike, weights: ArrayLike) -> np.ndarray:
        """``dJ/dp`` (n_p,) of ``J = Σ_k w_k Var y_k`` (``weights`` (n_y,)); with
        ``weights`` (r, n_y), the r gradients (r, n_p), one adjoint solve each."""
        w = np.asarray(weights)
        if w.ndim == 2:
            return np.array([self.gradient(p, row) for row in w])
        sysm = self.system
        Ab, Bb, Cb, Db = self.matrix_gradients(p, w)
        return (
            np.tensordot(sysm.dA, Ab, axes=([1, 2], [0, 1]))
            + np.tensordot(sysm.dB, Bb, axes=([1, 2], [0, 1]))
            + np.tensordot(sysm.dC, Cb, axes=([1, 2], [0, 1]))
            + np.tensordot(sysm.dD, Db, axes=([1, 2], [0, 1]))
        )

    def variance_jacobian(self, p: ArrayLike, outputs: Sequence[str] | None = None) -> np.ndarray:
        """``d Var y_k / dp`` (len(outputs), n_p) for the named outputs (all by default)."""
        names = self.system.outputs if outputs is None else tuple(outputs)
        W = np.zeros((len(names), len(self.system.outputs)))
        for r, name in enumerate(names):
            W[r, self.system.output_index(name)] = 1.0
        return self.gradient(p, W)
