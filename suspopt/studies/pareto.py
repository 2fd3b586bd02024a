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

import numpy as np

from suspopt.errors import ConfigError
from suspopt.models.metrics import METRICS, term_kind
from suspopt.output.roads import keep_study_inputs
from suspopt.output.rundir import RunDirectory, write_record
from suspopt.records.pareto import ParetoFront, ParetoInitial, ParetoPoint
from suspopt.records.solve import SolveRecord
from suspopt.spec.schema import StudyConfig
from suspopt.studies.run import Guess, Interrupted, Progress, evaluate, optimize, problem_stats
from suspopt.transcription.problem import VehicleProblem
from suspopt.verification.scales import resolve_scales


def sides(config: StudyConfig) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The two sides of the trade-off: the study's weighted comfort terms and its
    weighted road-holding terms (:data:`~suspopt.models.metrics.METRICS`' groups); where
    the study weights none of a side, the paper's (the chassis accelerations, the wheels'
    displacements)."""
    terms, w = config.terms(), config.objective.weights
    out = []
    for group, paper in (('comfort', config.layout().dofs), ('road_holding', ('wheel_',))):
        weighted = tuple(
            t for t in terms if METRICS[term_kind(t)].group == group and w.get(t, 0.0) > 0.0
        )
        out.append(weighted or tuple(t for t in terms if t in paper or t.startswith(paper)))
    return out[0], out[1]


def comfort_share_weights(config: StudyConfig, alpha: float) -> dict[str, float]:
    """Objective weights of comfort share ``alpha`` in [0, 1]: α/n on each of the n
    comfort terms, (1 - α)/m on each of the m road-holding terms (:func:`sides`)."""
    comfort, road = sides(config)
    a = float(alpha)
    out = dict.fromkeys(config.terms(), 0.0)
    out.update({t: a / len(comfort) for t in comfort})
    out.update({t: (1.0 - a) / len(road) for t in road})
    return out


def comfort_and_road_holding(
    config: StudyConfig, terms: dict[str, float], scales: dict[str, float]
) -> tuple[float, float]:
    """C (the mean normalized comfort term) and R (the mean normalized road-holding
    term) of ``terms`` (:func:`sides`)."""
    comfort, road = sides(config)
    return (
        sum(terms[t] / scales[t] for t in comfort) / len(comfort),
        sum(terms[t] / scales[t] for t in road) / len(road),
    )


def point(
    config: StudyConfig,
    alpha: float,
    weights: dict[str, float],
    res: SolveRecord,
    scales: dict[str, float],
) -> ParetoPoint:
    """One point of the front from an optimization's record."""
    ok = res.success
    J = res.terms if ok else res.terms_at_stop
    C, R = comfort_and_road_holding(config, J, scales) if J else (None, None)
    return ParetoPoint(
        alpha=float(alpha),
        weights=weights,
        result=res,
        comfort=C if ok else None,
        road_holding=R if ok else None,
        comfort_at_stop=None if ok else C,
        road_holding_at_stop=None if ok else R,
    )


def run_pareto(
    config: StudyConfig,
    out_dir: str | Path | RunDirectory,
    *,
    fidelity: str = 'low',
    points: int = 9,
    progress: Progress | None = None,
    log: Callable[[str], None] | None = None,
    verify: bool = True,
) -> ParetoFront:
    """Optimize ``fidelity``'s model for ``points`` comfort shares α = 0 … 1, writing
    ``pareto.json`` after every point, the case recorder ``cases.sql`` (the trajectory
    at every point, as case ``alpha=<α>``) and, at the end, ``table.md`` and
    ``figures/``; the initial design evaluated in the same model is kept as ``initial``.
    A point where IPOPT does not converge is kept with ``success: false`` (its C, R and f
    are None: not results; their values at the stop are kept as ``*_at_stop``) and the
    sweep goes on from the last converged point. Interrupted (Ctrl-C, SIGTERM), it stops
    with ``complete: false``, keeping the point being solved only if IPOPT had converged.
    Returns the front."""
    if points < 2:
        raise ValueError(f'points must be >= 2, got {points}')
    if len(config.scenarios()) > 1:  # C and R are one road's: a front of several is not
        raise ConfigError(
            'scenario: a Pareto front is traced on one load case (its comfort and road '
            f'holding terms); this study has {len(config.scenarios())} [[scenario]] tables '
            '(robust design weighs several)'
        )
    out = out_dir.path if isinstance(out_dir, RunDirectory) else Path(out_dir)
    return ParetoRun(config, out, fidelity, progress, log, verify).run(points)


