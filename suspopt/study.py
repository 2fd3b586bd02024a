"""Optimize, evaluate, and the paper's two-step study (paper §4, SPEC §7).

These are the operations of the command line, as a Python API:

* :func:`optimize` — one IPOPT solve of one model from a starting design;
* :func:`evaluate` — one design in one model, by collocation (IPOPT solving the
  collocation equations with the design held) or by independent time marching;
* :func:`run_study` — low-fidelity optimum from the initial design, then the
  mixed-fidelity optimum from there; every design evaluated in both models; the
  paper's Table 4 and Figures 3-5 and more, written to a directory as it goes.

Every collocation result is **verified** by time marching (:func:`time_marching_check`, on
by default):
its record carries ``verification`` with ``verified`` true or false (collocation and time
marching agree on every weighted objective term within :data:`VERIFY_TOLERANCE`), or says
the check was skipped. Results are plain dictionaries (JSON-ready,
:func:`suspopt.results.result_record`); every function takes the study description, so
many can run side by side in separate processes.
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from suspopt.background import Background
from suspopt.config import PAPER_SCALES, StudyConfig
from suspopt.driver import IterationInfo
from suspopt.errors import ModelError
from suspopt.results import RunDirectory, keep_inputs, write_json
from suspopt.timemarching import reference_scales, simulate
from suspopt.trajectory import Trajectory
from suspopt.transcription.problem import Scales, SolveResult, VehicleProblem

Progress = Callable[[IterationInfo], None]


class Interrupted(KeyboardInterrupt):
    """Ctrl-C or SIGTERM during a solve: IPOPT stopped at the end of an iteration.
    ``result`` is that solve's record: converged (``success``; the interrupt came after
    IPOPT's last iteration) and kept by the caller, or not converged and not a result."""

    def __init__(self, result: dict[str, Any] | None = None):
        super().__init__()
        self.result = result


def interrupted_verification() -> dict[str, Any]:
    return {
        'verified': None,
        'interrupted': True,
        'note': 'interrupted before the time-marching verification: not checked',
    }


#: a constraint violation (IPOPT's inf_pr, scaled) below which an iterate counts as feasible
FEASIBLE = 1e-6
#: collocation and time marching must agree this well on every weighted J_k (relative)
VERIFY_TOLERANCE = 5e-3
#: the verification's time-marching tolerances: the J_k to about 1e-6 relative, thousands
#: of times finer than VERIFY_TOLERANCE (tests/test_timemarching.py checks it against
#: a tight integration)
VERIFY_RTOL, VERIFY_ATOL = 1e-6, 1e-9


def resolve_scales(config: StudyConfig) -> Scales:
    """Normalization ``s_k`` of SPEC §5, one table per scenario."""
    norm, n = config.objective.normalization, len(config.scenarios())
    if norm == 'reference':
        return reference_scales(config)
    if norm == 'paper':
        return (dict(PAPER_SCALES),) * n
    return (dict(config.objective.scales),) * n  # custom


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


def initial_guess(
    config: StudyConfig, fidelity: str, design: dict[str, float]
) -> list[Trajectory | None]:
    """The collocation's starting trajectory of every scenario, or None for the zero guess
    (``transcription.initial_guess``).

    ``simulate`` is the low-fidelity model's time marching at ``design`` for both
    fidelities: the states are the same quantities, and it costs far less than the mixed
    model's own time marching, for a start about as good.
    ``auto`` (default) starts the
    low-fidelity model from zero instead: it is linear in its states, so IPOPT's first step
    solves its collocation equations whatever the start, and simulates for the nonlinear
    mixed model.
    """
    mode = config.transcription.initial_guess
    if mode == 'zero' or (mode == 'auto' and fidelity == 'low'):
        return [None] * len(config.scenarios())
    # a starting point only: the collocation error (~1e-4) is far above these tolerances
    return [
        simulate(config, 'low', design, scenario=i, rtol=1e-3, atol=1e-6)
        for i in range(len(config.scenarios()))
    ]


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


