"""ISO 2631-1 frequency weightings as linear state-space filters (ride comfort).

ISO 2631-1:1997 Annex A (restated as ISO 8041-1:2017 formulae (1)-(5)) defines every
weighting as a product of at most four second-order factors in ``s = j 2π f``, with
``ω_i = 2π f_i``:

* band-limiting high pass ``H_h = s² / (s² + ω1/Q1 s + ω1²)``, ``Q1 = 1/√2``;
* band-limiting low pass ``H_l = ω2² / (s² + ω2/Q2 s + ω2²)``, ``Q2 = 1/√2``;
* acceleration-velocity transition
  ``H_t = (ω4²/ω3)(s + ω3) / (s² + ω4/Q4 s + ω4²)`` (``(1 + s/ω3)/(1 + s/(Q4 ω4) + s²/ω4²)``;
  ``ω4² / (…)`` when ``f3 = ∞``, absent when ``f4 = ∞`` too);
* upward step ``H_s = (s² + ω5/Q5 s + ω5²) / (s² + ω6/Q6 s + ω6²)``.

The standards write the step as ``(1 + s/(Q5 ω5) + s²/ω5²)/(1 + s/(Q6 ω6) + s²/ω6²)``
times ``(ω5/ω6)²``: the same function, whose gain goes from ``(f5/f6)²`` at low
frequency to 1 at high frequency (unity at high frequency is what makes Wk 1.054 at
6.3 Hz and 0.482 at 1 Hz in ISO 2631-1 Table 3). Parameters: ISO 2631-1:1997 Annex A,
ISO 8041-1:2017 Table 3 (reproduced in the Larson Davis HVM200 reference manual,
Table 3.1).

**Realization.** Each factor is one second-order section in scaled oscillator
coordinates: for the denominator ``s² + (ω0/Q) s + ω0²`` the states are ``q`` and
``q̇/ω0`` of ``q̈ + (ω0/Q) q̇ + ω0² q = ω0² u``, so

    A = ω0 [[0, 1], [-1, -1/Q]],   B = ω0 [0, 1]ᵀ,

and the numerator enters through ``C`` and ``D`` exactly. Both states have unit static
gain from the section's input and stay of the order of the input at every frequency
(their peak gain is of order one), each section's entries scale with its own ``ω0`` only,
and the sections are cascaded (low pass, high pass, transition, step), so the states of
a channel are all of the magnitude of the filtered signal. This is why it suits
collocation and Dymos state scaling; a companion form of the same eighth-order
polynomial would carry coefficients from 1 to products of eight corner frequencies. The
realization is exact: its transfer function is the standard's (tests compare both).

:func:`filter_bank` stacks several channels block-diagonally (e.g. several seats, plus
pitch and roll): channel ``k`` owns states ``offsets[k]:offsets[k + 1]``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike

from suspopt.errors import ConfigError

#: the Butterworth quality factor of both band-limiting filters (Q1 = Q2)
BUTTERWORTH_Q = 1.0 / math.sqrt(2.0)


def _frozen(a: ArrayLike) -> np.ndarray:
    out = np.array(a, dtype=float)
    out.setflags(write=False)
    return out


@dataclass(frozen=True, eq=False)
class StateSpace:
    """A linear system ``x' = A x + B u``, ``y = C x + D u`` (continuous time).

    Arrays are read-only. :meth:`rates` and :meth:`output` act on the last axis, so a
    (nodes, states) array of states and a (nodes, inputs) array of inputs give the values
    at every node at once."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray

    def __post_init__(self) -> None:
        for name in ('A', 'B', 'C', 'D'):
            object.__setattr__(self, name, _frozen(getattr(self, name)))
        n, m, p = self.A.shape[0], self.B.shape[1], self.C.shape[0]
        shapes = {'A': (n, n), 'B': (n, m), 'C': (p, n), 'D': (p, m)}
        for name, shape in shapes.items():
            if getattr(self, name).shape != shape:
                raise ValueError(f'{name}: shape {getattr(self, name).shape}, expected {shape}')

    @property
    def n_states(self) -> int:
        return self.A.shape[0]

    @property
    def n_inputs(self) -> int:
        return self.B.shape[1]

    @property
    def n_outputs(self) -> int:
        return self.C.shape[0]

    def rates(self, x: ArrayLike, u: ArrayLike) -> np.ndarray:
        """``A x + B u`` over the last axis of ``x`` (…, states) and ``u`` (…, inputs)."""
        return np.asarray(x) @ self.A.T + np.asarray(u) @ self.B.T

    def output(self, x: ArrayLike, u: ArrayLike) -> np.ndarray:
        """``C x + D u`` over the last axis of ``x`` (…, states) and ``u`` (…, inputs)."""
        return np.asarray(x) @ self.C.T + np.asarray(u) @ self.D.T

    def response(self, f: ArrayLike) -> np.ndarray:
        """The frequency response ``C (sI - A)⁻¹ B + D`` at ``s = j 2π f`` [Hz]:
        (frequencies, outputs, inputs), complex."""
        s = 2j * np.pi * np.atleast_1d(np.asarray(f, dtype=float))
        M = s[:, None, None] * np.eye(self.n_states) - self.A
        return self.C @ np.linalg.solve(M, np.broadcast_to(self.B, M.shape[:1] + self.B.shape)) + (
            self.D
        )

    def then(self, other: StateSpace) -> StateSpace:
        """The series connection: ``self``'s output drives ``other`` (states of ``self``
        first)."""
        n1 = self.n_states
        A = np.block(
            [
                [self.A, np.zeros((n1, other.n_states))],
                [other.B @ self.C, other.A],
            ]
        )
        B = np.vstack([self.B, other.B @ self.D])
        C = np.hstack([other.D @ self.C, other.C])
        return StateSpace(A, B, C, other.D @ self.D)

    @staticmethod
    def block_diagonal(systems: Sequence[StateSpace]) -> StateSpace:
        """Independent systems side by side: states, inputs and outputs concatenated."""

        def diag(mats: list[np.ndarray]) -> np.ndarray:
            rows, cols = sum(m.shape[0] for m in mats), sum(m.shape[1] for m in mats)
            out = np.zeros((rows, cols))
            r = c = 0
            for m in mats:
                out[r : r + m.shape[0], c : c + m.shape[1]] = m
                r, c = r + m.shape[0], c + m.shape[1]
            return out

        return StateSpace(
            diag([s.A for s in systems]),
            diag([s.B for s in systems]),
            diag([s.C for s in systems]),
            diag([s.D for s in systems]),
        )


