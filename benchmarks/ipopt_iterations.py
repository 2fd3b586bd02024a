"""IPOPT iteration counts of the benchmark cases under a few IPOPT option sets and Hessians.

    python benchmarks/ipopt_iterations.py [--options default,hist3,...] [--cases paper,...]
                                          [--hessian limited-memory,exact]

Iteration counts are deterministic (the same on a loaded machine), so this answers
"would another IPOPT setting need fewer iterations?" without timing noise. Cases
(low fidelity, from the initial design, cached coloring): the paper's half car; the half
car on the full car's ISO 8608 road and grid (``bench_full_car.py``'s pair); the default
full car (and the same from the middle of its design box and from near its optimum,
``full_car@mid``, ``full_car@near_optimum``); the robust NLP of ``examples/robust.toml``
and each of its scenarios alone (``bench_robust.py``'s comparison); a long ISO 8608 road
(``iso40``: ``bench_horizon.py``'s 40 s case, class C at 20 m/s, 16 segments per second);
and the paper's half car with the multibody suspensions (``paper@mixed``, mixed
fidelity). Prints one row per case, Hessian
and option set: iterations, objective, solve wall and CPU time (the CPU time is less
disturbed by other processes on a shared machine), and writes the table with
``_common.write_result``. Each option set is added to the driver's defaults (``default``:
those alone, which include ``limited_memory_aug_solver = extended`` with the L-BFGS
Hessian; ``sherman``: IPOPT's own default instead, the same steps at a different cost per
step, which the solve time column shows side by side). ``--hessian``: the Hessians of the
Lagrangian to compare (:class:`~suspopt.transcription.problem.VehicleProblem`'s
``hessian``: IPOPT's L-BFGS, ``exact`` by second-order adjoints, ``auto``: the one
:func:`~suspopt.transcription.problem.auto_hessian` picks, shown in brackets and measured
once). ``--max-iter`` caps IPOPT's iterations (the exact Hessian on the mixed fidelity
does not converge).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import git_revision, machine, timed_optimize, write_result  # noqa: E402

from suspopt.spec.load import config_from_dict, full_car_defaults, load_config
from suspopt.spec.resolve import auto_segments  # noqa: E402
from suspopt.spec.schema import StudyConfig
from suspopt.studies.robust import single_scenario  # noqa: E402
from suspopt.transcription.problem import auto_hessian  # noqa: E402
from suspopt.verification.scales import resolve_scales  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
#: the Hessians of the Lagrangian compared (VehicleProblem's ``hessian``)
HESSIANS = ('limited-memory', 'exact', 'auto')
OPTIONS = {
    'default': {},
    'hist3': {'limited_memory_max_history': 3},
    'hist12': {'limited_memory_max_history': 12},
    'adaptive': {'mu_strategy': 'adaptive'},
    'scalar2': {'limited_memory_initialization': 'scalar2'},
    'obj0.25': {'obj_scaling_factor': 0.25},
    'extended': {'limited_memory_aug_solver': 'extended'},
    'sherman': {'limited_memory_aug_solver': 'sherman-morrison'},
}


#: cases started elsewhere than at their initial design
START: dict[str, dict[str, float]] = {}


def cases() -> dict:
    full = full_car_defaults()
    seg = auto_segments(full, full.scenarios()[0], full.transcription.order)
    full = config_from_dict({**full.to_dict(), 'transcription': {'segments': seg}})
    half_iso = config_from_dict(
        {
            **StudyConfig().to_dict(),
            'road': dict(full.road),
            'maneuver': full.maneuver.__dict__,
            'transcription': {'segments': seg},
        }
    )
    robust = load_config(ROOT / 'examples' / 'robust.toml')
    out = {'paper': StudyConfig(), 'half_iso': half_iso, 'full_car': full}
    # the default full car (its objective's reference scales at its initial design, so the
    # same NLP) from other starts: the middle of its design box, and near its optimum (on
    # the lower bounds of both springs and dampers, no front bar)
    d = full.design
    START['full_car@mid'] = {k: 0.5 * (d[k].lower + d[k].upper) for k in d.initial()}
    START['full_car@near_optimum'] = {
        'k_S1': 11000.0,
        'k_S2': 11000.0,
        'c_S1': 1100.0,
        'c_S2': 1100.0,
        'k_R1': 2000.0,
        'k_R2': 7000.0,
    }
    out.update({name: full for name in START})
    out['robust'] = robust
    out.update({f'robust[{i}]': single_scenario(robust, i) for i in range(len(robust.scenarios()))})
    horizon = 40.0  # bench_horizon.py's longest default low-fidelity case
    out['iso40'] = config_from_dict(
        {
            'maneuver': {'speed': 20.0, 'horizon': horizon},
            'road': {'profile': 'iso8608', 'road_class': 'C', 'seed': 1},
            'transcription': {'segments': int(round(16 * horizon))},
        }
    )
    out['paper@mixed'] = StudyConfig()
    return out


def fidelity(case: str) -> str:
    return 'mixed' if case.endswith('@mixed') else 'low'


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        '--options',
        default='default,hist3,hist12,adaptive',
        help=f'comma-separated, of {", ".join(OPTIONS)}',
    )
    ap.add_argument('--cases', default=None, help='comma-separated case names (default all)')
    ap.add_argument(
        '--hessian',
        default='limited-memory',
        help=f'comma-separated, of {", ".join(HESSIANS)}',
    )
    ap.add_argument(
        '--max-iter', type=int, default=None, help="IPOPT's iteration limit (default the study's)"
    )
    args = ap.parse_args()
    chosen = args.options.split(',')
    unknown = sorted(set(chosen) - set(OPTIONS))
    if unknown:
        raise SystemExit(f'--options: unknown {unknown}; known: {", ".join(OPTIONS)}')
    hessians = args.hessian.split(',')
    unknown = sorted(set(hessians) - set(HESSIANS))
    if unknown:
        raise SystemExit(f'--hessian: unknown {unknown}; known: {", ".join(HESSIANS)}')
    all_cases = cases()
    names = args.cases.split(',') if args.cases else list(all_cases)
    unknown = sorted(set(names) - set(all_cases))
    if unknown:
        raise SystemExit(f'--cases: unknown {unknown}; known: {", ".join(all_cases)}')
    header = (
        '| case | Hessian | options | IPOPT iterations | f | solve [s] | solve CPU [s] '
        '| sparsity, coloring [s] |\n|---|---|---|---|---|---|---|---|'
    )
    print(f'# IPOPT iterations by option set — {machine()}, suspopt {git_revision()}\n')
    print(header)
    rows, data = [], []
    for name in names:
        cfg = all_cases[name]
        if args.max_iter is not None:
            cfg = dataclasses.replace(
                cfg, optimizer=dataclasses.replace(cfg.optimizer, max_iter=args.max_iter)
            )
        scales = resolve_scales(cfg)
        measured: dict[tuple[str, str], dict] = {}
        for hessian in hessians:
            # 'auto' is the one it picks: measured once if that one is compared too
            used = auto_hessian(cfg, fidelity(name)) if hessian == 'auto' else hessian
            for opt in chosen:
                c = dataclasses.replace(
                    cfg,
                    optimizer=dataclasses.replace(
                        cfg.optimizer, options={**cfg.optimizer.options, **OPTIONS[opt]}
                    ),
                )
                start = START.get(name, cfg.design.initial())
                if (used, opt) in measured and hessian == 'auto':
                    r = measured[used, opt]
                else:
                    r = timed_optimize(c, fidelity(name), scales, start, hessian=used)
                    r.pop('problem').cleanup()
                    measured[used, opt] = r
                flag = '' if r['success'] else ' (not converged)'
                label = hessian if hessian == used else f'{hessian} ({used})'
                row = (
                    f'| {name} | {label} | {opt} | {r["iterations"]}{flag} | {r["f"]:.10g} '
                    f'| {r["solve"]:.2f} | {r["solve_cpu"]:.2f} | {r["coloring"]:.2f} |'
                )
                print(row, flush=True)
                rows.append(row)
                data.append(
                    {
                        'case': name,
                        'hessian': hessian,
                        'hessian_used': used,
                        'options': opt,
                        'iterations': r['iterations'],
                        'success': r['success'],
                        'f': r['f'],
                        'solve_s': r['solve'],
                        'solve_cpu_s': r['solve_cpu'],
                        'coloring_s': r['coloring'],
                        'design': r['design'],
                    }
                )
    note = (
        'Low fidelity unless the case says `@mixed`; from the initial design (or the '
        'start in the case name). The solve times leave out the sparsity and coloring '
        "(the Jacobian's, and with the exact Hessian its nonlinear terms, pattern and "
        "coloring): computed on a structure's first run, then read from the coloring "
        'cache (the last column: what this run took). Iteration counts are '
        'deterministic; the times are of one run each on a shared machine (compare rows '
        'of one run, CPU time first).'
    )
    write_result(
        'ipopt_iterations',
        'IPOPT iterations by Hessian and option set',
        f'{header}\n' + '\n'.join(rows) + f'\n\n{note}\n',
        data,
    )


if __name__ == '__main__':
    main()