def result_record(
    config: StudyConfig,
    res: SolveResult,
    *,
    mode: str,
    start: dict[str, float],
    wall: float,
    verification: dict[str, Any] | None,
) -> dict[str, Any]:
    """The record of one IPOPT solve (the keys of ``result.json``)."""
    best = None
    feas = [h for h in res.history if h.constraint_violation <= FEASIBLE]
    if feas:
        b = min(feas, key=lambda h: h.objective)
        best = {
            'iteration': b.iteration,
            'objective': b.objective,
            'constraint_violation': b.constraint_violation,
            'design': {k.rsplit(':', 1)[-1]: v for k, v in b.design.items()},
        }
    last = res.history[-1] if res.history else None
    scenarios = config.scenarios()
    ok = res.success  # a failed solve's values are not results: they are kept *_at_stop
    out = {
        'fidelity': res.fidelity,
        'mode': mode,
        'method': 'collocation',
        'design': res.design,
        'objective': res.objective if ok else None,
        'terms': res.terms[0] if ok else None,
        'scales': res.scales[0],
        'scenarios': [
            {
                'name': sc.name,
                'weight': sc.weight,
                'objective': f if ok else None,
                'terms': J if ok else None,
                'scales': s,
                'grid': {'segments': sc.segments, 'order': sc.order},
                **({} if ok else {'objective_at_stop': f, 'terms_at_stop': J}),
            }
            for sc, f, J, s in zip(scenarios, res.scenario_objectives, res.terms, res.scales)
        ],
        'normalization': config.objective.normalization,
        'weights': dict(config.objective.weights),
        'aggregate': config.objective.aggregate,
        'success': res.success,
        'status': res.status,
        'message': res.message,
        'interrupted': res.interrupted,
        'iterations': res.iterations,
        'wall_time_s': wall,
        'times': res.times,
        'coloring_from_cache': res.coloring_from_cache,
        'function_evaluations': res.function_evaluations,
        'gradient_evaluations': res.gradient_evaluations,
        'multibody_calls': res.multibody_calls,
        'grid': {'segments': scenarios[0].segments, 'order': scenarios[0].order},
        'start': start,
        'last_iterate': None
        if last is None
        else {
            'iteration': last.iteration,
            'objective': last.objective,
            'constraint_violation': last.constraint_violation,
        },
        'best_feasible_iterate': best,
        'history': [
            {
                'iteration': h.iteration,
                'objective': h.objective,
                'constraint_violation': h.constraint_violation,
                'elapsed_s': h.elapsed_s,
            }
            for h in res.history
        ],
        'verification': verification,
    }
    if not ok:  # never a plain number for a failed solve
        out['objective_at_stop'] = res.objective
        out['terms_at_stop'] = res.terms[0]
    return out


def verified(record: dict[str, Any]) -> bool | None:
    """True/False: the record's verification; None: skipped or not applicable."""
    v = record.get('verification')
    return None if not v else v.get('verified')


def _attach_verification(config, fidelity, record, scales, problem, do_verify, keep=False):
    if not record['success']:
        record['verification'] = {'verified': None, 'note': 'not verified: the solve failed'}
    elif do_verify:
        record['verification'] = time_marching_check(
            config,
            fidelity,
            record['design'],
            [s['terms'] for s in record['scenarios']],
            scales,
            modules=problem.modules or None,
            keep=keep,
        )
    else:
        record['verification'] = skipped_verification()
    record['verified'] = verified(record)
    return record


def optimize(
    config: StudyConfig,
    fidelity: str,
    *,
    start: dict[str, float] | None = None,
    scales: Scales | None = None,
    out_dir: str | Path | RunDirectory | None = None,
    progress: Progress | None = None,
    problem: VehicleProblem | None = None,
    guess: list | str | None = 'auto',
    label: str | None = None,
    verify: bool = True,
) -> dict[str, Any]:
    """Optimize the design of one model (SPEC §1) from ``start`` (default: the configured
    initial design) and verify the optimum by time marching. Writes ``result.json`` (first
    right after IPOPT, so an interrupt during the verification loses nothing), the case
    recorder ``cases.sql`` and copies of the input files (``inputs/``) to ``out_dir`` if
    given. ``problem`` reuses an already built
    problem of this fidelity; ``label`` names the optimum's case in its recorder (default
    ``'<fidelity>_optimum'``). Returns the result record; ``success`` tells whether IPOPT
    converged, ``verified`` whether time marching confirms it. An interrupted solve is
    written and then raises :class:`Interrupted` (with the record: converged or not)."""
    t0 = time.perf_counter()
    start = dict(config.design.initial() if start is None else start)
    scales = resolve_scales(config) if scales is None else scales
    own = problem is None
    out = (
        None
        if out_dir is None
        else out_dir.path
        if isinstance(out_dir, RunDirectory)
        else Path(out_dir)
    )
    config_dict = config.to_dict() if out is None else keep_inputs(out, config.to_dict())
    if own:
        problem = VehicleProblem(
            config,
            fidelity,
            scales,
            progress=progress,
            recorder=None if out is None else out / 'cases.sql',
        )
    try:
        problem.set_weights(config.objective.weights)
        problem.set_design(start)
        if guess == 'auto':
            guess = initial_guess(config, fidelity, start)
        if guess != 'keep':
            problem.set_initial_guess(guess)
        res = problem.solve(optimize=True)
        problem.record(label or f'{fidelity}_optimum')
        record = result_record(
            config,
            res,
            mode='optimize',
            start=start,
            wall=time.perf_counter() - t0,
            verification=None,
        )
        if res.interrupted:
            record['verification'], record['verified'] = interrupted_verification(), None
        if out is not None:  # before the verification: an interrupt there loses nothing
            write_json(out / 'result.json', {**record, 'config': config_dict})
        if res.interrupted:
            raise Interrupted(record)
        _attach_verification(config, fidelity, record, scales, problem, verify)
        record['wall_time_s'] = time.perf_counter() - t0
    except ModelError as err:
        if out is not None:  # what failed, where, is part of the results
            write_json(
                out / 'result.json',
                {
                    'fidelity': fidelity,
                    'mode': 'optimize',
                    'method': 'collocation',
                    'design': start,
                    'start': start,
                    'objective': None,
                    'success': False,
                    'status': 'Model_Error',
                    'message': str(err),
                    'iterations': 0,
                    'verified': None,
                    'normalization': config.objective.normalization,
                    'wall_time_s': time.perf_counter() - t0,
                    'config': config_dict,
                },
            )
        raise
    finally:
        if own:
            problem.cleanup()
    if out is not None:  # with its study description: the file is self-contained
        write_json(out / 'result.json', {**record, 'config': config_dict})
    return record