class ParetoRun:
    """One run of :func:`run_pareto`: the front as it grows, on one built problem."""

    def __init__(
        self,
        config: StudyConfig,
        out: Path,
        fidelity: str,
        progress: Progress | None,
        log: Callable[[str], None] | None,
        verify: bool,
    ):
        self.config, self.out, self.fidelity, self.verify = config, out, fidelity, verify
        self.progress = progress
        self.say = log or (lambda msg: None)
        self.t0 = time.perf_counter()
        self.scales = resolve_scales(config)
        self.front = ParetoFront(
            config=keep_study_inputs(out, config),
            fidelity=fidelity,
            scales=tuple(self.scales),
            terms=tuple(config.terms()),
            design_names=tuple(config.design_names()),
            bounds=config.design.bounds(),
            normalization=config.objective.normalization,
        )

    def save(self) -> None:
        write_record(self.out, self.front)

    def run(self, points: int) -> ParetoFront:
        import suspopt.output.report as report  # matplotlib only when figures are drawn

        self.save()
        problem = VehicleProblem(
            self.config,
            self.fidelity,
            self.scales,
            recorder=self.out / 'cases.sql',
            progress=self.progress,
        )
        try:
            self.say('the initial design in this model (for reference)')
            self.front.initial = self._initial(problem)
            self.save()
            start: dict[str, float] = self.config.design.initial()
            guess: Guess = 'keep'  # the first point starts from the initial design's solution
            for alpha in np.linspace(0.0, 1.0, points):
                start, guess = self._point(problem, float(alpha), start, guess)
            self.front.problem = problem_stats(problem)
            self.front.wall_time_s = time.perf_counter() - self.t0
            self.front.complete = True
            self.save()
            self.say('writing table and figures')
            report.render(self.out)
        finally:
            problem.cleanup()
        return self.front

    def _initial(self, problem: VehicleProblem) -> ParetoInitial:
        """The initial design in the front's model (not converged: no reference point)."""
        start = self.config.design.initial()
        try:
            init = evaluate(
                self.config,
                self.fidelity,
                start,
                scales=self.scales,
                problem=problem,
                label='initial',
                verify=False,
            )
        except Interrupted as stop:  # a converged evaluation is kept before stopping
            if stop.result is not None and stop.result.success:
                self.front.initial = self._initial_of(start, stop.result)
                self.save()
            raise
        return self._initial_of(start, init)

    def _initial_of(self, start: dict[str, float], init: SolveRecord) -> ParetoInitial:
        J = init.terms
        C, R = comfort_and_road_holding(self.config, J, self.scales[0]) if J else (None, None)
        return ParetoInitial(design=start, success=init.success, terms=J, comfort=C, road_holding=R)

    def _point(
        self, problem: VehicleProblem, alpha: float, start: dict[str, float], guess: Guess
    ) -> tuple[dict[str, float], Guess]:
        """Optimize comfort share ``alpha`` and keep the point; the next one's start: this
        optimum (trajectory included) if it converged, else the last converged one."""
        w = comfort_share_weights(self.config, alpha)
        self.say(f'comfort share {alpha:.3f}')
        try:
            res = optimize(
                self.config.with_weights(w),
                self.fidelity,
                start=start,
                scales=self.scales,
                problem=problem,
                guess=guess,
                label=f'alpha={alpha:.6f}',
                verify=self.verify,
            )
        except Interrupted as stop:
            if stop.result is not None and stop.result.success:
                self.front.points.append(point(self.config, alpha, w, stop.result, self.scales[0]))
                self.save()
            raise
        self.front.points.append(point(self.config, alpha, w, res, self.scales[0]))
        self.save()
        return (res.design, 'keep') if res.success else (start, 'auto')
