"""Ride comfort against road holding: the Pareto front by weighted sums (beyond the paper).

The paper's objective (eq. 4) adds two goals: ride comfort (the chassis terms: heave and
pitch, and roll in the full car) and road holding (the wheel terms: wheel travel, the
tyre-load variation). Its weights pick one compromise. :func:`run_pareto` sweeps the
comfort share α from 0 to 1, weight α/n_C on each of the n_C chassis terms and (1 − α)/n_R
on each of the n_R wheel terms (the paper's equal 0.25 is α = 0.5 on the half car), and
optimizes one model for every α on ONE built problem — the weights are inputs of
:class:`~suspopt.models.objective.WeightedObjectiveComp`, so there is no new setup and no
new coloring — each point starting from the previous optimum and its trajectory. Every
point is reported by its comfort C (the mean normalized chassis term) and road holding R
(the mean normalized wheel term); with the ``reference`` normalization both are 1 at the
initial design; smaller is better. Every point is verified by time marching.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from suspopt.output.rundir import RunDirectory, keep_inputs, write_json
from suspopt.spec.schema import StudyConfig
from suspopt.studies.run import Interrupted, Progress, evaluate, optimize
from suspopt.transcription.problem import VehicleProblem
from suspopt.verification.scales import resolve_scales


def _split(terms) -> tuple[list[str], list[str]]:
    chassis = [t for t in terms if not t.startswith('wheel_')]
    return chassis, [t for t in terms if t.startswith('wheel_')]


def comfort_share_weights(terms, alpha: float) -> dict[str, float]:
    """Objective weights of comfort share ``alpha`` in [0, 1]."""
    chassis, wheels = _split(terms)
    a = float(alpha)
    return {t: (a / len(chassis) if t in chassis else (1.0 - a) / len(wheels)) for t in terms}


def comfort_and_road_holding(
    terms: dict[str, float], scales: dict[str, float]
) -> tuple[float, float]:
    """C (mean normalized chassis term) and R (mean normalized wheel term) of ``terms``."""
    chassis, wheels = _split(terms)
    return (
        sum(terms[t] / scales[t] for t in chassis) / len(chassis),
        sum(terms[t] / scales[t] for t in wheels) / len(wheels),
    )


def _point(
    alpha: float, weights: dict[str, float], res: dict[str, Any], scales: dict[str, float]
) -> dict[str, Any]:
    """One point of the front from an optimization's record."""
    ok = res['success']
    C, R = comfort_and_road_holding(res['terms'] if ok else res['terms_at_stop'], scales)
    return {
        'alpha': float(alpha),
        'weights': weights,
        'design': res['design'],
        'objective': res['objective'],
        'terms': res['terms'],
        'comfort': C if ok else None,
        'road_holding': R if ok else None,
        **({} if ok else {'comfort_at_stop': C, 'road_holding_at_stop': R}),
        'success': ok,
        'status': res['status'],
        'verified': res.get('verified'),
        'verification': res['verification'],
        'iterations': res['iterations'],
        'wall_time_s': res['wall_time_s'],
        'history': res['history'],
    }


def run_pareto(
    config: StudyConfig,
    out_dir: str | Path | RunDirectory,
    *,
    fidelity: str = 'low',
    points: int = 9,
    progress: Progress | None = None,
    log: Callable[[str], None] | None = None,
    verify: bool = True,
) -> dict[str, Any]:
    """Optimize ``fidelity``'s model for ``points`` comfort shares α = 0 … 1, writing
    ``pareto.json`` after every point, the case recorder ``cases.sql`` (the trajectory
    at every point, as case ``alpha=<α>``) and, at the end, ``table.md`` and
    ``figures/``; the initial design evaluated in the same model is kept as ``initial``.
    A point where IPOPT does not converge is kept with ``success: false`` (its C, R and f
    are None: not results; their values at the stop are kept as ``*_at_stop``) and the
    sweep goes on from the last converged point. Interrupted (Ctrl-C, SIGTERM), it stops
    with ``complete: false``, keeping the point being solved only if IPOPT had converged.
    Returns the front."""
    import suspopt.output.report as report  # matplotlib only when figures are drawn

    if points < 2:
        raise ValueError(f'points must be >= 2, got {points}')
    out = out_dir.path if isinstance(out_dir, RunDirectory) else Path(out_dir)
    say = log or (lambda msg: None)
    t0 = time.perf_counter()
    scales = resolve_scales(config)
    terms = config.terms()
    config_dict = keep_inputs(out, config.to_dict())
    data: dict[str, Any] = {
        'config': config_dict,
        'fidelity': fidelity,
        'scales': list(scales),
        'terms': list(terms),
        'design_names': list(config.design_names()),
        'bounds': config.design.bounds(),
        'normalization': config.objective.normalization,
        'points': [],
        'complete': False,
    }
    save = lambda: write_json(out / 'pareto.json', data)  # noqa: E731
    save()
    problem = VehicleProblem(
        config, fidelity, scales, recorder=out / 'cases.sql', progress=progress
    )
    try:
        start = config.design.initial()
        say('the initial design in this model (for reference)')
        init = evaluate(
            config, fidelity, start, scales=scales, problem=problem, label='initial', verify=False
        )
        C, R = (
            comfort_and_road_holding(init['terms'], scales[0]) if init['success'] else (None, None)
        )  # not converged: no reference point
        data['initial'] = {
            'design': start,
            'terms': init['terms'],
            'comfort': C,
            'road_holding': R,
            'success': init['success'],
        }
        save()
        guess = 'keep'  # the first point starts from the initial design's solution
        for alpha in np.linspace(0.0, 1.0, points):
            w = comfort_share_weights(terms, alpha)
            cfg = config.with_weights(w)
            say(f'comfort share {alpha:.3f}')
            try:
                res = optimize(
                    cfg,
                    fidelity,
                    start=start,
                    scales=scales,
                    problem=problem,
                    guess=guess,
                    label=f'alpha={alpha:.6f}',
                    verify=verify,
                )
            except Interrupted as stop:
                if stop.result and stop.result['success']:
                    data['points'].append(_point(alpha, w, stop.result, scales[0]))
                    save()
                raise
            data['points'].append(_point(alpha, w, res, scales[0]))
            save()
            if res['success']:  # the next point starts from here, trajectory included
                start, guess = res['design'], 'keep'
            else:
                guess = 'auto'
        data['problem'] = problem.stats()
        data['wall_time_s'] = time.perf_counter() - t0
        data['complete'] = True
        save()
        say('writing table and figures')
        report.render(out)
    finally:
        problem.cleanup()
    return data
