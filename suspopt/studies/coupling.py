"""How much the paper's coupling assumption moves the optimum (beyond the paper).

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

from suspopt.output.roads import keep_study_inputs
from suspopt.output.rundir import RunDirectory, write_record
from suspopt.records.coupling import (
    COUPLING_DESIGNS,
    COUPLING_MODEL_LABELS,
    CouplingStudy,
    CouplingSummary,
)
from suspopt.records.solve import SolveRecord
from suspopt.spec.schema import StudyConfig
from suspopt.studies.run import (
    Interrupted,
    Progress,
    StepFailed,
    evaluate,
    optimize,
    problem_stats,
)
from suspopt.transcription.problem import VehicleProblem
from suspopt.verification.scales import resolve_scales

#: the three models: (fidelity, mount)
MODELS = {'low': ('low', 'ground'), 'ground': ('mixed', 'ground'), 'chassis': ('mixed', 'chassis')}
#: each optimization: the model and the design it starts from
STEPS = (('low', 'initial'), ('ground', 'low_optimum'), ('chassis', 'low_optimum'))


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
) -> CouplingStudy:
    """Both couplings' two-step studies and the 4 × 3 cross-evaluation (module docstring).

    Every optimization starts from the collocation solution of its starting design in its
    own model; both multibody optimizations start from the low-fidelity optimum. Returns
    the study's record; a step whose IPOPT does not converge raises
    :class:`~suspopt.studies.run.StepFailed` after writing what was done."""
    out = out_dir.path if isinstance(out_dir, RunDirectory) else Path(out_dir)
    return CouplingRun(config, out, progress, log, verify).run()


class CouplingRun:
    """One run of :func:`run_coupling`: its record and the three models' problems."""

    def __init__(
        self,
        config: StudyConfig,
        out: Path,
        progress: Progress | None,
        log: Callable[[str], None] | None,
        verify: bool,
    ):
        self.out, self.progress, self.verify = out, progress, verify
        self.say = log or (lambda msg: None)
        self.t0 = time.perf_counter()
        self.scales = resolve_scales(config)
        self.configs = {m: model_config(config, m) for m in MODELS}
        self.problems: dict[str, VehicleProblem] = {}
        self.study = CouplingStudy(
            config=keep_study_inputs(out, config),
            scales=tuple(self.scales),
            terms=tuple(config.terms()),
            design_names=tuple(config.design_names()),
            bounds=config.design.bounds(),
            normalization=config.objective.normalization,
            weights=dict(config.objective.weights),
            verify=verify,
            designs={'initial': config.design.initial()},
        )

    def save(self) -> None:
        write_record(self.out, self.study)

    def run(self) -> CouplingStudy:
        import suspopt.output.report as report

        self.save()
        try:
            for m, (fid, _) in MODELS.items():
                self.problems[m] = VehicleProblem(
                    self.configs[m], fid, self.scales, progress=self.progress
                )
            for model, start in STEPS:
                self._step(model, start)
            for model in MODELS:
                for design in COUPLING_DESIGNS:
                    self._cell(model, design)
            self._finish()
            self.say('writing table and figure')
            report.render(self.out)
        finally:
            for p in self.problems.values():
                p.cleanup()
        return self.study

    def _cell(self, model: str, design: str) -> SolveRecord:
        """Design ``design`` evaluated in ``model`` (once), kept."""
        done = self.study.evaluation(model, design)
        if done is not None:
            return done
        label = COUPLING_MODEL_LABELS[model]
        self.say(f'evaluating the {design.replace("_", " ")} in the {label} model')
        try:
            rec = evaluate(
                self.configs[model],
                MODELS[model][0],
                self.study.designs[design],
                scales=self.scales,
                problem=self.problems[model],
                verify=self.verify,
            )
        except Interrupted as stop:  # a converged evaluation is kept before stopping
            if stop.result is not None and stop.result.success:
                self.study.evaluations[model][design] = stop.result
                self.save()
            raise
        self.study.evaluations[model][design] = rec
        self.save()
        return rec

    def _step(self, model: str, start: str) -> None:
        """Optimize ``model`` from the collocation solution of design ``start`` in it."""
        fid, mount = MODELS[model]
        self._cell(model, start)
        label = COUPLING_MODEL_LABELS[model]
        self.say(f'optimizing the {label} model from the {start.replace("_", " ")}')
        try:
            step = optimize(
                self.configs[model],
                fid,
                start=self.study.designs[start],
                scales=self.scales,
                problem=self.problems[model],
                guess='keep',
                verify=self.verify,
            )
        except Interrupted as stop:  # a converged step is kept (not checked) before stopping
            if stop.result is not None and stop.result.success:
                self.study.steps[model] = stop.result
                self.study.designs[f'{model}_optimum'] = stop.result.design
                self.study.evaluations[model][f'{model}_optimum'] = stop.result
                self.save()
            raise
        self.study.steps[model] = step
        self.save()
        if not step.success:
            raise StepFailed(f'{fid} ({mount} mount)', step)
        name = f'{model}_optimum'
        self.study.designs[name] = step.design
        self.study.evaluations[model][name] = step
        self.save()

    def _finish(self) -> None:
        study = self.study
        unverified = [
            f'{d} in {m}'
            for m in MODELS
            for d, e in study.evaluations[m].items()
            if e.verified is False
        ]
        study.verified = None if not self.verify else not unverified
        if unverified:
            study.warnings = [f'not verified by time marching: {", ".join(unverified)}']
        study.summary = summary(study)
        study.problems = {m: problem_stats(p) for m, p in self.problems.items()}
        study.wall_time_s = time.perf_counter() - self.t0
        study.complete = True
        self.save()


def summary(study: CouplingStudy) -> CouplingSummary | None:
    """How far the coupling assumption moves the optimum: the change of every design
    variable from the paper-coupling optimum to the consistent one (relative), and what
    the paper-coupling optimum loses in the chassis-mounted model (f there against the
    consistent optimum's f). None if an evaluation it needs is not a result."""
    g, c = study.designs['ground_optimum'], study.designs['chassis_optimum']
    f = {
        (m, d): e.objective
        for m in ('ground', 'chassis')
        for d in ('ground_optimum', 'chassis_optimum')
        for e in [study.evaluation(m, d)]
        if e is not None
    }
    f_cg, f_cc = f.get(('chassis', 'ground_optimum')), f.get(('chassis', 'chassis_optimum'))
    f_gc, f_gg = f.get(('ground', 'chassis_optimum')), f.get(('ground', 'ground_optimum'))
    if f_cg is None or f_cc is None or f_gc is None or f_gg is None:
        return None
    return CouplingSummary(
        design_change={n: c[n] / g[n] - 1.0 for n in g},
        f_chassis_at_ground_optimum=f_cg,
        f_chassis_at_chassis_optimum=f_cc,
        loss_of_paper_optimum_in_chassis_model=f_cg / f_cc - 1.0,
        f_ground_at_chassis_optimum=f_gc,
        f_ground_at_ground_optimum=f_gg,
    )
