"""Benchmark: ``optimize_spectral`` (stationary RMS on an ISO 8608 road, IPOPT in reduced
space) on the hand-written quarter, half and full cars of ``tests/spectral``, and
``suspopt optimize --method spectral`` on suspopt's own vehicles (the study's quarter,
half and full car with a seat's Wk filter).

    python benchmarks/bench_spectral.py [--repeat 5] [--cases quarter half full]
        [--studies quarter_car half_car full_car]

Per case and Hessian (``exact``: complex step of the adjoint gradient; ``limited-memory``:
IPOPT's L-BFGS): the wall time of one ``optimize_spectral`` call (the Padé order chosen by
self-convergence included), IPOPT iterations, response evaluations, the augmented state
size and the objective reached; and the time of one variance evaluation and of one
gradient at the start. Median (min-max) over the repeats.

Per study (``suspopt.studies.spectral.optimize_spectral_study``, what the command runs,
objective on comfort and tyre load, travel and no-lift-off constraints as 3σ RMS
limits): the time to build the stationary system from the study (the assembly's
matrices, the Padé order and the reference scales at the initial design) and the
solve (``optimize_spectral``: Padé order, IPOPT, the check at the optimum).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / 'tests' / 'spectral'))

from _common import stats, write_result  # noqa: E402
from spectral_vehicles import (  # noqa: E402
    FULL_CAR_DESIGN,
    HALF_CAR_DESIGN,
    full_car,
    half_car,
    quarter_car,
)
from threadpoolctl import threadpool_limits  # noqa: E402

from suspopt.spec.load import config_from_dict  # noqa: E402
from suspopt.spectral import RandomRoad, StationaryModel  # noqa: E402
from suspopt.spectral.optimize import optimize_spectral  # noqa: E402
from suspopt.studies.spectral import optimize_spectral_study  # noqa: E402

#: the studies timed: each model's default car on a class C road at 20 m/s
STUDIES = ('quarter_car', 'half_car', 'full_car')


def study(model: str):
    """The default car of ``model`` with a seat, comfort and tyre load weighted, the
    travel and the tyre contact (no lift-off, ``margin = 0``) constrained."""
    return config_from_dict(
        {
            'vehicle': {'model': model},
            'comfort': {'seats': [{'name': 'driver'}]},
            'road': {'profile': 'iso8608', 'road_class': 'C'},
            'maneuver': {'speed': 20.0},
            'objective': {'weights': {'comfort': 0.5, 'tyre_load': 0.5}},
            'constraints': {
                'travel': {'bump': 0.08, 'rebound': 0.1},
                'tyre_contact': {'margin': 0.0},
            },
        }
    )


def fmt(value: float | None) -> str:
    return '—' if value is None else f'{value:.4f}'


def measure_study(model: str, repeat: int) -> dict:
    """``optimize_spectral_study`` of one study: build and solve times."""
    cfg = study(model)
    optimize_spectral_study(cfg)  # warm (imports, the first assembly)
    build, solve, rec = [], [], None
    for _ in range(repeat):
        rec = optimize_spectral_study(cfg)
        solve.append(rec.solve_time_s)
        build.append(rec.wall_time_s - rec.solve_time_s)
    assert rec is not None
    return {
        'build': build,
        'solve': solve,
        'iterations': rec.iterations,
        'evaluations': rec.evaluations,
        'pade_order': rec.scenarios[0].pade_order,
        'objective': rec.objective,
        'success': rec.success,
        'status': rec.status,
        'design': rec.design,
        'active': [lim.term for lim in rec.limits if lim.active],
    }


def cases() -> dict[str, dict]:
    """The three problems: system, road, start and optimize_spectral's keywords."""
    half = half_car()
    full = full_car()
    return {
        'quarter': dict(
            system=quarter_car(),
            road=RandomRoad('C', 20.0),
            start={'k': 20000.0, 'c': 1500.0},
            kwargs=dict(
                objective={'acc': 1.0, 'tyre': 0.3},
                lower={'k': 10000.0, 'c': 300.0},
                upper={'k': 60000.0, 'c': 8000.0},
                rms_limits={'travel': 0.012},
            ),
            label='quarter car (k, c), class C, 20 m/s',
        ),
        'half': dict(
            system=half,
            road=RandomRoad('C', 20.0),
            start=dict(zip(half.design, HALF_CAR_DESIGN)),
            kwargs=dict(
                objective={'heave_acc': 1.0, 'pitch_acc': 1.0, 'tyre_0': 0.3, 'tyre_1': 0.3},
                lower={'k1': 1e4, 'k2': 1e4, 'c1': 500.0, 'c2': 500.0},
                upper={'k1': 8e4, 'k2': 8e4, 'c1': 8000.0, 'c2': 8000.0},
                rms_limits={'travel_0': 0.012, 'travel_1': 0.012},
            ),
            label='half car (k1, k2, c1, c2), wheelbase delay, class C, 20 m/s',
        ),
        'full': dict(
            system=full,
            road=RandomRoad('C', 20.0, tracks='isotropic', separation=1.5),
            start=dict(zip(full.design, FULL_CAR_DESIGN)),
            kwargs=dict(
                objective={'heave_acc': 1.0, 'pitch_acc': 1.0, 'roll_acc': 1.0},
                lower={'k1': 1e4, 'k2': 1e4, 'c1': 500.0, 'c2': 500.0, 'kR1': 0.0, 'kR2': 0.0},
                upper={'k1': 8e4, 'k2': 8e4, 'c1': 8e3, 'c2': 8e3, 'kR1': 1e5, 'kR2': 1e5},
                rms_limits={f'travel_{i}': 0.012 for i in range(4)},
            ),
            label='full car (k, c per axle, two anti-roll bars), isotropic tracks, class C, 20 m/s',
        ),
    }