@dataclass(frozen=True)
class Section:
    """One second-order factor ``H(s) = (b2 s² + b1 s + b0) / (s² + (ω0/Q) s + ω0²)``
    of a weighting (``kind``: ``low_pass``, ``high_pass``, ``transition`` or ``step``)."""

    kind: str
    b: tuple[float, float, float]
    w0: float
    Q: float

    @property
    def numerator(self) -> np.ndarray:
        """``(b2, b1, b0)``, descending powers of ``s``."""
        return np.array(self.b, dtype=float)

    @property
    def denominator(self) -> np.ndarray:
        """``(1, ω0/Q, ω0²)``, descending powers of ``s``."""
        return np.array([1.0, self.w0 / self.Q, self.w0**2])

    def response(self, s: ArrayLike) -> np.ndarray:
        """``H(s)`` at complex ``s`` [rad/s]."""
        s = np.asarray(s)
        b2, b1, b0 = self.b
        return (b2 * s * s + b1 * s + b0) / (s * s + (self.w0 / self.Q) * s + self.w0**2)

    @property
    def state_space(self) -> StateSpace:
        """The scaled oscillator realization (module docstring): states ``(q, q̇/ω0)``."""
        w, Q = self.w0, self.Q
        b2, b1, b0 = self.b
        return StateSpace(
            A=w * np.array([[0.0, 1.0], [-1.0, -1.0 / Q]]),
            B=np.array([[0.0], [w]]),
            C=np.array([[(b0 - b2 * w * w) / (w * w), (b1 - b2 * w / Q) / w]]),
            D=np.array([[b2]]),
        )


