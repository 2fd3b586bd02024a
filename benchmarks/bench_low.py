"""Benchmark: low-fidelity optimization (issue 5), side by side with the CasADi peer.

    python benchmarks/bench_low.py [--repeat 3] [--segments 80] [--normalization paper]
                                   [--no-peer] [--compare-totals]

Prints, for suspopt: the one-time total-coloring cost (empty cache) and, over repeats with
the cached coloring, setup (building the Dymos/OpenMDAO problem), initial guess (the
default `auto`: zero states for the half car), solve (IPOPT, including the model
evaluations and colored total derivatives), total, IPOPT iterations and evaluations; and
for the hand-written CasADi direct collocation of the same problem
(benchmarks/casadi_peer.py): build, solve, total and its optimum.
``--compare-totals`` also runs, interleaved with the others, the driver's public-API
total derivatives (one OpenMDAO linear solve per color) and prints both side by side.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import fresh_cache, git_revision, machine, table, timed_optimize  # noqa: E402

from suspopt.spec.schema import StudyConfig  # noqa: E402

DESIGN_NAMES = StudyConfig().design_names()
from suspopt.verification.scales import resolve_scales  # noqa: E402


def run_once(cfg: StudyConfig, scales, totals: str = 'auto') -> dict:
    out = timed_optimize(cfg, 'low', scales, cfg.design.initial(), totals=totals)
    out.pop('problem').cleanup()
    assert out['success'], 'IPOPT did not converge'
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--repeat', type=int, default=3)
    ap.add_argument('--segments', type=int, default=StudyConfig().transcription.segments)
    ap.add_argument('--order', type=int, default=5)
    ap.add_argument('--no-peer', action='store_true')
    ap.add_argument('--compare-totals', action='store_true')
    ap.add_argument('--normalization', choices=('reference', 'paper'), default='reference')
    args = ap.parse_args()
    cfg = StudyConfig()
    cfg = cfg.replace(
        transcription=dataclasses.replace(
            cfg.transcription, segments=args.segments, order=args.order
        ),
        objective=dataclasses.replace(cfg.objective, normalization=args.normalization),
    )
    scales = resolve_scales(cfg)
    print(
        f'# low-fidelity optimize, {args.segments} x {args.order} grid, '
        f'{args.normalization} normalization — {machine()}, suspopt {git_revision()}\n'
    )
    with fresh_cache():
        cold = run_once(cfg, scales)
        warm, solves = [], []
        for _ in range(args.repeat):
            warm.append(run_once(cfg, scales))
            if args.compare_totals:
                solves.append(run_once(cfg, scales, totals='solves'))
    print(
        f'one-time total coloring (empty cache): {cold["coloring"]:.2f} s; first run total '
        f'{cold["total"]:.2f} s\n'
    )
    rows = [
        (f'{k} [s]' if k not in ('iterations', 'fevals', 'gevals') else k, [r[k] for r in warm])
        for k in ('setup', 'guess', 'solve', 'total', 'iterations', 'fevals', 'gevals')
    ]
    print(f'suspopt, cached coloring, {args.repeat} runs:\n')
    print(table(rows))
    if solves:
        med = lambda rs, k: sorted(r[k] for r in rs)[len(rs) // 2]  # noqa: E731
        print(
            f'\nthe same with one OpenMDAO linear solve per color (public path), '
            f'{args.repeat} runs interleaved:\n'
        )
        print(
            table(
                [(f'{k} [s]', [r[k] for r in solves]) for k in ('solve', 'total')]
                + [('iterations', [r['iterations'] for r in solves])]
            )
        )
        max_rel_diff = max(
            abs(warm[-1]['design'][n] / solves[-1]['design'][n] - 1) for n in DESIGN_NAMES
        )
        print(
            f'\nsolve, propagated / linear solves (medians): '
            f'{med(warm, "solve") / med(solves, "solve"):.2f}x; optimum difference '
            f'{max_rel_diff:.1e}'
        )
    x = warm[-1]['design']
    print(
        '\noptimum: '
        + ', '.join(f'{n} = {x[n]:.2f}' for n in DESIGN_NAMES)
        + f', f = {warm[-1]["f"]:.7f}'
    )
    if args.no_peer:
        return
    try:
        import casadi_peer
    except ImportError as err:  # casadi is a benchmark-only extra: pip install -e '.[bench]'
        print(f'\n(CasADi peer skipped: {err})')
        return
    peer = [
        casadi_peer.solve_peer(segments=args.segments, order=args.order, scales=scales)
        for _ in range(args.repeat)
    ]
    print(f'\nCasADi peer (hand-written direct collocation, exact Hessian), {args.repeat} runs:\n')
    print(
        table(
            [
                ('build [s]', [p['build_time_s'] for p in peer]),
                ('solve [s]', [p['solve_time_s'] for p in peer]),
                ('total [s]', [p['total_time_s'] for p in peer]),
                ('iterations', [p['iterations'] for p in peer]),
            ]
        )
    )
    px = peer[-1]['design']
    print(
        '\npeer optimum: '
        + ', '.join(f'{n} = {px[n]:.2f}' for n in DESIGN_NAMES)
        + f', f = {peer[-1]["objective"]:.7f}'
    )
    dx = max(abs(x[n] / px[n] - 1.0) for n in DESIGN_NAMES)
    print(
        f'max relative design difference suspopt vs peer: {dx:.2e}; '
        f'f difference {abs(warm[-1]["f"] - peer[-1]["objective"]):.2e}'
    )
    ratio = [w['total'] for w in warm]
    peer_total = sorted(p['total_time_s'] for p in peer)[len(peer) // 2]
    print(
        f'suspopt total / peer total (medians): {sorted(ratio)[len(ratio) // 2] / peer_total:.2f}x'
    )

    # the same NLP as suspopt's (J_k by quadrature, IPOPT's limited-memory Hessian): what
    # the framework costs, separated from what the exact Hessian buys
    same = [
        casadi_peer.solve_peer(
            segments=args.segments,
            order=args.order,
            scales=scales,
            hessian='limited-memory',
            integrals='quadrature',
        )
        for _ in range(args.repeat)
    ]
    print(
        f'\nCasADi, the NLP as suspopt poses it (J_k by Radau quadrature, IPOPT '
        f'limited-memory Hessian), {args.repeat} runs:\n'
    )
    print(
        table(
            [
                ('build [s]', [p['build_time_s'] for p in same]),
                ('solve [s]', [p['solve_time_s'] for p in same]),
                ('total [s]', [p['total_time_s'] for p in same]),
                ('iterations', [p['iterations'] for p in same]),
            ]
        )
    )
    same_total = sorted(p['total_time_s'] for p in same)[len(same) // 2]
    print(
        f"suspopt total / this peer's total (medians): "
        f'{sorted(ratio)[len(ratio) // 2] / same_total:.2f}x'
    )


if __name__ == '__main__':
    main()
