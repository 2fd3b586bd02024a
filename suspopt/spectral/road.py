"""The stationary road input: an ISO 8608 road of a class, driven at constant speed
(docs/spectral.md).

ISO 8608 gives the one-sided displacement PSD in the spatial frequency ``n`` [cycle/m],
``G_d(n) = G_d(n0) (n/n0)^-2`` with ``n0 = 0.1`` cycle/m (waviness 2); the class values
``G_d(n0)`` are :data:`suspopt.road.ISO8608_CLASSES`. Its slope PSD ``(2π n)² G_d(n)`` is
constant, so at speed ``v`` the road *velocity* ``dδ/dt`` under a wheel is white noise of
one-sided PSD (in Hz)

    W = 4π² G_d(n0) n0² v    [m²/s² per Hz = m²/s].

A white noise ``u`` with ``E[u(t) u(t+τ)] = q δ(τ)`` has the two-sided PSD ``q`` in Hz,
one-sided ``2q``: the intensity of the Lyapunov equation is therefore ``q = W/2``
(:meth:`RandomRoad.velocity_intensity`). In rad/s the two-sided height PSD is
``S_δ(ω) = q / (2π ω²)`` (:meth:`RandomRoad.height_psd`), which integrates to the same
variances as ``W`` over Hz.

The two wheel tracks of a full car (``tracks``):

``identical``    the same profile under both (coherence 1);
``independent``  two independent profiles of the same PSD (coherence 0);
``isotropic``    the isotropic road of Kamash & Robson (1978), coherence of the tracks
                 ``separation`` metres apart ``γ = x K₁(x)``, ``x = 2π n B`` (the real
                 cross-spectrum over the auto-spectrum, as :func:`suspopt.road.track_coherence`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from suspopt.errors import ConfigError
from suspopt.road import ISO8608_CLASSES, track_coherence

#: ISO 8608's reference spatial frequency [cycle/m]
N0 = 0.1
#: the left/right track models (:class:`RandomRoad`)
TRACK_MODELS = ('identical', 'independent', 'isotropic')


@dataclass(frozen=True)
class RandomRoad:
    """An ISO 8608 road of class ``road_class`` (A-H, the class's geometric mean
    ``G_d(n0)``; ``gd_n0`` [m³] overrides it) driven at ``speed`` [m/s], its tracks
    ``separation`` metres apart with the coherence model ``tracks``."""

    road_class: str = 'C'
    speed: float = 20.0
    tracks: str = 'identical'
    separation: float = 0.0
    gd_n0: float | None = None

    def __post_init__(self) -> None:
        if self.gd_n0 is None:
            if str(self.road_class).upper() not in ISO8608_CLASSES:
                raise ConfigError(
                    f'road.road_class: must be one of {", ".join(ISO8608_CLASSES)}, '
                    f'got {self.road_class!r}'
                )
        elif not (np.isfinite(self.gd_n0) and self.gd_n0 > 0.0):
            raise ConfigError(f'road.gd_n0: must be > 0 m³, got {self.gd_n0}')
        if not (np.isfinite(self.speed) and self.speed > 0.0):
            raise ConfigError(f'road.speed: must be > 0 m/s, got {self.speed}')
        if self.tracks not in TRACK_MODELS:
            raise ConfigError(
                f'road.tracks: must be one of {", ".join(TRACK_MODELS)}, got {self.tracks!r}'
            )
        if not (np.isfinite(self.separation) and self.separation >= 0.0):
            raise ConfigError(f'road.separation: must be >= 0 m, got {self.separation}')
        if self.tracks == 'isotropic' and self.separation == 0.0:
            raise ConfigError(
                'road.separation: the isotropic model needs the track separation (> 0 m)'
            )

    @property
    def displacement_psd_n0(self) -> float:
        """``G_d(n0)`` [m³]."""
        if self.gd_n0 is not None:
            return float(self.gd_n0)
        return ISO8608_CLASSES[str(self.road_class).upper()]

    def velocity_psd_one_sided(self) -> float:
        """``W = 4π² G_d(n0) n0² v``: the one-sided PSD of the road velocity under a
        wheel, per Hz [m²/s]."""
        return 4.0 * np.pi**2 * self.displacement_psd_n0 * N0**2 * self.speed

    def velocity_intensity(self) -> float:
        """``q = W/2``: the intensity of the white road velocity, ``E[u(t)u(t+τ)] = q δ(τ)``
        (the two-sided PSD per Hz), as it enters the Lyapunov equation [m²/s]."""
        return 0.5 * self.velocity_psd_one_sided()

    def height_psd(self, omega: ArrayLike) -> np.ndarray:
        """Two-sided PSD of the road height under a wheel in rad/s,
        ``S_δ(ω) = q / (2π ω²)`` [m²/(rad/s)]."""
        omega = np.asarray(omega, dtype=float)
        return self.velocity_intensity() / (2.0 * np.pi * omega**2)

    def coherence(self, omega: ArrayLike) -> np.ndarray:
        """Coherence of the two tracks at circular frequency ``omega`` [rad/s]."""
        omega = np.asarray(omega, dtype=float)
        if self.tracks == 'independent':  # whatever the separation
            return np.zeros_like(omega)
        n = np.abs(omega) / (2.0 * np.pi * self.speed)
        return track_coherence(self.tracks, n, self.separation)
