"""One filled-in record of every kind (made-up values, every optional part present), for
the round-trip and dispatch tests (tests/records, tests/output)."""

from __future__ import annotations

import math

from suspopt.records.codesign import CodesignStudy
from suspopt.records.compare import (
    CompareStudy,
    Failure,
    Kinematics,
    MechanismCurves,
    ModelBest,
    Topology,
)
from suspopt.records.constraints import ConstraintCheck, ConstraintValue, Infeasibility
from suspopt.records.control import ControlHistory
from suspopt.records.coupling import CouplingStudy, CouplingSummary
from suspopt.records.pareto import ParetoFront, ParetoInitial, ParetoPoint
from suspopt.records.robust import CrossEvaluation, RobustStudy
from suspopt.records.solve import (
    BestIterate,
    Grid,
    Iterate,
    NlpSize,
    ProblemStats,
    ScenarioResult,
    SolveRecord,
    SolveTimes,
)
from suspopt.records.spectral import RmsLimit, SpectralRecord, SpectralRoad, SpectralScenario
from suspopt.records.twostep import TwoStepStudy
from suspopt.records.verification import Comparison, ScenarioComparison, Verification
from suspopt.spec.schema import StudyConfig

CONFIG = StudyConfig().to_dict()
TERMS = ('heave', 'pitch', 'wheel_1', 'wheel_2')
DESIGN = {'k_S1': 30000.0, 'k_S2': 30000.0, 'c_S1': 3000.0, 'c_S2': 3000.0}
SCALES = {'heave': 2.4, 'pitch': 1.56, 'wheel_1': 4.5e-4, 'wheel_2': 4.7e-4}
WEIGHTS = dict.fromkeys(TERMS, 0.25)
BOUNDS = {'k_S1': (1e4, 5e4), 'k_S2': (1e4, 5e4), 'c_S1': (1e3, 5e3), 'c_S2': (1e3, 5e3)}


def comparison(diff: float = 1e-4) -> Comparison:
    sc = ScenarioComparison('city', dict(SCALES), 1.0, diff, 'pitch', 0.25, 1e-13)
    check = ConstraintCheck('travel.bump', True, 0.05, 0.0498, 1.5e-3, 'scenario city')
    return Comparison(
        'time-marching (SciPy DOP853, rtol 1e-06)', 5e-3, (sc,), 1.0, diff, 0.3, (check,)
    )


#: the engineering constraints of a solve: a path one (active) and a design-only one
CONSTRAINTS = (
    ConstraintValue('travel.bump', 'path', 'm', True, 0.05, 0.05, True, 'scenario city'),
    ConstraintValue('roll_gradient.max', 'design', 'deg/g', True, 3.5, 3.1, False),
)


def solve(
    success: bool = True, verification: Verification | None = None, mode: str = 'optimize'
) -> SolveRecord:
    """A two-scenario solve: converged, or stopped where IPOPT gave up."""
    terms = {'heave': 1.3, 'pitch': 0.9, 'wheel_1': 4.9e-4, 'wheel_2': 5.8e-4}
    scenarios = tuple(
        ScenarioResult(
            name,
            w,
            dict(SCALES),
            0.86 if success else None,
            terms if success else None,
            None if success else 0.9,
            None if success else terms,
            Grid(80, 5),
        )
        for name, w in (('city', 1.0), ('highway', 3.0))
    )
    return SolveRecord(
        fidelity='mixed',
        mode=mode,
        method='collocation',
        start=dict(DESIGN),
        design={**DESIGN, 'k_S1': 37524.0},
        success=success,
        status='Solve_Succeeded' if success else 'Maximum_Iterations_Exceeded',
        objective=3.44 if success else None,
        objective_at_stop=None if success else 3.6,
        scenarios=scenarios,
        aggregate='sum',
        normalization='reference',
        weights=dict(WEIGHTS),
        message='Optimal Solution Found.',
        interrupted=False,
        iterations=10,
        function_evaluations=12,
        gradient_evaluations=11,
        times=SolveTimes(0.46, 3.43),
        wall_time_s=5.2,
        coloring_from_cache=True,
        multibody_calls={'augmented': 90, 'positions': 20, 'factorizations': 20},
        history=(Iterate(0, 4.0, 1e-2, 0.1), Iterate(1, 3.5, 1e-9, 0.4)),
        best_feasible_iterate=BestIterate(1, 3.5, 1e-9, dict(DESIGN)),
        verification=verification
        or (Verification.of(comparison()) if success else Verification.skipped()),
        max_constraint_residual_m=1e-13,
        controls=tuple(
            ControlHistory(
                name='c_A',
                units='N*s/m',
                corners=('1', '2'),
                scenario=name,
                segment_ends=(0.0, 2.5, 5.0),
                tau=(-1.0, 0.0),
                values=((300.0, 800.0, 2500.0, 300.0), (300.0, 300.0, 900.0, 1200.0)),
            )
            for name in ('city', 'highway')
        ),
        constraints=CONSTRAINTS,
        infeasibility=None
        if success
        else Infeasibility('travel.bump', 'm', True, 0.05, 0.061, 'scenario city'),
        config=CONFIG,
    )


