"""The engineering constraints of a result (``docs/metrics.md``, "Constraints"): each side
of each constraint at the solution, by collocation (in the solve's record) and by time
marching (in its verification)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from suspopt.records.codec import Record


def margin(value: float, bound: float, upper: bool) -> float:
    """How far ``value`` is inside its bound (negative: violated)."""
    return bound - value if upper else value - bound


@dataclass(frozen=True)
class ConstraintValue(Record):
    """One side of one constraint at a solution: the quantity ``name`` (its study-file
    key, e.g. ``travel.bump``) in ``units`` is at most (``upper``) or at least the
    ``bound``; ``value`` is its worst over every node, corner and scenario (a path
    constraint; ``where``: the scenario, corner and time of it) or its value (a
    ``design``-only one), and ``active`` tells whether the solution lies on the bound."""

    name: str
    kind: str
    units: str
    upper: bool
    bound: float
    value: float
    active: bool
    where: str = ''

    @property
    def margin(self) -> float:
        return margin(self.value, self.bound, self.upper)

    def derived(self) -> dict[str, Any]:
        return {'margin': self.margin}


@dataclass(frozen=True)
class ConstraintCheck(Record):
    """A path constraint checked along a dense time-marching trajectory: its worst
    ``value`` (and ``where``), and whether it exceeds the bound by more than the
    ``tolerance`` (``violated``)."""

    name: str
    upper: bool
    bound: float
    value: float
    tolerance: float
    where: str = ''

    @property
    def margin(self) -> float:
        return margin(self.value, self.bound, self.upper)

    @property
    def violated(self) -> bool:
        return bool(self.margin < -self.tolerance)

    def derived(self) -> dict[str, Any]:
        return {'margin': self.margin, 'violated': self.violated}
