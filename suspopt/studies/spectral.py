"""The stationary (spectral) evaluation and optimization of a study's low-fidelity vehicle
on its ISO 8608 road (``docs/spectral.md``, section 9): ``suspopt evaluate --method
spectral`` and ``suspopt optimize --method spectral``.

The vehicle is the study's quarter, half or full car with its seats' Wk filters
(:func:`suspopt.spectral.vehicle.vehicle_system`); each scenario's road must be an ISO
8608 road (:func:`suspopt.spectral.vehicle.random_road`), driven at the scenario's speed.

**Objective.** The stationary limit of the time-domain objective (eq. 4): a term's
integral over a horizon ``T`` is ``J_k ≈ T Var_k`` on a stationary road, so

    f_s = Σ_k w_k Var_k / s_k,

with the mean-square scales ``s_k``: ``reference`` — ``Var_k`` at the study's initial
design by this method, so ``f_s = Σ_k w_k`` there (1 for weights summing to 1, as every
default and Pareto weighting); ``paper`` and ``custom`` — the study's scales of ``J_k``
over the scenario's horizon divided by it, ``s_k = S_k / T``, so that ``f_s`` is the
expected time-domain objective over that horizon. Scenarios combine as in the
time-domain (``Σ_s w_s f_s`` or ``max_s f_s``).

**Constraints** (optimization): a zero-mean Gaussian response exceeds ``k σ`` a fraction
``erfc(k/√2)`` of the time (0.27 % at ``k = 3``; Rice: it up-crosses ``kσ`` at the rate
``ν₀ exp(-k²/2)``, ``ν₀`` its zero up-crossing rate). The study's path constraints become
``k·RMS <= bound`` with ``k = sigmas`` (3 by default):

* ``[constraints.travel]``: ``k·RMS(travel_c) <= min(bump, rebound)`` (the given ones) at
  every corner;
* ``[constraints.tyre_contact]``: ``k·RMS(F_T,c) <= (1 - margin) F_static,c``, i.e.
  ``RMS(F_T)/F_static <= (1 - margin)/k``.

The design-only constraints (``roll_gradient``, ``ride_frequency``) are not applied by
this method: the record and the command say so.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from suspopt.errors import ConfigError
from suspopt.output.rundir import RunDirectory, keep_inputs, write_record
from suspopt.records.spectral import (
    RmsLimit,
    SpectralRecord,
    SpectralRoad,
    SpectralScenario,
)
from suspopt.spec import StudyConfig
from suspopt.spec.resolve import Scenario
from suspopt.spectral import RandomRoad, StationaryModel, choose_pade_order, optimize_spectral
from suspopt.spectral.system import AffineLinearSystem
from suspopt.spectral.vehicle import is_unbounded, random_road, vehicle_system
from suspopt.transcription.vehicle import vehicle_assembly

#: the multiple of the RMS a path constraint's bound must cover (a 3σ rule)
SIGMAS = 3.0
#: relative RMS accuracy the Padé order of the wheelbase delay is chosen for
PADE_RTOL = 1e-4


@dataclass(frozen=True, eq=False)
class SpectralCase:
    """One scenario of a study for the spectral method: the stationary ``system`` of the
    vehicle (its outputs the terms of finite variance on this road), the ``road``, the
    static tyre load of each corner [N] and the terms left out (``not_stationary``)."""

    scenario: Scenario
    system: AffineLinearSystem
    road: RandomRoad
    static_load: dict[str, float]
    not_stationary: tuple[str, ...]


def _road_key(config: StudyConfig, index: int) -> str:
    """The study file's key of scenario ``index``'s road."""
    if config.scenario and config.scenario[index].road:
        return f'scenario[{index}].road'
    return 'road'


def refuse_unbounded_terms(config: StudyConfig) -> None:
    """A weighted absolute wheel displacement (``wheel_<c>``, the paper's road-holding
    terms) is refused in one line naming its key and what to weight instead."""
    bad = [t for t, w in config.objective.weights.items() if w > 0.0 and is_unbounded(t)]
    if bad:
        more = f' (and {", ".join(bad[1:])})' if bad[1:] else ''
        corner = bad[0].removeprefix('wheel_')
        raise ConfigError(
            f'objective.weights.{bad[0]}{more}: the absolute wheel displacement has no '
            'stationary variance on a random road (it follows the road height, whose ISO '
            '8608 spectrum grows without bound at long wavelengths); for the spectral '
            f'method weight the dynamic tyre load (tyre_load_{corner}, or the group '
            f'tyre_load) for road holding, or the suspension travel (travel_{corner}), '
            'instead'
        )


def spectral_cases(config: StudyConfig) -> tuple[SpectralCase, ...]:
    """The study's scenarios for the spectral method (refusing what it cannot take:
    a road that is not ISO 8608, a weighted term of infinite variance)."""
    layout = config.layout()
    scenarios = config.scenarios()
    roads = [
        random_road(sc.road, sc.speed, layout, _road_key(config, i))
        for i, sc in enumerate(scenarios)
    ]
    refuse_unbounded_terms(config)
    assembly = vehicle_assembly(config, scenarios[0], 'low')
    full = vehicle_system(assembly)
    p0 = full.design_vector(config.design.initial())
    static = assembly.spec.static_load
    assert static is not None  # every study's vehicle has its static tyre loads
    loads = {c: float(f) for c, f in zip(layout.labels, static)}
    weights = config.objective.weights
    out = []
    for i, (sc, road) in enumerate(zip(scenarios, roads)):
        infinite = StationaryModel(full, road, pade_order=2).infinite_output_names(p0)
        weighted = [t for t in infinite if weights.get(t, 0.0) > 0.0]
        if weighted:
            coherence = f'{_road_key(config, i)}.coherence'
            raise ConfigError(
                f'{coherence}: on {road.tracks} tracks the variance of '
                f'{", ".join(weighted)} is infinite (tracks that drift apart without bound '
                'warp a car whose front and rear tracks differ); use coherence = '
                '"isotropic" (the physical model of two tracks) or weight other terms'
            )
        kept = tuple(t for t in full.outputs if t not in infinite)
        system = full.select_outputs(kept) if infinite else full
        out.append(SpectralCase(sc, system, road, loads, infinite))
    return tuple(out)


def _road_record(road: RandomRoad) -> SpectralRoad:
    return SpectralRoad(
        road_class=road.road_class,
        displacement_psd_n0=road.displacement_psd_n0,
        speed=road.speed,
        tracks=road.tracks,
        separation=road.separation,
        velocity_intensity=road.velocity_intensity(),
    )


def _weighted(config: StudyConfig, case: SpectralCase) -> dict[str, float]:
    """The weighted terms of the objective, by name."""
    return {
        t: float(w)
        for t, w in config.objective.weights.items()
        if w > 0.0 and t in case.system.outputs
    }


def spectral_scales(
    config: StudyConfig, cases: tuple[SpectralCase, ...], pade_orders: list[int]
) -> list[dict[str, float]]:
    """The mean-square scales ``s_k`` of every scenario (module docstring): ``reference``
    the variances at the initial design, else the study's scales over the horizon."""
    norm = config.objective.normalization
    out = []
    for case, order in zip(cases, pade_orders):
        outputs = case.system.outputs
        if norm == 'reference':
            model = StationaryModel(case.system, case.road, order)
            var = model.variances(case.system.design_vector(config.design.initial()))
            zero = [
                t
                for t, v in zip(outputs, var)
                if not v > 0.0 and config.objective.weights.get(t, 0.0) > 0.0
            ]
            if zero:
                where = f'scenario {case.scenario.name!r}: ' if config.scenario else ''
                raise ConfigError(
                    f'objective.normalization: {where}reference normalization impossible: '
                    f'the road does not excite {", ".join(zero)} at the initial design; use '
                    "normalization = 'custom' with scales"
                )
            out.append({t: float(v) if v > 0.0 else 1.0 for t, v in zip(outputs, var)})
        else:
            from suspopt.spec import PAPER_SCALES

            given = PAPER_SCALES if norm == 'paper' else config.objective.scales
            T = case.scenario.horizon
            out.append({t: float(given.get(t, 1.0)) / T for t in outputs})
    return out


