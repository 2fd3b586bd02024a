"""The topology study: the same car with different suspension linkages.

The paper argues for a multibody suspension because a mass-spring-damper "will not
capture the behavioural differences between different types of suspension designs, e.g.,
a double-wishbone design vs. a MacPherson design". :func:`run_compare` measures it:

1. the low-fidelity model (half or full car, no linkage) optimized once from the initial
   design;
2. for every *topology* (a mechanism on both axles, or ``FRONT+REAR``), the
   mixed-fidelity model optimized from that low-fidelity optimum;
3. the cross table: every design (the initial design, the low-fidelity optimum and every
   topology's optimum) evaluated by collocation in every model (the low-fidelity model
   and every topology), each cell verified by time marching;
4. the kinematic curves of every mechanism (:mod:`suspopt.multibody.kinematics`) on a
   common wheel-travel range.

Everything goes to a results directory as it goes: ``compare.json`` (atomic, after every
step and cell), the case recorders ``low.sql`` and ``mixed_<topology>.sql`` (the
trajectory of every cell, as case ``<design key>``), and at the end ``table.md`` and
``figures/`` (:mod:`suspopt.output.compare_report`; ``suspopt report DIR`` re-renders them from
the directory alone). A failed optimization or cell is kept with ``success: false`` and
the study goes on with the others; only a failed low-fidelity step stops it (every
topology starts from its optimum).

Design keys: ``initial``, ``low_optimum`` and ``optimum:<topology>``; model keys: ``low``
and ``mixed:<topology>``; a cell is ``cells["<design>|<model>"]``
(:mod:`suspopt.records.compare`).
"""

from __future__ import annotations

import re
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

from suspopt.errors import ConfigError, ModelError
from suspopt.models.design import SPRING, design_id
from suspopt.output.roads import keep_study_inputs
from suspopt.output.rundir import RunDirectory, copy_input, write_record
from suspopt.records.compare import (
    LOW,
    CompareStudy,
    Failure,
    Kinematics,
    MechanismCurves,
    ModelBest,
    Topology,
    cell_key,
    design_key,
    model_key,
)
from suspopt.records.solve import SolveRecord, model_failure
from suspopt.spec.load import config_from_dict
from suspopt.spec.schema import StudyConfig
from suspopt.studies.run import (
    Guess,
    Interrupted,
    Progress,
    StepFailed,
    evaluate,
    optimize,
    problem_stats,
)
from suspopt.transcription.problem import VehicleProblem
from suspopt.verification.scales import resolve_scales
from suspopt.verification.verify import VERIFY_TOLERANCE

#: the shipped topologies, in the order the paper names them (and the SLA variation)
DEFAULT_MECHANISMS = ('double_wishbone', 'sla_double_wishbone', 'macpherson')
#: points of the kinematic curves
KINEMATIC_POINTS = 41
#: the spring rate of the kinematic curves' wheel rate when the design has none [N/m]
DEFAULT_SPRING_RATE = 30000.0


def _safe(label: str) -> str:
    return re.sub(r'[^A-Za-z0-9_.+-]', '_', label)


def parse_topologies(text: str | list[str] | tuple[str, ...]) -> list[tuple[str, str]]:
    """``"a,b,c"`` (or a list) → [(front, rear)]: each entry one mechanism for both axles
    or ``FRONT+REAR``; a built-in name or a mechanism TOML path. Refuses empty entries and
    duplicates (ConfigError naming ``--mechanisms``)."""
    from suspopt.multibody.mechanism import builtin_mechanisms

    items = [s.strip() for s in (text.split(',') if isinstance(text, str) else text)]
    if not items or any(not s for s in items):
        raise ConfigError(
            f'--mechanisms: expected a comma-separated list of mechanisms '
            f'(built-in: {", ".join(builtin_mechanisms())}, or TOML paths; '
            f'FRONT+REAR for one per axle), got {text!r}'
        )
    out = []
    for s in items:
        parts = [p.strip() for p in s.split('+')]
        if len(parts) > 2 or any(not p for p in parts):
            raise ConfigError(f'--mechanisms: {s!r}: one mechanism, or FRONT+REAR')
        front, rear = parts if len(parts) == 2 else (parts[0], parts[0])
        fix = lambda p: p if p in builtin_mechanisms() else str(Path(p).resolve())  # noqa: E731
        out.append((fix(front), fix(rear)))
    if len(set(out)) != len(out):
        raise ConfigError(f'--mechanisms: a topology is listed twice in {text!r}')
    return out


