"""Control co-design (``docs/codesign.md``): a suspension's hardware and its controller
optimized together, in one NLP, three ways:

* ``passive`` — the spring-dampers alone (no actuator: the baseline);
* ``open_loop`` — the hardware with the actuator's (or variable damper's) whole time
  history as Dymos controls: the best any controller could do with full preview of the
  road, a performance bound;
* ``feedback`` — the hardware with a realizable state-feedback law whose gains are design
  variables (:mod:`suspopt.models.control`), verified in closed loop by time marching.

All three minimize the same objective with the same scales (the controlled study's:
the passive car's effort is zero), so their ``f`` compare directly; the share of the
bound's gain the feedback law realizes is :meth:`~suspopt.records.codesign.CodesignStudy.
recovered`. The controlled variants start from the passive optimum's hardware.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

from suspopt.errors import ConfigError
from suspopt.models.design import GAIN_KINDS, design_kind
from suspopt.output.roads import keep_study_inputs
from suspopt.output.rundir import RunDirectory, write_record
from suspopt.records.codesign import FEEDBACK, OPEN_LOOP, PASSIVE, CodesignStudy
from suspopt.records.solve import SolveRecord
from suspopt.spec import StudyConfig, config_from_dict
from suspopt.studies.run import Interrupted, Progress, optimize
from suspopt.transcription.problem import Scales
from suspopt.verification.scales import resolve_scales


def _without_control_terms(table: Any) -> Any:
    if isinstance(table, dict):
        return {k: v for k, v in table.items() if not k.startswith('control')}
    return table


def variant(config: StudyConfig, law: str) -> StudyConfig:
    """``config`` (a controlled study) as the ``passive`` car (no actuator, no effort
    terms, no gains) or with its control under ``law`` (``open_loop``: no gains;
    ``feedback``: the gains of ``config``'s design, or their defaults)."""
    if not config.control.enabled:
        raise ConfigError('control.kind: a co-design study needs a controlled suspension')
    data = config.to_dict()
    design = data['design']
    data['design'] = {
        k: v
        for k, v in design.items()
        if k == 'per_corner' or law == FEEDBACK or design_kind(k) not in GAIN_KINDS
    }
    if law == PASSIVE:
        data['control'] = {}
        obj = data['objective']
        obj['weights'] = _without_control_terms(obj['weights'])
        obj['scales'] = _without_control_terms(obj['scales'])
    else:
        data['control'] = {**data['control'], 'law': law}
    return config_from_dict(data)


def passive_scales(config: StudyConfig, scales: Scales) -> Scales:
    """The controlled study's scales, for its passive car's terms."""
    terms = variant(config, PASSIVE).terms()
    return tuple({t: s[t] for t in terms} for s in scales)


def _directory(out_dir: str | Path | RunDirectory | None) -> Path | None:
    if out_dir is None:
        return None
    return out_dir.path if isinstance(out_dir, RunDirectory) else Path(out_dir)


def run_codesign(
    config: StudyConfig,
    fidelity: str = 'low',
    *,
    laws: tuple[str, ...] = (PASSIVE, OPEN_LOOP, FEEDBACK),
    scales: Scales | None = None,
    passive: SolveRecord | None = None,
    progress: Progress | None = None,
    log: Callable[[str], None] | None = None,
    verify: bool = True,
    out_dir: str | Path | RunDirectory | None = None,
) -> CodesignStudy:
    """The passive, open-loop and feedback co-design of ``config``'s controlled suspension
    in one model (``laws``: which of them), each verified by time marching. ``passive``:
    an already solved passive optimum to reuse (same objective and scales). With
    ``out_dir``, the study is written there as each solve comes in (``codesign.json``;
    ``suspopt report DIR`` renders it); interrupted, a converged solve is kept."""
    say = log or (lambda msg: None)
    t0 = time.perf_counter()
    controlled = {law: variant(config, law) for law in (OPEN_LOOP, FEEDBACK) if law in laws}
    out = _directory(out_dir)
    inputs = keep_study_inputs(out, config) if out is not None else {}
    data = CodesignStudy(fidelity=fidelity, control=config.control.kind, config=inputs)

    def keep(law: str, solve: Callable[[], SolveRecord]) -> SolveRecord:
        """One law's solve, written as it comes in; interrupted, kept if it converged."""
        try:
            data.entries[law] = solve()
        except Interrupted as stop:
            if out is not None and stop.result is not None and stop.result.success:
                data.entries[law] = stop.result
                write_record(out, data)
            raise
        if out is not None:
            write_record(out, data)
        return data.entries[law]

    if out is not None:
        write_record(out, data)
    scales = resolve_scales(config) if scales is None else scales
    start: dict[str, float] = {}
    if PASSIVE in laws or passive is not None:
        if passive is None:
            say(f'{fidelity} fidelity: the passive optimum')
            cfg = variant(config, PASSIVE)
            own = passive_scales(config, scales)
            passive = keep(
                PASSIVE,
                partial(optimize, cfg, fidelity, scales=own, progress=progress, verify=verify),
            )
        else:
            data.entries[PASSIVE] = passive
            if out is not None:
                write_record(out, data)
        if passive.success:
            start = dict(passive.design)
    for law, cfg in controlled.items():
        first = {
            **cfg.design.initial(),
            **{k: v for k, v in start.items() if k in cfg.design.names},
        }
        say(f'{fidelity} fidelity: {config.control.kind} {law.replace("_", "-")} co-design')
        keep(
            law,
            partial(
                optimize,
                cfg,
                fidelity,
                start=first,
                scales=scales,
                progress=progress,
                verify=verify,
            ),
        )
    data.wall_time_s = time.perf_counter() - t0
    data.complete = True
    if out is not None:
        write_record(out, data)
    return data
