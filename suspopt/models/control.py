"""Controlled suspensions (``docs/codesign.md``): an active actuator or a semi-active
damper at some corners, in parallel with the passive spring-damper, and the
state-feedback laws that drive them.

Each is one equation, a component of the vehicle assembly (:mod:`suspopt.models.assembly`):

* :class:`StrutRateComp` — the suspension's compression rate ``v_A = v_W - v_M`` (bump +;
  the low-fidelity model; the multibody module gives its spring's own rate);
* :class:`ActiveForceComp` — the actuator force ``u`` (a Dymos control, or a feedback law's
  output) and its power ``P = u v_A``;
* :class:`VariableDamperComp` — the semi-active damper's force ``c(t) v_A`` (it can only
  dissipate: ``P = c v_A² >= 0``);
* :class:`LinearFeedbackComp` — an active force from measurable signals,
  ``u = -g_sky v_M + g_gnd v_W + g_tr s + g_rt (v_W - v_M)``;
* :class:`SkyGroundhookComp` — a semi-active damper's coefficient from the hybrid
  skyhook-groundhook demand ``F = -g_sky v_M + g_gnd v_W``, ``c = sat(F v_A / (v_A² +
  ε²))`` clipped smoothly to ``[c_min, c_max]`` (:func:`smooth_clip`).

Signs: every actuator force ``F_A`` acts like the suspension force ``F_S`` (eq. 9): up on
the chassis, down on the wheel, along the suspension's line; ``v_M`` is the chassis above
the corner, ``v_W`` the wheel (``wheel_v``), ``s`` the travel (bump +). The controlled
corners are the option ``controlled`` (their indices); per-controlled-corner signals have
shape (nodes, controlled corners), the forces on the vehicle (nodes, corners), zero at a
corner without an actuator.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from suspopt.models.base import NodeComponent


def smooth_clip(x: np.ndarray, lo: float, hi: float, width: float) -> np.ndarray:
    """``x`` clipped smoothly to ``(lo, hi)``: ``lo + s(x - lo) - s(x - hi)`` with the
    smooth ramp ``s(z) = (z + sqrt(z² + w²)) / 2`` (a C-infinity ``max(z, 0)``, within
    ``w / 2`` of it). Strictly inside ``(lo, hi)`` for any ``x`` (``s`` has slope in
    (0, 1)); equal to ``x`` up to ``w² / (4 d)`` at a distance ``d`` from both bounds."""
    return lo + _ramp(x - lo, width) - _ramp(x - hi, width)


def smooth_clip_slope(x: np.ndarray, lo: float, hi: float, width: float) -> np.ndarray:
    """``d smooth_clip / dx``."""
    return _ramp_slope(x - lo, width) - _ramp_slope(x - hi, width)


def _ramp(z: np.ndarray, w: float) -> np.ndarray:
    return 0.5 * (z + np.sqrt(z * z + w * w))


def _ramp_slope(z: np.ndarray, w: float) -> np.ndarray:
    return 0.5 * (1.0 + z / np.sqrt(z * z + w * w))


def skyhook_demand(g_sky: Any, g_gnd: Any, v_M: Any, v_W: Any) -> np.ndarray:
    """The hybrid skyhook-groundhook force on the chassis, ``-g_sky v_M + g_gnd v_W``: a
    damper to the sky on the body, one to the ground on the wheel (Karnopp, Crosby &
    Harwood, J. Eng. Ind. 96(2), 1974; Valášek et al., Veh. Syst. Dyn. 28, 1997)."""
    return -np.asarray(g_sky) * v_M + np.asarray(g_gnd) * v_W


def saturate(x: np.ndarray, limits: tuple[float, float] | None) -> np.ndarray:
    """``x`` within the hardware's ``limits`` (None: none): what an actuator or damper
    commanded beyond its range gives. Where the optimizer sets the command (the nodes,
    strictly inside its bounds) this is the identity; between the nodes, where a
    polynomial through bang-bang values overshoots, it is the hardware's limit."""
    if limits is None:
        return x
    lo, hi = limits
    return np.where(x.real < lo, lo, np.where(x.real > hi, hi, x))


def saturate_slope(x: np.ndarray, limits: tuple[float, float] | None) -> np.ndarray:
    """``d saturate / dx``: 1 within the limits, 0 beyond."""
    if limits is None:
        return np.ones(x.shape)
    return ((x.real >= limits[0]) & (x.real <= limits[1])).astype(float)