def evaluate(
    config: StudyConfig,
    fidelity: str,
    design: dict[str, float] | None = None,
    *,
    method: str = 'collocation',
    scales: Scales | None = None,
    problem: VehicleProblem | None = None,
    label: str | None = None,
    guess: list | str | None = 'auto',
    verify: bool = True,
    keep_trajectories: bool = False,
) -> dict[str, Any]:
    """Evaluate one design in one model without optimizing.

    ``method='collocation'`` solves the collocation equations on the configured grid
    (IPOPT with the design held), verified by time marching; ``'time-marching'``
    integrates with SciPy's adaptive DOP853 instead (independent of the grid). Returns the
    same keys as :func:`optimize`."""
    t0 = time.perf_counter()
    design = dict(config.design.initial() if design is None else design)
    scales = resolve_scales(config) if scales is None else scales
    if method == 'time-marching':
        v = time_marching_check(
            config,
            fidelity,
            design,
            [dict.fromkeys(config.terms(), 0.0)] * len(scales),
            scales,
            modules=problem.modules if problem else None,
        )
        sc = v['scenarios']
        return {
            'fidelity': fidelity,
            'mode': 'evaluate',
            'method': method,
            'design': design,
            'objective': v['objective'],
            'terms': sc[0]['terms'],
            'scales': scales[0],
            'scenarios': [
                {
                    'name': s['name'],
                    'objective': s['objective'],
                    'terms': s['terms'],
                    'scales': sc_scales,
                }
                for s, sc_scales in zip(sc, scales)
            ],
            'normalization': config.objective.normalization,
            'success': True,
            'status': 'integrated',
            'iterations': None,
            'verified': None,
            'verification': {'verified': None, 'note': 'this is the time marching'},
            'wall_time_s': time.perf_counter() - t0,
            **(
                {'max_constraint_residual_m': max(s['max_constraint_residual_m'] for s in sc)}
                if fidelity == 'mixed'
                else {}
            ),
        }
    if method != 'collocation':
        raise ValueError(f"method must be 'collocation' or 'time-marching', got {method!r}")
    own = problem is None
    if own:
        problem = VehicleProblem(config, fidelity, scales)
    try:
        problem.set_weights(config.objective.weights)
        problem.set_design(design)
        if guess == 'auto':
            guess = initial_guess(config, fidelity, design)
        if guess != 'keep':
            problem.set_initial_guess(guess)
        res = problem.solve(optimize=False)
        if label:
            problem.record(label)
        traj = problem.timeseries()
        record = result_record(
            config,
            res,
            mode='evaluate',
            start=design,
            wall=time.perf_counter() - t0,
            verification=None,
        )
        if res.interrupted:
            record['verification'], record['verified'] = interrupted_verification(), None
            raise Interrupted(record)
        _attach_verification(
            config, fidelity, record, scales, problem, verify, keep=keep_trajectories
        )
    finally:
        if own:
            problem.cleanup()
    if fidelity == 'mixed':
        record['max_constraint_residual_m'] = traj.info['max_constraint_residual_m']
    record['wall_time_s'] = time.perf_counter() - t0
    return record


# ---------------------------------------------------------------------------- the study
class StepFailed(Exception):
    """A step of the study did not converge (its partial results are written)."""

    def __init__(self, fidelity: str, result: dict[str, Any]):
        self.fidelity, self.result = fidelity, result
        last = result.get('last_iterate') or {}
        super().__init__(
            f'{fidelity}-fidelity optimization did not converge: IPOPT {result["status"]} '
            f'after {result["iterations"]} iterations (last objective '
            f'{last.get("objective", math.nan):.6g}, constraint violation '
            f'{last.get("constraint_violation", math.nan):.3g})'
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
    from suspopt import report  # matplotlib only when figures are drawn

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
