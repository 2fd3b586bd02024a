"""The paper's two-step study (paper §4, ``docs/studies.md``): the low-fidelity optimum
from the initial design, then the mixed-fidelity optimum from there, every design in both
models, each verified by time marching, written as it goes."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, cast

import numpy as np

from suspopt.driver import IterationInfo
from suspopt.output.roads import keep_study_inputs
from suspopt.output.rundir import RunDirectory, atomic_path, write_record
from suspopt.output.study_report import FINGERPRINT, study_fingerprint
from suspopt.records.solve import SolveRecord
from suspopt.records.twostep import STEP_RESULT, TwoStepStudy, evaluation_key
from suspopt.spec import StudyConfig
from suspopt.studies.run import (
    Guess,
    Interrupted,
    Progress,
    StepFailed,
    evaluate,
    initial_guess,
    optimize,
    problem_stats,
)
from suspopt.transcription.problem import VehicleProblem
from suspopt.verification.scales import resolve_scales
from suspopt.verification.verify import Verified, Verifier

#: the signals of a time-marched trajectory kept for the verification figure
KEPT_SIGNALS = ('zdd_C', 'thdd_C', 'phidd_C', 'wheel_z')


def run_study(
    config: StudyConfig,
    out_dir: str | Path | RunDirectory,
    *,
    progress: Progress | None = None,
    log: Callable[[str], None] | None = None,
    verify: bool = True,
    verify_jobs: int | None = None,
) -> TwoStepStudy:
    """The two-step study (paper §4), written to ``out_dir`` as it goes.

    1. low-fidelity optimization from the initial design;
    2. mixed-fidelity optimization from the step-1 optimum;
    then each of the three designs evaluated in both models by collocation, each verified
    (with ``verify``) by time marching. Writes ``study.json`` (after every step),
    ``table.md``, the case recorders ``low.sql`` and ``mixed.sql`` (the full trajectories
    of every design in each model), ``time_marching.npz`` and the figures in
    ``figures/``. Returns the study's record.

    The time-marching verifications run beside the optimizations, in background processes
    (:class:`~suspopt.verification.verify.Verifier`; ``verify_jobs`` of them at once,
    None: the cores less one; 0: each in this process, after the solves), and are written
    as they come in."""
    out = out_dir.path if isinstance(out_dir, RunDirectory) else Path(out_dir)
    return TwoStepRun(config, out, progress, log, verify, verify_jobs).run()


class TwoStepRun:
    """One run of the two-step study: its record, problems, verifications and the
    time-marched signals kept for the figures (:func:`run_study`)."""

    def __init__(
        self,
        config: StudyConfig,
        out: Path,
        progress: Progress | None,
        log: Callable[[str], None] | None,
        verify: bool,
        verify_jobs: int | None,
    ):
        self.config, self.out, self.progress = config, out, progress
        self.say = log or (lambda msg: None)
        self.t_start = time.perf_counter()
        self.scales = resolve_scales(config)
        self.study = TwoStepStudy(
            config=keep_study_inputs(out, config),
            scales=tuple(self.scales),
            terms=tuple(config.terms()),
            design_names=tuple(config.design_names()),
            normalization=config.objective.normalization,
            weights=dict(config.objective.weights),
            verify=verify,
            designs={'initial': config.design.initial()},
        )
        self.save()
        self.problems: dict[str, VehicleProblem] = {}
        self.arrays: dict[str, np.ndarray] = {}
        #: verification key → (model, design)
        self.checking: dict[str, tuple[str, str]] = {}
        self.verifier = Verifier(config, self.scales, enabled=verify, jobs=verify_jobs)

    def save(self) -> None:
        write_record(self.out, self.study)

    def run(self) -> TwoStepStudy:
        try:
            for fid in ('low', 'mixed'):
                self.problems[fid] = VehicleProblem(
                    self.config,
                    fid,
                    self.scales,
                    recorder=self.out / f'{fid}.sql',
                    progress=self._pumped,
                )
            self._solve_all()
            self._finish()
        except BaseException as err:
            # a failure keeps every verification still running (results already
            # computed); an interrupt keeps those already in, marks the others not checked
            for v in self.verifier.settle(interrupted=isinstance(err, KeyboardInterrupt)):
                self._verified(v)
            self.save()
            raise
        finally:
            self.verifier.close()
            for prob in self.problems.values():
                prob.cleanup()
        return self.study

    def _solve_all(self) -> None:
        low, mixed = self.problems['low'], self.problems['mixed']
        self.say(
            'step 1/2: low-fidelity model at the initial design (evaluation), then its '
            'optimization from there'
        )
        start = initial_guess(self.config, 'low', self.study.designs['initial'])
        self._step('low', 'initial', start)
        self.say(
            'step 2/2: mixed-fidelity model at the low-fidelity optimum (evaluation), then '
            'its optimization from there'
        )
        self._step('mixed', 'low_optimum', [low.timeseries(i) for i in range(len(low.scenarios))])
        self.say(
            'evaluating every design in both models (IPOPT solves the collocation '
            'equations with the design held)'
        )
        self._evaluation('mixed', 'initial')
        guess = [mixed.timeseries(i) for i in range(len(mixed.scenarios))]
        self._evaluation('low', 'mixed_optimum', guess)

    # ------------------------------------------------------------------ one step
    def _pumped(self, info: IterationInfo) -> None:
        self.verifier.pump()
        if self.progress is not None:
            self.progress(info)

    def _keep(self, fid: str, name: str, record: SolveRecord) -> None:
        self.study.evaluations[evaluation_key(fid, name)] = record
        if STEP_RESULT.get(fid) == name and fid in self.study.steps:
            self.study.steps[fid] = record  # the step's optimum is its own evaluation
        self.save()

    def _evaluation(self, fid: str, name: str, guess: Guess = 'auto') -> None:
        """Evaluate design ``name`` in model ``fid``, keep it and verify it beside what
        follows; interrupted, keep it only if IPOPT had converged (then not verified, and
        said so) and stop."""
        try:
            rec = evaluate(
                self.config,
                fid,
                self.study.designs[name],
                scales=self.scales,
                problem=self.problems[fid],
                label=name,
                verify=False,
                guess=guess,
            )
        except Interrupted as stop:
            if stop.result is not None and stop.result.success:
                self._keep(fid, name, stop.result)
            raise
        self._keep(fid, name, self._submit(fid, name, rec))
        self._collect(block=False)

    def _step(self, fid: str, start: str, guess: Guess) -> None:
        """Evaluate model ``fid`` at design ``start``, optimize it from there (same
        problem, IPOPT starting from that collocation solution), verify, record, save."""
        self._evaluation(fid, start, guess)
        result = STEP_RESULT[fid]
        try:
            rec = optimize(
                self.config,
                fid,
                start=self.study.designs[start],
                scales=self.scales,
                problem=self.problems[fid],
                guess='keep',
                label=result,
                verify=False,
            )
        except Interrupted as stop:
            if stop.result is not None and stop.result.success:  # converged: kept, unchecked
                self.study.steps[fid] = stop.result
                self.study.designs[result] = stop.result.design
                self.save()
            raise
        self.study.steps[fid] = rec
        self.save()
        if not rec.success:
            raise StepFailed(fid, rec)
        self.study.designs[result] = rec.design
        self._keep(fid, result, self._submit(fid, result, rec))

    # ------------------------------------------------------------------ verifications
    def _submit(self, fid: str, name: str, record: SolveRecord) -> SolveRecord:
        """Verify design ``name`` in model ``fid`` beside what follows; the record as it
        stands meanwhile (pending, or final: a failed solve, verification skipped)."""
        key = evaluation_key(fid, name)
        self.checking[key] = (fid, name)
        return self.verifier.submit(key, record, self.problems[fid].modules)

    def _verified(self, v: Verified) -> None:
        """A verification came in: keep the record with it, and the first scenario's
        time-marched signals for the figures."""
        fid, name = self.checking[v.key]
        for tr in v.trajectories[:1]:
            for key in KEPT_SIGNALS:
                if key in tr.values:
                    self.arrays[f'{v.key}/{key}'] = tr[key]
            self.arrays[f'{v.key}/t'] = tr.t
        self._keep(fid, name, v.record)

    def _collect(self, block: bool) -> None:
        """Keep the verifications that came in (with ``block``: all of them); a failed one
        is kept as failed, then raised."""
        came = self.verifier.collect(block)
        for v in came:
            self._verified(v)
        errors = [v.error for v in came if v.error is not None]
        if errors:
            raise errors[0]

    # ------------------------------------------------------------------ the end
    def _finish(self) -> None:
        import suspopt.output.report as report  # matplotlib only when figures are drawn

        study = self.study
        if self.verifier.pending():
            self.say('waiting for the time-marching verifications')
        self._collect(block=True)
        if self.arrays:  # tied to this study: a report never draws another run's
            arrays = {**self.arrays, FINGERPRINT: np.array(study_fingerprint(study))}
            with atomic_path(self.out / 'time_marching.npz') as tmp, open(tmp, 'wb') as fh:
                np.savez_compressed(fh, **cast(dict[str, Any], arrays))
        unverified = [k for k, e in study.evaluations.items() if e.verified is False]
        if unverified:
            study.warnings.append(_not_verified_warning(study, unverified))
            self.say(f'warning: {study.warnings[-1]}')
        study.verified = None if not study.verify else not unverified
        study.problems = {fid: problem_stats(prob) for fid, prob in self.problems.items()}
        study.wall_time_s = time.perf_counter() - self.t_start
        study.complete = True
        self.save()
        self.say('writing table and figures')
        report.render(self.out)


def _not_verified_warning(study: TwoStepStudy, unverified: list[str]) -> str:
    """The warning of a study whose evaluations ``unverified`` time marching disagrees with
    (every one of them has a comparison), naming the worst."""
    compared = {k: study.evaluations[k].verification.comparison for k in unverified}
    worst, c = max(compared.items(), key=lambda kc: kc[1].severity() if kc[1] else (0, 0.0))
    assert c is not None
    return (
        f'not verified: {c.disagreement()} ({worst}): the grid is too coarse '
        'for this car and road; more --segments or segments = "auto"'
    )
