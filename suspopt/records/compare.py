"""The record of a topology study (``compare.json``, :mod:`suspopt.studies.compare`).

Design keys: ``initial``, ``low_optimum`` and ``optimum:<topology>``; model keys: ``low``
and ``mixed:<topology>``; a cell (a design evaluated in a model) is
``cells[cell_key(design, model)]``."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from suspopt.records.codec import Node, Record
from suspopt.records.solve import ProblemStats, SolveRecord

LOW = 'low'


def design_key(topology: str) -> str:
    return f'optimum:{topology}'


def model_key(topology: str) -> str:
    return f'mixed:{topology}'


def cell_key(design: str, model: str) -> str:
    return f'{design}|{model}'


@dataclass(frozen=True)
class Topology(Record):
    """One topology: its mechanisms (a built-in name or the run's copy of a file), their
    labels, its model and optimum keys, and its case recorder."""

    label: str
    front: str
    rear: str
    front_label: str
    rear_label: str
    model: str
    optimum: str
    recorder: str


@dataclass(frozen=True)
class Failure(Record):
    """An optimization or evaluation that failed (the study went on without it)."""

    what: str
    model: str
    status: str
    message: str = ''
    design: str | None = None


@dataclass(frozen=True)
class MechanismCurves(Record):
    """The kinematic curves of one mechanism (:mod:`suspopt.multibody.kinematics`) over
    the common wheel travel, with the reference-pose values and its moving mass."""

    name: str
    spring_rate: float
    travel: tuple[float, ...]
    independent: tuple[float, ...]
    spring_deflection: tuple[float, ...]
    motion_ratio: tuple[float, ...]
    wheel_rate: tuple[float, ...]
    camber: tuple[float, ...]
    track_change: tuple[float, ...]
    at_reference: dict[str, float]
    moving_mass_kg: float

    def curve(self, column: str) -> tuple[float, ...]:
        """One of the curves by its name (``motion_ratio``, ``camber``, ...)."""
        value = getattr(self, column)
        assert isinstance(value, tuple), column
        return value


@dataclass(frozen=True)
class Kinematics(Record):
    """Every mechanism's curves on the travel range they share."""

    travel_range: tuple[float, float]
    spring_rate: float
    points: int
    curves: dict[str, MechanismCurves]


@dataclass(frozen=True)
class ModelBest(Record):
    """In one model: the design with the lowest f among the converged cells, the model's
    own optimum and its f, and each design's excess ``f / f_own - 1`` over it."""

    best: str | None
    own_optimum: str
    f_own: float | None
    excess: dict[str, float | None]


@dataclass
class CompareStudy(Record):
    """The topology study as it goes (module docstring)."""

    KIND = 'compare'

    config: dict[str, Any]
    vehicle_model: str
    topologies: tuple[Topology, ...]
    models: tuple[str, ...]
    design_order: tuple[str, ...]
    recorders: dict[str, str]
    scales: tuple[dict[str, float], ...]
    terms: tuple[str, ...]
    design_names: tuple[str, ...]
    normalization: str
    weights: dict[str, float]
    tolerance: float
    verify: bool = True
    steps: dict[str, SolveRecord] = field(default_factory=dict)
    designs: dict[str, dict[str, float]] = field(default_factory=dict)
    cells: dict[str, SolveRecord] = field(default_factory=dict)
    failures: list[Failure] = field(default_factory=list)
    kinematics: Kinematics | None = None
    best: dict[str, ModelBest] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    complete: bool = False
    interrupted: bool = False
    verified: bool | None = None
    problems: dict[str, ProblemStats] = field(default_factory=dict)
    wall_time_s: float | None = None

    def cell(self, design: str, model: str) -> SolveRecord | None:
        return self.cells.get(cell_key(design, model))

    def own_optimum(self, model: str) -> str:
        """The design key of ``model``'s own optimum."""
        if model == LOW:
            return 'low_optimum'
        return next(t.optimum for t in self.topologies if t.model == model)

    def check(self, node: Node) -> None:
        for m in self.models:
            if m != LOW and m not in {t.model for t in self.topologies}:
                raise node.child('models').error(f'{m!r} is not the model of a topology')
            if m not in self.recorders:
                raise node.child('recorders').child(m).error('missing')
