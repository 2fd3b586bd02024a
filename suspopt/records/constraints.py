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
    ``value`` (and ``where``), whether the design exceeds the bound by more than the
    ``tolerance`` there (``exceeded``), and whether that is a verification failure
    (``violated``): only if the collocation met the constraint (``collocation_met``) —
    a design the collocation already finds outside (an evaluation's, which reports its
    constraints instead of enforcing them) is not a disagreement of the two."""

    name: str
    upper: bool
    bound: float
    value: float
    tolerance: float
    where: str = ''
    collocation_met: bool = True

    @property
    def margin(self) -> float:
        return margin(self.value, self.bound, self.upper)

    @property
    def exceeded(self) -> bool:
        return bool(self.margin < -self.tolerance)

    @property
    def violated(self) -> bool:
        return self.collocation_met and self.exceeded

    def describe(self) -> str:
        """One line: the bound, the time marching's worst value and where."""
        side = '<=' if self.upper else '>='
        at = f' at {self.where}' if self.where else ''
        return (
            f'constraints.{self.name} {side} {self.bound:g}: {self.value:.4g}{at} '
            f'(tolerance {self.tolerance:.2g})'
        )

    def derived(self) -> dict[str, Any]:
        return {'margin': self.margin, 'exceeded': self.exceeded, 'violated': self.violated}


@dataclass(frozen=True)
class Infeasibility(Record):
    """IPOPT stopped without a feasible design: the constraint ``name`` violated most
    (relative to its scale) at the design where it stopped, and its ``value`` there, in
    ``units``, against the ``bound``. A path constraint's value is by time marching of
    that design (exact dynamics, not the unconverged collocation), a design-only one's is
    exact; IPOPT's restoration phase minimizes the violation, so ``violation`` is the
    smallest it found, an upper bound of the smallest any design in the box reaches."""

    name: str
    units: str
    upper: bool
    bound: float
    value: float
    where: str = ''

    @property
    def violation(self) -> float:
        return -margin(self.value, self.bound, self.upper)

    def derived(self) -> dict[str, Any]:
        return {'violation': self.violation}

    def describe(self) -> str:
        """One line: which constraint no design met, and by how much at best."""
        side = '<=' if self.upper else '>='
        unit = f' {self.units}' if self.units else ''
        at = f' ({self.where})' if self.where else ''
        return (
            f'constraints.{self.name}: no design in the box meets {side} {self.bound:g}{unit}; '
            f'at the design where IPOPT stopped it is {self.value:.4g}{unit}{at}, '
            f'violated by {self.violation:.3g}{unit}'
        )
