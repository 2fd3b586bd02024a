"""Robust design over several load cases (beyond the paper): one NLP, and the robustness
table.

A study file may list scenarios (``[[scenario]]``: road, speed, horizon, grid, weight).
:func:`~suspopt.study.optimize` then solves ONE NLP in which every scenario's trajectory
(its own Dymos phase and grid) shares the design; the objective is ``Σ_s w_s f_s``, each
``f_s`` normalized by its own reference, or the worst case ``max_s f_s``
(``objective.aggregate = "max"``, epigraph form: minimize ``t`` subject to ``f_s ≤ t``).

:func:`run_robust` shows what that buys: the robust optimum and every scenario's own
optimum (the same problem with that scenario alone), each evaluated on every scenario by
time marching (independent of the grids), in ``robust.json`` (rendered by :func:`suspopt.report.render_robust`: ``table.md`` and a
figure).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from suspopt.errors import ConfigError
from suspopt.output.rundir import RunDirectory, write_json
from suspopt.spec.schema import StudyConfig
from suspopt.studies.run import Progress, optimize
from suspopt.verification.scales import resolve_scales
from suspopt.verification.verify import combine, time_marching_check, verified


def single_scenario(config: StudyConfig, index: int) -> StudyConfig:
    """The study with only its ``index``-th scenario (weight 1)."""
    import dataclasses

    sc = config.scenario[index]
    return config.replace(scenario=(dataclasses.replace(sc, weight=1.0),))


def run_robust(
    config: StudyConfig,
    out_dir: str | Path | RunDirectory,
    *,
    fidelity: str = 'low',
    progress: Progress | None = None,
    log: Callable[[str], None] | None = None,
    verify: bool = True,
) -> dict[str, Any]:
    """The robust optimum, each scenario's own optimum, and every one of them on every
    scenario by time marching; written to ``out_dir`` as it goes (``robust.json``; the
    report renders it: ``suspopt report DIR``). Returns the record."""
    if len(config.scenario) < 2:
        raise ConfigError(
            'scenario: robust design needs at least two [[scenario]] tables in '
            f'the study file, got {len(config.scenario)}'
        )
    out = out_dir.path if isinstance(out_dir, RunDirectory) else Path(out_dir)
    say = log or (lambda msg: None)
    t0 = time.perf_counter()
    scales = resolve_scales(config)
    scenarios = config.scenarios()
    names = [sc.name for sc in scenarios]
    config_dict = (
        out_dir.keep_inputs(config.to_dict())
        if isinstance(out_dir, RunDirectory)
        else config.to_dict()
    )
    data: dict[str, Any] = {
        'config': config_dict,
        'fidelity': fidelity,
        'scenarios': names,
        'weights': [sc.weight for sc in scenarios],
        'aggregate': config.objective.aggregate,
        'scales': list(scales),
        'design_names': list(config.design_names()),
        'optima': {},
        'cross': {},
        'complete': False,
    }
    save = lambda: write_json(out / 'robust.json', data)  # noqa: E731
    save()
    say(f'robust optimum over {len(names)} scenarios ({config.objective.aggregate}), one NLP')
    data['optima']['robust'] = optimize(
        config, fidelity, scales=scales, progress=progress, verify=verify
    )
    save()
    for i, name in enumerate(names):
        say(f'scenario {name!r} alone')
        data['optima'][name] = optimize(
            single_scenario(config, i),
            fidelity,
            scales=(scales[i],),
            progress=progress,
            verify=verify,
        )
        save()
    say('every optimum on every scenario, by time marching')
    for label, res in data['optima'].items():
        if not res['success']:
            continue
        check = time_marching_check(
            config,
            fidelity,
            res['design'],
            [dict.fromkeys(config.terms(), 0.0)] * len(scales),
            scales,
        )
        data['cross'][label] = {
            'design': res['design'],
            'scenarios': {s['name']: s['objective'] for s in check['scenarios']},
            'aggregate': combine(config, [s['objective'] for s in check['scenarios']]),
            'time_s': check['time_s'],
        }
        save()
    data['verified'] = (
        None if not verify else all(verified(r) for r in data['optima'].values() if r['success'])
    )
    data['wall_time_s'] = time.perf_counter() - t0
    data['complete'] = True
    save()
    return data