def mechanism_label(mechanism: str) -> str:
    """A built-in name as it is; a file by its stem."""
    from suspopt.multibody.mechanism import builtin_mechanisms

    return mechanism if mechanism in builtin_mechanisms() else Path(mechanism).stem


def mechanism_labels(mechanisms: list[str]) -> dict[str, str]:
    """Every mechanism's label, unique by construction: a built-in name, or a file's stem
    (``strut``); a second mechanism of the same label (another folder's ``strut.toml``,
    a file named like a built-in) is numbered (``strut-2``). Every table row, figure
    curve and dictionary of a study is keyed by these, never by a bare stem."""
    labels: dict[str, str] = {}
    for m in dict.fromkeys(mechanisms):
        base = label = mechanism_label(m)
        k = 2
        while label in labels.values():
            label, k = f'{base}-{k}', k + 1
        labels[m] = label
    return labels


def topology_labels(topologies: list[tuple[str, str]]) -> list[str]:
    """Unique, file-name-safe labels: ``macpherson``, ``macpherson+double_wishbone``."""
    labels, seen = [], set()
    names = mechanism_labels([m for t in topologies for m in t])
    for front, rear in topologies:
        lab = names[front] if front == rear else f'{names[front]}+{names[rear]}'
        lab = _safe(lab)
        base, i = lab, 2
        while lab in seen:
            lab, i = f'{base}-{i}', i + 1
        seen.add(lab)
        labels.append(lab)
    return labels


def topology_config(
    config: StudyConfig, front: str, rear: str, where: str = '--mechanisms'
) -> StudyConfig:
    """``config`` with ``front``/``rear`` as the axles' mechanisms (validated: a bad
    mechanism is a ConfigError naming ``where``)."""
    d = config.to_dict()
    d['vehicle']['front']['mechanism'] = front
    d['vehicle']['rear']['mechanism'] = rear
    try:
        return config_from_dict(d)
    except ConfigError as err:
        raise ConfigError([f'{where}: {p}' for p in err.problems]) from None


def common_travel(mechanisms: list) -> tuple[float, float]:
    """The wheel-travel range every mechanism passes (the intersection of theirs)."""
    lo = max(m.travel[0] for m in mechanisms)
    hi = min(m.travel[1] for m in mechanisms)
    if not lo < hi:
        raise ConfigError(
            '--mechanisms: the mechanisms share no wheel-travel range '
            f'({", ".join(f"{m.name}: {m.travel}" for m in mechanisms)})'
        )
    return lo, hi


def kinematics_record(mechanisms: dict[str, str], spring_rate: float) -> Kinematics:
    """Kinematic curves of every mechanism (label → file) on the common travel range,
    with the reference-pose values (travel 0) picked out."""
    from suspopt.multibody.kinematics import kinematic_curves
    from suspopt.multibody.mechanism import load_mechanism

    mechs = {lab: load_mechanism(src, suspension=True) for lab, src in mechanisms.items()}
    travel = common_travel(list(mechs.values()))
    curves = {}
    for lab, mech in mechs.items():
        c = kinematic_curves(mech, travel, spring_rate, KINEMATIC_POINTS)
        w = np.asarray(c['travel'])
        arrays = {
            k: tuple(float(x) for x in np.asarray(c[k]))
            for k in (
                'travel',
                'independent',
                'spring_deflection',
                'motion_ratio',
                'wheel_rate',
                'camber',
                'track_change',
            )
        }
        curves[lab] = MechanismCurves(
            name=str(c['name']),
            spring_rate=float(c['spring_rate']),
            **arrays,
            at_reference={
                k: float(np.interp(0.0, w, c[k])) for k in ('motion_ratio', 'wheel_rate')
            },
            moving_mass_kg=float(sum(b.mass for b in mech.bodies if not b.fixed)),
        )
    return Kinematics(
        travel_range=travel, spring_rate=spring_rate, points=KINEMATIC_POINTS, curves=curves
    )


