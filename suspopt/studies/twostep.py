"""The paper's two-step study (paper §4, ``docs/studies.md``): the low-fidelity optimum
from the initial design, then the mixed-fidelity optimum from there, every design in both
models, each verified by time marching, written as it goes."""

from __future__ import annotations

import functools
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np

from suspopt.driver import IterationInfo
from suspopt.output.rundir import RunDirectory, keep_inputs, write_json
from suspopt.records.trajectory import Trajectory
from suspopt.spec import StudyConfig
from suspopt.studies.run import (
    Interrupted,
    Progress,
    StepFailed,
    _attach_verification,
    evaluate,
    initial_guess,
    optimize,
)
from suspopt.transcription.problem import VehicleProblem
from suspopt.verification.background import Background
from suspopt.verification.scales import resolve_scales
from suspopt.verification.verify import (
    VERIFY_TOLERANCE,
    failed_verification,
    interrupted_verification,
    pending_verification,
    time_marching_check,
    verified,
)


def _strip(record: dict[str, Any]) -> tuple[dict[str, Any], list[Trajectory]]:
    """A record without its (non-JSON) kept trajectories."""
    v = record.get('verification') or {}
    trajs = v.pop('trajectories', [])
    return record, trajs


def run_study(
    config: StudyConfig,
    out_dir: str | Path | RunDirectory,
    *,
    progress: Progress | None = None,
    log: Callable[[str], None] | None = None,
    verify: bool = True,
    verify_jobs: int | None = None,
) -> dict[str, Any]:
    """The two-step study of SPEC §7, written to ``out_dir`` as it goes.

    1. low-fidelity optimization from the initial design;
    2. mixed-fidelity optimization from the step-1 optimum;
    then each of the three designs evaluated in both models by collocation, each verified
    (with ``verify``) by time marching. Writes ``study.json`` (after every step),
    ``table.md``, the case recorders ``low.sql`` and ``mixed.sql`` (the full trajectories
    of every design in each model), ``time_marching.npz`` and the figures in
    ``figures/``. Returns the study dictionary.

    The time-marching verifications run beside the optimizations, in background processes
    (:mod:`suspopt.background`; ``verify_jobs`` of them at once, None: the cores less one;
    0: each in this process, after the solves), and are written as they come in."""
    import suspopt.output.report as report  # matplotlib only when figures are drawn

    out = out_dir.path if isinstance(out_dir, RunDirectory) else Path(out_dir)
    say = log or (lambda msg: None)
    t_start = time.perf_counter()
    scales = resolve_scales(config)
    config_dict = keep_inputs(out, config.to_dict())
    study: dict[str, Any] = {
        'config': config_dict,
        'scales': list(scales),
        'terms': list(config.terms()),
        'design_names': list(config.design_names()),
        'normalization': config.objective.normalization,
        'steps': {},
        'evaluations': {},
        'complete': False,
        'verify': verify,
    }
    save = lambda: write_json(out / 'study.json', study)  # noqa: E731
    save()
    designs = {'initial': config.design.initial()}
    problems: dict[str, VehicleProblem] = {}
    arrays: dict[str, np.ndarray] = {}

    def keep(fid: str, name: str, record: dict[str, Any]) -> dict[str, Any]:
        record, trajs = _strip(record)
        for i, tr in enumerate(trajs[:1]):
            for key in ('zdd_C', 'thdd_C', 'phidd_C', 'wheel_z'):
                if key in tr.values:
                    arrays[f'{fid}/{name}/{key}'] = tr[key]
            arrays[f'{fid}/{name}/t'] = tr.t
        study['evaluations'][f'{fid}/{name}'] = record
        save()
        return record

    checks = Background(verify_jobs if verify else 0)
    waiting: dict[str, Callable[[dict[str, Any]], None]] = {}  # job -> what to do with it

    def check_later(
        fid: str, name: str, record: dict[str, Any], done: Callable[[dict[str, Any]], None]
    ) -> None:
        """Verify ``record`` (design ``name`` in model ``fid``) by time marching in the
        background; ``done`` is called again with the record once its verification is in.
        A failed solve, or ``verify`` off, is marked at once."""
        if not verify or not record['success']:
            _attach_verification(config, fid, record, scales, problems[fid], verify)
            return
        key = f'{fid}/{name}'
        record['verification'], record['verified'] = pending_verification(), None
        checks.submit(
            key,
            functools.partial(
                time_marching_check,
                config,
                fid,
                record['design'],
                [s['terms'] for s in record['scenarios']],
                scales,
                modules=problems[fid].modules or None,
                keep=True,
            ),
        )

        def finish(verification: dict[str, Any]) -> None:
            record['verification'] = verification
            record['verified'] = verified(record)
            done(record)

        waiting[key] = finish

    def collect(block: bool) -> None:
        """Attach the verifications that are done (with ``block``: all of them). A failed
        one is written as failed, then raised."""
        for key in checks.pending():
            if block or checks.done(key):
                finish = waiting.pop(key)
                try:
                    verification = checks.result(key)
                except Exception as err:
                    finish(failed_verification(err))
                    raise
                finish(verification)

    def pumped(info: IterationInfo) -> None:
        checks.pump()
        if progress is not None:
            progress(info)

    def evaluation(fid: str, name: str, **kw: Any) -> None:
        """Evaluate design ``name`` in model ``fid`` and keep it; interrupted, keep it
        only if IPOPT had converged (then not verified, and said so) and stop."""
        try:
            rec = evaluate(
                config,
                fid,
                designs[name],
                scales=scales,
                problem=problems[fid],
                label=name,
                verify=False,
                keep_trajectories=True,
                **kw,
            )
        except Interrupted as stop:
            if stop.result and stop.result['success']:
                keep(fid, name, stop.result)
            raise
        check_later(fid, name, rec, lambda r: keep(fid, name, r))
        keep(fid, name, rec)
        collect(block=False)

    try:
        for fid in ('low', 'mixed'):
            problems[fid] = VehicleProblem(
                config, fid, scales, recorder=out / f'{fid}.sql', progress=pumped
            )
        low, mixed = problems['low'], problems['mixed']

        def step(fid: str, start: str, result: str, guess) -> None:
            """Evaluate model ``fid`` at design ``start``, optimize it from there (same
            problem, IPOPT starting from that collocation solution), verify, record, save."""
            evaluation(fid, start, guess=guess)
            try:
                res = optimize(
                    config,
                    fid,
                    start=designs[start],
                    scales=scales,
                    problem=problems[fid],
                    guess='keep',
                    label=result,
                    verify=False,
                )
            except Interrupted as stop:
                if stop.result and stop.result['success']:  # converged: kept, unchecked
                    study['steps'][fid] = stop.result
                    designs[result] = stop.result['design']
                    save()
                raise
            study['steps'][fid] = res
            designs[result] = res['design']
            save()
            if not res['success']:
                raise StepFailed(fid, res)
            ev = dict(res, mode='optimize')

            def done(record: dict[str, Any]) -> None:
                v = record['verification']
                study['steps'][fid]['verification'] = {
                    k: x for k, x in v.items() if k != 'trajectories'
                }
                study['steps'][fid]['verified'] = record['verified']
                keep(fid, result, record)

            check_later(fid, result, ev, done)
            done(ev)

        say(
            'step 1/2: low-fidelity model at the initial design (evaluation), then its '
            'optimization from there'
        )
        step('low', 'initial', 'low_optimum', initial_guess(config, 'low', designs['initial']))
        say(
            'step 2/2: mixed-fidelity model at the low-fidelity optimum (evaluation), then '
            'its optimization from there'
        )
        step(
            'mixed',
            'low_optimum',
            'mixed_optimum',
            [low.timeseries(i) for i in range(len(low.scenarios))],
        )

        say(
            'evaluating every design in both models (IPOPT solves the collocation '
            'equations with the design held)'
        )
        evaluation('mixed', 'initial')
        evaluation(
            'low', 'mixed_optimum', guess=[mixed.timeseries(i) for i in range(len(mixed.scenarios))]
        )
        if checks.pending():
            say('waiting for the time-marching verifications')
        collect(block=True)
        study['designs'] = designs
        if arrays:
            np.savez_compressed(out / 'time_marching.npz', **arrays)
        unverified = [k for k, e in study['evaluations'].items() if verified(e) is False]
        if unverified:
            worst = max(
                unverified, key=lambda k: study['evaluations'][k]['verification']['max_rel_diff']
            )
            v = study['evaluations'][worst]['verification']
            study.setdefault('warnings', []).append(
                f'not verified: collocation and time marching differ by '
                f'{100 * v["max_rel_diff"]:.2g} % on {v["scenarios"][0]["worst_term"]} '
                f'({worst}; tolerance {100 * VERIFY_TOLERANCE:g} %): the grid is too coarse '
                'for this car and road; more --segments or segments = "auto"'
            )
            say(f'warning: {study["warnings"][-1]}')
        study['verified'] = None if not verify else not unverified
        study['problems'] = {fid: prob.stats() for fid, prob in problems.items()}
        study['wall_time_s'] = time.perf_counter() - t_start
        study['complete'] = True
        save()
        say('writing table and figures')
        report.render(out)
    except BaseException as err:
        # a failure keeps every verification still running (results already computed);
        # an interrupt keeps those already in, and marks the others as not checked
        interrupt = isinstance(err, KeyboardInterrupt)
        for key in checks.pending():
            if not interrupt or checks.done(key):
                try:
                    waiting[key](checks.result(key))
                except Exception as failed:  # noqa: BLE001 - the first error is raised
                    waiting[key](failed_verification(failed))
                continue
            waiting[key](interrupted_verification())
        save()
        raise
    finally:
        checks.close()
        for prob in problems.values():
            prob.cleanup()
    return study