def _objective(
    weights: Mapping[str, float], var: Mapping[str, float], s: Mapping[str, float]
) -> float:
    return float(sum(w * var[t] / s[t] for t, w in weights.items()))


def _combine(config: StudyConfig, cases: tuple[SpectralCase, ...], f: list[float]) -> float:
    if config.objective.aggregate == 'max' and len(f) > 1:
        return max(f)
    return float(sum(c.scenario.weight * fs for c, fs in zip(cases, f)))


def _pade(case: SpectralCase, p: np.ndarray, rtol: float) -> tuple[int, float]:
    choice = choose_pade_order(case.system, case.road, p, rtol=rtol)
    return choice.order, choice.error


def evaluate_spectral(
    config: StudyConfig, design: Mapping[str, float] | None = None, *, pade_rtol: float = PADE_RTOL
) -> SpectralRecord:
    """The stationary RMS of every metric of the study's low-fidelity vehicle at
    ``design`` (default: the initial design) on each scenario's ISO 8608 road, and the
    study's objective (module docstring)."""
    t0 = time.perf_counter()
    design = dict(config.design.initial() if design is None else design)
    cases = spectral_cases(config)
    t1 = time.perf_counter()
    rows, f = [], []
    pades = []
    for case in cases:
        pv = case.system.design_vector(design)
        pades.append(_pade(case, pv, pade_rtol))
    scales = spectral_scales(config, cases, [o for o, _ in pades])
    for case, (order, err), s in zip(cases, pades, scales):
        model = StationaryModel(case.system, case.road, order)
        pv = case.system.design_vector(design)
        var = dict(zip(case.system.outputs, model.variances(pv).tolist()))
        rms = dict(zip(case.system.outputs, model.rms(pv).tolist()))
        f_s = _objective(_weighted(config, case), var, s)
        f.append(f_s)
        rows.append(
            SpectralScenario(
                name=case.scenario.name,
                weight=case.scenario.weight,
                road=_road_record(case.road),
                pade_order=order,
                pade_error=err,
                scales=s,
                rms=rms,
                objective=f_s,
                not_stationary=case.not_stationary,
            )
        )
    return SpectralRecord(
        mode='evaluate',
        start=dict(design),
        design=dict(design),
        success=True,
        status='stationary',
        objective=_combine(config, cases, f),
        objective_start=None,
        scenarios=tuple(rows),
        weights=dict(config.objective.weights),
        normalization=config.objective.normalization,
        aggregate=config.objective.aggregate if len(cases) > 1 else 'sum',
        solve_time_s=time.perf_counter() - t1,
        wall_time_s=time.perf_counter() - t0,
    )


