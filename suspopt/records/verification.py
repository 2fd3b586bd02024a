"""The time-marching verification of a collocation result (``docs/model.md``,
"Verification"): one typed state, and the comparison when there is one."""

from __future__ import annotations

import enum
from dataclasses import dataclass

from suspopt.records.codec import Node, Record
from suspopt.records.constraints import ConstraintCheck


class Check(enum.StrEnum):
    """Where a result's verification stands."""

    VERIFIED = 'verified'  # time marching agrees within the tolerance
    NOT_VERIFIED = 'not_verified'  # time marching disagrees
    SKIPPED = 'skipped'  # --no-verify
    INTERRUPTED = 'interrupted'  # Ctrl-C or SIGTERM before it was done
    FAILED = 'failed'  # the time marching itself failed
    PENDING = 'pending'  # not done yet (running beside the solves)
    NOT_APPLICABLE = 'not_applicable'  # nothing to verify: no converged result, or the
    # result is the time marching itself


@dataclass(frozen=True)
class ScenarioComparison(Record):
    """One scenario: the time marching's objective terms and ``f_s``, and the largest
    relative difference of a weighted term to the collocation's (and which term)."""

    name: str
    terms: dict[str, float]
    objective: float
    max_rel_diff: float
    worst_term: str
    wall_time_s: float
    max_constraint_residual_m: float | None = None


@dataclass(frozen=True)
class Comparison(Record):
    """Collocation against time marching over every scenario; ``objective`` is the time
    marching's f (the scenarios combined as the NLP combines them). ``constraints``: every
    path constraint checked along the time-marching trajectories (dense in time, not only
    at the collocation nodes)."""

    method: str
    tolerance: float
    scenarios: tuple[ScenarioComparison, ...]
    objective: float
    max_rel_diff: float
    time_s: float
    constraints: tuple[ConstraintCheck, ...] = ()

    @property
    def violated(self) -> tuple[ConstraintCheck, ...]:
        """The path constraints time marching finds violated beyond their tolerance."""
        return tuple(c for c in self.constraints if c.violated)

    @property
    def agrees(self) -> bool:
        """The weighted terms agree within the tolerance and every path constraint holds
        along the time marching (within its own tolerance)."""
        return bool(self.max_rel_diff <= self.tolerance) and not self.violated

    @property
    def worst(self) -> ScenarioComparison:
        """The scenario with the largest difference."""
        return max(self.scenarios, key=lambda s: s.max_rel_diff)

    def disagreement(self) -> str:
        """Why the two routes disagree, in words (empty if they agree): the path
        constraints time marching violates, and the largest difference of the weighted
        terms if it is beyond the tolerance."""
        why = []
        if self.violated:
            why.append(
                'time marching violates '
                + '; '.join(k.describe() for k in self.violated)
                + ' (the collocation holds it at its nodes only)'
            )
        if self.max_rel_diff > self.tolerance:
            term = f' on {self.worst.worst_term}' if self.scenarios else ''
            why.append(
                f'collocation and time marching differ by {100 * self.max_rel_diff:.3g} %'
                f'{term} (tolerance {100 * self.tolerance:g} %)'
            )
        return '; '.join(why)

    def severity(self) -> tuple[int, float]:
        """Orders disagreements: a violated constraint first, then the larger difference."""
        return (len(self.violated), self.max_rel_diff)


#: the note of each state without a comparison, unless a more specific one is given
NOTES = {
    Check.SKIPPED: 'time-marching verification skipped (--no-verify): this result is not checked',
    Check.INTERRUPTED: 'interrupted before the time-marching verification: not checked',
    Check.PENDING: 'time-marching verification running in the background',
}


@dataclass(frozen=True)
class Verification(Record):
    """A result's verification: its ``state``, the ``comparison`` (exactly when verified
    or not verified) and a ``note`` saying why there is none (or what failed)."""

    state: Check
    comparison: Comparison | None = None
    note: str = ''

    @property
    def verified(self) -> bool | None:
        """True/False: time marching agrees / disagrees; None: not checked."""
        if self.state is Check.VERIFIED:
            return True
        if self.state is Check.NOT_VERIFIED:
            return False
        return None

    def derived(self) -> dict[str, bool | None]:
        return {'verified': self.verified}

    def check(self, node: Node) -> None:
        compared = self.state in (Check.VERIFIED, Check.NOT_VERIFIED)
        if compared != (self.comparison is not None):
            raise node.child('comparison').error(
                f'{"missing" if compared else "unexpected"} for state {self.state.value!r}'
            )
        if self.comparison is not None and self.comparison.agrees != (self.state is Check.VERIFIED):
            raise node.child('state').error(
                f'{self.state.value!r} contradicts max_rel_diff '
                f'{self.comparison.max_rel_diff:g} against tolerance '
                f'{self.comparison.tolerance:g} and {len(self.comparison.violated)} '
                'violated constraints'
            )

    # ------------------------------------------------------------------ the states
    @classmethod
    def of(cls, comparison: Comparison) -> Verification:
        return cls(Check.VERIFIED if comparison.agrees else Check.NOT_VERIFIED, comparison)

    @classmethod
    def skipped(cls) -> Verification:
        return cls(Check.SKIPPED, note=NOTES[Check.SKIPPED])

    @classmethod
    def interrupted(cls) -> Verification:
        return cls(Check.INTERRUPTED, note=NOTES[Check.INTERRUPTED])

    @classmethod
    def pending(cls) -> Verification:
        return cls(Check.PENDING, note=NOTES[Check.PENDING])

    @classmethod
    def failed(cls, err: BaseException) -> Verification:
        return cls(Check.FAILED, note=f'time-marching verification failed: {err}')

    @classmethod
    def not_applicable(cls, why: str) -> Verification:
        return cls(Check.NOT_APPLICABLE, note=why)
