"""The record of a comfort/road-holding Pareto front (``pareto.json``,
:mod:`suspopt.studies.pareto`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from suspopt.records.codec import Node, Record
from suspopt.records.solve import ProblemStats, SolveRecord


@dataclass(frozen=True)
class ParetoPoint(Record):
    """The optimum of comfort share ``alpha``: its term weights, the optimization, and its
    comfort C and road holding R (None unless IPOPT converged; their values where it
    stopped are kept as ``*_at_stop``)."""

    alpha: float
    weights: dict[str, float]
    result: SolveRecord
    comfort: float | None
    road_holding: float | None
    comfort_at_stop: float | None = None
    road_holding_at_stop: float | None = None

    @property
    def success(self) -> bool:
        return self.result.success

    @property
    def reached(self) -> tuple[float | None, float | None]:
        """C and R where the solve ended, result or not."""
        if self.success:
            return self.comfort, self.road_holding
        return self.comfort_at_stop, self.road_holding_at_stop

    def check(self, node: Node) -> None:
        if self.success != (self.comfort is not None and self.road_holding is not None):
            raise node.child('comfort').error(
                'given exactly when the optimization converged (result.success)'
            )


@dataclass(frozen=True)
class ParetoInitial(Record):
    """The initial design evaluated in the front's model (the reference point)."""

    design: dict[str, float]
    success: bool
    terms: dict[str, float] | None
    comfort: float | None
    road_holding: float | None


@dataclass
class ParetoFront(Record):
    """The front as it goes: one optimization per comfort share, on one problem."""

    KIND = 'pareto'

    config: dict[str, Any]
    fidelity: str
    scales: tuple[dict[str, float], ...]
    terms: tuple[str, ...]
    design_names: tuple[str, ...]
    bounds: dict[str, tuple[float, float]]
    normalization: str
    points: list[ParetoPoint] = field(default_factory=list)
    initial: ParetoInitial | None = None
    complete: bool = False
    problem: ProblemStats | None = None
    wall_time_s: float | None = None