def rms_limits(config: StudyConfig, case: SpectralCase, sigmas: float = SIGMAS) -> list[RmsLimit]:
    """The study's path constraints as RMS limits (module docstring)."""
    if not (math.isfinite(sigmas) and sigmas > 0.0):
        raise ConfigError(f'sigmas: must be > 0, got {sigmas}')
    c = config.constraints
    out = []
    labels = config.layout().labels
    if c.travel.enabled:
        sides = {k: v for k, v in (('bump', c.travel.bump), ('rebound', c.travel.rebound)) if v > 0}
        side = min(sides, key=lambda k: sides[k])
        for lab in labels:
            out.append(
                RmsLimit(
                    f'travel_{lab}',
                    f'constraints.travel.{side}',
                    sides[side],
                    sigmas,
                    sides[side] / sigmas,
                )
            )
    if c.tyre_contact.enabled:
        keep = 1.0 - c.tyre_contact.margin
        for lab in labels:
            bound = keep * case.static_load[lab]
            out.append(
                RmsLimit(
                    f'tyre_load_{lab}',
                    'constraints.tyre_contact.margin',
                    bound,
                    sigmas,
                    bound / sigmas,
                )
            )
    for lim in out:
        if lim.term not in case.system.outputs:
            raise ConfigError(
                f'{lim.key}: {lim.term} has no stationary variance on this road '
                f'({_road_key(config, 0)}.coherence)'
            )
    return out


def not_applied(config: StudyConfig) -> list[str]:
    """The study's constraints this method does not apply, one line each."""
    c = config.constraints
    out = []
    for name in ('roll_gradient', 'ride_frequency'):
        if getattr(c, name).enabled:
            out.append(
                f'constraints.{name}: not applied by the spectral method (a constraint on '
                'the design alone, applied by the collocation steps)'
            )
    return out