def _check_frequency(name: str, key: str, value: float | None) -> None:
    if value is not None and not (math.isfinite(value) and value > 0.0):
        raise ConfigError(f'{name}.{key}: must be a positive frequency in Hz or None, got {value}')


@dataclass(frozen=True)
class Weighting:
    """One ISO 2631-1 frequency weighting, by its Annex A parameters [Hz].

    ``None`` stands for the standard's ``∞`` (the factor is absent): ``f1``/``f2`` the
    band limits (``f2 = None`` drops the 100 Hz low pass, the one stiff factor, e.g. for
    Radau segments too long for it, see :mod:`suspopt.models.comfort`; the weighting then
    departs from the standard by that low pass alone);
    ``f3``, ``f4``, ``Q4`` the acceleration-velocity transition; ``f5``, ``Q5``, ``f6``,
    ``Q6`` the upward step. Build variants with :func:`dataclasses.replace`."""

    name: str
    f1: float | None = 0.4
    f2: float | None = 100.0
    f3: float | None = None
    f4: float | None = None
    Q4: float = 1.0
    f5: float | None = None
    Q5: float = 1.0
    f6: float | None = None
    Q6: float = 1.0

    def __post_init__(self) -> None:
        for key in ('f1', 'f2', 'f3', 'f4', 'f5', 'f6'):
            _check_frequency(self.name, key, getattr(self, key))
        for key in ('Q4', 'Q5', 'Q6'):
            q = getattr(self, key)
            if not (math.isfinite(q) and q > 0.0):
                raise ConfigError(f'{self.name}.{key}: must be > 0, got {q}')
        if self.f3 is not None and self.f4 is None:
            raise ConfigError(f'{self.name}.f4: a transition with finite f3 needs f4')
        if (self.f5 is None) != (self.f6 is None):
            raise ConfigError(f'{self.name}.f5, f6: the upward step needs both or neither')

    @cached_property
    def sections(self) -> tuple[Section, ...]:
        """The second-order factors in cascade order: low pass, high pass, transition,
        step (those present)."""
        w = {
            k: 2.0 * math.pi * v
            for k in ('f1', 'f2', 'f3', 'f4', 'f5', 'f6')
            if (v := getattr(self, k)) is not None
        }
        out = []
        if 'f2' in w:
            out.append(Section('low_pass', (0.0, 0.0, w['f2'] ** 2), w['f2'], BUTTERWORTH_Q))
        if 'f1' in w:
            out.append(Section('high_pass', (1.0, 0.0, 0.0), w['f1'], BUTTERWORTH_Q))
        if 'f4' in w:
            w4 = w['f4']
            b1 = w4 * w4 / w['f3'] if 'f3' in w else 0.0
            out.append(Section('transition', (0.0, b1, w4 * w4), w4, self.Q4))
        if 'f5' in w:
            w5 = w['f5']
            out.append(Section('step', (1.0, w5 / self.Q5, w5 * w5), w['f6'], self.Q6))
        return tuple(out)

    @property
    def n_states(self) -> int:
        return 2 * len(self.sections)

    @property
    def state_labels(self) -> tuple[str, ...]:
        """One label per state, in order: ``<section>.q`` and ``<section>.qdot/w0``."""
        return tuple(f'{s.kind}.{c}' for s in self.sections for c in ('q', 'qdot/w0'))

    def transfer_function(self) -> tuple[np.ndarray, np.ndarray]:
        """``(numerator, denominator)`` in descending powers of ``s`` [rad/s]: the
        product of the sections' polynomials."""
        num, den = np.ones(1), np.ones(1)
        for sec in self.sections:
            num, den = np.polymul(num, sec.numerator), np.polymul(den, sec.denominator)
        return np.trim_zeros(num, 'f'), den

    def response(self, f: ArrayLike) -> np.ndarray:
        """The complex weighting at frequencies ``f`` [Hz] (product of the sections)."""
        s = 2j * np.pi * np.asarray(f, dtype=float)
        out = np.ones_like(s)
        for sec in self.sections:
            out = out * sec.response(s)
        return out

    def magnitude(self, f: ArrayLike) -> np.ndarray:
        """The weighting factor ``|W(j 2π f)|`` at frequencies ``f`` [Hz]."""
        return np.abs(self.response(f))

    @cached_property
    def state_space(self) -> StateSpace:
        """The cascade realization (module docstring), one input, one output."""
        systems = [sec.state_space for sec in self.sections]
        if not systems:  # every factor absent: the identity
            return StateSpace(np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.eye(1))
        ss = systems[0]
        for nxt in systems[1:]:
            ss = ss.then(nxt)
        return ss