def stats() -> ProblemStats:
    return ProblemStats(1.2, 0.15, False, NlpSize(3204, 3200, 35132, 29), {'augmented': 90})


def twostep() -> TwoStepStudy:
    return TwoStepStudy(
        config=CONFIG,
        scales=(dict(SCALES),),
        terms=TERMS,
        design_names=tuple(DESIGN),
        normalization='reference',
        weights=dict(WEIGHTS),
        verify=True,
        steps={'low': solve(), 'mixed': solve(False)},
        evaluations={
            'low/initial': solve(mode='evaluate', verification=Verification.pending()),
            'low/low_optimum': solve(verification=Verification.of(comparison(0.02))),
            'mixed/initial': solve(verification=Verification.interrupted()),
            'mixed/low_optimum': solve(
                verification=Verification.failed(RuntimeError('no road file'))
            ),
        },
        designs={'initial': dict(DESIGN), 'low_optimum': dict(DESIGN)},
        complete=True,
        verified=False,
        warnings=['not verified: ...'],
        problems={'low': stats(), 'mixed': stats()},
        wall_time_s=51.5,
    )


def pareto() -> ParetoFront:
    return ParetoFront(
        config=CONFIG,
        fidelity='low',
        scales=(dict(SCALES),),
        terms=TERMS,
        design_names=tuple(DESIGN),
        bounds=dict(BOUNDS),
        normalization='reference',
        points=[
            ParetoPoint(0.0, dict(WEIGHTS), solve(), 0.5, 1.2),
            ParetoPoint(0.5, dict(WEIGHTS), solve(False), None, None, 0.7, 0.9),
        ],
        initial=ParetoInitial(dict(DESIGN), True, dict(SCALES), 1.0, 1.0),
        complete=True,
        problem=stats(),
        wall_time_s=12.0,
    )


def robust() -> RobustStudy:
    cross = CrossEvaluation(dict(DESIGN), {'city': 0.9, 'highway': 1.1}, 4.2, 0.8)
    return RobustStudy(
        config=CONFIG,
        fidelity='low',
        scenarios=('city', 'highway'),
        weights=(1.0, 3.0),
        aggregate='max',
        scales=(dict(SCALES), dict(SCALES)),
        design_names=tuple(DESIGN),
        optima={'robust': solve(), 'city': solve(False)},
        cross={'robust': cross},
        complete=True,
        verified=True,
        wall_time_s=30.0,
    )


