"""Benchmark: robust design over several scenarios in one NLP against the scenarios solved
one by one (issue 14).

    python benchmarks/bench_robust.py [--config examples/robust.toml] [--repeat 3]
                                      [--fidelity low] [--aggregate sum|max]

Side by side in one process: the robust optimization (one NLP in which every scenario's
trajectory shares the design) and each scenario's own optimization, ``--repeat`` times
with the coloring cache (after one cold round that fills it). Prints the medians of wall
time (setup + starting trajectories + IPOPT; the reference scales and the time-marching
verification are left out, they are the same work in both), IPOPT iterations, the NLP's
size, and the ratio robust / Σ singles; and the process's peak resident memory.
"""

from __future__ import annotations

import argparse
import resource
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import fresh_cache, git_revision, machine, timed_optimize  # noqa: E402

from suspopt.spec.load import load_config  # noqa: E402
from suspopt.studies.robust import single_scenario  # noqa: E402
from suspopt.verification.scales import resolve_scales  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def run(cfg, fidelity, scales):
    out = timed_optimize(cfg, fidelity, scales, cfg.design.initial())
    vp = out.pop('problem')
    lay = vp.driver.layout()
    out['size'] = (lay.n, lay.m)
    vp.cleanup()
    if not out['success']:
        raise SystemExit(f'bench_robust: IPOPT did not converge ({cfg.scenarios()[0].name})')
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--config', default=str(ROOT / 'examples' / 'robust.toml'))
    ap.add_argument('--repeat', type=int, default=3)
    ap.add_argument('--fidelity', choices=('low', 'mixed'), default='low')
    ap.add_argument('--aggregate', choices=('sum', 'max'), default=None)
    args = ap.parse_args()
    cfg = load_config(args.config)
    if args.aggregate:
        cfg = cfg.replace(
            objective=cfg.objective.__class__(
                **{**cfg.objective.__dict__, 'aggregate': args.aggregate}
            )
        )
    scales = resolve_scales(cfg)
    names = [sc.name for sc in cfg.scenarios()]
    singles = [single_scenario(cfg, i) for i in range(len(names))]
    print(
        f'# robust design, {len(names)} scenarios ({", ".join(names)}), '
        f'{cfg.objective.aggregate}, {args.fidelity} fidelity — {machine()}, '
        f'suspopt {git_revision()}\n'
    )
    rounds = []
    with fresh_cache():
        for r in range(args.repeat + 1):
            rob = run(cfg, args.fidelity, scales)
            one = [run(c, args.fidelity, (s,)) for c, s in zip(singles, scales)]
            rounds.append((rob, one))
            print(
                f'round {r}{" (cold: coloring computed)" if r == 0 else ""}: robust '
                f'{rob["total"] + rob["coloring"]:.1f} s, singles '
                f'{sum(o["total"] + o["coloring"] for o in one):.1f} s',
                flush=True,
            )
    warm = rounds[1:] or rounds
    med = statistics.median
    rob_t = [r['total'] for r, _ in warm]
    one_t = [[o['total'] for o in ones] for _, ones in warm]
    print(
        '\n| problem | NLP variables × constraints | IPOPT iterations | wall [s], median '
        f'of {len(warm)} |\n|---|---|---|---|'
    )
    rob = warm[-1][0]
    print(
        f'| robust (one NLP) | {rob["size"][0]} × {rob["size"][1]} | {rob["iterations"]} | '
        f'{med(rob_t):.2f} |'
    )
    for i, name in enumerate(names):
        o = warm[-1][1][i]
        print(
            f'| {name} alone | {o["size"][0]} × {o["size"][1]} | {o["iterations"]} | '
            f'{med(t[i] for t in one_t):.2f} |'
        )
    ratios = [r / sum(t) for r, t in zip(rob_t, one_t)]
    cold_robust, cold_singles = rounds[0]
    cold = (cold_robust['total'] + cold_robust['coloring']) / sum(
        o['total'] + o['coloring'] for o in cold_singles
    )
    print(
        f'\nrobust / Σ singles: {med(ratios):.2f} (per round: '
        f'{", ".join(f"{x:.2f}" for x in ratios)}); cold round, coloring included: '
        f'{cold:.2f}'
    )
    print(
        f'robust f = {rob["f"]:.6f}; peak RSS of this process '
        f'{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2:.2f} GB'
    )


if __name__ == '__main__':
    main()
