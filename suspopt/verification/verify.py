"""The time-marching verification of a collocation result: the same design marched by an
independent integrator (:mod:`suspopt.verification.timemarching`), its objective terms
compared with the collocation's (``docs/model.md``, "Verification").

:func:`verify` gives a solve record its :class:`~suspopt.records.verification.Verification`
at once; a :class:`Verifier` runs the verifications of a study beside its solves, in
background processes (:mod:`suspopt.verification.background`)."""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Iterable
from dataclasses import dataclass, field, replace

import numpy as np

from suspopt.errors import ModelError
from suspopt.records.constraints import ConstraintCheck, ConstraintValue, Infeasibility
from suspopt.records.control import ControlHistory
from suspopt.records.solve import SolveRecord
from suspopt.records.trajectory import Trajectory
from suspopt.records.verification import Comparison, ScenarioComparison, Verification
from suspopt.spec import StudyConfig
from suspopt.transcription.constraints import ACTIVE_RTOL, Bound, Worst, bounds, worst_on_path
from suspopt.transcription.problem import Scales
from suspopt.verification.background import Background
from suspopt.verification.timemarching import simulate

#: collocation and time marching must agree this well on every weighted J_k (relative)
VERIFY_TOLERANCE = 5e-3


#: the verification's time-marching tolerances: the J_k to about 1e-6 relative, thousands
#: of times finer than VERIFY_TOLERANCE (tests/verification/test_timemarching.py checks it
#: against a tight integration)
VERIFY_RTOL, VERIFY_ATOL = 1e-6, 1e-9
METHOD = 'time-marching'


def method_of(integrators: Iterable[str]) -> str:
    """The verification's method as the records state it: time marching, and the
    integrators the scenarios used (exact for the linear models, waveform relaxation or
    SciPy's DOP853 otherwise; docs/model.md)."""
    used = sorted({i for i in integrators if i})
    return f'{METHOD} ({"; ".join(used)})' if used else METHOD


#: a path constraint is checked along the time-marching trajectory sampled this finely
#: [s]: a peak between two samples is missed by at most ``1 - cos(π f Δt)`` of its
#: amplitude, 0.1 % for a 15 Hz wheel hop
CONSTRAINT_SAMPLING_S = 1e-3
#: a path constraint holds by time marching if its worst value exceeds the bound by at
#: most this share of the bound (the allowed excursion of its signal: the bump or rebound
#: travel, the tyre's allowed unloading ``1 - margin``) ...
CONSTRAINT_RTOL = 0.03
#: ... or by this much in the signal's units (a bound near zero): 0.5 mm of travel, 0.5 %
#: of the static tyre load
CONSTRAINT_ATOL = {'travel': 5e-4, 'tyre_load_ratio': 5e-3}


def objective_value(
    config: StudyConfig, terms: dict[str, float], scales: dict[str, float]
) -> float:
    """``f = Σ w_k J_k / s_k`` (paper eq. 4) — for results computed outside the NLP."""
    w = config.objective.weights
    return float(sum(w[t] * terms[t] / scales[t] for t in config.terms()))


def combine(config: StudyConfig, scenario_objectives: list[float]) -> float:
    """The scenarios' objectives combined as the NLP does (Σ w_s f_s, or the worst case)."""
    if config.objective.aggregate == 'max' and len(scenario_objectives) > 1:
        return max(scenario_objectives)
    return float(sum(sc.weight * f for sc, f in zip(config.scenarios(), scenario_objectives)))


def constraint_tolerance(bound: Bound) -> float:
    """How far time marching may find path constraint ``bound`` exceeded and still hold
    (:data:`CONSTRAINT_RTOL`, :data:`CONSTRAINT_ATOL`): the collocation holds it at the
    nodes only, and between them a peak of the wheel hop (``NODES_PER_PERIOD`` nodes per
    period of the automatic grid) can rise a few per cent above the nodes' samples."""
    allowed = abs(bound.bound - bound.offset)  # the bound on the signal itself
    return max(CONSTRAINT_RTOL * allowed, CONSTRAINT_ATOL.get(bound.signal, 0.0))


