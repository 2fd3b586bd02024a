"""Benchmark: mixed-fidelity optimization from the low-fidelity optimum (issue 5).

    python benchmarks/bench_mixed.py [--repeat 3] [--segments 80] [--mount ground|chassis|both]
    python benchmarks/bench_mixed.py --mechanism macpherson [--repeat 5]

Prints the one-time coloring cost, then over repeats (cached coloring): setup, solve,
total, IPOPT iterations, black-box calls per Jacobian and in total, and the share of the
solve spent inside the multibody solver; plus the low-fidelity solve on the same grid for
the mixed/low ratio. ``--mount chassis`` benchmarks the chassis-mounted modules (issue
16); ``both`` runs the two mounts interleaved, repeat by repeat, from the same
low-fidelity optimum and prints the chassis/ground ratio of the medians.
``--mechanism NAME`` (built-in name or TOML path, on both axles) measures that topology
side by side with the double wishbone in the same run, interleaved the same way, and
prints the NAME/double-wishbone ratios of the medians (issue 12's target: the MacPherson
at most 1.5x the double wishbone).
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

from suspopt.multibody.components import (
    ChassisMountDynamicsComp,  # noqa: E402
    SuspensionDynamicsComp,
    SuspensionKinematicsComp,
)
from suspopt.spec.load import config_from_dict  # noqa: E402
from suspopt.spec.schema import StudyConfig  # noqa: E402
from suspopt.studies.run import optimize  # noqa: E402
from suspopt.verification.scales import resolve_scales  # noqa: E402


@contextmanager
def _count_compute(*comp_classes):
    """Count black-box queries (evaluate() calls) of component classes."""
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
        with _count_compute(
            SuspensionKinematicsComp, SuspensionDynamicsComp, ChassisMountDynamicsComp
        ) as counts:
            vp.problem.model.run_linearize()  # the partials of one total Jacobian
        out['per_jacobian'] = (
            counts[SuspensionKinematicsComp],
            counts[SuspensionDynamicsComp] + counts[ChassisMountDynamicsComp],
        )
    vp.cleanup()
    return out


def _report(label: str, runs: list[dict], cold: dict, segments: int) -> None:
    print(f'{label}: one-time total coloring (empty cache): {cold["coloring"]:.2f} s\n')
    print(f'{label}, cached coloring, {len(runs)} runs:\n')
    print(
        table(
            [
                ('setup [s]', [r['setup'] for r in runs]),
                ('guess (half-car time marching) [s]', [r['guess'] for r in runs]),
                ('solve [s]', [r['solve'] for r in runs]),
                ('total [s]', [r['total'] for r in runs]),
                ('IPOPT iterations', [r['iterations'] for r in runs]),
                ('function evaluations', [r['fevals'] for r in runs]),
                ('gradient evaluations', [r['gevals'] for r in runs]),
                (
                    'position analyses, batched over all nodes (whole solve)',
                    [r['calls']['positions'] for r in runs],
                ),
                (
                    'augmented solves of eq. 11, batched (whole solve)',
                    [r['calls']['augmented'] for r in runs],
                ),
                (
                    'module queries answered from its memory (whole solve)',
                    [r['reused'] for r in runs],
                ),
                ('time inside the multibody solver [s]', [r['mbd_s'] for r in runs]),
                (
                    'share of the solve inside the multibody solver',
                    [r['mbd_s'] / r['solve'] for r in runs],
                ),
                ('f at the optimum', [r['f'] for r in runs]),
            ]
        )
    )
    kin, dyn = runs[-1]['per_jacobian']
    print(
        f'\nblack-box calls per total Jacobian: {kin} kinematic + {dyn} dynamic component '
        f'evaluations (one per input variable with forward FD), independent of the '
        f'{segments * 5} nodes\n'
    )


def with_mechanism(cfg: StudyConfig, mechanism: str) -> StudyConfig:
    d = cfg.to_dict()
    for axle in ('front', 'rear'):
        d['vehicle'][axle]['mechanism'] = mechanism
    return config_from_dict(d)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--repeat', type=int, default=3)
    ap.add_argument('--segments', type=int, default=StudyConfig().transcription.segments)
    ap.add_argument('--mount', choices=('ground', 'chassis', 'both'), default='ground')
    ap.add_argument(
        '--mechanism',
        metavar='NAME',
        help='measure this mechanism (both axles) side by side with the double wishbone',
    )
    args = ap.parse_args()
    cfg = StudyConfig()
    cfg = cfg.replace(transcription=dataclasses.replace(cfg.transcription, segments=args.segments))
    mounts = ('ground', 'chassis') if args.mount == 'both' else (args.mount,)
    mechs = ['double_wishbone'] + (
        [args.mechanism] if args.mechanism and args.mechanism != 'double_wishbone' else []
    )
    cfgs = {
        (mech, m): with_mechanism(cfg, mech).replace(
            multibody=dataclasses.replace(cfg.multibody, mount=m)
        )
        for mech in mechs
        for m in mounts
    }
    label = {key: (f'{key[0]}, ' if len(mechs) > 1 else '') + f'mount {key[1]}' for key in cfgs}
    scales = resolve_scales(cfg)
    print(
        f'# mixed-fidelity optimize from the low-fidelity optimum, {args.segments} x 5 grid, '
        f'mount {args.mount}, {", ".join(mechs)} — {machine()}, suspopt {git_revision()}\n'
    )
    with fresh_cache():
        low = optimize(cfg, 'low', scales=scales)
        start = low.design
        cold = {k: run_once(c, scales, start) for k, c in cfgs.items()}
        runs = {k: [] for k in cfgs}
        lows = []
        for _ in range(args.repeat):  # interleaved: the machine's load hits all alike
            for k, c in cfgs.items():
                runs[k].append(run_once(c, scales, start))
            lows.append(run_once(cfg, scales, cfg.design.initial(), 'low'))
    for k in cfgs:
        _report(label[k], runs[k], cold[k], args.segments)
    lo = statistics.median(r['total'] for r in lows)
    print(
        f'low fidelity on the same grid (from the initial design): total {lo:.2f} s, '
        f'{statistics.median(r["iterations"] for r in lows):.0f} iterations'
    )
    for k in cfgs:
        mi = statistics.median(r['total'] for r in runs[k])
        it = statistics.median(r['iterations'] for r in runs[k])
        print(
            f'{label[k]}: mixed / low total (medians): {mi / lo:.2f}x; per iteration: '
            f'{(mi / it) / (lo / statistics.median(r["iterations"] for r in lows)):.2f}x'
        )
    med = {
        k: {
            q: statistics.median(r[q] for r in runs[k])
            for q in ('solve', 'total', 'iterations', 'mbd_s')
        }
        for k in cfgs
    }

    def ratio(a, b, what: str) -> None:
        r = {q: med[b][q] / med[a][q] for q in ('solve', 'total', 'mbd_s')}
        per_it = r['solve'] * med[a]['iterations'] / med[b]['iterations']
        print(
            f'\n{what} (medians, measured side by side): solve {r["solve"]:.2f}x, total '
            f'{r["total"]:.2f}x, solve per IPOPT iteration {per_it:.2f}x (iterations '
            f'{med[b]["iterations"]:.0f} vs {med[a]["iterations"]:.0f}), time inside the '
            f'multibody solver {r["mbd_s"]:.2f}x'
        )

    for mech in mechs:
        if len(mounts) == 2:
            ratio((mech, 'ground'), (mech, 'chassis'), f'{mech}: chassis / ground mount')
    for m in mounts:
        if len(mechs) == 2:
            ratio(('double_wishbone', m), (mechs[1], m), f'mount {m}: {mechs[1]} / double_wishbone')


if __name__ == '__main__':
    main()
