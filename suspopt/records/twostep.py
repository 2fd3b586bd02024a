"""The record of the paper's two-step study (``study.json``, ``docs/studies.md``): the
low- and mixed-fidelity optimizations and every design evaluated in both models."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from suspopt.records.codec import Node, Record
from suspopt.records.solve import ProblemStats, SolveRecord

#: the designs of the two-step study, as recorded (evaluation keys, case labels)
STUDY_DESIGNS = ('initial', 'low_optimum', 'mixed_optimum')
#: the two models
FIDELITIES = ('low', 'mixed')
#: each step's optimum (the design key of its result)
STEP_RESULT = {'low': 'low_optimum', 'mixed': 'mixed_optimum'}
#: the model whose optimum each design is (the initial design: the low-fidelity model's
#: starting point)
OWN_MODEL = {'initial': 'low', 'low_optimum': 'low', 'mixed_optimum': 'mixed'}


def evaluation_key(fidelity: str, design: str) -> str:
    """The key of design ``design`` evaluated in model ``fidelity``: ``low/initial``."""
    return f'{fidelity}/{design}'


@dataclass
class TwoStepStudy(Record):
    """The two-step study as it goes (built step by step, written after every change).

    ``steps``: each fidelity's optimization; ``evaluations``: each design in each model
    (:func:`evaluation_key`), the optima included; ``designs``: the designs found so far;
    ``complete``: every step and evaluation done and verified (or not) by time marching."""

    KIND = 'study'

    config: dict[str, Any]
    scales: tuple[dict[str, float], ...]
    terms: tuple[str, ...]
    design_names: tuple[str, ...]
    normalization: str
    weights: dict[str, float]
    verify: bool = True
    steps: dict[str, SolveRecord] = field(default_factory=dict)
    evaluations: dict[str, SolveRecord] = field(default_factory=dict)
    designs: dict[str, dict[str, float]] = field(default_factory=dict)
    complete: bool = False
    verified: bool | None = None
    warnings: list[str] = field(default_factory=list)
    problems: dict[str, ProblemStats] = field(default_factory=dict)
    wall_time_s: float | None = None

    def evaluation(self, fidelity: str, design: str) -> SolveRecord | None:
        return self.evaluations.get(evaluation_key(fidelity, design))

    def check(self, node: Node) -> None:
        known = {evaluation_key(f, d) for f in FIDELITIES for d in STUDY_DESIGNS}
        for key in self.evaluations:
            if key not in known:
                raise (
                    node.child('evaluations')
                    .child(key)
                    .error(f'not an evaluation of the study (one of {", ".join(sorted(known))})')
                )
        for key in self.steps:
            if key not in FIDELITIES:
                raise node.child('steps').child(key).error("not a step ('low' or 'mixed')")
