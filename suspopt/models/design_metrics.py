"""The design-only metrics (``docs/metrics.md``, "Constraints"): functions of the design
alone, not of the drive, that an engineering constraint bounds.

* the roll gradient [deg/g], the steady-state body roll per g of lateral acceleration
  (full car): each axle's roll stiffness, springs and anti-roll bar in series with the
  tyres, against the roll moment of the sprung mass about the roll axis, gravity
  included (Gillespie, *Fundamentals of Vehicle Dynamics*, SAE 1992, roll in cornering:
  ``dφ/da_y = W h1 / (K_φf + K_φr - W h1)``; tyres in series: Milliken & Milliken,
  *Race Car Vehicle Dynamics*, SAE 1995, ch. 16, "Ride and roll rates");
* the front axle's share of the roll stiffness;
* the undamped heave and pitch frequencies [Hz] of the sprung mass on the corners' ride
  rates (the wheel rate in series with the tyre), from the eigenvalues of its stiffness
  and mass matrices (Gillespie, on pitch and bounce, gives the two-axle closed form
  the tests check).

Every equation is a NumPy function here, wrapped by one OpenMDAO component with analytic
partials; the components are vectorized over corners (and axles), their inputs and
outputs have units. The wheel rate is the low-fidelity model's ``k_S`` itself, or the
linkage's wheel rate at its reference pose, ``a k_S + b``
(:func:`suspopt.multibody.kinematics.reference_wheel_rate`), in the mixed model.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import openmdao.api as om
from numpy.typing import ArrayLike

from suspopt.models.metrics import GRAVITY

#: radians to degrees
DEG = 180.0 / np.pi


# ---------------------------------------------------------------------------- equations
def wheel_rate(k_S: ArrayLike, slope: ArrayLike, offset: ArrayLike) -> np.ndarray:
    """The wheel rate at each corner, ``k_W = a k_S + b`` [N/m] (``a = 1, b = 0`` when the
    spring acts at the wheel, as in the low-fidelity model)."""
    return np.asarray(slope) * np.asarray(k_S) + np.asarray(offset)


def series_rate(k_1: ArrayLike, k_2: ArrayLike) -> np.ndarray:
    """Two springs in series, ``k_1 k_2 / (k_1 + k_2)``: the ride rate of a wheel rate on
    its tyre, an axle's roll stiffness on its tyres' (Milliken & Milliken, ch. 16)."""
    k_1, k_2 = np.asarray(k_1), np.asarray(k_2)
    return k_1 * k_2 / (k_1 + k_2)


def axle_roll_stiffness(
    k_W: ArrayLike,
    k_R: ArrayLike,
    k_T: ArrayLike,
    y: ArrayLike,
    axle: ArrayLike,
    bar_axle: ArrayLike,
    n_axles: int = 2,
) -> np.ndarray:
    """Each axle's roll stiffness [N m/rad]: its wheels' springs, ``Σ_c k_W,c y_c²``
    (``k_W t²/2`` for a pair on track ``t``), plus its anti-roll bar's rate ``k_R`` (its
    twist is the body's roll), in series with its tyres' ``Σ_c k_T,c y_c²``."""
    y2 = np.asarray(y, dtype=float) ** 2
    axle, bar_axle = np.asarray(axle, dtype=int), np.asarray(bar_axle, dtype=int)
    k_W = np.asarray(k_W)
    springs = np.zeros(n_axles, dtype=k_W.dtype)
    np.add.at(springs, axle, k_W * y2)
    np.add.at(springs, bar_axle, np.asarray(k_R, dtype=springs.dtype))
    tyres = np.zeros(n_axles)
    np.add.at(tyres, axle, np.asarray(k_T, dtype=float) * y2)
    return series_rate(springs, tyres)


def roll_moment_arm(
    cg_height: float, rc_front: float, rc_rear: float, a_front: float, a_rear: float
) -> float:
    """The height of the centre of gravity above the roll axis [m]: the axis joins the
    axles' roll centres, and is interpolated at the CG (``a`` ahead of the CG)."""
    share = a_front / (a_front - a_rear)  # 0 at the front axle, 1 at the rear
    return cg_height - (rc_front + share * (rc_rear - rc_front))


