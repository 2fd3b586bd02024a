"""IPOPT iteration counts of the benchmark cases under a few IPOPT option sets.

    python benchmarks/ipopt_iterations.py [--options default,hist3,...] [--cases paper,...]

Iteration counts are deterministic (the same on a loaded machine), so this answers
"would another IPOPT setting need fewer iterations?" without timing noise. Cases
(low fidelity, from the initial design, cached coloring): the paper's half car; the half
car on the full car's ISO 8608 road and grid (``bench_full_car.py``'s pair); the default
full car (and the same from the middle of its design box and from near its optimum,
``full_car@mid``, ``full_car@near_optimum``); the robust NLP of ``examples/robust.toml`` and each of its scenarios alone
(``bench_robust.py``'s comparison). Prints one row per case and option set: iterations,
objective, solve time. Each option set is added to the driver's defaults (``default``:
those alone, which include ``limited_memory_aug_solver = extended``; ``sherman``: IPOPT's
own default instead, the same steps at a different cost per step, which the solve time
column shows side by side).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import git_revision, machine, timed_optimize  # noqa: E402

from suspopt.spec.load import config_from_dict, full_car_defaults, load_config
from suspopt.spec.resolve import auto_segments  # noqa: E402
from suspopt.spec.schema import StudyConfig
from suspopt.studies.robust import single_scenario  # noqa: E402
from suspopt.verification.scales import resolve_scales  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
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
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        '--options',
        default='default,hist3,hist12,adaptive',
        help=f'comma-separated, of {", ".join(OPTIONS)}',
    )
    ap.add_argument('--cases', default=None, help='comma-separated case names (default all)')
    args = ap.parse_args()
    chosen = args.options.split(',')
    unknown = sorted(set(chosen) - set(OPTIONS))
    if unknown:
        raise SystemExit(f'--options: unknown {unknown}; known: {", ".join(OPTIONS)}')
    all_cases = cases()
    names = args.cases.split(',') if args.cases else list(all_cases)
    print(f'# IPOPT iterations by option set — {machine()}, suspopt {git_revision()}\n')
    print('| case | options | IPOPT iterations | f | solve [s] |\n|---|---|---|---|---|')
    for name in names:
        cfg = all_cases[name]
        scales = resolve_scales(cfg)
        for opt in chosen:
            c = dataclasses.replace(
                cfg,
                optimizer=dataclasses.replace(
                    cfg.optimizer, options={**cfg.optimizer.options, **OPTIONS[opt]}
                ),
            )
            r = timed_optimize(c, 'low', scales, START.get(name, cfg.design.initial()))
            r.pop('problem').cleanup()
            flag = '' if r['success'] else ' (not converged)'
            print(
                f'| {name} | {opt} | {r["iterations"]}{flag} | {r["f"]:.10g} | {r["solve"]:.2f} |',
                flush=True,
            )


if __name__ == '__main__':
    main()
