"""Benchmark: what the engineering constraints cost (``docs/metrics.md``, "Constraints").

    python benchmarks/bench_constraints.py [--parts study horizon] [--horizon 5]
                                           [--segments 80] [--horizons 10 80]
                                           [--density 16] [--travel 0.05 0.03]
                                           [--no-verify]

* ``study``: the two-step study of the default full car (``suspopt init --model
  full_car``: travel, tyre-contact and roll-gradient constraints) and the same study with
  its constraints removed, on the same grid (``--horizon`` s, ``--segments``), whole
  wall time and each step's IPOPT solve; the target is at most 1.5× the unconstrained.
* ``horizon``: one low-fidelity optimization of the paper's half car on an ISO 8608
  class C road at 20 m/s with a travel constraint (each of ``--travel``, bump and
  rebound, at every node) and without, at each of ``--horizons`` with ``--density`` segments per
  second; the target is a cost linear in the horizon (80 s at most 10× 10 s).

Every run is in this process, each study from its own empty cache (each problem's
sparsity, coloring and reference scales are part of its time, as on a first run).
Timings on a shared machine are noisy: the ratios are measured side by side in one run.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import fresh_cache, git_revision, machine, timed_optimize, write_result  # noqa: E402

from suspopt.spec.load import config_from_dict, full_car_defaults  # noqa: E402
from suspopt.spec.schema import ConstraintsConfig, StudyConfig  # noqa: E402
from suspopt.studies.twostep import run_study  # noqa: E402
from suspopt.verification.scales import resolve_scales  # noqa: E402


def study_case(cfg: StudyConfig, verify: bool) -> dict:
    """One two-step study: its wall time and each step's solve and iterations."""
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        study = run_study(cfg, Path(tmp) / 'study', verify=verify)
        wall = time.perf_counter() - t0
    s = study.steps
    return {
        'wall_s': wall,
        **{f'{k}_solve_s': getattr(s[k].times, 'solve_s', None) for k in ('low', 'mixed')},
        **{f'{k}_iterations': s[k].iterations for k in ('low', 'mixed')},
        **{f'{k}_f': s[k].objective for k in ('low', 'mixed')},
        'active': sorted({v.name for k in ('low', 'mixed') for v in s[k].constraints if v.active}),
    }


def part_study(a: argparse.Namespace) -> tuple[str, dict]:
    base = full_car_defaults()
    cfg = base.replace(
        maneuver=dataclasses.replace(base.maneuver, horizon=a.horizon),
        transcription=dataclasses.replace(base.transcription, segments=a.segments),
    )
    free = cfg.replace(constraints=ConstraintsConfig())
    out = {}
    for name, c in (('constrained', cfg), ('unconstrained', free)):
        with fresh_cache():  # each a first run: nothing of the other's cached
            out[name] = study_case(c, verify=not a.no_verify)
        print(name, out[name], flush=True)
    ratio = out['constrained']['wall_s'] / out['unconstrained']['wall_s']
    rows = [
        '| study | wall [s] | low solve [s] (iterations) | mixed solve [s] (iterations) | '
        'f low / mixed | active constraints |',
        '|---|---|---|---|---|---|',
    ]
    for name, r in out.items():
        rows.append(
            f'| {name} | {r["wall_s"]:.1f} | {r["low_solve_s"]:.1f} ({r["low_iterations"]}) | '
            f'{r["mixed_solve_s"]:.1f} ({r["mixed_iterations"]}) | {r["low_f"]:.4f} / '
            f'{r["mixed_f"]:.4f} | {", ".join(r["active"]) or "none"} |'
        )
    md = (
        f'Two-step study of the default full car, {a.horizon:g} s on {a.segments} segments, '
        f'with its constraints and without (each from an empty cache):\n\n'
        + '\n'.join(rows)
        + f'\n\nConstrained / unconstrained wall time: **{ratio:.2f}×** (target ≤ 1.5×).'
    )
    return md, {**out, 'ratio': ratio}


