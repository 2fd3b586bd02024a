"""The normalization ``s_k`` of the objective terms (``docs/model.md``, "Objective")."""

from __future__ import annotations

from suspopt.spec import PAPER_SCALES, StudyConfig
from suspopt.transcription.problem import Scales
from suspopt.verification.timemarching import reference_scales


def resolve_scales(config: StudyConfig) -> Scales:
    """Normalization ``s_k`` of SPEC §5, one table per scenario."""
    norm, n = config.objective.normalization, len(config.scenarios())
    if norm == 'reference':
        return reference_scales(config)
    if norm == 'paper':
        return (dict(PAPER_SCALES),) * n
    return (dict(config.objective.scales),) * n  # custom
