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

import math
import time
from pathlib import Path
from typing import Any, Callable

from suspopt.driver import IterationInfo
from suspopt.errors import ModelError
from suspopt.output.rundir import RunDirectory, keep_inputs, write_json
from suspopt.records.trajectory import Trajectory
from suspopt.spec import StudyConfig
from suspopt.transcription.problem import Scales, SolveResult, VehicleProblem
from suspopt.verification.scales import resolve_scales
from suspopt.verification.timemarching import simulate
from suspopt.verification.verify import (
    interrupted_verification,
    skipped_verification,
    time_marching_check,
    verified,
)

Progress = Callable[[IterationInfo], None]


class Interrupted(KeyboardInterrupt):
    """Ctrl-C or SIGTERM during a solve: IPOPT stopped at the end of an iteration.
    ``result`` is that solve's record: converged (``success``; the interrupt came after
    IPOPT's last iteration) and kept by the caller, or not converged and not a result."""

    def __init__(self, result: dict[str, Any] | None = None):
        super().__init__()
        self.result = result


#: a constraint violation (IPOPT's inf_pr, scaled) below which an iterate counts as feasible
FEASIBLE = 1e-6


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