def roll_gradient(K_roll: ArrayLike, sprung_mass: float, arm: float) -> np.ndarray:
    """The steady-state roll per g of lateral acceleration [deg/g], ``W h' / (ΣK_φ - W
    h')`` rad (Gillespie): the lateral force ``W`` per g at the CG a height ``h'``
    above the roll axis, and gravity's moment ``W h' φ`` once the body has rolled."""
    moment = sprung_mass * GRAVITY * arm
    return DEG * moment / (np.sum(K_roll, axis=-1) - moment)


def front_share(K_roll: ArrayLike) -> np.ndarray:
    """The front axle's share of the roll stiffness, ``K_φf / (K_φf + K_φr)``."""
    K = np.asarray(K_roll)
    return K[..., 0] / np.sum(K, axis=-1)


def pitch_plane_matrix(
    a: ArrayLike, sprung_mass: float, pitch_inertia: float, pitch: bool
) -> np.ndarray:
    """``B = D Gᵀ`` (degrees of freedom × corners) of the sprung mass' heave[-pitch]
    motion: its point above corner c moves by ``g_cᵀ (z, θ) = z - a_c θ`` and ``D =
    diag(M, I)^(-1/2)``, so its modes solve ``B diag(k_ride) Bᵀ v = ω² v``."""
    a = np.asarray(a, dtype=float)
    G = np.stack([np.ones_like(a), -a], axis=1)[:, : 2 if pitch else 1]
    inertia = np.array([sprung_mass, pitch_inertia])[: G.shape[1]]
    return inertia[:, None] ** -0.5 * G.T