def part_horizon(a: argparse.Namespace) -> tuple[str, dict]:
    out: dict[str, dict] = {}
    for travel in (*a.travel, None):
        for T in a.horizons:
            data = {
                'maneuver': {'speed': 20.0, 'horizon': T},
                'road': {'profile': 'iso8608', 'road_class': 'C', 'seed': 1},
                'transcription': {'segments': int(round(a.density * T))},
            }
            if travel is not None:
                data['constraints'] = {'travel': {'bump': travel, 'rebound': travel}}
            cfg = config_from_dict(data)
            scales = resolve_scales(cfg)
            r = timed_optimize(cfg, 'low', scales, cfg.design.initial())
            vp = r.pop('problem')
            key = f'{T:g} s, ' + ('no constraint' if travel is None else f'travel ±{travel:g} m')
            out[key] = {k: r[k] for k in ('setup', 'guess', 'solve', 'total', 'iterations', 'f')}
            out[key] |= {
                'horizon': T,
                'constrained': travel is not None,
                'travel': travel,
                'success': r['success'],
                'active': [v.name for v in vp.constraint_values() if v.active],
            }
            vp.cleanup()
            print(key, out[key], flush=True)
    rows = [
        '| case | segments | setup [s] | solve [s] | iterations | solve per iteration [s] | '
        'total [s] | active |',
        '|---|---|---|---|---|---|---|---|',
    ]
    for key, r in out.items():
        rows.append(
            f'| {key} | {int(round(a.density * r["horizon"]))} | {r["setup"]:.2f} | '
            f'{r["solve"]:.2f} | {r["iterations"]} | {r["solve"] / r["iterations"]:.3f} | '
            f'{r["total"]:.2f} | {", ".join(r["active"]) or "none"} |'
        )
    lo, hi = min(a.horizons), max(a.horizons)

    def ratio(travel: float | None) -> float:
        t = {r['horizon']: r['total'] for r in out.values() if r.get('travel') == travel}
        return t[hi] / t[lo]

    with_travel = ', '.join(f'**{ratio(x):.2f}×** with ±{1e3 * x:g} mm' for x in a.travel)

    md = (
        'Low-fidelity optimization of the half car from its initial design, ISO 8608 class C '
        f'at 20 m/s, {a.density:g} segments/s of order 5, with a travel constraint at every '
        'node and without:\n\n'
        + '\n'.join(rows)
        + f'\n\n{hi:g} s / {lo:g} s total (horizon ratio {hi / lo:g}; target ≤ 10×): '
        f'{with_travel}, {ratio(None):.2f}× without.'
    )
    ratios = {f'{x:g}': ratio(x) for x in a.travel}
    return md, {'runs': out, 'ratio': ratios, 'ratio_unconstrained': ratio(None)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--parts', nargs='+', default=['study', 'horizon'])
    ap.add_argument('--horizon', type=float, default=5.0, help='study horizon [s]')
    ap.add_argument('--segments', type=int, default=80, help='study segments')
    ap.add_argument('--horizons', type=float, nargs='+', default=[10.0, 80.0])
    ap.add_argument('--density', type=float, default=16.0, help='segments per second')
    ap.add_argument(
        '--travel',
        type=float,
        nargs='+',
        default=[0.05, 0.03],
        help='horizon part: bump/rebound [m], each a case',
    )
    ap.add_argument('--no-verify', action='store_true')
    a = ap.parse_args()
    print(f'# engineering constraints — {machine()}, suspopt {git_revision()}\n', flush=True)
    sections, data = [], {}
    with fresh_cache():
        for part in a.parts:
            md, d = {'study': part_study, 'horizon': part_horizon}[part](a)
            print(md + '\n', flush=True)
            sections.append(md)
            data[part] = d
    name = 'constraints' + ('' if set(a.parts) == {'study', 'horizon'} else '_' + a.parts[0])
    write_result(name, 'Engineering constraints', '\n\n'.join(sections), data)


if __name__ == '__main__':
    main()
