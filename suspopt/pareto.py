"""Ride comfort against road holding: the Pareto front by weighted sums (beyond the paper).

The paper's objective (eq. 4) adds two goals: ride comfort (J1, J2: chassis heave and pitch
accelerations) and road holding (J3, J4: wheel travel, the tyre-load variation). Its
weights pick one compromise. :func:`run_pareto` sweeps the comfort share α from 0 to 1,

    w = (α/2, α/2, (1 − α)/2, (1 − α)/2),   f_α = Σ w_k J_k / s_k   (s_k: the study's),

and optimizes one model for every α on ONE built problem — the weights are inputs of
:class:`~suspopt.models.objective.WeightedObjectiveComp`, so there is no new setup and no
new coloring — each point starting from the previous optimum and its trajectory. Every
point is reported by its comfort ``C = (J1/s1 + J2/s2)/2`` and road holding
``R = (J3/s3 + J4/s4)/2`` (with the ``reference`` normalization both are 1 at the initial
design; smaller is better). A weighted sum finds the convex part of the front; α = 0.5
is the paper's equal weighting, i.e. the study's optimum.
"""
from __future__ import annotations

import dataclasses
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np

from suspopt.config import StudyConfig
from suspopt.problem import VehicleProblem
from suspopt.study import Progress, _scales, evaluate, optimize, resolve_scales, write_json


def comfort_share_weights(alpha: float) -> tuple[float, float, float, float]:
    """Objective weights of comfort share ``alpha`` in [0, 1]."""
    a = float(alpha)
    return (0.5 * a, 0.5 * a, 0.5 * (1.0 - a), 0.5 * (1.0 - a))


def comfort_and_road_holding(terms: dict[str, float],
                             scales: tuple[float, ...]) -> tuple[float, float]:
    """``C = (J1/s1 + J2/s2)/2`` and ``R = (J3/s3 + J4/s4)/2`` of a result's ``terms``."""
    q = [terms[f'J{k + 1}'] / scales[k] for k in range(4)]
    return 0.5 * (q[0] + q[1]), 0.5 * (q[2] + q[3])


def run_pareto(config: StudyConfig, out_dir: str | Path, *, fidelity: str = 'low',
               points: int = 9, progress: Progress | None = None,
               log: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Optimize ``fidelity``'s model for ``points`` comfort shares α = 0 … 1, writing
    ``pareto.json`` after every point, the case recorder ``cases.sql`` (the trajectory
    at every point, as case ``alpha=<α>``) and, at the end, ``table.md`` and
    ``figures/``; the initial design evaluated in the same model is kept as ``initial``.
    A point where IPOPT does not converge is kept with ``success: false`` and the sweep
    goes on from the last converged point. Returns the front."""
    from suspopt import report  # matplotlib only when figures are drawn

    if points < 2:
        raise ValueError(f'points must be >= 2, got {points}')
    out = Path(out_dir)
    say = log or (lambda msg: None)
    t0 = time.perf_counter()
    scales = resolve_scales(config)
    data: dict[str, Any] = {'config': config.to_dict(), 'fidelity': fidelity,
                            'scales': _scales(scales),
                            'normalization': config.objective.normalization,
                            'points': [], 'complete': False}
    save = lambda: write_json(out / 'pareto.json', data)  # noqa: E731
    save()
    problem = VehicleProblem(config, fidelity, scales, recorder=out / 'cases.sql',
                             progress=progress)
    try:
        start = config.design.initial()
        say('the initial design in this model (for reference)')
        init = evaluate(config, fidelity, start, scales=scales, problem=problem,
                        label='initial')
        C, R = comfort_and_road_holding(init['terms'], scales)
        data['initial'] = {'design': start, 'terms': init['terms'], 'comfort': C,
                           'road_holding': R}
        save()
        guess = 'keep'  # the first point starts from the initial design's solution
        for alpha in np.linspace(0.0, 1.0, points):
            w = comfort_share_weights(alpha)
            cfg = config.replace(objective=dataclasses.replace(config.objective, weights=w))
            say(f'comfort share {alpha:.3f} (weights {", ".join(f"{x:g}" for x in w)})')
            res = optimize(cfg, fidelity, start=start, scales=scales, problem=problem,
                           guess=guess, label=f'alpha={alpha:.6f}')
            C, R = comfort_and_road_holding(res['terms'], scales)
            data['points'].append({
                'alpha': float(alpha), 'weights': list(w), 'design': res['design'],
                'objective': res['objective'], 'terms': res['terms'], 'comfort': C,
                'road_holding': R, 'success': res['success'], 'status': res['status'],
                'iterations': res['iterations'], 'wall_time_s': res['wall_time_s'],
                'history': res['history']})
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
