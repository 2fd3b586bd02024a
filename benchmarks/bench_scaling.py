"""Benchmark: cost against the number of collocation segments (issue 5).

    python benchmarks/bench_scaling.py [--segments 16 32 64 128] [--repeat 3]

For each grid: one-time coloring, then (cached coloring) the solve time of the
low-fidelity optimization from the initial design and of the mixed-fidelity optimization
from the low-fidelity optimum of that grid, with iterations and time per iteration.
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import fresh_cache, git_revision, machine, timed_optimize  # noqa: E402

from suspopt.spec.schema import StudyConfig  # noqa: E402
from suspopt.verification.scales import resolve_scales  # noqa: E402


def solve(cfg, scales, fidelity, start):
    out = timed_optimize(cfg, fidelity, scales, start)
    out.pop('problem').cleanup()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--segments', type=int, nargs='+', default=[16, 32, 64, 128])
    ap.add_argument('--repeat', type=int, default=3)
    args = ap.parse_args()
    base = StudyConfig()
    scales = resolve_scales(base)
    print(f'# cost against grid size (order 5) — {machine()}, suspopt {git_revision()}\n')
    print(
        '| segments | nodes | model | coloring [s] (once) | solve [s] median (min–max) | '
        'iterations | solve / Jacobian evaluation [ms] | f |'
    )
    print('|---|---|---|---|---|---|---|---|')
    x0 = base.design.initial()
    with fresh_cache():
        for n in args.segments:
            cfg = base.replace(transcription=dataclasses.replace(base.transcription, segments=n))
            start = {'low': x0}
            for fid in ('low', 'mixed'):
                first = solve(cfg, scales, fid, start[fid])
                runs = [solve(cfg, scales, fid, start[fid]) for _ in range(args.repeat)]
                walls = [r['solve'] for r in runs]
                res = runs[-1]
                med = statistics.median(walls)
                print(
                    f'| {n} | {n * 5 + 1} | {fid} | {first["coloring"]:.2f} | '
                    f'{med:.2f} ({min(walls):.2f}–{max(walls):.2f}) | {res["iterations"]} | '
                    f'{1e3 * med / max(res["gevals"], 1):.0f} | '
                    f'{res["f"]:.5f}{"" if res["success"] else " (not converged)"} |',
                    flush=True,
                )
                if fid == 'low':
                    start['mixed'] = res['design']


if __name__ == '__main__':
    main()
