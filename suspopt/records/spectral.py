"""The record of a stationary (spectral) evaluation or optimization (``spectral.json``,
:mod:`suspopt.studies.spectral`; ``docs/spectral.md``, section 9).

The low-fidelity vehicle driven at constant speed on an ISO 8608 road of a class: the
stationary RMS of every metric with a finite variance, the objective
``f = Σ_k w_k Var_k / s_k`` (``s_k`` mean squares, ``reference``: their values at the
study's initial design, so ``f = Σ_k w_k`` there), and, for an optimization, IPOPT's
outcome and the RMS limits that stand for the study's constraints."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from suspopt.records.codec import Node, Record

SPECTRAL = 'spectral'


@dataclass(frozen=True)
class SpectralRoad(Record):
    """The stationary road of a scenario: ISO 8608 ``road_class`` (``G_d(n0)`` [m³]),
    ``speed`` [m/s], the tracks' coherence model and separation [m], and the intensity
    ``q`` [m²/s] of the white road velocity (two-sided, per Hz)."""

    road_class: str
    displacement_psd_n0: float
    speed: float
    tracks: str
    separation: float
    velocity_intensity: float


@dataclass(frozen=True)
class SpectralScenario(Record):
    """One scenario: its ``weight`` ``w_s``, road, the Padé order of the wheelbase delay
    (0: none) and its estimated relative RMS error, the mean-square scales ``s_k``, and
    the stationary RMS of every metric with its ``f_s`` at the design (``rms``,
    ``objective``; None unless a result) and at the start (``rms_start``,
    ``objective_start``). ``not_stationary``: the metrics whose variance on this road is
    infinite (left out)."""

    name: str
    weight: float
    road: SpectralRoad
    pade_order: int
    pade_error: float
    scales: dict[str, float]
    rms: dict[str, float] | None
    objective: float | None
    rms_start: dict[str, float] = field(default_factory=dict)
    objective_start: float | None = None
    not_stationary: tuple[str, ...] = ()


@dataclass(frozen=True)
class RmsLimit(Record):
    """A constraint of the study as a bound on a stationary RMS: ``term``'s RMS at most
    ``rms_limit`` = ``bound / sigmas`` (``bound``: the constraint's value in the term's
    units, e.g. the travel to the stop [m]; ``key`` the study file's key); ``rms`` at the
    design and IPOPT's ``multiplier`` of ``Var/rms_limit² <= 1`` (None unless a result)."""

    term: str
    key: str
    bound: float
    sigmas: float
    rms_limit: float
    rms: float | None = None
    multiplier: float | None = None

    @property
    def active(self) -> bool | None:
        """Whether the limit binds at the design (within 10⁻⁶)."""
        if self.rms is None:
            return None
        return bool(self.rms >= self.rms_limit * (1.0 - 1e-6))


@dataclass(frozen=True)
class SpectralRecord(Record):
    """One stationary evaluation (``mode = 'evaluate'``) or optimization (``'optimize'``)
    of the low-fidelity vehicle (see the module docstring). ``objective`` combines the
    scenarios' ``f_s`` by ``aggregate`` (None unless a result); ``limits`` the RMS
    bounds of the optimization; ``iterations`` IPOPT's (None: an evaluation),
    ``evaluations`` the covariances solved; ``solve_time_s`` the solve alone,
    ``wall_time_s`` with building the vehicle's matrices; ``warnings`` what of the
    study was not applied. ``config``: the study description, in a run's own file."""

    KIND = SPECTRAL

    mode: str
    start: dict[str, float]
    design: dict[str, float]
    success: bool
    status: str
    objective: float | None
    objective_start: float | None
    scenarios: tuple[SpectralScenario, ...]
    weights: dict[str, float]
    normalization: str
    aggregate: str = 'sum'
    limits: tuple[RmsLimit, ...] = ()
    method: str = SPECTRAL
    fidelity: str = 'low'
    iterations: int | None = None
    evaluations: int = 0
    hessian: str = ''
    message: str = ''
    solve_time_s: float = 0.0
    wall_time_s: float = 0.0
    warnings: tuple[str, ...] = ()
    config: dict[str, Any] | None = field(default=None, metadata={'omit_none': True})

    @property
    def rms(self) -> dict[str, float] | None:
        """The first scenario's RMS values (None unless a result)."""
        return self.scenarios[0].rms if self.scenarios else None

    @property
    def scales(self) -> dict[str, float]:
        """The first scenario's mean-square scales ``s_k``."""
        return self.scenarios[0].scales if self.scenarios else {}

    def formula(self) -> str:
        """``f = Σ_k w_k Var_k / s_k`` written out, and how the scenarios combine."""
        f_s = ' + '.join(f'{w:g} Var_{t}/s_{t}' for t, w in self.weights.items() if w)
        if len(self.scenarios) <= 1:
            return f'f = {f_s}'
        names = [s.name for s in self.scenarios]
        total = (
            'max(' + ', '.join(f'f_{n}' for n in names) + ')'
            if self.aggregate == 'max'
            else ' + '.join(f'{s.weight:g} f_{s.name}' for s in self.scenarios)
        )
        return f'f = {total}; f_s = {f_s} (s_k of each scenario)'

    def derived(self) -> dict[str, Any]:
        return {'rms': self.rms, 'formula': self.formula()}

    def check(self, node: Node) -> None:
        if self.success and self.objective is None:
            raise node.child('objective').error('missing for a converged result')
        if not self.success and self.objective is not None:
            raise node.child('objective').error('a failed solve has no objective')
        if self.mode not in ('evaluate', 'optimize'):
            raise node.child('mode').error(f"expected 'evaluate' or 'optimize', got {self.mode!r}")
