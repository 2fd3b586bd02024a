"""How many Padé states a delay needs: the order chosen from an accuracy check
(docs/spectral.md).

Two checks of the RMS values of every output at one design:

``lyapunov``  self-convergence: the Lyapunov RMS at an order against the next order of
              :data:`PADE_ORDERS` (a few Lyapunov solves, milliseconds);
``spectral``  against the spectral integral with the delays exact
              (:func:`suspopt.spectral.integral.spectral_variances`, with the coherence
              approximation of the Lyapunov route so that only the delay's error is
              measured; about a second).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from suspopt.errors import ConfigError
from suspopt.spectral.integral import spectral_variances
from suspopt.spectral.lyapunov import StationaryModel
from suspopt.spectral.road import RandomRoad
from suspopt.spectral.system import AffineLinearSystem

#: Padé orders tried, in order (states per delayed track)
PADE_ORDERS = (2, 4, 6, 8, 12, 16, 24, 32, 48, 64)


@dataclass(frozen=True)
class PadeChoice:
    """The chosen ``order`` (0: no delayed corner), its estimated largest relative RMS
    error over the outputs ``error``, how it was estimated (``check``), and the estimate
    of every order tried (``errors``)."""

    order: int
    error: float
    check: str
    errors: dict[int, float] = field(default_factory=dict)


def rms_error(rms: np.ndarray, reference: np.ndarray, floor: np.ndarray | float = 0.0) -> float:
    """Largest relative difference of two RMS vectors, relative to ``max(reference,
    floor)`` (``floor``: below it an RMS is rounding, e.g.
    ``sqrt(StationaryModel.variance_rounding)``)."""
    den = np.maximum(reference, floor)
    den = np.where(den > 0.0, den, 1.0)
    return float(np.max(np.abs(rms - reference) / den))


def _lyapunov_rms(
    system: AffineLinearSystem, road: RandomRoad, p: np.ndarray, order: int
) -> tuple[np.ndarray, np.ndarray]:
    """RMS values and their rounding floors at Padé ``order``."""
    model = StationaryModel(system, road, order)
    return model.rms(p), np.sqrt(model.variance_rounding(p))


def choose_pade_order(
    system: AffineLinearSystem,
    road: RandomRoad,
    p: ArrayLike,
    *,
    rtol: float = 1e-4,
    check: str = 'lyapunov',
    orders: tuple[int, ...] = PADE_ORDERS,
) -> PadeChoice:
    """The smallest order of ``orders`` whose RMS values at design ``p`` are within
    ``rtol`` (relative, every output) of the reference of ``check`` (module docstring).
    Raises :class:`ConfigError` if none is."""
    if check not in ('lyapunov', 'spectral'):
        raise ConfigError(f"check: must be 'lyapunov' or 'spectral', got {check!r}")
    if not any(c.offset > 0.0 for c in system.corners):
        return PadeChoice(0, 0.0, check)
    pv = np.asarray(p, dtype=float)
    errors: dict[int, float] = {}
    if check == 'spectral':
        ref = np.sqrt(
            spectral_variances(system, road, pv, coherence='rational', rtol=min(1e-9, rtol / 100))
        )
        for order in orders:
            rms, floor = _lyapunov_rms(system, road, pv, order)
            errors[order] = rms_error(rms, ref, floor)
            if errors[order] <= rtol:
                return PadeChoice(order, errors[order], check, errors)
    else:
        prev = None
        for order in orders:
            rms, floor = _lyapunov_rms(system, road, pv, order)
            if prev is not None:
                errors[prev[0]] = rms_error(prev[1], rms, floor)
                if errors[prev[0]] <= rtol:
                    return PadeChoice(prev[0], errors[prev[0]], check, errors)
            prev = (order, rms)
    raise ConfigError(
        f'pade_order: no order of {list(orders)} reaches rtol = {rtol:g} '
        f'(errors {", ".join(f"{k}: {v:.2g}" for k, v in errors.items())})'
    )