def dense_times(horizon: float) -> np.ndarray:
    """The times a trajectory is sampled at to check the path constraints."""
    return np.linspace(0.0, horizon, max(2001, int(np.ceil(horizon / CONSTRAINT_SAMPLING_S)) + 1))


@dataclass(frozen=True)
class Marched:
    """One scenario marched in time: its terms, ``f_s``, cost and (mixed fidelity) the
    largest constraint residual of the linkages; the worst value of every path
    constraint (by name) along the dense trajectory; the trajectory if it was kept."""

    name: str
    terms: dict[str, float]
    objective: float
    wall_time_s: float
    max_constraint_residual_m: float | None
    trajectory: Trajectory | None
    integrator: str = ''
    worst: dict[str, Worst] = field(default_factory=dict)


def march(
    config: StudyConfig,
    fidelity: str,
    design: dict[str, float],
    scales: Scales,
    *,
    modules: dict | None = None,
    keep: bool = False,
    controls: tuple[ControlHistory, ...] = (),
) -> list[Marched]:
    """Every scenario of ``design`` marched at the verification's tolerances, with its
    open-loop ``controls`` (``docs/codesign.md``), its path constraints checked along a
    trajectory sampled every :data:`CONSTRAINT_SAMPLING_S`; with ``keep``, each trajectory
    (at least 2001 points) is kept."""
    out = []
    path = [b for b in bounds(config) if b.kind == 'path']
    labels = config.layout().labels
    for i, sc in enumerate(config.scenarios()):
        dense = dense_times(sc.horizon) if path else None
        tr = simulate(
            config,
            fidelity,
            design,
            scenario=i,
            modules=modules,
            rtol=VERIFY_RTOL,
            atol=VERIFY_ATOL,
            t_eval=dense if path else None if keep else np.array([0.0, sc.horizon]),
            controls=tuple(c for c in controls if c.scenario == sc.name),
        )
        worst = {}
        for b in path:
            w = worst_on_path(b, [(sc.name, tr.t, tr[b.signal])], labels)
            if w is not None:
                worst[b.name] = w
        terms = dict(zip(config.terms(), (float(x) for x in tr.J)))
        out.append(
            Marched(
                name=sc.name,
                terms=terms,
                objective=objective_value(config, terms, scales[i]),
                wall_time_s=tr.info['wall_time_s'],
                max_constraint_residual_m=tr.info.get('max_constraint_residual_m')
                if fidelity == 'mixed'
                else None,
                trajectory=tr if keep else None,
                integrator=str(tr.info.get('integrator', '')),
                worst=worst,
            )
        )
    return out


#: a term's difference is relative to its time-marched value, but never to less than
#: this fraction of its scale s_k: a term that is numerically zero (exactly 0 by time
#: marching, 1e-30 by collocation) contributes nothing to f and verifies
VERIFY_FLOOR = 1e-6


def _rel_diff(coll: float, tm: float, floor: float = 0.0) -> float:
    """|coll - tm| relative to |tm|, or to ``floor`` where |tm| is below it."""
    ref = max(abs(tm), floor)
    if ref > 0.0:
        return abs(coll - tm) / ref
    return 0.0 if coll == tm else math.inf


