"""Stationary (spectral) evaluation of linear vehicle models on ISO 8608 roads, with design
derivatives and a reduced-space optimizer (docs/spectral.md)."""

from suspopt.spectral.accuracy import PADE_ORDERS, PadeChoice, choose_pade_order
from suspopt.spectral.integral import spectral_variances
from suspopt.spectral.lyapunov import (
    LyapunovSolver,
    RoadModel,
    StationaryModel,
    StationaryResponse,
    road_model,
)
from suspopt.spectral.optimize import SpectralOptimum, optimize_spectral
from suspopt.spectral.road import TRACK_MODELS, RandomRoad
from suspopt.spectral.system import AffineLinearSystem, RoadCorner, affine_system

__all__ = [
    'PADE_ORDERS',
    'TRACK_MODELS',
    'AffineLinearSystem',
    'LyapunovSolver',
    'PadeChoice',
    'RandomRoad',
    'RoadCorner',
    'RoadModel',
    'SpectralOptimum',
    'StationaryModel',
    'StationaryResponse',
    'affine_system',
    'choose_pade_order',
    'optimize_spectral',
    'road_model',
    'spectral_variances',
]