def ride_modes(
    k_ride: ArrayLike, a: ArrayLike, sprung_mass: float, pitch_inertia: float, pitch: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The undamped modes of the sprung mass on the ride rates: their frequencies [Hz]
    in the order heave[, pitch], the mass-normalized eigenvectors (columns, same order) and
    ``B`` (:func:`pitch_plane_matrix`).

    A mode is named by its motion, not by its frequency's rank: the heave mode is the one
    whose mass-normalized eigenvector has the larger heave component (the eigenvectors of
    the symmetric ``B diag(k) Bᵀ`` are orthonormal, so exactly one has ``v_z² > 1/2``
    unless both are at 45°), which holds however the two frequencies are ordered."""
    B = pitch_plane_matrix(a, sprung_mass, pitch_inertia, pitch)
    lam, V = np.linalg.eigh((B * np.asarray(k_ride)) @ B.T)
    if pitch and V[0, 0] ** 2 < V[0, 1] ** 2:  # the first column is the pitch mode
        lam, V = lam[::-1], V[:, ::-1]
    return np.sqrt(lam) / (2.0 * np.pi), V, B


# ---------------------------------------------------------------------------- components
class _DesignComponent(om.ExplicitComponent):
    """A component of design-only quantities: ``evaluate`` is its equation (``compute``
    calls it), from the options only."""

    def evaluate(self, inputs: Mapping[str, Any]) -> dict[str, np.ndarray]:
        raise NotImplementedError

    def compute(self, inputs, outputs) -> None:
        for name, value in self.evaluate(inputs).items():
            outputs[name] = value


class WheelRateComp(_DesignComponent):
    """The wheel rate at each corner from its spring rate: :func:`wheel_rate`."""

    def initialize(self) -> None:
        self.options.declare('slope', types=np.ndarray, desc='a per corner (dk_W/dk_S)')
        self.options.declare('offset', types=np.ndarray, desc='b per corner [N/m]')

    def setup(self) -> None:
        nc = self.options['slope'].size
        self.add_input('k_S', shape=(nc,), units='N/m', desc='spring rate per corner')
        self.add_output('k_W', shape=(nc,), units='N/m', desc='wheel rate per corner')
        rows = np.arange(nc)
        self.declare_partials('k_W', 'k_S', rows=rows, cols=rows, val=self.options['slope'])

    def evaluate(self, inputs: Mapping[str, Any]) -> dict[str, np.ndarray]:
        return {'k_W': wheel_rate(inputs['k_S'], self.options['slope'], self.options['offset'])}


class RideRateComp(_DesignComponent):
    """The ride rate at each corner, the wheel rate in series with the tyre:
    :func:`series_rate`."""

    def initialize(self) -> None:
        self.options.declare('k_T', types=np.ndarray, desc='tyre rate per corner [N/m]')

    def setup(self) -> None:
        nc = self.options['k_T'].size
        self.add_input('k_W', shape=(nc,), units='N/m', desc='wheel rate per corner')
        self.add_output('k_ride', shape=(nc,), units='N/m', desc='ride rate per corner')
        rows = np.arange(nc)
        self.declare_partials('k_ride', 'k_W', rows=rows, cols=rows)

    def evaluate(self, inputs: Mapping[str, Any]) -> dict[str, np.ndarray]:
        return {'k_ride': series_rate(inputs['k_W'], self.options['k_T'])}

    def compute_partials(self, inputs, partials) -> None:
        k_T = self.options['k_T']
        partials['k_ride', 'k_W'] = k_T**2 / (inputs['k_W'] + k_T) ** 2


class AxleRollStiffnessComp(_DesignComponent):
    """Each axle's roll stiffness: :func:`axle_roll_stiffness`."""

    def initialize(self) -> None:
        self.options.declare('y', types=np.ndarray, desc='corner left of the CG [m]')
        self.options.declare('k_T', types=np.ndarray, desc='tyre rate per corner [N/m]')
        self.options.declare('axle', types=np.ndarray, desc='axle of each corner (0 front)')
        self.options.declare('bar_axle', types=np.ndarray, desc='axle of each anti-roll bar')

    def setup(self) -> None:
        o = self.options
        nc, nb = o['y'].size, o['bar_axle'].size
        self.add_input('k_W', shape=(nc,), units='N/m', desc='wheel rate per corner')
        self.add_output('K_roll', shape=(2,), units='N*m/rad', desc='roll stiffness per axle')
        self.declare_partials('K_roll', 'k_W', rows=o['axle'], cols=np.arange(nc))
        if nb:
            self.add_input('k_R', shape=(nb,), units='N*m/rad', desc='anti-roll bar rates')
            self.declare_partials('K_roll', 'k_R', rows=o['bar_axle'], cols=np.arange(nb))

    def _k_R(self, inputs: Mapping[str, Any]) -> np.ndarray:
        return np.asarray(inputs['k_R']) if self.options['bar_axle'].size else np.zeros(0)

    def evaluate(self, inputs: Mapping[str, Any]) -> dict[str, np.ndarray]:
        o = self.options
        K = axle_roll_stiffness(
            inputs['k_W'], self._k_R(inputs), o['k_T'], o['y'], o['axle'], o['bar_axle']
        )
        return {'K_roll': K}

    def compute_partials(self, inputs, partials) -> None:
        o = self.options
        y2, axle, bars = o['y'] ** 2, o['axle'], o['bar_axle']
        springs = np.zeros(2)
        np.add.at(springs, axle, inputs['k_W'] * y2)
        np.add.at(springs, bars, self._k_R(inputs))
        tyres = np.zeros(2)
        np.add.at(tyres, axle, o['k_T'] * y2)
        with np.errstate(invalid='ignore', divide='ignore'):  # an axle without corners
            d = np.nan_to_num(tyres**2 / (springs + tyres) ** 2)
        partials['K_roll', 'k_W'] = d[axle] * y2
        if bars.size:
            partials['K_roll', 'k_R'] = d[bars]


class RollGradientComp(_DesignComponent):
    """The roll gradient [deg/g]: :func:`roll_gradient`."""

    def initialize(self) -> None:
        self.options.declare('sprung_mass', types=float, desc='M [kg]')
        self.options.declare('arm', types=float, desc='CG above the roll axis [m]')

    def setup(self) -> None:
        self.add_input('K_roll', shape=(2,), units='N*m/rad', desc='roll stiffness per axle')
        self.add_output('roll_gradient', units=None, desc='roll per g of lateral acc. [deg/g]')
        self.declare_partials('roll_gradient', 'K_roll', rows=[0, 0], cols=[0, 1])

    def evaluate(self, inputs: Mapping[str, Any]) -> dict[str, np.ndarray]:
        o = self.options
        return {
            'roll_gradient': np.atleast_1d(
                roll_gradient(inputs['K_roll'], o['sprung_mass'], o['arm'])
            )
        }

    def compute_partials(self, inputs, partials) -> None:
        o = self.options
        moment = o['sprung_mass'] * GRAVITY * o['arm']
        d = -DEG * moment / (np.sum(inputs['K_roll']) - moment) ** 2
        partials['roll_gradient', 'K_roll'] = np.array([d, d])


class RollStiffnessShareComp(_DesignComponent):
    """The front axle's share of the roll stiffness: :func:`front_share`."""

    def setup(self) -> None:
        self.add_input('K_roll', shape=(2,), units='N*m/rad', desc='roll stiffness per axle')
        self.add_output('front_share', units=None, desc='front share of the roll stiffness')
        self.declare_partials('front_share', 'K_roll', rows=[0, 0], cols=[0, 1])

    def evaluate(self, inputs: Mapping[str, Any]) -> dict[str, np.ndarray]:
        return {'front_share': np.atleast_1d(front_share(inputs['K_roll']))}

    def compute_partials(self, inputs, partials) -> None:
        K0, K1 = inputs['K_roll']
        S2 = (K0 + K1) ** 2
        partials['front_share', 'K_roll'] = np.array([K1 / S2, -K0 / S2])


class RideFrequencyComp(_DesignComponent):
    """The undamped heave (and pitch) frequencies of the sprung mass [Hz]:
    :func:`ride_modes`. Partials by the eigenvalues' derivatives: for a simple eigenvalue
    of the symmetric ``A = B diag(k) Bᵀ`` with unit eigenvector ``v``, ``dω²/dk_c = (vᵀ
    b_c)²`` (``b_c`` the c-th column of ``B``), and ``df = dω² / (8π² f)``."""

    def initialize(self) -> None:
        self.options.declare('a', types=np.ndarray, desc='corner ahead of the CG [m]')
        self.options.declare('sprung_mass', types=float, desc='M [kg]')
        self.options.declare('pitch_inertia', types=float, default=0.0, desc='I [kg m^2]')
        self.options.declare('pitch', types=bool, default=True, desc='the body pitches')

    def setup(self) -> None:
        nc = self.options['a'].size
        self.add_input('k_ride', shape=(nc,), units='N/m', desc='ride rate per corner')
        cols = np.arange(nc)
        for name in self.frequency_names():
            self.add_output(name, units='Hz', desc=f'undamped {name[2:]} frequency')
            self.declare_partials(name, 'k_ride', rows=np.zeros(nc, dtype=int), cols=cols)

    def frequency_names(self) -> tuple[str, ...]:
        return ('f_heave', 'f_pitch') if self.options['pitch'] else ('f_heave',)

    def _modes(self, inputs: Mapping[str, Any]) -> tuple[np.ndarray, ...]:
        o = self.options
        return ride_modes(
            inputs['k_ride'], o['a'], o['sprung_mass'], o['pitch_inertia'], o['pitch']
        )

    def evaluate(self, inputs: Mapping[str, Any]) -> dict[str, np.ndarray]:
        f = self._modes(inputs)[0]
        return {name: f[i : i + 1] for i, name in enumerate(self.frequency_names())}

    def compute_partials(self, inputs, partials) -> None:
        f, V, B = self._modes(inputs)
        for i, name in enumerate(self.frequency_names()):
            partials[name, 'k_ride'] = (V[:, i] @ B) ** 2 / (8.0 * np.pi**2 * f[i])


# ---------------------------------------------------------------------------- closed loop
#: the smoothing of the slowest mode's real part [s]: the log-sum-exp of the real parts
#: exceeds their maximum by at most ``log(n) / SMOOTHING``
SMOOTHING = 10.0


def decay_rate(A: np.ndarray, smoothing: float = SMOOTHING) -> tuple[float, np.ndarray]:
    """The decay rate of the slowest mode of ``x' = A x``, smoothed: ``σ = -(1/β) log
    Σ_i exp(β Re λ_i)`` [1/s] with ``β`` = ``smoothing``, at most ``-max Re λ`` (positive:
    asymptotically stable), and its derivative with respect to ``A``'s entries,
    ``dσ/dA``: each simple eigenvalue's ``dλ_i = y_iᴴ dA x_i / y_iᴴ x_i`` (Lancaster,
    *On eigenvalues of matrices dependent on a parameter*, Numer. Math. 6, 1964) weighted
    by its softmax share. Unlike the maximum it stays differentiable where two modes'
    real parts cross (``docs/codesign.md``, "Unstable closed loops")."""
    import scipy.linalg

    w, vl, vr = scipy.linalg.eig(A, left=True, right=True)
    re = w.real
    top = re.max()
    share = np.exp(smoothing * (re - top))
    total = share.sum()
    sigma = -(top + np.log(total) / smoothing)
    share /= total
    scale = np.einsum('ij,ij->j', np.conj(vl), vr)  # y_iᴴ x_i
    # dRe λ_i / dA_kl = Re(conj(y_ki) x_li / y_iᴴ x_i); weighted by the shares
    grad = -np.einsum('i,ki,li->kl', share / scale, np.conj(vl), vr).real
    return float(sigma), grad


class DecayRateComp(_DesignComponent):
    """The smoothed decay rate of the slowest mode of the closed loop at the design
    (:func:`decay_rate`): its state matrix affine in the design variables, ``A(p) = A0 +
    Σ_i p_i A_i`` (:func:`suspopt.models.linear.affine_linearize`, or the mixed model's
    :func:`~suspopt.models.linear.affine_rest_jacobian`). Inputs: the design variables by
    name."""

    def initialize(self) -> None:
        self.options.declare('design', types=tuple, desc='design-variable names, in order')
        self.options.declare('units', types=tuple, desc='their units')
        self.options.declare('A0', types=np.ndarray, desc='A at zero design')
        self.options.declare('dA', types=np.ndarray, desc='dA/dp_i, (n_design, n, n)')

    def setup(self) -> None:
        o = self.options
        for name, unit in zip(o['design'], o['units']):
            self.add_input(name, units=unit, desc='design variable')
            self.declare_partials('decay', name, rows=[0], cols=[0])
        self.add_output('decay', units='1/s', desc='decay rate of the slowest mode')

    def _A(self, inputs: Mapping[str, Any]) -> np.ndarray:
        o = self.options
        p = np.array([float(np.asarray(inputs[n]).ravel()[0]) for n in o['design']])
        return o['A0'] + np.tensordot(p, o['dA'], axes=1)

    def evaluate(self, inputs: Mapping[str, Any]) -> dict[str, np.ndarray]:
        return {'decay': np.atleast_1d(decay_rate(self._A(inputs))[0])}

    def compute_partials(self, inputs, partials) -> None:
        grad = decay_rate(self._A(inputs))[1]
        for name, dA in zip(self.options['design'], self.options['dA']):
            partials['decay', name] = float(np.sum(grad * dA))