def time_marching_check(
    config: StudyConfig,
    fidelity: str,
    design: dict[str, float],
    terms: list[dict[str, float]],
    scales: Scales,
    *,
    modules: dict | None = None,
    keep: bool = False,
    controls: tuple[ControlHistory, ...] = (),
    collocation: tuple[ConstraintValue, ...] = (),
) -> tuple[Comparison, list[Trajectory]]:
    """Time-march ``design`` (and its open-loop ``controls``) in every scenario and
    compare with the collocation's ``terms``: verified if every term with a nonzero weight
    agrees within :data:`VERIFY_TOLERANCE` (relative to its time-marched value, at least
    :data:`VERIFY_FLOOR` of its scale) and every path constraint the collocation meets
    (its values: ``collocation``) holds along the dense time-marching trajectories
    (:func:`constraint_tolerance`). With ``keep``, the trajectories come too."""
    t0 = time.perf_counter()
    weights = config.objective.weights
    marched = march(config, fidelity, design, scales, modules=modules, keep=keep, controls=controls)
    scenarios = []
    for m, coll, s in zip(marched, terms, scales):
        diffs = {
            t: _rel_diff(coll[t], m.terms[t], VERIFY_FLOOR * abs(s.get(t, 0.0)))
            for t in config.terms()
            if weights[t] > 0.0
        }
        worst = max(diffs, key=lambda t: diffs[t])
        scenarios.append(
            ScenarioComparison(
                name=m.name,
                terms=m.terms,
                objective=m.objective,
                max_rel_diff=diffs[worst],
                worst_term=worst,
                wall_time_s=m.wall_time_s,
                max_constraint_residual_m=m.max_constraint_residual_m,
            )
        )
    comparison = Comparison(
        method=method_of(m.integrator for m in marched),
        tolerance=VERIFY_TOLERANCE,
        scenarios=tuple(scenarios),
        objective=combine(config, [s.objective for s in scenarios]),
        max_rel_diff=max([0.0] + [s.max_rel_diff for s in scenarios]),
        time_s=time.perf_counter() - t0,
        constraints=constraint_checks(config, marched, collocation),
    )
    return comparison, [m.trajectory for m in marched if m.trajectory is not None]


def constraint_checks(
    config: StudyConfig,
    marched: list[Marched],
    collocation: tuple[ConstraintValue, ...] = (),
) -> tuple[ConstraintCheck, ...]:
    """Every path constraint at its worst over the scenarios' time-marching trajectories,
    each marked whether the collocation (its ``collocation`` values; none given: met)
    meets it within the same tolerance."""
    coll = {v.name: v for v in collocation}
    out = []
    for b in bounds(config):
        found = [m.worst[b.name] for m in marched if b.name in m.worst]
        if b.kind != 'path' or not found:
            continue
        w = min(found, key=lambda x: b.margin(x.value))
        tol = constraint_tolerance(b)
        out.append(
            ConstraintCheck(
                name=b.name,
                upper=b.upper,
                bound=b.bound,
                value=w.value,
                tolerance=tol,
                where=w.where,
                collocation_met=b.name not in coll or coll[b.name].margin >= -tol,
            )
        )
    return tuple(out)


def infeasibility(
    config: StudyConfig,
    record: SolveRecord,
    scales: Scales,
    modules: dict | None = None,
) -> Infeasibility | None:
    """The constraint a failed solve violates most (relative to its scale) at the design
    where IPOPT stopped, or None if it meets every one there: a path constraint by time
    marching that design (the unconverged collocation's signals are not the dynamics'),
    beyond :func:`constraint_tolerance`; a design-only one at its exact value."""
    if record.success or not record.constraints:
        return None
    by_name = {b.name: b for b in bounds(config)}
    found: list[tuple[float, Infeasibility]] = []
    if any(b.kind == 'path' for b in by_name.values()):
        try:
            marched = march(config, record.fidelity, record.design, scales, modules=modules)
        except ModelError:  # the design cannot be marched: only the design-only ones
            marched = []
        for k in constraint_checks(config, marched):
            if k.exceeded:
                found.append(
                    (
                        -k.margin / by_name[k.name].scale,
                        Infeasibility(
                            k.name, by_name[k.name].units, k.upper, k.bound, k.value, k.where
                        ),
                    )
                )
    for v in record.constraints:
        scale = by_name[v.name].scale if v.name in by_name else abs(v.bound) or 1.0
        if v.kind == 'design' and v.margin < -ACTIVE_RTOL * scale:
            found.append(
                (-v.margin / scale, Infeasibility(v.name, v.units, v.upper, v.bound, v.value))
            )
    return max(found, key=lambda x: x[0])[1] if found else None