def optimize_spectral_study(
    config: StudyConfig,
    *,
    start: Mapping[str, float] | None = None,
    out_dir: str | Path | RunDirectory | None = None,
    sigmas: float = SIGMAS,
    hessian: str = 'exact',
    pade_rtol: float = PADE_RTOL,
) -> SpectralRecord:
    """The stationary optimum of the study's low-fidelity vehicle on its ISO 8608 road
    (one scenario) by :func:`suspopt.spectral.optimize_spectral`: the design variables
    (those with ``optimize = false`` held), the study's weights and normalization, its
    travel and tyre-contact constraints as RMS limits (``sigmas``; module docstring).
    Writes ``spectral.json`` (with ``manifest.json``), ``table.md`` and the inputs to
    ``out_dir`` if given."""
    t0 = time.perf_counter()
    if len(config.scenarios()) > 1:
        raise ConfigError(
            'scenario: the spectral optimization takes one road and speed; the study has '
            f'{len(config.scenarios())} scenarios (evaluate them with --method spectral, or '
            'optimize each one on its own)'
        )
    initial = config.design.initial()
    start = dict(initial if start is None else start)
    (case,) = spectral_cases(config)
    limits = rms_limits(config, case, sigmas)
    warnings = not_applied(config)
    names = case.system.design
    lower = {n: config.design[n].lower if config.design[n].optimize else initial[n] for n in names}
    upper = {n: config.design[n].upper if config.design[n].optimize else initial[n] for n in names}
    weights = _weighted(config, case)
    if not weights:
        raise ConfigError('objective.weights: no weighted term (give at least one weight > 0)')
    order0, _ = _pade(case, case.system.design_vector(initial), pade_rtol)
    (scales,) = spectral_scales(config, (case,), [order0])
    t1 = time.perf_counter()
    opt = optimize_spectral(
        case.system,
        case.road,
        start,
        objective=weights,
        lower=lower,
        upper=upper,
        rms_limits={lim.term: lim.rms_limit for lim in limits},
        measure='variance',
        scales={t: scales[t] for t in weights},
        pade_order='auto',
        pade_rtol=pade_rtol,
        hessian=hessian,
        tol=config.optimizer.tol,
        max_iter=config.optimizer.max_iter,
        print_level=config.optimizer.print_level,
    )
    solve_time = time.perf_counter() - t1
    ok = opt.success
    limits = [
        replace(lim, rms=opt.rms[lim.term], multiplier=opt.constraint_multipliers[lim.term])
        if ok
        else lim
        for lim in limits
    ]
    scenario = SpectralScenario(
        name=case.scenario.name,
        weight=case.scenario.weight,
        road=_road_record(case.road),
        pade_order=opt.pade.order,
        pade_error=opt.pade.error,
        scales=scales,
        rms=dict(opt.rms) if ok else None,
        objective=opt.objective if ok else None,
        rms_start=dict(opt.rms_initial),
        objective_start=opt.objective_initial,
        not_stationary=case.not_stationary,
    )
    record = SpectralRecord(
        mode='optimize',
        start=start,
        design=dict(opt.design),
        success=ok,
        status=opt.status_message,
        objective=opt.objective if ok else None,
        objective_start=opt.objective_initial,
        scenarios=(scenario,),
        weights=dict(config.objective.weights),
        normalization=config.objective.normalization,
        limits=tuple(limits),
        iterations=opt.iterations,
        evaluations=opt.evaluations,
        hessian=hessian,
        message='' if ok else f'IPOPT stopped: {opt.status_message}',
        solve_time_s=solve_time,
        wall_time_s=time.perf_counter() - t0,
        warnings=tuple(warnings),
    )
    if out_dir is not None:
        write_spectral_run(out_dir, config, record)
    return record


def write_spectral_run(
    out_dir: str | Path | RunDirectory, config: StudyConfig, record: SpectralRecord
) -> SpectralRecord:
    """Write a spectral run's directory: the record (with the study description and
    copies of its inputs), its manifest and ``table.md``."""
    from suspopt.output.spectral_report import render_spectral

    out = out_dir.path if isinstance(out_dir, RunDirectory) else Path(out_dir)
    record = replace(record, config=keep_inputs(out, config.to_dict()))
    write_record(out, record)
    render_spectral(out, record)
    return record
