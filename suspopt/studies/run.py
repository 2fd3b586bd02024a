"""Optimize and evaluate one design in one model (paper §4, ``docs/studies.md``).

These are the operations of the command line, as a Python API; every study is made of
them:

* :func:`optimize` — one IPOPT solve of one model from a starting design;
* :func:`evaluate` — one design in one model, by collocation (IPOPT solving the
  collocation equations with the design held) or by independent time marching.

Each is one build → solve → verify → record step: the problem is built (or a built one
reused), IPOPT solves it (:func:`solve_step`), the result is verified by time marching
(:func:`~suspopt.verification.verify.verify`, on by default) and returned as a
:class:`~suspopt.records.solve.SolveRecord`: ``success`` tells whether IPOPT converged,
``verified`` whether time marching agrees with it (None: not checked, and the record's
verification says why). Every function takes the study description, so many can run side
by side in separate processes.
"""

from __future__ import annotations

import functools
import sqlite3
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path
from typing import Any

from suspopt import interrupts
from suspopt.driver import IterationInfo
from suspopt.errors import ModelError, RunError
from suspopt.output.roads import keep_study_inputs
from suspopt.output.rundir import RunDirectory, write_record
from suspopt.records.solve import (
    NlpSize,
    ProblemStats,
    ScenarioResult,
    SolveRecord,
    model_failure,
)
from suspopt.records.trajectory import Trajectory
from suspopt.records.verification import Verification
from suspopt.spec import StudyConfig
from suspopt.transcription.problem import Scales, VehicleProblem
from suspopt.verification.scales import resolve_scales
from suspopt.verification.verify import combine, march, verify

Progress = Callable[[IterationInfo], None]
#: a collocation's starting trajectories: per scenario (None: zero), ``'auto'``
#: (:func:`initial_guess`), ``'keep'`` (the problem's last solution) or None (zero)
Guess = Sequence[Trajectory | None] | str | None


class Interrupted(KeyboardInterrupt):
    """Ctrl-C or SIGTERM during a solve: IPOPT stopped at the end of an iteration.
    ``result`` is that solve's record: converged (``success``; the interrupt came after
    IPOPT's last iteration) and kept by the caller, or not converged and not a result."""

    def __init__(self, result: SolveRecord | None = None):
        super().__init__()
        self.result = result


class StepFailed(Exception):
    """A step of a study did not converge (its partial results are written)."""

    def __init__(self, what: str, result: SolveRecord):
        self.fidelity, self.result = what, result
        last = result.last_iterate
        nan = float('nan')
        super().__init__(
            f'{what}-fidelity optimization did not converge: IPOPT {result.status} '
            f'after {result.iterations} iterations (last objective '
            f'{last.objective if last else nan:.6g}, constraint violation '
            f'{last.constraint_violation if last else nan:.3g})'
        )


def initial_guess(
    config: StudyConfig, fidelity: str, design: dict[str, float]
) -> list[Trajectory | None]:
    """The collocation's starting trajectory of every scenario, or None for the zero guess
    (``transcription.initial_guess``).

    ``simulate`` is the low-fidelity model's time marching at ``design`` for both
    fidelities: the states are the same quantities, and it costs far less than the mixed
    model's own time marching, for a start about as good. ``auto`` (default) starts the
    low-fidelity model from zero instead: it is linear in its states, so IPOPT's first step
    solves its collocation equations whatever the start, and simulates for the nonlinear
    mixed model.
    """
    from suspopt.verification.timemarching import simulate, starting_controls

    mode = config.transcription.initial_guess
    if mode == 'zero' or (mode == 'auto' and fidelity == 'low'):
        return [None] * len(config.scenarios())
    # a starting point only: the collocation error (~1e-4) is far above these tolerances;
    # an open-loop control at its starting value, as the collocation starts it
    return [
        simulate(
            config,
            'low',
            design,
            scenario=i,
            rtol=1e-3,
            atol=1e-6,
            controls=starting_controls(config, i),
        )
        for i in range(len(config.scenarios()))
    ]