def verify(
    config: StudyConfig,
    record: SolveRecord,
    scales: Scales,
    *,
    modules: dict | None = None,
    keep: bool = False,
) -> tuple[SolveRecord, list[Trajectory]]:
    """``record`` with its verification: time marching compared with its terms (a failed
    solve has nothing to verify). With ``keep``, the time-marched trajectories come too."""
    if not record.success:
        failed = replace(record, infeasibility=infeasibility(config, record, scales, modules))
        return failed.with_verification(
            Verification.not_applicable('not verified: the solve failed')
        ), []
    comparison, trajectories = time_marching_check(
        config,
        record.fidelity,
        record.design,
        [s.terms or {} for s in record.scenarios],
        scales,
        modules=modules,
        keep=keep,
        controls=record.controls,
        collocation=record.constraints,
    )
    return record.with_verification(Verification.of(comparison)), trajectories


# ---------------------------------------------------------------------------- beside the solves
@dataclass(frozen=True)
class Verified:
    """A verification that came in: the record with it, the kept trajectories, and the
    error if the time marching failed (the record then says ``failed``)."""

    key: str
    record: SolveRecord
    trajectories: list[Trajectory]
    error: Exception | None = None


class Verifier:
    """The verifications of a study, run beside its solves (``jobs`` background processes
    at once, :class:`~suspopt.verification.background.Background`; None: the cores less
    one; 0: each in this process when collected).

    :meth:`submit` returns the record marked pending (or final at once: a failed solve,
    or ``enabled`` false: skipped); :meth:`collect` returns those that came in. Use as a
    context manager: leaving stops every background process."""

    def __init__(
        self, config: StudyConfig, scales: Scales, *, enabled: bool = True, jobs: int | None = None
    ):
        self.config, self.scales, self.enabled = config, scales, enabled
        self._background = Background(jobs if enabled else 0)
        self._pending: dict[str, SolveRecord] = {}

    def __enter__(self) -> Verifier:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def submit(self, key: str, record: SolveRecord, modules: dict | None = None) -> SolveRecord:
        """Start verifying ``record`` (kept under ``key``); keeps its trajectories."""
        if not record.success:
            return verify(self.config, record, self.scales)[0]
        if not self.enabled:
            return record.with_verification(Verification.skipped())
        job = functools.partial(
            verify, self.config, record, self.scales, modules=modules or None, keep=True
        )
        self._background.submit(key, job)
        self._pending[key] = record
        return record.with_verification(Verification.pending())

    def pump(self) -> None:
        """Start queued verifications as background processes become free (cheap)."""
        self._background.pump()

    def pending(self) -> list[str]:
        return list(self._pending)

    def collect(self, block: bool = False) -> list[Verified]:
        """The verifications that came in (with ``block``, all of them), in submission
        order; a failed one is returned with its error, the record marked failed."""
        out = []
        for key in list(self._pending):
            if block or self._background.done(key):
                out.append(self._take(key))
        return out

    def _take(self, key: str) -> Verified:
        record = self._pending.pop(key)
        try:
            verified, trajectories = self._background.result(key)
        except Exception as err:
            return Verified(key, record.with_verification(Verification.failed(err)), [], err)
        return Verified(key, verified, trajectories)

    def settle(self, interrupted: bool) -> list[Verified]:
        """On a stop: those already in, and the others waited for (after a failure:
        their results are already being computed) or, after an interrupt, marked so."""
        out = []
        for key in list(self._pending):
            if not interrupted or self._background.done(key):
                out.append(self._take(key))
            else:
                record = self._pending.pop(key)
                out.append(Verified(key, record.with_verification(Verification.interrupted()), []))
        return out

    def close(self) -> None:
        self._background.close()
        self._pending.clear()
