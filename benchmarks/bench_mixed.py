"""Benchmark: mixed-fidelity optimization from the low-fidelity optimum (issue 5).

    python benchmarks/bench_mixed.py [--repeat 3] [--segments 80]
    python benchmarks/bench_mixed.py --mechanism macpherson [--repeat 5]

Prints the one-time coloring cost, then over repeats (cached coloring): setup, solve,
total, IPOPT iterations, black-box calls per Jacobian and in total, and the share of the
solve spent inside the multibody solver; plus the low-fidelity solve on the same grid for
the mixed/low ratio.

``--mechanism NAME`` (built-in name or TOML path, on both axles) measures that topology
side by side with the double wishbone in the same run, the repeats interleaved (DW,
NAME, DW, NAME, ...) so that a change of machine load hits both alike, and prints both
tables and the ratios of their medians (issue 12's target: MacPherson at most 1.5x the
double wishbone).
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

from suspopt.config import StudyConfig, config_from_dict  # noqa: E402
from suspopt.multibody.components import SuspensionDynamicsComp, SuspensionKinematicsComp  # noqa: E402
from suspopt.study import optimize, resolve_scales  # noqa: E402


@contextmanager
def _count_compute(*comp_classes):
    """Count the black-box calls (``evaluate``: one batched query of every node) of
    component classes, whether from compute() or from the FD of compute_partials()."""
    counts = {cls: 0 for cls in comp_classes}
    originals = {cls: cls.evaluate for cls in comp_classes}

    def counting(cls):
        def evaluate(self, values):
            counts[cls] += 1
            return originals[cls](self, values)
        return evaluate

    for cls in comp_classes:
        cls.evaluate = counting(cls)
    try:
        yield counts
    finally:
        for cls, orig in originals.items():
            cls.evaluate = orig


def run_once(cfg, scales, start, fidelity='mixed') -> dict:
    out = timed_optimize(cfg, fidelity, scales, start)
    vp = out.pop('problem')
    if fidelity == 'mixed':
        # black-box calls per Jacobian: one colored total-derivative evaluation
        totals = vp.driver._totals  # the driver's colored total Jacobian (after the solve)
        totals.compute()
        with _count_compute(SuspensionKinematicsComp, SuspensionDynamicsComp) as counts:
            totals.compute()
        out['per_jacobian'] = (counts[SuspensionKinematicsComp], counts[SuspensionDynamicsComp])
    vp.cleanup()
    return out


def with_mechanism(cfg: StudyConfig, mechanism: str) -> StudyConfig:
    d = cfg.to_dict()
    for axle in ('front', 'rear'):
        d['vehicle'][axle]['mechanism'] = mechanism
    return config_from_dict(d)


def mixed_table(runs: list[dict]) -> str:
    return table([
        ('setup [s]', [r['setup'] for r in runs]),
        ('guess (half-car time marching) [s]', [r['guess'] for r in runs]),
        ('solve [s]', [r['solve'] for r in runs]),
        ('total [s]', [r['total'] for r in runs]),
        ('IPOPT iterations', [r['iterations'] for r in runs]),
        ('function evaluations', [r['fevals'] for r in runs]),
        ('gradient evaluations', [r['gevals'] for r in runs]),
        ('solve per IPOPT iteration [s]', [r['solve'] / max(r['iterations'], 1) for r in runs]),
        ('position analyses, batched over all nodes (whole solve)',
         [r['calls']['positions'] for r in runs]),
        ('augmented solves of eq. 11, batched (whole solve)',
         [r['calls']['augmented'] for r in runs]),
        ('module queries answered from its memory (whole solve)', [r['reused'] for r in runs]),
        ('time inside the multibody solver [s]', [r['mbd_s'] for r in runs]),
        ('share of the solve inside the multibody solver', [r['mbd_s'] / r['solve'] for r in runs]),
    ])


def med(runs: list[dict], key: str) -> float:
    return statistics.median(r[key] for r in runs)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--repeat', type=int, default=3)
    ap.add_argument('--segments', type=int, default=StudyConfig().transcription.segments)
    ap.add_argument('--mechanism', metavar='NAME',
                    help='measure this mechanism (both axles) side by side with the double '
                         'wishbone')
    args = ap.parse_args()
    cfg = StudyConfig()
    cfg = cfg.replace(transcription=dataclasses.replace(cfg.transcription,
                                                        segments=args.segments))
    scales = resolve_scales(cfg)
    names = ['double_wishbone'] + ([args.mechanism] if args.mechanism
                                   and args.mechanism != 'double_wishbone' else [])
    cfgs = {n: with_mechanism(cfg, n) for n in names}
    print(f'# mixed-fidelity optimize from the low-fidelity optimum, {args.segments} x 5 grid '
          f"— {', '.join(names)} — {machine()}, suspopt {git_revision()}\n")
    with fresh_cache():
        low = optimize(cfg, 'low', scales=scales, verify=False)
        start = low['design']
        cold = {n: run_once(c, scales, start) for n, c in cfgs.items()}
        runs: dict[str, list[dict]] = {n: [] for n in names}
        for _ in range(args.repeat):  # interleaved: the same load for every mechanism
            for n, c in cfgs.items():
                runs[n].append(run_once(c, scales, start))
        lows = [run_once(cfg, scales, cfg.design.initial(), 'low')
                for _ in range(args.repeat)]
    for n in names:
        r0 = runs[n][-1]
        print(f'## {n}\n')
        print(f"one-time total coloring (empty cache): {cold[n]['coloring']:.2f} s\n")
        print(f'mixed fidelity, cached coloring, {args.repeat} runs:\n')
        print(mixed_table(runs[n]))
        kin, dyn = r0['per_jacobian']
        print(f'\nblack-box calls per total Jacobian: {kin} kinematic + {dyn} dynamic component '
              'evaluations (one component of each kind for both corners; forward FD: one '
              'perturbation per input — z_W, v_W; z_W, v_W, z_M, v_M, F_T, k_S, c_S — the base '
              f'point reused from compute), independent of the {args.segments * 5} nodes')
        print('optimum: ' + ', '.join(f'{k} = {v:.2f}' for k, v in r0['design'].items())
              + f", f = {r0['f']:.7f} ({'converged' if r0['success'] else 'NOT converged'})\n")
    lo = statistics.median(r['total'] for r in lows)
    lo_it = statistics.median(r['iterations'] for r in lows)
    print(f'low fidelity on the same grid (from the initial design): total {lo:.2f} s, '
          f'{lo_it:.0f} iterations')
    for n in names:
        mi = med(runs[n], 'total')
        print(f"{n}: mixed / low total (medians): {mi / lo:.2f}x; per iteration: "
              f"{(mi / med(runs[n], 'iterations')) / (lo / lo_it):.2f}x")
    if len(names) > 1:
        a, b = runs[names[0]], runs[names[1]]
        per_it = (med(b, 'solve') / med(b, 'iterations')) / \
            (med(a, 'solve') / med(a, 'iterations'))
        print(f'\n{names[1]} / {names[0]} (medians, measured side by side): total '
              f"{med(b, 'total') / med(a, 'total'):.2f}x, solve "
              f"{med(b, 'solve') / med(a, 'solve'):.2f}x, IPOPT iterations "
              f"{med(b, 'iterations'):.0f} / {med(a, 'iterations'):.0f}, solve per iteration "
              f"{per_it:.2f}x, "
              f"time inside the multibody solver {med(b, 'mbd_s') / med(a, 'mbd_s'):.2f}x")


if __name__ == '__main__':
    main()