def solve_step(
    problem: VehicleProblem,
    config: StudyConfig,
    design: dict[str, float],
    *,
    optimize: bool,
    guess: Guess = 'auto',
    label: str | None = None,
    keep: Callable[[SolveRecord], SolveRecord] | None = None,
) -> SolveRecord:
    """Solve ``problem`` from ``design`` with ``config``'s weights: optimize it, or only
    solve the collocation equations; record the solution as case ``label`` and pass the
    record to ``keep`` (which writes it). The record's verification is pending (an
    interrupted solve's: interrupted).

    From the solve to ``keep`` a first Ctrl-C or SIGTERM is held
    (:func:`suspopt.interrupts.hold`): IPOPT stops at once, and whatever it
    returned — a converged result included — is recorded and kept before the run stops;
    the record says ``interrupted``. Before the solve (the starting trajectory) a signal
    stops at once: nothing is computed yet."""
    problem.set_weights(config.objective.weights)
    problem.set_design(design)
    if guess == 'auto':
        guess = initial_guess(config, problem.fidelity, design)
    if guess != 'keep':
        problem.set_initial_guess(guess)  # type: ignore[arg-type]
    with interrupts.hold(raise_on_exit=False):
        record = problem.solve(optimize=optimize)
        interrupts.stage('solve:returned', success=record.success, design=record.design)
        if label:
            record_case(problem, label)
        if record.interrupted or interrupts.requested():
            record = replace(record, interrupted=True).with_verification(Verification.interrupted())
        if keep is not None:
            record = keep(record)
    return record


def record_case(problem: VehicleProblem, label: str) -> None:
    """``problem``'s solution as case ``label`` in its case recorder; a recorder that
    cannot be written (a full disk, an SQLite error) is a RunError naming it."""
    try:
        problem.record(label)
    except sqlite3.Error as err:
        raise RunError(f'cannot write the case recorder {problem.recorder_path}: {err}') from None
    interrupts.stage(f'record:{label}')


def verified(
    config: StudyConfig,
    record: SolveRecord,
    scales: Scales,
    problem: VehicleProblem,
    enabled: bool = True,
) -> SolveRecord:
    """``record`` verified by time marching now (``enabled`` false: skipped, and said so)."""
    if record.success and not enabled:
        return record.with_verification(Verification.skipped())
    interrupts.stage('verify')
    return verify(config, record, scales, modules=problem.modules or None)[0]


def problem_stats(problem: VehicleProblem) -> ProblemStats:
    """What building ``problem`` cost, its NLP, and its multibody calls so far."""
    s = problem.stats()
    return ProblemStats(
        setup_s=s['setup_s'],
        coloring_s=s['coloring_s'],
        coloring_from_cache=s['coloring_from_cache'],
        nlp=NlpSize(**s['nlp']),
        multibody_calls_total=dict(s['multibody_calls_total']),
    )


def _out_path(out_dir: str | Path | RunDirectory | None) -> Path | None:
    if out_dir is None:
        return None
    return out_dir.path if isinstance(out_dir, RunDirectory) else Path(out_dir)


@contextmanager
def built(
    config: StudyConfig,
    fidelity: str,
    scales: Scales,
    problem: VehicleProblem | None = None,
    **build: Any,
) -> Iterator[VehicleProblem]:
    """``problem`` if given, else one built now (``build``: its options) and cleaned up
    on leaving."""
    if problem is not None:
        yield problem
        return
    interrupts.stage('build')
    own = VehicleProblem(config, fidelity, scales, **build)
    try:
        yield own
    finally:
        own.cleanup()


