"""The record of a control co-design study (``docs/codesign.md``): the passive optimum,
the open-loop co-design (the bound of any controller with full preview of the road) and
the realizable state-feedback co-design of one controlled suspension, each a verified
solve of the same objective."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from suspopt.records.codec import Record
from suspopt.records.solve import SolveRecord

#: the entries of a study, in order: the car without control, and the two control laws
PASSIVE, OPEN_LOOP, FEEDBACK = 'passive', 'open_loop', 'feedback'


@dataclass
class CodesignStudy(Record):
    """One controlled suspension (``control``: ``active`` or ``semi_active``) in one model
    (``fidelity``), optimized three ways from the same objective and scales:
    ``entries`` by :data:`PASSIVE`, :data:`OPEN_LOOP`, :data:`FEEDBACK` (those run, in
    that order; written as each comes in by ``suspopt codesign``). ``config``: the study
    description (inputs kept in the run's directory); ``complete``: every law was run."""

    KIND = 'codesign'

    fidelity: str
    control: str
    entries: dict[str, SolveRecord] = field(default_factory=dict)
    wall_time_s: float = 0.0
    config: dict[str, Any] = field(default_factory=dict)
    complete: bool = False

    @property
    def verified(self) -> bool | None:
        """Every converged entry verified by time marching (None: none was checked)."""
        checks = [r.verified for r in self.entries.values() if r.success]
        if not checks or any(v is None for v in checks):
            return None
        return all(checks)

    def objective(self, entry: str) -> float | None:
        """``f`` of an entry by time marching where it was verified, else the collocation's
        (None: not converged)."""
        rec = self.entries.get(entry)
        if rec is None or not rec.success:
            return None
        c = rec.verification.comparison
        return c.objective if c is not None else rec.objective

    def recovered(self) -> float | None:
        """The share of the open-loop bound's gain over the passive optimum that the
        feedback law realizes, ``(f_passive - f_feedback) / (f_passive - f_open_loop)``
        (None unless all three converged)."""
        p, o, b = (self.objective(e) for e in (PASSIVE, OPEN_LOOP, FEEDBACK))
        if p is None or o is None or b is None or p == o:
            return None
        return (p - b) / (p - o)

    def derived(self) -> dict[str, Any]:
        return {
            'objectives': {e: self.objective(e) for e in self.entries},
            'feedback_recovers': self.recovered(),
        }