def compare() -> CompareStudy:
    curve = (0.44, 0.45, math.inf)
    curves = MechanismCurves(
        'double_wishbone',
        30000.0,
        (-0.05, 0.0, 0.05),
        curve,
        curve,
        curve,
        curve,
        curve,
        curve,
        {'motion_ratio': 0.45, 'wheel_rate': 6000.0},
        12.5,
    )
    return CompareStudy(
        config=CONFIG,
        vehicle_model='half_car',
        topologies=(
            Topology(
                'dw',
                'double_wishbone',
                'inputs/mechanism_0_dw.toml',
                'double_wishbone',
                'dw',
                'mixed:dw',
                'optimum:dw',
                'mixed_dw.sql',
            ),
        ),
        models=('low', 'mixed:dw'),
        design_order=('initial', 'low_optimum', 'optimum:dw'),
        recorders={'low': 'low.sql', 'mixed:dw': 'mixed_dw.sql'},
        scales=(dict(SCALES),),
        terms=TERMS,
        design_names=tuple(DESIGN),
        normalization='reference',
        weights=dict(WEIGHTS),
        tolerance=5e-3,
        verify=True,
        steps={'low': solve()},
        designs={'initial': dict(DESIGN)},
        cells={'initial|low': solve(mode='evaluate')},
        failures=[Failure('optimization', 'mixed:dw', 'Model_Error', 'toggle', None)],
        kinematics=Kinematics((-0.05, 0.05), 30000.0, 3, {'dw': curves}),
        best={'low': ModelBest('initial', 'low_optimum', None, {'initial': None})},
        warnings=['w'],
        complete=False,
        interrupted=True,
        verified=None,
        problems={'low': stats()},
        wall_time_s=3.0,
    )


def coupling() -> CouplingStudy:
    return CouplingStudy(
        config=CONFIG,
        scales=(dict(SCALES),),
        terms=TERMS,
        design_names=tuple(DESIGN),
        bounds=dict(BOUNDS),
        normalization='reference',
        weights=dict(WEIGHTS),
        verify=False,
        designs={'initial': dict(DESIGN)},
        steps={'low': solve()},
        evaluations={'low': {'initial': solve(mode='evaluate')}, 'ground': {}, 'chassis': {}},
        complete=True,
        verified=None,
        warnings=[],
        summary=CouplingSummary({'k_S1': 0.1}, 1.0, 0.9, 0.11, 1.05, 1.0),
        problems={'low': stats()},
        wall_time_s=40.0,
    )


def spectral() -> SpectralRecord:
    rms = {'heave': 0.7, 'travel_1': 0.012, 'tyre_load_1': 1050.0}
    road = SpectralRoad('C', 2.56e-4, 20.0, 'identical', 0.0, 1.01e-3)
    scenario = SpectralScenario(
        name='main',
        weight=1.0,
        road=road,
        pade_order=6,
        pade_error=3e-5,
        scales={'heave': 0.5, 'travel_1': 1.4e-4, 'tyre_load_1': 1.1e6},
        rms=rms,
        objective=0.93,
        rms_start=dict(rms),
        objective_start=1.0,
        not_stationary=('wheel_1',),
    )
    return SpectralRecord(
        mode='optimize',
        start=dict(DESIGN),
        design=dict(DESIGN),
        success=True,
        status='Solve_Succeeded',
        objective=0.93,
        objective_start=1.0,
        scenarios=(scenario,),
        weights={'heave': 0.5, 'tyre_load_1': 0.5},
        normalization='reference',
        limits=(RmsLimit('travel_1', 'constraints.travel.bump', 0.06, 3.0, 0.02, 0.012, 0.0),),
        iterations=8,
        evaluations=12,
        hessian='exact',
        solve_time_s=0.04,
        wall_time_s=0.08,
        warnings=('constraints.roll_gradient: not applied',),
        config=CONFIG,
    )


def codesign() -> CodesignStudy:
    """A co-design study (``suspopt codesign``), its feedback law not converged."""
    return CodesignStudy(
        fidelity='low',
        control='active',
        entries={'passive': solve(), 'open_loop': solve(), 'feedback': solve(success=False)},
        wall_time_s=12.5,
        config=CONFIG,
        complete=True,
    )


#: one sample of every document kind
DOCUMENT_SAMPLES = {
    'solve': solve,
    'study': twostep,
    'pareto': pareto,
    'robust': robust,
    'compare': compare,
    'coupling': coupling,
    'spectral': spectral,
    'codesign': codesign,
}
