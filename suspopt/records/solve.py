"""The record of one solve or evaluation (what ``result.json`` holds): the design, every
scenario's objective terms and scales, how they combine, IPOPT's outcome and history, the
costs, and the time-marching verification.

A failed solve's values are not results: its ``objective`` and ``terms`` are None, and
where IPOPT stopped is kept as ``objective_at_stop`` / ``terms_at_stop``."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

from suspopt.records.codec import Node, Record
from suspopt.records.constraints import ConstraintCheck, ConstraintValue, Infeasibility
from suspopt.records.control import ControlHistory
from suspopt.records.verification import Check, Verification

#: a constraint violation (IPOPT's inf_pr, scaled) below which an iterate counts as feasible
FEASIBLE = 1e-6


def term_formula(terms: tuple[str, ...] | list[str], weights: dict[str, float]) -> str:
    """``f = Σ_k w_k J_k / s_k`` written out: ``0.25 J_heave/s_heave + ...`` (eq. 4)."""
    return ' + '.join(f'{weights[t]:g} J_{t}/s_{t}' for t in terms if weights.get(t))


@dataclass(frozen=True)
class Grid(Record):
    """A scenario's collocation grid: Radau segments and order."""

    segments: int
    order: int


@dataclass(frozen=True)
class Iterate(Record):
    """One IPOPT iteration: objective, constraint violation (scaled), time since the start."""

    iteration: int
    objective: float
    constraint_violation: float
    elapsed_s: float = 0.0


@dataclass(frozen=True)
class BestIterate(Record):
    """The feasible iterate with the lowest objective, and its design."""

    iteration: int
    objective: float
    constraint_violation: float
    design: dict[str, float]


@dataclass(frozen=True)
class ScenarioResult(Record):
    """One scenario of a solve: its weight ``w_s``, scales ``s_k``, grid, and its
    ``f_s = Σ_k w_k J_k / s_k`` with the terms ``J_k`` (None unless a result)."""

    name: str
    weight: float
    scales: dict[str, float]
    objective: float | None
    terms: dict[str, float] | None
    objective_at_stop: float | None = None
    terms_at_stop: dict[str, float] | None = None
    grid: Grid | None = None

    @property
    def reached(self) -> tuple[float | None, dict[str, float] | None]:
        """f_s and J_k where the solve ended, result or not."""
        if self.objective is not None:
            return self.objective, self.terms
        return self.objective_at_stop, self.terms_at_stop


@dataclass(frozen=True)
class SolveTimes(Record):
    """Seconds spent on the sparsity and coloring, and in IPOPT (with the first model run)."""

    coloring_s: float = 0.0
    coloring_cpu_s: float = 0.0
    solve_s: float = 0.0


