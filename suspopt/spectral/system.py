"""A linear vehicle whose matrices are affine in the design (docs/spectral.md).

    x' = A(p) x + B(p) δ,    y = C(p) x + D(p) δ,
    A(p) = A0 + Σ_i p_i A_i  (and likewise B, C, D),

``x`` the states (vehicle, and any output filters such as the ISO 2631-1 weightings),
``δ`` the road heights under the corners [m] (one column of ``B``/``D`` per corner), ``y``
the named outputs. Spring rates, damping rates and anti-roll-bar rates enter the forces
linearly, so every low-fidelity vehicle of suspopt (eqs. 5-10 of the paper, the full car's
roll and anti-roll bars) is of this form with ``p`` the design variables.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from suspopt.errors import ConfigError


@dataclass(frozen=True)
class RoadCorner:
    """Where a corner's wheel meets the road: its ``track`` (0 left or only, 1 right) and
    its ``offset`` behind the front axle [m]; at speed ``v`` it sees the road ``offset/v``
    seconds after the front wheel of its track."""

    track: int = 0
    offset: float = 0.0

    def delay(self, speed: float) -> float:
        """The corner's road delay behind the front axle [s]."""
        return self.offset / speed


def _matrix(value: ArrayLike, name: str, shape: tuple[int, ...]) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.shape != shape:
        raise ConfigError(f'{name}: must have shape {shape}, got {arr.shape}')
    if not np.all(np.isfinite(arr)):
        raise ConfigError(f'{name}: contains NaN or inf')
    arr = arr.copy()
    arr.flags.writeable = False
    return arr


