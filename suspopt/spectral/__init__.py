"""Stationary (spectral) evaluation of linear vehicle models on ISO 8608 roads, with design
derivatives and a reduced-space optimizer (docs/spectral.md)."""

from suspopt.spectral.lyapunov import RoadModel, StationaryModel, StationaryResponse, road_model
from suspopt.spectral.road import TRACK_MODELS, RandomRoad
from suspopt.spectral.system import AffineLinearSystem, RoadCorner, affine_system

__all__ = [
    'TRACK_MODELS',
    'AffineLinearSystem',
    'RandomRoad',
    'RoadCorner',
    'RoadModel',
    'StationaryModel',
    'StationaryResponse',
    'affine_system',
    'road_model',
]