class ControlComponent(NodeComponent):
    """Shared options and partial patterns of the controlled corners."""

    def initialize(self) -> None:
        super().initialize()
        self.options.declare('controlled', types=tuple, desc='indices of the controlled corners')
        self.options.declare(
            'limits',
            types=tuple,
            default=None,
            allow_none=True,
            desc="the hardware's range of the command (saturation); None: unlimited",
        )

    @property
    def _idx(self) -> np.ndarray:
        return np.asarray(self.options['controlled'], dtype=int)

    @property
    def _nk(self) -> int:
        return len(self.options['controlled'])

    def _picked(self, value: Any) -> np.ndarray:
        """The controlled corners' columns of a (nodes, corners) signal."""
        return np.asarray(value)[:, self._idx]

    def _scattered(self, value: np.ndarray) -> np.ndarray:
        """A (nodes, controlled) signal spread to (nodes, corners), zero elsewhere."""
        nc = self.options['corners']
        out = np.zeros(value.shape[:1] + (nc,), dtype=value.dtype)
        out[:, self._idx] = value
        return out

    def _pick_partials(self, of: str, wrt: str) -> None:
        """(nodes, controlled) output of a (nodes, corners) input."""
        nn, nc = self._shape
        node = np.arange(nn)[:, None]
        self.declare_partials(
            of, wrt, rows=np.arange(nn * self._nk), cols=(node * nc + self._idx).ravel()
        )

    def _scatter_partials(self, of: str, wrt: str) -> None:
        """(nodes, corners) output of a (nodes, controlled) input."""
        nn, nc = self._shape
        node = np.arange(nn)[:, None]
        self.declare_partials(
            of, wrt, rows=(node * nc + self._idx).ravel(), cols=np.arange(nn * self._nk)
        )

    def _own_partials(self, of: str, wrt: str) -> None:
        """(nodes, controlled) output of a (nodes, controlled) input, entry by entry."""
        self.declare_partials(of, wrt, diagonal=True)

    def _gain_partials(self, of: str, wrt: str) -> None:
        """(nodes, controlled) output of a per-corner (corners,) setting."""
        nn = self.options['num_nodes']
        self.declare_partials(of, wrt, rows=np.arange(nn * self._nk), cols=np.tile(self._idx, nn))


class StrutRateComp(NodeComponent):
    """The suspension's compression rate at every corner (bump +), ``v_A = v_W - v_M``:
    the relative velocity across an actuator or damper in parallel with the spring-damper
    of eq. 9."""

    def setup(self) -> None:
        nn, nc = self._shape
        self.add_input('v_W', shape=(nn, nc), units='m/s', desc='wheel velocity, up')
        self.add_input('v_M', shape=(nn, nc), units='m/s', desc='chassis above the corner, up')
        self.add_output('v_A', shape=(nn, nc), units='m/s', desc='compression rate, bump +')
        self._corner_partials('v_A', 'v_W', val=np.ones(nn * nc))
        self._corner_partials('v_A', 'v_M', val=-np.ones(nn * nc))

    def evaluate(self, inputs: Mapping[str, Any]) -> dict[str, np.ndarray]:
        return {'v_A': np.asarray(inputs['v_W']) - np.asarray(inputs['v_M'])}


class ActiveForceComp(ControlComponent):
    """An actuator force ``u`` at each controlled corner (``u_A``: a Dymos control or a
    feedback law's output, saturated at the actuator's ``limits``, :func:`saturate`):
    ``F_A`` on the vehicle (zero elsewhere), the actuator's force ``u_F = u`` (its square
    is the control effort) and the power it absorbs, ``P_A = u v_A`` (negative while it
    drives the suspension)."""

    def setup(self) -> None:
        nn, nc = self._shape
        nk = self._nk
        self.add_input('u_A', shape=(nn, nk), units='N', desc='actuator force (control)')
        self.add_input('v_A', shape=(nn, nc), units='m/s', desc='compression rate, bump +')
        self.add_output('F_A', shape=(nn, nc), units='N', desc='actuator force on the chassis, up')
        self.add_output('u_F', shape=(nn, nk), units='N', desc='actuator force')
        self.add_output('P_A', shape=(nn, nk), units='W', desc='power absorbed')
        self._scatter_partials('F_A', 'u_A')
        self._own_partials('u_F', 'u_A')
        self._own_partials('P_A', 'u_A')
        self._pick_partials('P_A', 'v_A')

    def evaluate(self, inputs: Mapping[str, Any]) -> dict[str, np.ndarray]:
        u = saturate(np.asarray(inputs['u_A']), self.options['limits'])
        return {
            'F_A': self._scattered(u),
            'u_F': u.copy(),
            'P_A': u * self._picked(inputs['v_A']),
        }

    def compute_partials(self, inputs, partials) -> None:
        raw = np.asarray(inputs['u_A'])
        u, ds = saturate(raw, self.options['limits']), saturate_slope(raw, self.options['limits'])
        partials['F_A', 'u_A'] = ds.ravel()
        partials['u_F', 'u_A'] = ds.ravel()
        partials['P_A', 'u_A'] = (ds * self._picked(inputs['v_A'])).ravel()
        partials['P_A', 'v_A'] = u.ravel()