def _save_run(out: Path | None, config: dict[str, Any], record: SolveRecord) -> SolveRecord:
    """Write ``record`` as the run's ``result.json`` (with its study description: the file
    is self-contained), if there is an ``out``; returns it."""
    if out is not None:
        write_record(out, replace(record, config=config))
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
    guess: Guess = 'auto',
    label: str | None = None,
    verify: bool = True,
) -> SolveRecord:
    """Optimize the design of one model (paper eq. 14) from ``start`` (default: the configured
    initial design) and verify the optimum by time marching. Writes ``result.json`` (first
    right after IPOPT, so an interrupt during the verification loses nothing), the case
    recorder ``cases.sql`` and copies of the input files (``inputs/``) to ``out_dir`` if
    given. ``problem`` reuses an already built problem of this fidelity; ``label`` names
    the optimum's case in its recorder (default ``'<fidelity>_optimum'``). An interrupted
    solve is written and then raises :class:`Interrupted` (with the record)."""
    t0 = time.perf_counter()
    start = dict(config.design.initial() if start is None else start)
    scales = resolve_scales(config) if scales is None else scales
    out = _out_path(out_dir)
    config_dict = config.to_dict() if out is None else keep_study_inputs(out, config)
    save = functools.partial(_save_run, out, config_dict)
    recorder = None if out is None else out / 'cases.sql'
    with built(config, fidelity, scales, problem, progress=progress, recorder=recorder) as vp:
        try:
            rec = solve_step(
                vp,
                config,
                start,
                optimize=True,
                guess=guess,
                label=label or f'{fidelity}_optimum',
                keep=lambda r: save(replace(r, wall_time_s=time.perf_counter() - t0)),
            )
        except ModelError as err:  # what failed, where, is part of the results
            failed = model_failure(
                fidelity,
                'optimize',
                start,
                err,
                normalization=config.objective.normalization,
                wall_time_s=time.perf_counter() - t0,
            )
            save(failed)
            raise
        if rec.interrupted:
            raise Interrupted(rec)
        try:
            rec = verified(config, rec, scales, vp, verify)
        except KeyboardInterrupt:
            save(rec.with_verification(Verification.interrupted()))
            raise
    return save(replace(rec, wall_time_s=time.perf_counter() - t0))


def evaluate(
    config: StudyConfig,
    fidelity: str,
    design: dict[str, float] | None = None,
    *,
    method: str = 'collocation',
    scales: Scales | None = None,
    problem: VehicleProblem | None = None,
    label: str | None = None,
    guess: Guess = 'auto',
    verify: bool = True,
) -> SolveRecord:
    """Evaluate one design in one model without optimizing.

    ``method='collocation'`` solves the collocation equations on the configured grid
    (IPOPT with the design held), verified by time marching; ``'time-marching'``
    integrates with SciPy's adaptive DOP853 instead (independent of the grid). An
    interrupted solve raises :class:`Interrupted` (with the record)."""
    t0 = time.perf_counter()
    design = dict(config.design.initial() if design is None else design)
    scales = resolve_scales(config) if scales is None else scales
    if method == 'time-marching':
        modules = problem.modules if problem else None
        return replace(
            time_marching_record(config, fidelity, design, scales, modules),
            wall_time_s=time.perf_counter() - t0,
        )
    if method != 'collocation':
        raise ValueError(f"method must be 'collocation' or 'time-marching', got {method!r}")
    with built(config, fidelity, scales, problem) as vp:
        rec = solve_step(vp, config, design, optimize=False, guess=guess, label=label)
        if rec.interrupted:
            raise Interrupted(rec)
        residual = vp.timeseries().info.get('max_constraint_residual_m')
        rec = verified(config, rec, scales, vp, verify)
    return replace(rec, max_constraint_residual_m=residual, wall_time_s=time.perf_counter() - t0)


def time_marching_record(
    config: StudyConfig,
    fidelity: str,
    design: dict[str, float],
    scales: Scales,
    modules: dict | None = None,
) -> SolveRecord:
    """The record of ``design`` evaluated by time marching alone (nothing to verify)."""
    marched = march(config, fidelity, design, scales, modules=modules)
    return SolveRecord(
        fidelity=fidelity,
        mode='evaluate',
        method='time-marching',
        start=dict(design),
        design=dict(design),
        success=True,
        status='integrated',
        objective=combine(config, [m.objective for m in marched]),
        scenarios=tuple(
            ScenarioResult(m.name, sc.weight, dict(s), m.objective, m.terms)
            for m, sc, s in zip(marched, config.scenarios(), scales)
        ),
        aggregate=config.objective.aggregate if len(marched) > 1 else 'sum',
        normalization=config.objective.normalization,
        weights=dict(config.objective.weights),
        iterations=None,
        verification=Verification.not_applicable('this is the time marching'),
        max_constraint_residual_m=max(m.max_constraint_residual_m or 0.0 for m in marched)
        if fidelity == 'mixed'
        else None,
    )
