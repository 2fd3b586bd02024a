"""How much the paper's coupling assumption moves the optimum (issue 16, beyond the paper).

The paper's mixed-fidelity model fixes each multibody module's frame to the ground and
gives the chassis the spring force only (``multibody.mount = "ground"``); in a car the
linkage is bolted to the chassis, which then receives every chassis-side reaction
(``"chassis"``, :mod:`suspopt.multibody.suspension`). :func:`run_coupling` runs the
two-step study with both couplings from the same low-fidelity optimum and evaluates the
four designs (initial, low-fidelity optimum, paper-coupling optimum, consistent-coupling
optimum) in the three models (half car, ground mount, chassis mount), every evaluation by
collocation and verified by time marching. It writes ``coupling.json`` (after every step,
atomically), ``table.md`` and ``figures/coupling.png``.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from suspopt.output.rundir import (
    COUPLING_DESIGN_LABELS,
    COUPLING_DESIGNS,
    COUPLING_MODEL_LABELS,
    RunDirectory,
    write_json,
)
from suspopt.spec.schema import StudyConfig
from suspopt.studies.run import Progress, StepFailed, evaluate, optimize
from suspopt.transcription.problem import VehicleProblem
from suspopt.verification.scales import resolve_scales
from suspopt.verification.verify import verified

#: the three models: (fidelity, mount)
MODELS = {'low': ('low', 'ground'), 'ground': ('mixed', 'ground'), 'chassis': ('mixed', 'chassis')}
#: labels and the four designs (with the model whose optimum each is): see suspopt.results
MODEL_LABELS, DESIGNS, DESIGN_LABELS = (
    COUPLING_MODEL_LABELS,
    COUPLING_DESIGNS,
    COUPLING_DESIGN_LABELS,
)


def model_config(config: StudyConfig, model: str) -> StudyConfig:
    """The study description of one of the three :data:`MODELS`."""
    return config.replace(multibody=dataclasses.replace(config.multibody, mount=MODELS[model][1]))


def run_coupling(
    config: StudyConfig,
    out_dir: str | Path | RunDirectory,
    *,
    progress: Progress | None = None,
    log: Callable[[str], None] | None = None,
    verify: bool = True,
) -> dict[str, Any]:
    """Both couplings' two-step studies and the 4 × 3 cross-evaluation (module docstring).

    Every optimization starts from the collocation solution of its starting design in its
    own model; both multibody optimizations start from the low-fidelity optimum. Returns
    the ``coupling.json`` dictionary; a step whose IPOPT does not converge raises
    :class:`~suspopt.study.StepFailed` after writing what was done."""
    import suspopt.output.report as report

    out = out_dir.path if isinstance(out_dir, RunDirectory) else Path(out_dir)
    say = log or (lambda msg: None)
    t0 = time.perf_counter()
    scales = resolve_scales(config)
    config_dict = (
        out_dir.keep_inputs(config.to_dict())
        if isinstance(out_dir, RunDirectory)
        else config.to_dict()
    )
    res: dict[str, Any] = {
        'config': config_dict,
        'scales': list(scales),
        'terms': list(config.terms()),
        'design_names': list(config.design_names()),
        'models': dict(MODEL_LABELS),
        'normalization': config.objective.normalization,
        'designs': {},
        'steps': {},
        'evaluations': {m: {} for m in MODELS},
        'verify': verify,
        'complete': False,
    }
    save = lambda: write_json(out / 'coupling.json', res)  # noqa: E731
    save()
    configs = {m: model_config(config, m) for m in MODELS}
    problems: dict[str, VehicleProblem] = {}
    designs = res['designs']
    designs['initial'] = config.design.initial()
    try:
        for m, (fid, _) in MODELS.items():
            problems[m] = VehicleProblem(configs[m], fid, scales, progress=progress)

        def cell(model: str, design: str, guess='auto') -> dict[str, Any]:
            fid = MODELS[model][0]
            if design in res['evaluations'][model]:
                return res['evaluations'][model][design]
            say(f'evaluating the {design.replace("_", " ")} in the {MODEL_LABELS[model]} model')
            rec = evaluate(
                configs[model],
                fid,
                designs[design],
                scales=scales,
                problem=problems[model],
                guess=guess,
                verify=verify,
            )
            res['evaluations'][model][design] = rec
            save()
            return rec

        for model, start in (
            ('low', 'initial'),
            ('ground', 'low_optimum'),
            ('chassis', 'low_optimum'),
        ):
            fid = MODELS[model][0]
            cell(model, start)
            say(f'optimizing the {MODEL_LABELS[model]} model from the {start.replace("_", " ")}')
            step = optimize(
                configs[model],
                fid,
                start=designs[start],
                scales=scales,
                problem=problems[model],
                guess='keep',
                verify=verify,
            )
            res['steps'][model] = step
            save()
            if not step['success']:
                raise StepFailed(f'{fid} ({MODELS[model][1]} mount)', step)
            name = f'{model}_optimum'
            designs[name] = step['design']
            res['evaluations'][model][name] = dict(step, mode='optimize')
            save()
        for model in MODELS:
            for design in DESIGNS:
                cell(model, design)
        unverified = [
            f'{d} in {m}'
            for m in MODELS
            for d, e in res['evaluations'][m].items()
            if verified(e) is False
        ]
        res['verified'] = None if not verify else not unverified
        if unverified:
            res['warnings'] = [f'not verified by time marching: {", ".join(unverified)}']
        res['summary'] = summary(res)
        res['problems'] = {m: p.stats() for m, p in problems.items()}
        res['wall_time_s'] = time.perf_counter() - t0
        res['complete'] = True
        save()
        say('writing table and figure')
        report.render_coupling(out)
    finally:
        for p in problems.values():
            p.cleanup()
    return res


def summary(res: dict[str, Any]) -> dict[str, Any]:
    """How far the coupling assumption moves the optimum: the change of every design
    variable from the paper-coupling optimum to the consistent one (relative), and what
    the paper-coupling optimum loses in the chassis-mounted model (f there against the
    consistent optimum's f)."""
    d, ev = res['designs'], res['evaluations']
    g, c = d['ground_optimum'], d['chassis_optimum']
    f = {m: {k: e['objective'] for k, e in ev[m].items()} for m in ev}
    return {
        'design_change': {n: c[n] / g[n] - 1.0 for n in g},
        'f_chassis_at_ground_optimum': f['chassis']['ground_optimum'],
        'f_chassis_at_chassis_optimum': f['chassis']['chassis_optimum'],
        'loss_of_paper_optimum_in_chassis_model': f['chassis']['ground_optimum']
        / f['chassis']['chassis_optimum']
        - 1.0,
        'f_ground_at_chassis_optimum': f['ground']['chassis_optimum'],
        'f_ground_at_ground_optimum': f['ground']['ground_optimum'],
    }
