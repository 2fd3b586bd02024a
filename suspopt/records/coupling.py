"""The record of the coupling comparison (``coupling.json``,
:mod:`suspopt.studies.coupling`): four designs in three models."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from suspopt.records.codec import Node, Record
from suspopt.records.solve import ProblemStats, SolveRecord

#: the three models (half car, multibody on the ground as the paper, on the chassis)
COUPLING_MODEL_LABELS = {
    'low': 'half car',
    'ground': 'multibody, ground mount (paper)',
    'chassis': 'multibody, chassis mount',
}
#: the four designs and the model whose optimum each is (initial: none)
COUPLING_DESIGNS: dict[str, str | None] = {
    'initial': None,
    'low_optimum': 'low',
    'ground_optimum': 'ground',
    'chassis_optimum': 'chassis',
}
COUPLING_DESIGN_LABELS = {
    'initial': 'Initial guess',
    'low_optimum': 'Low-fidelity optimum',
    'ground_optimum': 'Paper-coupling optimum (ground mount)',
    'chassis_optimum': 'Consistent-coupling optimum (chassis mount)',
}


@dataclass(frozen=True)
class CouplingSummary(Record):
    """How far the coupling assumption moves the optimum: each design variable's change
    from the paper-coupling optimum to the consistent one (relative), and f of both optima
    in both multibody models."""

    design_change: dict[str, float]
    f_chassis_at_ground_optimum: float
    f_chassis_at_chassis_optimum: float
    loss_of_paper_optimum_in_chassis_model: float
    f_ground_at_chassis_optimum: float
    f_ground_at_ground_optimum: float


@dataclass
class CouplingStudy(Record):
    """Both couplings' two-step studies and the 4 × 3 cross-evaluation, as it goes:
    ``evaluations[model][design]``."""

    KIND = 'coupling'

    config: dict[str, Any]
    scales: tuple[dict[str, float], ...]
    terms: tuple[str, ...]
    design_names: tuple[str, ...]
    bounds: dict[str, tuple[float, float]]
    normalization: str
    weights: dict[str, float]
    verify: bool = True
    designs: dict[str, dict[str, float]] = field(default_factory=dict)
    steps: dict[str, SolveRecord] = field(default_factory=dict)
    evaluations: dict[str, dict[str, SolveRecord]] = field(
        default_factory=lambda: {m: {} for m in COUPLING_MODEL_LABELS}
    )
    complete: bool = False
    verified: bool | None = None
    warnings: list[str] = field(default_factory=list)
    summary: CouplingSummary | None = None
    problems: dict[str, ProblemStats] = field(default_factory=dict)
    wall_time_s: float | None = None

    def evaluation(self, model: str, design: str) -> SolveRecord | None:
        return self.evaluations.get(model, {}).get(design)

    def check(self, node: Node) -> None:
        for m, cells in self.evaluations.items():
            where = node.child('evaluations').child(m)
            if m not in COUPLING_MODEL_LABELS:
                raise where.error(f'not a model ({", ".join(COUPLING_MODEL_LABELS)})')
            for d in cells:
                if d not in COUPLING_DESIGNS:
                    raise where.child(d).error(f'not a design ({", ".join(COUPLING_DESIGNS)})')