class VariableDamperComp(ControlComponent):
    """A semi-active damper of coefficient ``c(t)`` (``c_A``, saturated at its range
    ``limits`` = (c_min, c_max), :func:`saturate`) at each controlled corner: its force
    ``u_F = c v_A`` (``F_A`` on the vehicle, zero elsewhere) and the power it dissipates,
    ``P_A = c v_A² >= 0``."""

    def setup(self) -> None:
        nn, nc = self._shape
        nk = self._nk
        self.add_input('c_A', shape=(nn, nk), units='N*s/m', desc='damping (control)')
        self.add_input('v_A', shape=(nn, nc), units='m/s', desc='compression rate, bump +')
        self.add_output('F_A', shape=(nn, nc), units='N', desc='damper force on the chassis, up')
        self.add_output('u_F', shape=(nn, nk), units='N', desc='damper force')
        self.add_output('P_A', shape=(nn, nk), units='W', desc='power dissipated')
        self._scatter_partials('F_A', 'c_A')
        # F_A at a controlled entry depends on v_A at that entry only
        entries = (np.arange(nn)[:, None] * nc + self._idx).ravel()
        self.declare_partials('F_A', 'v_A', rows=entries, cols=entries)
        self._own_partials('u_F', 'c_A')
        self._own_partials('P_A', 'c_A')
        self._pick_partials('u_F', 'v_A')
        self._pick_partials('P_A', 'v_A')

    def evaluate(self, inputs: Mapping[str, Any]) -> dict[str, np.ndarray]:
        c = saturate(np.asarray(inputs['c_A']), self.options['limits'])
        v = self._picked(inputs['v_A'])
        F = c * v
        return {'F_A': self._scattered(F), 'u_F': F, 'P_A': F * v}

    def compute_partials(self, inputs, partials) -> None:
        raw = np.asarray(inputs['c_A'])
        c, ds = saturate(raw, self.options['limits']), saturate_slope(raw, self.options['limits'])
        v = self._picked(inputs['v_A'])
        partials['F_A', 'c_A'] = (ds * v).ravel()
        partials['F_A', 'v_A'] = c.ravel()
        partials['u_F', 'c_A'] = (ds * v).ravel()
        partials['u_F', 'v_A'] = c.ravel()
        partials['P_A', 'c_A'] = (ds * v * v).ravel()
        partials['P_A', 'v_A'] = (2.0 * c * v).ravel()


#: the measured signals of the feedback laws: (input, units, description)
_MEASURED = (
    ('z_M', 'm', 'chassis above the corner'),
    ('v_M', 'm/s', 'its velocity'),
    ('wheel_z', 'm', 'wheel displacement'),
    ('wheel_v', 'm/s', 'wheel velocity'),
)


class LinearFeedbackComp(ControlComponent):
    """An active force by state feedback on what a suspension can measure at its corner
    (body and wheel accelerometers integrated, a travel sensor):

        u = -g_sky v_M + g_gnd v_W + g_tr (z_W - z_M) + g_rt (v_W - v_M),

    the gains per corner (design variables: ``docs/codesign.md``). The tyre deflection,
    which an optimal full-state law would also feed back, is not measured."""

    GAINS = (('g_sky', 'N*s/m'), ('g_gnd', 'N*s/m'), ('g_tr', 'N/m'), ('g_rt', 'N*s/m'))

    def setup(self) -> None:
        nn, nc = self._shape
        for name, units, desc in _MEASURED:
            self.add_input(name, shape=(nn, nc), units=units, desc=desc)
        for name, units in self.GAINS:
            self.add_input(name, shape=(nc,), units=units, desc='feedback gain per corner')
        self.add_output('u_A', shape=(nn, self._nk), units='N', desc='actuator force')
        for name, _, _ in _MEASURED:
            self._pick_partials('u_A', name)
        for name, _ in self.GAINS:
            self._gain_partials('u_A', name)

    def _signals(self, inputs: Mapping[str, Any]) -> dict[str, np.ndarray]:
        """The gains' signals at the controlled corners."""
        z_M, v_M = self._picked(inputs['z_M']), self._picked(inputs['v_M'])
        z_W, v_W = self._picked(inputs['wheel_z']), self._picked(inputs['wheel_v'])
        return {'g_sky': -v_M, 'g_gnd': v_W, 'g_tr': z_W - z_M, 'g_rt': v_W - v_M}

    def evaluate(self, inputs: Mapping[str, Any]) -> dict[str, np.ndarray]:
        y = self._signals(inputs)
        u = sum(np.asarray(inputs[g])[self._idx] * y[g] for g, _ in self.GAINS)
        return {'u_A': np.asarray(u)}

    def compute_partials(self, inputs, partials) -> None:
        nn = self.options['num_nodes']
        g = {n: np.tile(np.asarray(inputs[n])[self._idx], nn) for n, _ in self.GAINS}
        partials['u_A', 'z_M'] = -g['g_tr']
        partials['u_A', 'wheel_z'] = g['g_tr']
        partials['u_A', 'v_M'] = -g['g_sky'] - g['g_rt']
        partials['u_A', 'wheel_v'] = g['g_gnd'] + g['g_rt']
        for name, y in self._signals(inputs).items():
            partials['u_A', name] = y.ravel()


