"""The record of a robust-design study (``robust.json``, :mod:`suspopt.studies.robust`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from suspopt.records.codec import Node, Record
from suspopt.records.solve import SolveRecord

ROBUST = 'robust'


@dataclass(frozen=True)
class CrossEvaluation(Record):
    """One optimum marched on every scenario: each ``f_s`` and their combination."""

    design: dict[str, float]
    scenarios: dict[str, float]
    aggregate: float
    time_s: float


@dataclass
class RobustStudy(Record):
    """The robust optimum (``optima['robust']``) and each scenario's own optimum (by its
    name), each marched on every scenario (``cross``)."""

    KIND = 'robust'

    config: dict[str, Any]
    fidelity: str
    scenarios: tuple[str, ...]
    weights: tuple[float, ...]
    aggregate: str
    scales: tuple[dict[str, float], ...]
    design_names: tuple[str, ...]
    optima: dict[str, SolveRecord] = field(default_factory=dict)
    cross: dict[str, CrossEvaluation] = field(default_factory=dict)
    complete: bool = False
    verified: bool | None = None
    wall_time_s: float | None = None

    def formula(self) -> str:
        """How the scenarios combine: ``max_s f_s`` or ``Σ_s w_s f_s``."""
        return 'max_s f_s' if self.aggregate == 'max' else 'Σ_s w_s f_s'

    def check(self, node: Node) -> None:
        if len(self.weights) != len(self.scenarios):
            raise node.child('weights').error(
                f'{len(self.weights)} weights for {len(self.scenarios)} scenarios'
            )
        for label, c in self.cross.items():
            missing = [s for s in self.scenarios if s not in c.scenarios]
            if missing:
                raise (
                    node.child('cross')
                    .child(label)
                    .child('scenarios')
                    .error(f'no value for {", ".join(missing)}')
                )
