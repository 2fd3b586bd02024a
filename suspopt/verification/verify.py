"""The time-marching verification of a collocation result: the same design marched by an
independent integrator (:mod:`suspopt.verification.timemarching`), its objective terms
compared with the collocation's (``docs/model.md``, "Verification")."""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from suspopt.spec import StudyConfig
from suspopt.transcription.problem import Scales
from suspopt.verification.timemarching import simulate


def interrupted_verification() -> dict[str, Any]:
    return {
        'verified': None,
        'interrupted': True,
        'note': 'interrupted before the time-marching verification: not checked',
    }


#: collocation and time marching must agree this well on every weighted J_k (relative)
VERIFY_TOLERANCE = 5e-3


#: the verification's time-marching tolerances: the J_k to about 1e-6 relative, thousands
#: of times finer than VERIFY_TOLERANCE (tests/test_timemarching.py checks it against
#: a tight integration)
VERIFY_RTOL, VERIFY_ATOL = 1e-6, 1e-9


def objective_value(
    config: StudyConfig, terms: dict[str, float], scales: dict[str, float]
) -> float:
    """``f = Σ w_k J_k / s_k`` (eq. 4, SPEC §5) — for results computed outside the NLP."""
    w = config.objective.weights
    return float(sum(w[t] * terms[t] / scales[t] for t in config.terms()))


def combine(config: StudyConfig, scenario_objectives: list[float]) -> float:
    """The scenarios' objectives combined as the NLP does (Σ w_s f_s, or the worst case)."""
    if config.objective.aggregate == 'max' and len(scenario_objectives) > 1:
        return max(scenario_objectives)
    return float(sum(sc.weight * f for sc, f in zip(config.scenarios(), scenario_objectives)))


def time_marching_check(
    config: StudyConfig,
    fidelity: str,
    design: dict[str, float],
    terms: list[dict[str, float]],
    scales: Scales,
    *,
    modules: dict | None = None,
    keep: bool = False,
) -> dict[str, Any]:
    """Time-march ``design`` in every scenario and compare with the collocation's terms:
    ``verified`` if every term with a nonzero weight agrees within
    :data:`VERIFY_TOLERANCE` (relative). With ``keep``, the trajectories (2001 points) are
    returned under ``'trajectories'`` (not JSON)."""
    t0 = time.perf_counter()
    weights = config.objective.weights
    out: dict[str, Any] = {
        'method': f'time-marching (SciPy DOP853, rtol {VERIFY_RTOL:g})',
        'tolerance': VERIFY_TOLERANCE,
        'scenarios': [],
    }
    trajs = []
    worst = 0.0
    for i, sc in enumerate(config.scenarios()):
        tr = simulate(
            config,
            fidelity,
            design,
            scenario=i,
            modules=modules,
            rtol=VERIFY_RTOL,
            atol=VERIFY_ATOL,
            t_eval=None if keep else np.array([0.0, sc.horizon]),
        )
        tm = dict(zip(config.terms(), (float(x) for x in tr.J)))
        diffs = {
            t: abs(terms[i][t] / tm[t] - 1.0)
            if tm[t] != 0.0
            else (0.0 if terms[i][t] == 0.0 else math.inf)
            for t in config.terms()
            if weights[t] > 0.0
        }
        worst_term = max(diffs, key=diffs.get)
        worst = max(worst, diffs[worst_term])
        rec = {
            'name': sc.name,
            'terms': tm,
            'objective': objective_value(config, tm, scales[i]),
            'max_rel_diff': diffs[worst_term],
            'worst_term': worst_term,
            'wall_time_s': tr.info['wall_time_s'],
        }
        if fidelity == 'mixed':
            rec['max_constraint_residual_m'] = tr.info['max_constraint_residual_m']
        out['scenarios'].append(rec)
        trajs.append(tr)
    out['objective'] = combine(config, [s['objective'] for s in out['scenarios']])
    out['max_rel_diff'] = worst
    out['verified'] = bool(worst <= VERIFY_TOLERANCE)
    out['time_s'] = time.perf_counter() - t0
    if keep:
        out['trajectories'] = trajs
    return out


def failed_verification(err: BaseException) -> dict[str, Any]:
    return {'verified': None, 'failed': True, 'note': f'time-marching verification failed: {err}'}


def pending_verification() -> dict[str, Any]:
    return {
        'verified': None,
        'pending': True,
        'note': 'time-marching verification running in the background',
    }


def skipped_verification() -> dict[str, Any]:
    return {
        'verified': None,
        'skipped': True,
        'note': 'time-marching verification skipped (--no-verify): this result is not checked',
    }


def verified(record: dict[str, Any]) -> bool | None:
    """True/False: the record's verification; None: skipped or not applicable."""
    v = record.get('verification')
    return None if not v else v.get('verified')