def _copy_mechanisms(out: Path, topologies: list[tuple[str, str]]) -> dict[str, str]:
    """Copy every mechanism file (not the built-in ones) into ``inputs/``: file → its copy
    relative to ``out`` (``inputs/mechanism_<i>_<name>``; a built-in name maps to itself)."""
    from suspopt.multibody.mechanism import builtin_mechanisms

    copies: dict[str, str] = {}
    for src in dict.fromkeys(m for t in topologies for m in t):
        if src in builtin_mechanisms():
            copies[src] = src
            continue
        dst = out / 'inputs' / f'mechanism_{len(copies)}_{Path(src).name}'
        copy_input(src, dst)
        copies[src] = f'inputs/{dst.name}'
    return copies


def run_compare(
    config: StudyConfig,
    out_dir: str | Path | RunDirectory,
    mechanisms: str | list[str] | tuple[str, ...] = DEFAULT_MECHANISMS,
    *,
    progress: Progress | None = None,
    log: Callable[[str], None] | None = None,
    verify: bool = True,
) -> CompareStudy:
    """The topology study (see the module docstring), written to ``out_dir`` as it goes.

    ``mechanisms``: topologies as for :func:`parse_topologies`. ``config`` gives the car
    (half or full), road, grid, design space and objective; its own mechanisms are
    replaced by each topology's. Returns the study's record; ``failures`` lists what did
    not converge or failed, ``verified`` is False if a cell's collocation and time
    marching disagree (None with ``verify=False``). Raises
    :class:`~suspopt.studies.run.StepFailed` if the low-fidelity optimization fails and
    KeyboardInterrupt (after saving, ``interrupted: true``) on an interrupt."""
    out = out_dir.path if isinstance(out_dir, RunDirectory) else Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    return CompareRun(config, out, parse_topologies(mechanisms), progress, log, verify).run()


def _summary_line(res: SolveRecord) -> str:
    """A solve in one line, for the progress log."""
    if not res.success:
        return f'FAILED ({res.status})'
    c = res.verification.comparison
    check = (
        ''
        if c is None
        else f', time marching {100 * c.max_rel_diff:.3g} % off: '
        + ('verified' if c.agrees else 'NOT verified')
    )
    return f'f = {res.objective:.6f}, {res.iterations} iterations{check}'