@dataclass(frozen=True)
class SolveRecord(Record):
    """One IPOPT solve (``mode`` ``optimize`` or ``evaluate``) or one time-marching
    evaluation (``method``), with its verification.

    ``aggregate`` is how the scenarios' ``f_s`` combine into ``objective``:
    ``sum`` (``Σ_s w_s f_s``) or ``max`` (``max_s f_s``); ``weights`` are the terms'
    ``w_k``, ``normalization`` names where each scenario's scales come from. ``config``
    (the study description) is kept in a run's own ``result.json`` only."""

    KIND = 'solve'

    fidelity: str
    mode: str
    method: str
    start: dict[str, float]
    design: dict[str, float]
    success: bool
    status: str
    objective: float | None
    objective_at_stop: float | None = None
    scenarios: tuple[ScenarioResult, ...] = ()
    aggregate: str = 'sum'
    normalization: str = ''
    weights: dict[str, float] = field(default_factory=dict)
    message: str = ''
    interrupted: bool = False
    iterations: int | None = 0
    function_evaluations: int = 0
    gradient_evaluations: int = 0
    times: SolveTimes | None = None
    wall_time_s: float = 0.0
    coloring_from_cache: bool = False
    multibody_calls: dict[str, int] = field(default_factory=dict)
    history: tuple[Iterate, ...] = ()
    best_feasible_iterate: BestIterate | None = None
    verification: Verification = field(default_factory=Verification.pending)
    max_constraint_residual_m: float | None = None
    #: every side of every engineering constraint at the solution (collocation; where
    #: IPOPT stopped if it did not converge); the time marching's are in ``verification``
    constraints: tuple[ConstraintValue, ...] = ()
    #: a failed solve with a constraint violated where IPOPT stopped: which, by how much
    infeasibility: Infeasibility | None = field(default=None, metadata={'omit_none': True})
    #: the study description (plain data) of a run's own file, ``result.json``
    config: dict[str, Any] | None = field(default=None, metadata={'omit_none': True})
    #: the open-loop controls as solved, one per scenario (``docs/codesign.md``; none for
    #: a passive car or a feedback law): the time marching verifies with them
    controls: tuple[ControlHistory, ...] = ()

    # ------------------------------------------------------------------ views
    @property
    def verified(self) -> bool | None:
        return self.verification.verified

    @property
    def terms(self) -> dict[str, float] | None:
        """The first scenario's J_k (None unless a result)."""
        return self.scenarios[0].terms if self.scenarios else None

    @property
    def terms_at_stop(self) -> dict[str, float] | None:
        return self.scenarios[0].terms_at_stop if self.scenarios else None

    @property
    def scales(self) -> dict[str, float]:
        """The first scenario's scales s_k."""
        return self.scenarios[0].scales if self.scenarios else {}

    @property
    def last_iterate(self) -> Iterate | None:
        return self.history[-1] if self.history else None

    def constraint_rows(self) -> list[tuple[ConstraintValue, ConstraintCheck | None]]:
        """Every constraint side by collocation, with its time-marching check (None: a
        design-only constraint, or no comparison)."""
        c = self.verification.comparison
        checks = {k.name: k for k in c.constraints} if c is not None else {}
        return [(v, checks.get(v.name)) for v in self.constraints]

    def formula(self) -> str:
        """The objective written out: each ``f_s`` (eq. 4) and how they combine."""
        terms = tuple(self.scales)
        f_s = term_formula(terms, self.weights)
        if len(self.scenarios) <= 1:
            return f'f = {f_s}'
        names = [s.name for s in self.scenarios]
        if self.aggregate == 'max':
            total = 'max(' + ', '.join(f'f_{n}' for n in names) + ')'
        else:
            total = ' + '.join(f'{s.weight:g} f_{s.name}' for s in self.scenarios)
        return f'f = {total}; f_s = {f_s} (s_k of each scenario)'

    def derived(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            'verified': self.verified,
            'terms': self.terms,
            'scales': self.scales,
            'formula': self.formula(),
        }
        if not self.success and self.terms_at_stop is not None:
            out['terms_at_stop'] = self.terms_at_stop
        if self.scenarios and self.scenarios[0].grid is not None:
            out['grid'] = self.scenarios[0].grid
        out['last_iterate'] = self.last_iterate
        return out

    def check(self, node: Node) -> None:
        if self.success and self.objective is None:
            raise node.child('objective').error('missing for a converged result')
        if not self.success and self.objective is not None:
            raise node.child('objective').error(
                'a failed solve has no objective (its value where it stopped is objective_at_stop)'
            )

    # ------------------------------------------------------------------ changes
    def with_verification(self, verification: Verification) -> SolveRecord:
        return replace(self, verification=verification)

    def as_mode(self, mode: str) -> SolveRecord:
        return replace(self, mode=mode)


def best_feasible(
    history: tuple[Iterate, ...], designs: list[dict[str, float]]
) -> BestIterate | None:
    """The feasible iterate (:data:`FEASIBLE`) with the lowest objective; ``designs`` are
    the iterates' designs, in the order of ``history``."""
    feasible = [i for i, h in enumerate(history) if h.constraint_violation <= FEASIBLE]
    if not feasible:
        return None
    b = min(feasible, key=lambda i: history[i].objective)
    h = history[b]
    return BestIterate(h.iteration, h.objective, h.constraint_violation, designs[b])


def model_failure(
    fidelity: str,
    mode: str,
    design: dict[str, float],
    err: BaseException,
    *,
    normalization: str,
    wall_time_s: float = 0.0,
) -> SolveRecord:
    """The record of a solve whose model failed before IPOPT could start (no values)."""
    return SolveRecord(
        fidelity=fidelity,
        mode=mode,
        method='collocation',
        start=dict(design),
        design=dict(design),
        success=False,
        status='Model_Error',
        objective=None,
        normalization=normalization,
        message=str(err),
        iterations=0,
        wall_time_s=wall_time_s,
        verification=Verification.not_applicable('not verified: the model failed'),
    )


@dataclass(frozen=True)
class NlpSize(Record):
    """The NLP IPOPT solves: variables × constraints, Jacobian nonzeros and colors."""

    variables: int
    constraints: int
    jacobian_nonzeros: int
    colors: int


@dataclass(frozen=True)
class ProblemStats(Record):
    """What building one problem cost: setup, sparsity and coloring (or from the cache),
    its NLP, and every multibody solver call of its solves."""

    setup_s: float
    coloring_s: float
    coloring_from_cache: bool
    nlp: NlpSize
    multibody_calls_total: dict[str, int] = field(default_factory=dict)


__all__ = [
    'FEASIBLE',
    'BestIterate',
    'Check',
    'ConstraintCheck',
    'ConstraintValue',
    'Infeasibility',
    'Grid',
    'Iterate',
    'NlpSize',
    'ProblemStats',
    'ScenarioResult',
    'SolveRecord',
    'SolveTimes',
    'Verification',
    'best_feasible',
    'model_failure',
    'term_formula',
]
