"""The normalization ``s_k`` of the objective terms (``docs/model.md``, "Objective")."""

from __future__ import annotations

from suspopt import interrupts
from suspopt.errors import ConfigError
from suspopt.models.metrics import term_kind
from suspopt.spec import PAPER_SCALES, StudyConfig
from suspopt.transcription.problem import Scales
from suspopt.verification.timemarching import reference_scales

#: a weighted term whose reference value is below this fraction of its yardstick's (an
#: RMS below 1e-4 of it) carries no signal: the road barely excites it (two tracks that
#: differ only by the sampling of one profile), and normalizing by it would weight noise
NEGLIGIBLE = 1e-8


def resolve_scales(config: StudyConfig) -> Scales:
    """The normalization ``s_k`` of every term, one table per scenario: the ``reference``
    values (time marching at the initial design), the paper's printed factors, or the
    study's own (``custom``); a term without a weight that has none is scaled by 1. A
    weighted term whose reference value is negligible (:func:`negligible_terms`) is
    refused, naming it."""
    norm, n = config.objective.normalization, len(config.scenarios())
    interrupts.stage('scales')
    if norm == 'reference':
        scales = reference_scales(config)
        problems = [
            f'objective.weights.{t}: '
            + (f'scenario {sc.name!r}: ' if config.scenario else '')
            + why
            for sc, s in zip(config.scenarios(), scales)
            for t, why in negligible_terms(config, s).items()
        ]
        if problems:
            raise ConfigError(problems)
        return scales
    given = PAPER_SCALES if norm == 'paper' else config.objective.scales
    return ({t: float(given.get(t, 1.0)) for t in config.terms()},) * n


def negligible_terms(config: StudyConfig, scales: dict[str, float]) -> dict[str, str]:
    """The weighted terms whose reference values are numerically zero: below
    :data:`NEGLIGIBLE` of their yardstick — a chassis rotation's as an acceleration at
    the wheels (half the track or wheelbase as the lever) against the largest chassis
    term, a corner's or a seat's against the largest of its kind. Term → why."""
    v = config.vehicle
    lay = config.layout()
    lever = {'heave': 1.0, 'pitch': v.wheelbase / 2, 'roll': lay.track_separation() / 2}
    weights = config.objective.weights
    chassis = {t: scales[t] * lever[t] ** 2 for t in scales if t in lever and lever[t] > 0.0}
    out = {}
    for t, w in weights.items():
        if not w > 0.0 or t not in scales:
            continue
        kind = term_kind(t)
        if t in chassis:
            own, peers = chassis[t], chassis
            what = 'the chassis terms (as accelerations at the wheels)'
        else:
            own = scales[t]
            peers = {u: scales[u] for u in scales if term_kind(u) == kind}
            what = f'the {kind} terms'
        top = max(peers.values())
        if top > 0.0 and own <= NEGLIGIBLE * top:
            out[t] = (
                f'its reference value J = {scales[t]:.3g} is numerically zero ({own / top:.2g} '
                f'of the largest of {what}): the road does not excite {t}, and normalizing '
                f'by it would weight noise; give {t} no weight, or use normalization = '
                "'custom' with a scale"
            )
    return out