class CompareRun:
    """One run of :func:`run_compare`: its record, the topologies' study descriptions and
    the problems of every model."""

    def __init__(
        self,
        config: StudyConfig,
        out: Path,
        topologies: list[tuple[str, str]],
        progress: Progress | None,
        log: Callable[[str], None] | None,
        verify: bool,
    ):
        self.config, self.out, self.progress, self.verify = config, out, progress, verify
        self.say = log or (lambda msg: None)
        self.t_start = time.perf_counter()
        self.labels = topology_labels(topologies)
        cfgs = {lab: topology_config(config, f, r) for lab, (f, r) in zip(self.labels, topologies)}
        #: model key → (fidelity, study description)
        self.models: dict[str, tuple[str, StudyConfig]] = {LOW: ('low', config)}
        self.models.update({model_key(lab): ('mixed', cfgs[lab]) for lab in self.labels})
        copies = _copy_mechanisms(out, topologies)
        names = mechanism_labels([m for t in topologies for m in t])
        self.scales = resolve_scales(config)  # the low-fidelity model's: one for all
        self.problems: dict[str, VehicleProblem] = {}
        self.low_guess: Guess = 'auto'
        self.study = CompareStudy(
            config=keep_study_inputs(out, config),
            vehicle_model=config.vehicle.model,
            topologies=tuple(
                Topology(
                    label=lab,
                    front=copies[f],
                    rear=copies[r],
                    front_label=names[f],
                    rear_label=names[r],
                    model=model_key(lab),
                    optimum=design_key(lab),
                    recorder=f'mixed_{lab}.sql',
                )
                for lab, (f, r) in zip(self.labels, topologies)
            ),
            models=tuple(self.models),
            design_order=('initial', 'low_optimum', *(design_key(lab) for lab in self.labels)),
            recorders={
                LOW: 'low.sql',
                **{model_key(lab): f'mixed_{lab}.sql' for lab in self.labels},
            },
            scales=tuple(self.scales),
            terms=tuple(config.terms()),
            design_names=tuple(config.design_names()),
            normalization=config.objective.normalization,
            weights=dict(config.objective.weights),
            tolerance=VERIFY_TOLERANCE,
            verify=verify,
            designs={'initial': config.design.initial()},
        )
        self.mechanism_files = {
            names[m]: m if copies[m] == m else str(out / copies[m]) for t in topologies for m in t
        }

    def save(self) -> None:
        write_record(self.out, self.study)

    def run(self) -> CompareStudy:
        import suspopt.output.compare_report as compare_report  # matplotlib: at the end

        self.save()
        springs = [
            v for n, v in self.config.design.initial().items() if design_id(n).kind is SPRING
        ]
        k0 = float(springs[0]) if springs and springs[0] else DEFAULT_SPRING_RATE
        self.study.kinematics = kinematics_record(self.mechanism_files, k0)
        self.save()
        try:
            self._low()
            for i, lab in enumerate(self.labels):
                self._topology(i, lab)
            self._cross()
            self.study.problems = {m: problem_stats(p) for m, p in self.problems.items()}
        except KeyboardInterrupt:
            self.study.interrupted = True
            self.study.wall_time_s = time.perf_counter() - self.t_start
            self.save()
            raise
        finally:
            for p in self.problems.values():
                p.cleanup()
        finish(self.study)
        if self.study.warnings:
            self.say(f'warning: {self.study.warnings[-1]}')
        self.study.wall_time_s = time.perf_counter() - self.t_start
        self.study.complete = True
        self.save()
        self.say('writing table and figures')
        compare_report.render_compare(self.out, self.study, str(self.out / 'compare.json'))
        return self.study

    def _build(self, model: str, recorder: str) -> None:
        fid, cfg = self.models[model]
        self.problems[model] = VehicleProblem(
            cfg, fid, self.scales, recorder=self.out / recorder, progress=self.progress
        )

    def _low(self) -> None:
        """The low-fidelity model: the initial design, then its optimum from there."""
        n = 1 + len(self.labels)
        self.say(
            f'1/{n} low-fidelity model ({self.config.vehicle.model}, no linkage): the initial '
            'design, then its optimum from there'
        )
        self._build(LOW, 'low.sql')
        self._cell('initial', LOW)
        low = self._optimize(LOW, 'initial', 'low_optimum', 'keep')
        self.say(f'   low-fidelity optimum: {_summary_line(low)}')
        if not low.success:
            raise StepFailed('low', low)
        low_problem = self.problems[LOW]
        self.low_guess = [low_problem.timeseries(s) for s in range(len(low_problem.scenarios))]

    def _topology(self, i: int, lab: str) -> None:
        """Topology ``lab``: the low-fidelity optimum in its model, then its optimum from
        there (from the half car's time marching if that failed)."""
        model, n = model_key(lab), 1 + len(self.labels)
        self.say(
            f'{i + 2}/{n} mixed-fidelity model, {lab}: the low-fidelity optimum, '
            'then its optimum from there'
        )
        self._build(model, f'mixed_{lab}.sql')
        start = self._cell('low_optimum', model, guess=self.low_guess)
        guess: Guess = 'keep'
        if not start.success:
            self.say(
                f'   {lab}: the low-fidelity optimum failed in this model '
                f"({start.status}); optimizing from the half car's time marching"
            )
            guess = 'auto'
        res = self._optimize(model, 'low_optimum', design_key(lab), guess)
        self.say(f'   {lab} optimum: {_summary_line(res)}')

    def _cross(self) -> None:
        """Every design that exists in every model (those not evaluated yet)."""
        study = self.study
        todo = [
            (d, m)
            for m in study.models
            for d in study.design_order
            if d in study.designs and cell_key(d, m) not in study.cells
        ]
        for j, (d, m) in enumerate(todo):
            rec = self._cell(d, m)
            self.say(f'cross-evaluation {j + 1}/{len(todo)}: {d} in {m}: {_summary_line(rec)}')

    def _cell(self, design: str, model: str, guess: Guess = 'auto') -> SolveRecord:
        """Design ``design`` evaluated in ``model``, kept (a failed one as a failure)."""
        fid, cfg = self.models[model]
        x = self.study.designs[design]
        try:
            rec = evaluate(
                cfg,
                fid,
                x,
                scales=self.scales,
                problem=self.problems[model],
                label=design,
                guess=guess,
                verify=self.verify,
            )
        except ModelError as err:
            norm = cfg.objective.normalization
            rec = model_failure(fid, 'evaluate', x, err, normalization=norm)
        except Interrupted as stop:  # kept if IPOPT had converged (then unchecked)
            if stop.result is not None and stop.result.success:
                self._keep_cell(design, model, stop.result)
            raise
        return self._keep_cell(design, model, rec)

    def _keep_cell(self, design: str, model: str, record: SolveRecord) -> SolveRecord:
        if record.mode == 'evaluate':  # the per-iteration history: kept for optimizations
            record = replace(record, history=())
        self.study.cells[cell_key(design, model)] = record
        if not record.success:
            self.study.failures.append(
                Failure('evaluation', model, record.status, record.message, design)
            )
        self.save()
        return record

    def _optimize(self, model: str, start: str, result: str, guess: Guess) -> SolveRecord:
        """Optimize ``model`` from design ``start`` (with ``guess='keep'`` from the
        collocation solution of its cell, just solved on the same problem)."""
        fid, cfg = self.models[model]
        study = self.study
        try:
            res = optimize(
                cfg,
                fid,
                start=study.designs[start],
                scales=self.scales,
                problem=self.problems[model],
                guess=guess,
                label=result,
                verify=self.verify,
            )
        except ModelError as err:
            norm = cfg.objective.normalization
            res = model_failure(fid, 'optimize', study.designs[start], err, normalization=norm)
        except Interrupted as stop:  # a converged optimum is kept (then unchecked)
            if stop.result is not None and stop.result.success:
                self._keep_optimum(model, result, stop.result)
            raise
        if res.success:
            self._keep_optimum(model, result, res)
        else:
            study.steps[model] = res
            study.failures.append(Failure('optimization', model, res.status, res.message))
            self.save()
        return res

    def _keep_optimum(self, model: str, result: str, res: SolveRecord) -> None:
        self.study.steps[model] = res
        self.study.designs[result] = res.design
        self.study.cells[cell_key(result, model)] = res
        self.save()