class SkyGroundhookComp(ControlComponent):
    """A semi-active damper's coefficient by the hybrid skyhook-groundhook law: the damper
    realizes the demanded force ``F = -g_sky v_M + g_gnd v_W`` (:func:`skyhook_demand`)
    where it can, ``c = F / v_A`` within ``[c_min, c_max]``, written smoothly:

        c = smooth_clip(F v_A / (v_A² + ε²), c_min, c_max, w),

    ``ε`` the ``velocity_floor`` (the quotient is regularized where the damper hardly
    moves), ``w`` the clip's width, ``smoothing × (c_max - c_min)``. Where the demand and
    the damper's motion disagree in sign (a damper cannot push), the quotient is negative
    and ``c`` goes to ``c_min``; where the demand exceeds what ``c_max`` gives, to
    ``c_max``: the continuous clipped-skyhook law, differentiable in states and gains."""

    def initialize(self) -> None:
        super().initialize()
        self.options.declare('c_min', types=float, desc='lowest damping [N s/m]')
        self.options.declare('c_max', types=float, desc='highest damping [N s/m]')
        self.options.declare('smoothing', types=float, default=0.02, desc='clip width / range')
        self.options.declare('velocity_floor', types=float, default=0.005, desc='ε [m/s]')

    def setup(self) -> None:
        nn, nc = self._shape
        self.add_input('v_M', shape=(nn, nc), units='m/s', desc='chassis above the corner')
        self.add_input('wheel_v', shape=(nn, nc), units='m/s', desc='wheel velocity')
        self.add_input('v_A', shape=(nn, nc), units='m/s', desc='compression rate, bump +')
        for name in ('g_sky', 'g_gnd'):
            self.add_input(name, shape=(nc,), units='N*s/m', desc='feedback gain per corner')
        self.add_output('c_A', shape=(nn, self._nk), units='N*s/m', desc='damping')
        for name in ('v_M', 'wheel_v', 'v_A'):
            self._pick_partials('c_A', name)
        for name in ('g_sky', 'g_gnd'):
            self._gain_partials('c_A', name)

    def _parts(self, inputs: Mapping[str, Any]):
        o = self.options
        idx = self._idx
        v_M, v_W, v = (self._picked(inputs[n]) for n in ('v_M', 'wheel_v', 'v_A'))
        g_sky, g_gnd = np.asarray(inputs['g_sky'])[idx], np.asarray(inputs['g_gnd'])[idx]
        F = skyhook_demand(g_sky, g_gnd, v_M, v_W)
        eps2 = o['velocity_floor'] ** 2
        den = v * v + eps2
        quotient = F * v / den
        width = o['smoothing'] * (o['c_max'] - o['c_min'])
        return v_M, v_W, v, F, den, eps2, quotient, width

    def evaluate(self, inputs: Mapping[str, Any]) -> dict[str, np.ndarray]:
        o = self.options
        *_, quotient, width = self._parts(inputs)
        return {'c_A': smooth_clip(quotient, o['c_min'], o['c_max'], width)}

    def compute_partials(self, inputs, partials) -> None:
        o = self.options
        v_M, v_W, v, F, den, eps2, quotient, width = self._parts(inputs)
        dc = smooth_clip_slope(quotient, o['c_min'], o['c_max'], width)
        dq_dF = v / den
        dq_dv = F * (eps2 - v * v) / (den * den)
        nn = self.options['num_nodes']
        g_sky = np.tile(np.asarray(inputs['g_sky'])[self._idx], nn).reshape(v.shape)
        g_gnd = np.tile(np.asarray(inputs['g_gnd'])[self._idx], nn).reshape(v.shape)
        partials['c_A', 'v_M'] = (dc * dq_dF * -g_sky).ravel()
        partials['c_A', 'wheel_v'] = (dc * dq_dF * g_gnd).ravel()
        partials['c_A', 'v_A'] = (dc * dq_dv).ravel()
        partials['c_A', 'g_sky'] = (dc * dq_dF * -v_M).ravel()
        partials['c_A', 'g_gnd'] = (dc * dq_dF * v_W).ravel()
