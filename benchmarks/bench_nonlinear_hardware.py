"""Benchmark: a mixed-fidelity optimization with nonlinear dampers against the linear one.

    python benchmarks/bench_nonlinear_hardware.py [--repeat 3] [--segments 80]
                                                  [--variants rebound,slopes]

The paper's half car (two bumps, 10 m/s) in the mixed fidelity, on one grid, side by side
in one process, repeat by repeat after a cold round that fills the coloring cache:

* linear: the design ``k_S1, k_S2, c_S1, c_S2``;
* each variant: both dampers asymmetric two-stage curves (``docs/nonlinear_hardware.md``)
  started with every slope at the linear start's ``c_S`` (the same forces), some slopes
  design variables with ``k_S1, k_S2``: ``rebound`` the low-speed rebound slope (four
  variables, as the linear design), ``low-speed`` the low-speed bump and rebound ones
  (six), ``slopes`` all four (ten);

all from the low-fidelity linear optimum, with the same normalization. Prints each
phase's median (setup, starting trajectory, IPOPT solve), the IPOPT iterations, the time
per iteration, the black-box queries of one Jacobian (at this grid and at half of it: the
finite differences of the settings cost the same whatever the number of nodes), and the
ratios to linear (target: at most 1.3 for the whole optimization). Writes
``benchmarks/results/nonlinear_hardware.json``.
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import git_revision, timed_optimize, write_result  # noqa: E402

from suspopt.multibody.components import (  # noqa: E402
    SuspensionDynamicsComp,
    SuspensionKinematicsComp,
)
from suspopt.spec.load import config_from_dict  # noqa: E402
from suspopt.studies.run import optimize  # noqa: E402
from suspopt.transcription.problem import VehicleProblem  # noqa: E402
from suspopt.verification.scales import resolve_scales  # noqa: E402

SLOPES = ('c_bump_low', 'c_bump_high', 'c_rebound_low', 'c_rebound_high')
#: the damper curves' slopes' bounds: the linear c_S's (paper Table 3)
BOUNDS = {'lower': 1000.0, 'upper': 5000.0}


#: the damper curves' slopes that are design variables, by variant
VARIANTS = {
    'slopes': SLOPES,
    'low-speed': ('c_bump_low', 'c_rebound_low'),
    'rebound': ('c_rebound_low',),
}


def configs(segments: int, c_S: dict[str, float], designed: tuple[str, ...] = SLOPES) -> dict:
    """The linear study and the one with damper curves, every slope started at ``c_S``,
    the slopes ``designed`` design variables."""
    base = {'transcription': {'segments': segments}}
    linear = config_from_dict(base)
    vehicle, design = {}, {}
    for a, axle in enumerate(('front', 'rear')):
        c = c_S[f'c_S{a + 1}']
        vehicle[axle] = {
            'damper_curve': {
                **dict.fromkeys(SLOPES, c),
                'v_bump_knee': 0.1,
                'v_rebound_knee': 0.1,
            }
        }
        design.update({f'{s}_{a + 1}': dict(BOUNDS) for s in designed})
    curves = config_from_dict({**base, 'vehicle': vehicle, 'design': design})
    return {'linear': linear, 'curves': curves}


def black_box_queries(cfg, scales) -> tuple[int, int]:
    """Black-box queries (kinematics, dynamics) of one Jacobian of the model's partials."""
    counts = {SuspensionKinematicsComp: 0, SuspensionDynamicsComp: 0}
    originals = {cls: cls.evaluate for cls in counts}

    def counting(cls):
        def evaluate(self, values):
            counts[cls] += 1
            return originals[cls](self, values)

        return evaluate

    with VehicleProblem(cfg, 'mixed', scales) as vp:
        vp.problem.run_model()
        for cls in counts:
            cls.evaluate = counting(cls)  # type: ignore[method-assign]
        try:
            vp.problem.model.run_linearize()
        finally:
            for cls, orig in originals.items():
                cls.evaluate = orig  # type: ignore[method-assign]
    return counts[SuspensionKinematicsComp], counts[SuspensionDynamicsComp]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--repeat', type=int, default=3)
    ap.add_argument('--segments', type=int, default=80)
    ap.add_argument(
        '--variants',
        default='rebound,slopes',
        help="the damper curves' slopes designed, comma-separated: " + ', '.join(VARIANTS),
    )
    args = ap.parse_args()
    variants = [v for v in args.variants.split(',') if v]
    unknown = set(variants) - set(VARIANTS)
    if unknown:
        raise SystemExit(f'--variants: unknown {sorted(unknown)} (known: {", ".join(VARIANTS)})')
    base = config_from_dict({'transcription': {'segments': args.segments}})
    scales = resolve_scales(base)
    low = optimize(base, 'low', scales=scales, verify=False)
    c_S = {n: v for n, v in low.design.items() if n.startswith('c_S')}
    k_S = {n: v for n, v in low.design.items() if n.startswith('k_S')}
    cfgs = {'linear': base}
    starts = {'linear': low.design}
    for v in variants:
        cfgs[v] = configs(args.segments, c_S, VARIANTS[v])['curves']
        starts[v] = {**cfgs[v].design.initial(), **k_S}
    runs: dict[str, list[dict]] = {k: [] for k in cfgs}
    for r in range(args.repeat + 1):  # round 0 fills the coloring cache (not counted)
        for name, cfg in cfgs.items():
            out = timed_optimize(cfg, 'mixed', scales, starts[name])
            out.pop('problem').cleanup()
            if not out['success']:
                raise SystemExit(f'{name}: IPOPT did not converge')
            print(
                f'round {r} {name}: total {out["total"]:.1f} s, solve {out["solve"]:.1f} s, '
                f'{out["iterations"]} iterations, f = {out["f"]:.6f}'
            )
            if r:
                runs[name].append(out)
    half = dataclasses.replace(base.transcription, segments=max(args.segments // 2, 8))
    queries = {
        (name, n): black_box_queries(
            cfg if n == args.segments else cfg.replace(transcription=half), scales
        )
        for name, cfg in cfgs.items()
        for n in (args.segments, half.segments)
    }

    def med(name: str, key: str) -> float:
        return statistics.median(o[key] for o in runs[name])

    names = list(cfgs)
    keys = ('total', 'setup', 'guess', 'solve', 'solve_cpu', 'iterations')
    rows = []
    for key in keys:
        vals = [med(n, key) for n in names]
        ratios = [v / vals[0] for v in vals[1:]]
        rows.append(
            f'| {key} | '
            + ' | '.join(f'{v:.3g}' for v in vals)
            + ' | '
            + ' | '.join(f'{x:.2f}' for x in ratios)
            + ' |'
        )
    per_it = [med(n, 'solve') / med(n, 'iterations') for n in names]
    rows.append(
        '| solve per iteration | '
        + ' | '.join(f'{v:.3g}' for v in per_it)
        + ' | '
        + ' | '.join(f'{v / per_it[0]:.2f}' for v in per_it[1:])
        + ' |'
    )
    q = {
        n: ' / '.join(
            f'{queries[(n, s)][0]} + {queries[(n, s)][1]}' for s in (args.segments, half.segments)
        )
        for n in names
    }
    f = {n: statistics.median(o['f'] for o in runs[n]) for n in names}
    ratio = {v: med(v, 'total') / med('linear', 'total') for v in variants}
    described = {
        'rebound': 'the rebound low-speed slope per axle designed, with k_S (4 variables, '
        'as the linear design)',
        'low-speed': 'the bump and rebound low-speed slopes per axle (6 variables)',
        'slopes': 'all four slopes per axle (10 variables)',
    }
    md = '\n'.join(
        [
            f'Mixed-fidelity optimization of the half car, {args.segments} segments, from the '
            f'low-fidelity optimum; medians of {args.repeat} rounds (coloring cached), the '
            'problems interleaved. Linear: k_S1, k_S2, c_S1, c_S2. Curves: both dampers '
            'asymmetric two-stage curves started at the linear c_S (the same forces), '
            + '; '.join(f'{v}: {described[v]}' for v in variants)
            + '.',
            '',
            '| quantity [s] | '
            + ' | '.join(names)
            + ' | '
            + ' | '.join(f'{v} / linear' for v in variants)
            + ' |',
            '|---|' + '---:|' * (2 * len(names) - 1),
            *rows,
            '',
            f'Black-box queries of one Jacobian (kinematics + dynamics), at {args.segments} / '
            f'{half.segments} segments: '
            + ', '.join(f'{n} {q[n]}' for n in names)
            + ' (the same at both grids: one batched query per input or setting, whatever '
            'the nodes).',
            '',
            'Objective at the optimum: '
            + ', '.join(f'{n} {f[n]:.6f}' for n in names)
            + '. Whole optimization against linear: '
            + ', '.join(f'{v} **{ratio[v]:.2f}**' for v in variants)
            + ' (target <= 1.3).',
        ]
    )
    print(md)
    write_result(
        'nonlinear_hardware',
        'Mixed-fidelity optimization with nonlinear dampers against linear ones',
        md,
        {
            'revision': git_revision(),
            'segments': args.segments,
            'runs': {n: [{k: o[k] for k in (*keys, 'f')} for o in runs[n]] for n in runs},
            'queries': {f'{n}@{s}': v for (n, s), v in queries.items()},
            'ratio_total': ratio,
        },
    )


if __name__ == '__main__':
    main()
