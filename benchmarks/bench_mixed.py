"""Benchmark: mixed-fidelity optimization from the low-fidelity optimum (issue 5).

    python benchmarks/bench_mixed.py [--repeat 3] [--segments 80]

Prints the one-time coloring cost, then over repeats (cached coloring): setup, solve,
total, IPOPT iterations, black-box calls per Jacobian and in total, and the share of the
solve spent inside the multibody solver; plus the low-fidelity solve on the same grid for
the mixed/low ratio.
"""
from __future__ import annotations

import argparse
import dataclasses
import statistics
import sys
from contextlib import contextmanager
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import fresh_cache, git_revision, machine, table, timed_optimize  # noqa: E402

from suspopt.config import StudyConfig  # noqa: E402
from suspopt.multibody.components import SuspensionDynamicsComp, SuspensionKinematicsComp  # noqa: E402
from suspopt.study import optimize, resolve_scales  # noqa: E402


@contextmanager
def _count_compute(*comp_classes):
    """Count compute() calls of component classes (black-box queries)."""
    counts = {cls: 0 for cls in comp_classes}
    originals = {cls: cls.compute for cls in comp_classes}

    def counting(cls):
        def compute(self, inputs, outputs):
            counts[cls] += 1
            return originals[cls](self, inputs, outputs)
        return compute

    for cls in comp_classes:
        cls.compute = counting(cls)
    try:
        yield counts
    finally:
        for cls, orig in originals.items():
            cls.compute = orig


def run_once(cfg, scales, start, fidelity='mixed') -> dict:
    out = timed_optimize(cfg, fidelity, scales, start)
    vp = out.pop('problem')
    if fidelity == 'mixed':
        # black-box calls per Jacobian: one colored total-derivative evaluation
        drv = vp.driver
        drv._tjac = None
        drv._totals()
        with _count_compute(SuspensionKinematicsComp, SuspensionDynamicsComp) as counts:
            drv._totals()
        out['per_jacobian'] = (counts[SuspensionKinematicsComp], counts[SuspensionDynamicsComp])
    vp.cleanup()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--repeat', type=int, default=3)
    ap.add_argument('--segments', type=int, default=StudyConfig().transcription.segments)
    args = ap.parse_args()
    cfg = StudyConfig()
    cfg = cfg.replace(transcription=dataclasses.replace(cfg.transcription,
                                                        segments=args.segments))
    scales = resolve_scales(cfg)
    print(f'# mixed-fidelity optimize from the low-fidelity optimum, {args.segments} x 5 grid '
          f'— {machine()}, suspopt {git_revision()}\n')
    with fresh_cache():
        low = optimize(cfg, 'low', scales=scales)
        start = low['design']
        cold = run_once(cfg, scales, start)
        runs = [run_once(cfg, scales, start) for _ in range(args.repeat)]
        lows = [run_once(cfg, scales, cfg.design.initial(), 'low')
                for _ in range(args.repeat)]
    print(f"one-time total coloring (empty cache): {cold['coloring']:.2f} s\n")
    print(f'mixed fidelity, cached coloring, {args.repeat} runs:\n')
    print(table([
        ('setup [s]', [r['setup'] for r in runs]),
        ('guess (half-car time marching) [s]', [r['guess'] for r in runs]),
        ('solve [s]', [r['solve'] for r in runs]),
        ('total [s]', [r['total'] for r in runs]),
        ('IPOPT iterations', [r['iterations'] for r in runs]),
        ('function evaluations', [r['fevals'] for r in runs]),
        ('gradient evaluations', [r['gevals'] for r in runs]),
        ('position analyses, batched over all nodes (whole solve)',
         [r['calls']['positions'] for r in runs]),
        ('augmented solves of eq. 11, batched (whole solve)',
         [r['calls']['augmented'] for r in runs]),
        ('module queries answered from its memory (whole solve)', [r['reused'] for r in runs]),
        ('time inside the multibody solver [s]', [r['mbd_s'] for r in runs]),
        ('share of the solve inside the multibody solver', [r['mbd_s'] / r['solve'] for r in runs]),
    ]))
    kin, dyn = runs[-1]['per_jacobian']
    print(f'\nblack-box calls per total Jacobian: {kin} kinematic + {dyn} dynamic component '
          f'evaluations (2 axles; forward FD: 2 resp. 4 perturbations each), independent of '
          f'the {args.segments * 5} nodes')
    lo = statistics.median(r['total'] for r in lows)
    mi = statistics.median(r['total'] for r in runs)
    print(f'\nlow fidelity on the same grid (from the initial design): total {lo:.2f} s, '
          f"{statistics.median(r['iterations'] for r in lows):.0f} iterations")
    print(f'mixed / low total (medians): {mi / lo:.2f}x; per iteration: '
          f"{(mi / statistics.median(r['iterations'] for r in runs)) / (lo / statistics.median(r['iterations'] for r in lows)):.2f}x")


if __name__ == '__main__':
    main()