@dataclass(frozen=True, eq=False)
class AffineLinearSystem:
    """The matrices of ``x' = A x + B δ, y = C x + D δ`` at ``p = 0`` (``A0`` … ``D0``) and
    their derivatives with respect to each design variable (stacks ``dA`` (n_p, n, n),
    ``dB`` (n_p, n, m), ``dC`` (n_p, n_y, n), ``dD`` (n_p, n_y, m)).

    ``design`` names the design variables (n_p), ``outputs`` the rows of ``C``/``D``
    (n_y), ``corners`` the columns of ``B``/``D`` (m). Units are the caller's, SI
    throughout suspopt: states and outputs in m, rad, m/s, N, …; ``δ`` in m. Build it with
    :func:`affine_system`, which takes the derivative matrices by design variable and
    fills the missing ones with zeros.
    """

    A0: np.ndarray
    B0: np.ndarray
    C0: np.ndarray
    D0: np.ndarray
    dA: np.ndarray
    dB: np.ndarray
    dC: np.ndarray
    dD: np.ndarray
    design: tuple[str, ...]
    outputs: tuple[str, ...]
    corners: tuple[RoadCorner, ...] = field(default=(RoadCorner(),))

    def __post_init__(self) -> None:
        A0 = np.asarray(self.A0, dtype=float)
        if A0.ndim != 2 or A0.shape[0] != A0.shape[1]:
            raise ConfigError(f'A0: must be a square matrix, got shape {A0.shape}')
        n, m, ny, n_p = A0.shape[0], len(self.corners), len(self.outputs), len(self.design)
        if len(set(self.outputs)) != ny:
            raise ConfigError(f'outputs: names must be unique, got {list(self.outputs)}')
        if len(set(self.design)) != n_p:
            raise ConfigError(f'design: names must be unique, got {list(self.design)}')
        for i, c in enumerate(self.corners):
            if c.track not in (0, 1):
                raise ConfigError(f'corners[{i}].track: must be 0 or 1, got {c.track}')
            if not (np.isfinite(c.offset) and c.offset >= 0.0):
                raise ConfigError(f'corners[{i}].offset: must be >= 0 m, got {c.offset}')
        shapes = {
            'A0': (n, n),
            'B0': (n, m),
            'C0': (ny, n),
            'D0': (ny, m),
        }
        for name, shape in shapes.items():
            object.__setattr__(self, name, _matrix(getattr(self, name), name, shape))
            d = 'd' + name[0]
            object.__setattr__(self, d, _matrix(getattr(self, d), d, (n_p, *shape)))
        object.__setattr__(self, 'design', tuple(self.design))
        object.__setattr__(self, 'outputs', tuple(self.outputs))
        object.__setattr__(self, 'corners', tuple(self.corners))

    @property
    def n_states(self) -> int:
        return self.A0.shape[0]

    @property
    def n_corners(self) -> int:
        return len(self.corners)

    @property
    def n_design(self) -> int:
        return len(self.design)

    def design_vector(
        self, values: Mapping[str, float] | ArrayLike, where: str = 'p'
    ) -> np.ndarray:
        """The design as a vector in :attr:`design` order, from a mapping by name (every
        name required) or an array of length n_p."""
        if isinstance(values, Mapping):
            missing = [k for k in self.design if k not in values]
            unknown = [k for k in values if k not in self.design]
            if unknown:
                raise ConfigError(
                    f'{where}.{unknown[0]}: not a design variable (they are '
                    f'{", ".join(self.design)})'
                )
            if missing:
                raise ConfigError(f'{where}.{missing[0]}: missing')
            vec = np.array([values[k] for k in self.design])
        else:
            vec = np.asarray(values)
            if vec.shape != (self.n_design,):
                raise ConfigError(
                    f'{where}: must have {self.n_design} entries ({", ".join(self.design)}), '
                    f'got shape {vec.shape}'
                )
        return vec

    def matrices(self, p: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``A(p), B(p), C(p), D(p)`` (complex ``p`` gives complex matrices: the
        complex-step Hessian uses it)."""
        p = np.asarray(p)
        return (
            self.A0 + np.tensordot(p, self.dA, axes=1),
            self.B0 + np.tensordot(p, self.dB, axes=1),
            self.C0 + np.tensordot(p, self.dC, axes=1),
            self.D0 + np.tensordot(p, self.dD, axes=1),
        )

    def select_outputs(self, names: Sequence[str]) -> AffineLinearSystem:
        """The same system with only the outputs ``names`` (in that order)."""
        rows = [self.output_index(n) for n in names]
        return AffineLinearSystem(
            self.A0,
            self.B0,
            self.C0[rows],
            self.D0[rows],
            self.dA,
            self.dB,
            self.dC[:, rows],
            self.dD[:, rows],
            design=self.design,
            outputs=tuple(names),
            corners=self.corners,
        )

    def output_index(self, name: str, where: str = 'outputs') -> int:
        try:
            return self.outputs.index(name)
        except ValueError:
            raise ConfigError(
                f'{where}.{name}: not an output (they are {", ".join(self.outputs)})'
            ) from None


def affine_system(
    base: Mapping[str, ArrayLike],
    terms: Mapping[str, Mapping[str, ArrayLike]],
    outputs: Sequence[str],
    corners: Sequence[RoadCorner] = (RoadCorner(),),
) -> AffineLinearSystem:
    """An :class:`AffineLinearSystem` from ``base = {'A': A0, 'B': B0, 'C': C0, 'D': D0}``
    (``D`` may be left out: zero) and ``terms = {design name: {'A': A_i, 'C': C_i, …}}``
    (missing matrices are zero), design variables in the order of ``terms``."""
    for key in base:
        if key not in 'ABCD' or len(key) != 1:
            raise ConfigError(f'base.{key}: must be one of A, B, C, D')
    if 'A' not in base:
        raise ConfigError('base.A: missing')
    A0 = np.asarray(base['A'], dtype=float)
    n = A0.shape[0] if A0.ndim == 2 else 0
    m, ny = len(corners), len(outputs)
    shape = {'A': (n, n), 'B': (n, m), 'C': (ny, n), 'D': (ny, m)}
    mats = {k: np.asarray(base.get(k, np.zeros(shape[k])), dtype=float) for k in 'ABCD'}
    stacks = {k: np.zeros((len(terms), *shape[k])) for k in 'ABCD'}
    for i, (name, t) in enumerate(terms.items()):
        for key, val in t.items():
            if key not in shape:
                raise ConfigError(f'terms.{name}.{key}: must be one of A, B, C, D')
            arr = np.asarray(val, dtype=float)
            if arr.shape != shape[key]:
                raise ConfigError(
                    f'terms.{name}.{key}: must have shape {shape[key]}, got {arr.shape}'
                )
            stacks[key][i] = arr
    return AffineLinearSystem(
        mats['A'],
        mats['B'],
        mats['C'],
        mats['D'],
        stacks['A'],
        stacks['B'],
        stacks['C'],
        stacks['D'],
        design=tuple(terms),
        outputs=tuple(outputs),
        corners=tuple(corners),
    )
