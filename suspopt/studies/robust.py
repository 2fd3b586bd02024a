"""Robust design over several load cases (beyond the paper): one NLP, and the robustness
table.

A study file may list scenarios (``[[scenario]]``: road, speed, horizon, grid, weight).
:func:`~suspopt.studies.run.optimize` then solves ONE NLP in which every scenario's trajectory
(its own Dymos phase and grid) shares the design; the objective is ``Σ_s w_s f_s``, each
``f_s`` normalized by its own reference, or the worst case ``max_s f_s``
(``objective.aggregate = "max"``, epigraph form: minimize ``t`` subject to ``f_s ≤ t``).

:func:`run_robust` shows what that buys: the robust optimum and every scenario's own
optimum (the same problem with that scenario alone), each evaluated on every scenario by
time marching (independent of the grids), in ``robust.json`` (rendered by
:func:`suspopt.output.robust_report.render_robust`: ``table.md`` and a figure).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from pathlib import Path

from suspopt.errors import ConfigError
from suspopt.output.roads import keep_study_inputs
from suspopt.output.rundir import RunDirectory, write_record
from suspopt.records.robust import ROBUST, CrossEvaluation, RobustStudy
from suspopt.records.solve import SolveRecord
from suspopt.spec.schema import StudyConfig
from suspopt.studies.run import Interrupted, Progress, optimize
from suspopt.transcription.problem import Scales
from suspopt.verification.scales import resolve_scales
from suspopt.verification.verify import combine, march


def single_scenario(config: StudyConfig, index: int) -> StudyConfig:
    """The study with only its ``index``-th scenario (weight 1)."""
    sc = config.scenario[index]
    return config.replace(scenario=(dataclasses.replace(sc, weight=1.0),))


def cross_evaluation(
    config: StudyConfig, fidelity: str, res: SolveRecord, scales: Scales
) -> CrossEvaluation:
    """An optimum marched on every scenario of ``config``."""
    t0 = time.perf_counter()
    marched = march(config, fidelity, res.design, scales)
    return CrossEvaluation(
        design=res.design,
        scenarios={m.name: m.objective for m in marched},
        aggregate=combine(config, [m.objective for m in marched]),
        time_s=time.perf_counter() - t0,
    )


def run_robust(
    config: StudyConfig,
    out_dir: str | Path | RunDirectory,
    *,
    fidelity: str = 'low',
    progress: Progress | None = None,
    log: Callable[[str], None] | None = None,
    verify: bool = True,
) -> RobustStudy:
    """The robust optimum, each scenario's own optimum, and every one of them on every
    scenario by time marching; written to ``out_dir`` as it goes (``robust.json``; the
    report renders it: ``suspopt report DIR``). Returns the record."""
    if len(config.scenario) < 2:
        raise ConfigError(
            'scenario: robust design needs at least two [[scenario]] tables in '
            f'the study file, got {len(config.scenario)}'
        )
    for i, sc in enumerate(config.scenarios()):
        if sc.name == ROBUST:  # the label of the robust optimum: it would be overwritten
            raise ConfigError(
                f'scenario[{i}].name: {ROBUST!r} names the robust optimum in the results; '
                'name the scenario otherwise'
            )
    out = out_dir.path if isinstance(out_dir, RunDirectory) else Path(out_dir)
    say = log or (lambda msg: None)
    t0 = time.perf_counter()
    scales = resolve_scales(config)
    scenarios = config.scenarios()
    data = RobustStudy(
        config=keep_study_inputs(out, config),
        fidelity=fidelity,
        scenarios=tuple(sc.name for sc in scenarios),
        weights=tuple(sc.weight for sc in scenarios),
        aggregate=config.objective.aggregate,
        scales=tuple(scales),
        design_names=tuple(config.design_names()),
    )
    write_record(out, data)

    def solve(label: str, cfg: StudyConfig, own: Scales) -> None:
        """One optimum, kept and written; interrupted, kept if IPOPT had converged."""
        try:
            data.optima[label] = optimize(
                cfg, fidelity, scales=own, progress=progress, verify=verify
            )
        except Interrupted as stop:
            if stop.result is not None and stop.result.success:
                data.optima[label] = stop.result
                write_record(out, data)
            raise
        write_record(out, data)

    say(f'robust optimum over {len(scenarios)} scenarios ({config.objective.aggregate}), one NLP')
    solve(ROBUST, config, scales)
    for i, name in enumerate(data.scenarios):
        say(f'scenario {name!r} alone')
        solve(name, single_scenario(config, i), (scales[i],))
    say('every optimum on every scenario, by time marching')
    for label, res in data.optima.items():
        if res.success:
            data.cross[label] = cross_evaluation(config, fidelity, res, scales)
            write_record(out, data)
    converged = [r for r in data.optima.values() if r.success]
    data.verified = None if not verify else all(r.verified for r in converged)
    data.wall_time_s = time.perf_counter() - t0
    data.complete = True
    write_record(out, data)
    return data
