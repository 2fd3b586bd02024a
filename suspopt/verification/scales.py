"""The normalization ``s_k`` of the objective terms (``docs/model.md``, "Objective")."""

from __future__ import annotations

from suspopt.spec import PAPER_SCALES, StudyConfig
from suspopt.transcription.problem import Scales
from suspopt.verification.timemarching import reference_scales


def resolve_scales(config: StudyConfig) -> Scales:
    """The normalization ``s_k`` of every term, one table per scenario: the ``reference``
    values (time marching at the initial design), the paper's printed factors, or the
    study's own (``custom``); a term without a weight that has none is scaled by 1."""
    norm, n = config.objective.normalization, len(config.scenarios())
    if norm == 'reference':
        return reference_scales(config)
    given = PAPER_SCALES if norm == 'paper' else config.objective.scales
    return ({t: float(given.get(t, 1.0)) for t in config.terms()},) * n