#: ISO 2631-1:1997 Annex A / ISO 8041-1:2017 Table 3. Wk: vertical (z) on the seat and
#: for standing or recumbent persons; Wd: horizontal (x, y); We: rotational (all
#: directions, seat); Wc: seat-back x; Wj: head of a recumbent person.
WK = Weighting('Wk', f3=12.5, f4=12.5, Q4=0.63, f5=2.37, Q5=0.91, f6=3.35, Q6=0.91)
WD = Weighting('Wd', f3=2.0, f4=2.0, Q4=0.63)
WE = Weighting('We', f3=1.0, f4=1.0, Q4=0.63)
WC = Weighting('Wc', f3=8.0, f4=8.0, Q4=0.63)
WJ = Weighting('Wj', f5=3.75, Q5=0.91, f6=5.32, Q6=0.91)

WEIGHTINGS: dict[str, Weighting] = {w.name: w for w in (WK, WD, WE, WC, WJ)}
#: Wk as suspopt's comfort metric uses it in every method (collocation, time marching,
#: spectral): without the 100 Hz band-limiting low pass, whose pole (628 rad/s) would make
#: Radau collocation unstable on any grid that resolves the vehicle; below 20 Hz, where a
#: vehicle's body responds, it differs from Wk by less than 0.1 % (tests/models)
WK_RIDE = dataclasses.replace(WK, name='Wk (ride)', f2=None)


def weighting(spec: str | Weighting, key: str = 'weighting') -> Weighting:
    """The weighting named ``spec`` (``Wk``, ``Wd``, ``We``, ``Wc``, ``Wj``; any case) or
    ``spec`` itself; ``key`` names the setting in the error message."""
    if isinstance(spec, Weighting):
        return spec
    by_lower = {k.lower(): w for k, w in WEIGHTINGS.items()}
    if not isinstance(spec, str) or spec.lower() not in by_lower:
        raise ConfigError(
            f'{key}: unknown ISO 2631-1 weighting {spec!r}; one of {", ".join(WEIGHTINGS)}'
        )
    return by_lower[spec.lower()]


@dataclass(frozen=True, eq=False)
class FilterBank:
    """Several weighting filters side by side, one input and one output per channel:
    ``system`` is block diagonal, channel ``k`` owning states ``offsets[k]:offsets[k+1]``
    (its sections in cascade order, see :attr:`Weighting.state_labels`)."""

    weightings: tuple[Weighting, ...]
    system: StateSpace
    offsets: tuple[int, ...]

    @property
    def channels(self) -> int:
        return len(self.weightings)

    @property
    def n_states(self) -> int:
        return self.system.n_states

    def states_of(self, channel: int) -> slice:
        return slice(self.offsets[channel], self.offsets[channel + 1])

    @property
    def state_labels(self) -> tuple[str, ...]:
        """``<channel>:<weighting>.<section>.<state>`` for every state, in order."""
        return tuple(
            f'{k}:{w.name}.{label}'
            for k, w in enumerate(self.weightings)
            for label in w.state_labels
        )


def filter_bank(weightings: Sequence[str | Weighting], key: str = 'weightings') -> FilterBank:
    """The block-diagonal realization of one filter channel per entry of
    ``weightings`` (names or :class:`Weighting`)."""
    ws = tuple(weighting(w, f'{key}[{k}]') for k, w in enumerate(weightings))
    if not ws:
        raise ConfigError(f'{key}: at least one weighting channel is needed')
    offsets = tuple(int(x) for x in np.cumsum([0] + [w.n_states for w in ws]))
    return FilterBank(ws, StateSpace.block_diagonal([w.state_space for w in ws]), offsets)