def measure(case: dict, hessian: str, repeat: int) -> dict:
    times, res = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        res = optimize_spectral(
            case['system'], case['road'], case['start'], hessian=hessian, **case['kwargs']
        )
        times.append(time.perf_counter() - t0)
    assert res is not None
    return {
        'times': times,
        'iterations': res.iterations,
        'evaluations': res.evaluations,
        'pade_order': res.pade.order,
        'objective': res.objective,
        'objective_initial': res.objective_initial,
        'success': res.success,
        'status': res.status_message,
        'design': res.design,
    }


def micro(case: dict, loops: int = 50) -> dict:
    """One variance evaluation and one gradient at the start (a new design each loop)."""
    sysm = case['system']
    p0 = sysm.design_vector(case['start']).astype(float)
    model = StationaryModel(sysm, case['road'], 8)
    w = 1.0 / model.variances(p0)
    t_var, t_grad = [], []
    for i in range(loops):
        p = p0 * (1.0 + 1e-6 * (i + 1))
        t0 = time.perf_counter()
        model.variances(p)
        t1 = time.perf_counter()
        model.gradient(p, w)
        t_grad.append(time.perf_counter() - t1)
        t_var.append(t1 - t0)
    return {
        'variance_ms': 1e3 * statistics.median(t_var),
        'gradient_ms': 1e3 * statistics.median(t_grad),
        'states': model.n_states,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--repeat', type=int, default=5)
    ap.add_argument('--cases', nargs='+', default=['quarter', 'half', 'full'])
    ap.add_argument('--studies', nargs='+', default=list(STUDIES), choices=STUDIES)
    args = ap.parse_args()
    all_cases = cases()
    rows, data = [], {}
    study_rows = []
    for model in args.studies:
        r = measure_study(model, args.repeat)
        data[f'study_{model}'] = r
        study_rows.append(
            f'| {model} | {stats(r["build"])} | {stats(r["solve"])} | {r["iterations"]} | '
            f'{r["evaluations"]} | {r["pade_order"]} | {fmt(r["objective"])} | '
            f'{", ".join(r["active"]) or "none"} | {"yes" if r["success"] else r["status"]} |'
        )
        print(study_rows[-1], flush=True)
    for name in args.cases:
        case = all_cases[name]
        optimize_spectral(case['system'], case['road'], case['start'], **case['kwargs'])  # warm
        with threadpool_limits(limits=1, user_api='blas'):  # as optimize_spectral runs
            m = micro(case)
        data[name] = {'label': case['label'], 'micro': m}
        for hessian in ('exact', 'limited-memory'):
            r = measure(case, hessian, args.repeat)
            data[name][hessian] = r
            rows.append(
                f'| {case["label"]} | {hessian} | {stats(r["times"])} | {r["iterations"]} | '
                f'{r["evaluations"]} | {r["pade_order"]} | {r["objective"]:.6g} '
                f'({r["objective_initial"]:.4g} at start) | '
                f'{"yes" if r["success"] else r["status"]} |'
            )
            print(rows[-1], flush=True)
    md = [
        "`suspopt optimize --method spectral` on suspopt's own vehicles (each model's "
        "default car with a seat's Wk filter, class C at 20 m/s, f on comfort and tyre load, "
        '3σ travel and no-lift-off limits): building the stationary system from the study '
        '[s] and the solve [s], median (min–max) over '
        f'{args.repeat} repeats.',
        '',
        '| study | build [s] | solve [s] | iterations | evaluations | Padé order | f '
        '| active limits | converged |',
        '|---|---|---|---|---|---|---|---|---|',
        *study_rows,
        '',
        'Wall time of one `optimize_spectral` call [s] (Padé order chosen by self-convergence '
        'to 1e-4 included), median (min–max) over '
        f'{args.repeat} repeats; iterations of IPOPT, evaluations of the response.',
        '',
        '| problem | Hessian | time [s] | iterations | evaluations | Padé order | objective '
        '| converged |',
        '|---|---|---|---|---|---|---|---|',
        *rows,
        '',
        'One evaluation at the start (Padé order 8, single-threaded BLAS): augmented states, '
        'variances and one adjoint gradient [ms], median of 50.',
        '',
        '| problem | states | variances [ms] | gradient [ms] |',
        '|---|---|---|---|',
        *[
            f'| {data[n]["label"]} | {data[n]["micro"]["states"]} | '
            f'{data[n]["micro"]["variance_ms"]:.3g} | {data[n]["micro"]["gradient_ms"]:.3g} |'
            for n in args.cases
        ],
    ]
    path = write_result('spectral', 'Stationary (spectral) optimization', '\n'.join(md), data)
    print('\n'.join(md))
    print(f'written to {path}')


if __name__ == '__main__':
    main()