def finish(study: CompareStudy) -> CompareStudy:
    """The verdicts of a finished study, from its cells: ``best`` (:func:`best_designs`),
    ``warnings`` (the cells whose collocation and time marching disagree) and ``verified``
    (None when verification was skipped)."""
    study.best = best_designs(study)
    compared = {k: c.verification.comparison for k, c in study.cells.items() if c.verified is False}
    study.warnings = []
    if compared:
        worst, v = max(compared.items(), key=lambda kv: kv[1].severity() if kv[1] else (0, 0.0))
        assert v is not None
        study.warnings.append(
            f'not verified: {len(compared)} of {len(study.cells)} cells; worst '
            f'{worst}: {v.disagreement()}: '
            'the grid is too coarse for this car and road; more --segments'
        )
    study.verified = None if not study.verify else not compared
    return study


def best_designs(study: CompareStudy) -> dict[str, ModelBest]:
    """Per model: the design with the lowest f among the converged cells, and each
    design's excess ``f / f_own - 1`` over the model's own optimum (None where missing)."""
    out = {}
    for m in study.models:
        fs = {
            d: c.objective
            for d in study.design_order
            for c in [study.cell(d, m)]
            if c is not None and c.success and c.objective is not None
        }
        own = study.own_optimum(m)
        f_own = fs.get(own)
        out[m] = ModelBest(
            best=min(fs, key=lambda d: fs[d]) if fs else None,
            own_optimum=own,
            f_own=f_own,
            excess={d: (f / f_own - 1.0 if f_own else None) for d, f in fs.items()},
        )
    return out


def exit_code(study: CompareStudy) -> int:
    """The command line's exit code of a topology study: 1 if something failed, 3 if a
    cell is not verified, else 0 (130 is the interrupt, handled by the caller)."""
    if study.failures:
        return 1
    if study.verified is False:
        return 3
    return 0
