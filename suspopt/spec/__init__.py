"""The study description: schema, reading, checks, resolution and the template
(``docs/study-file.md``)."""

from suspopt.spec.load import config_from_dict, full_car_defaults, load_config
from suspopt.spec.schema import (
    AGGREGATES,
    MODELS,
    MOUNTS,
    NORMALIZATIONS,
    PAPER_SCALES,
    Scenario,
    StudyConfig,
)

__all__ = [
    'AGGREGATES',
    'MODELS',
    'MOUNTS',
    'NORMALIZATIONS',
    'PAPER_SCALES',
    'Scenario',
    'StudyConfig',
    'config_from_dict',
    'full_car_defaults',
    'load_config',
]
