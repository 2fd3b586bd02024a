"""Benchmark: the full car against the half car (issue 13).

    python benchmarks/bench_full_car.py [--repeat 2] [--segments auto] [--no-study]

On the default full car's road (ISO 8608 class C, 20 m/s, 5 s; the half car on the same
profile and grid), side by side in one process, ``--repeat`` rounds with the coloring
cache after a cold round that fills it:

* half-car and full-car low-fidelity optimization from the initial design;
* full-car mixed-fidelity optimization from the full car's low-fidelity optimum;

each timed by phase (setup, starting trajectory, IPOPT solve; coloring separately) with
IPOPT iterations; medians and the ratios full low / half low and full mixed / full low.
Then the default full car's whole two-step study, first run (empty coloring cache, with
the reference scales and every time-marching verification), as ``suspopt study --config
FILE`` runs it.
"""

from __future__ import annotations

import argparse
import resource
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import fresh_cache, git_revision, machine, timed_optimize  # noqa: E402

from suspopt.spec.load import config_from_dict, full_car_defaults  # noqa: E402
from suspopt.spec.resolve import auto_segments  # noqa: E402
from suspopt.spec.schema import StudyConfig  # noqa: E402
from suspopt.studies.twostep import run_study  # noqa: E402
from suspopt.verification.scales import resolve_scales  # noqa: E402


def run(cfg, fidelity, scales, start):
    out = timed_optimize(cfg, fidelity, scales, start)
    out.pop('problem').cleanup()
    if not out['success']:
        raise SystemExit(f'bench_full_car: {cfg.vehicle.model} {fidelity}: IPOPT did not converge')
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--repeat', type=int, default=2)
    ap.add_argument(
        '--segments',
        default='auto',
        help="segments of both cars ('auto': the full car's automatic grid)",
    )
    ap.add_argument('--no-study', action='store_true')
    args = ap.parse_args()
    full = full_car_defaults()
    segments = (
        auto_segments(full, full.scenarios()[0], full.transcription.order)
        if args.segments == 'auto'
        else int(args.segments)
    )
    full = config_from_dict({**full.to_dict(), 'transcription': {'segments': segments}})
    half = config_from_dict(
        {
            **StudyConfig().to_dict(),
            'road': dict(full.road),
            'maneuver': full.maneuver.__dict__,
            'transcription': {'segments': segments},
        }
    )
    print(
        f'# full car against half car, {full.road["profile"]} class {full.road["road_class"]}'
        f' at {full.maneuver.speed:g} m/s, {full.maneuver.horizon:g} s, {segments} segments'
        f' — {machine()}, suspopt {git_revision()}\n',
        flush=True,
    )
    s_half, s_full = resolve_scales(half), resolve_scales(full)
    rounds = []
    with fresh_cache():
        for r in range(args.repeat + 1):
            hl = run(half, 'low', s_half, half.design.initial())
            fl = run(full, 'low', s_full, full.design.initial())
            fm = run(full, 'mixed', s_full, fl['design'])
            rounds.append((hl, fl, fm))
            print(
                f'round {r}{" (cold)" if r == 0 else ""}: half low {hl["total"]:.1f} s, '
                f'full low {fl["total"]:.1f} s, full mixed {fm["total"]:.1f} s '
                f'(coloring {hl["coloring"]:.1f} / {fl["coloring"]:.1f} / '
                f'{fm["coloring"]:.1f} s)',
                flush=True,
            )
    warm = rounds[1:] or rounds
    med = statistics.median
    print(
        '\n| optimization (cached coloring) | setup [s] | guess [s] | solve [s] | total [s] '
        '| IPOPT iterations |\n|---|---|---|---|---|---|'
    )
    for i, label in enumerate(
        (
            'half car, low fidelity',
            'full car, low fidelity',
            'full car, mixed fidelity (from the low optimum)',
        )
    ):
        xs = [w[i] for w in warm]
        print(
            f'| {label} | '
            + ' | '.join(
                f'{med(x[k] for x in xs):.2f}' for k in ('setup', 'guess', 'solve', 'total')
            )
            + f' | {xs[-1]["iterations"]} |'
        )
    r1 = [w[1]['total'] / w[0]['total'] for w in warm]
    r2 = [w[2]['total'] / w[1]['total'] for w in warm]
    print(
        f'\nfull low / half low: {med(r1):.2f} (per round {", ".join(f"{x:.2f}" for x in r1)})'
        f'\nfull mixed / full low: {med(r2):.2f} (per round '
        f'{", ".join(f"{x:.2f}" for x in r2)})',
        flush=True,
    )
    if not args.no_study:
        with fresh_cache(), tempfile.TemporaryDirectory() as tmp:
            t = time.perf_counter()
            study = run_study(full_car_defaults(), Path(tmp) / 'study')
            wall = time.perf_counter() - t
        s = study.steps
        print(
            f'\ndefault full car, two-step study, first run (empty cache, verified '
            f'{all(e.verified for e in study.evaluations.values())}): '
            f'{wall:.1f} s; f low {s["low"].objective:.4f}, mixed '
            f'{s["mixed"].objective:.4f}'
        )
    print(
        f'peak RSS of this process: '
        f'{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2:.2f} GB'
    )


if __name__ == '__main__':
    main()
