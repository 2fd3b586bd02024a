"""Profile one optimization (cProfile): where the time of a solve goes.

    python benchmarks/profile_solve.py [--fidelity low|mixed] [--segments 80] [--top 25]
                                       [--sort tottime|cumulative] [--car half|full]
                                       [--hessian limited-memory|exact|auto] [--cpu]

Builds the problem and solves it once unprofiled (so that the total coloring is cached
and imports are warm), then profiles a second build + solve from the same start (low:
the initial design; mixed: the low-fidelity optimum) and prints the top functions, the
IPOPT iterations and the multibody solver calls. ``--car full``: the default full car
(``--segments`` default: its automatic grid); ``--hessian``: VehicleProblem's; ``--cpu``:
the profiler's clock is the process's CPU time (on a loaded machine the wall clock
counts the time other processes take).
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import git_revision, machine, timed_optimize  # noqa: E402

from suspopt.spec.load import config_from_dict, full_car_defaults  # noqa: E402
from suspopt.spec.resolve import auto_segments  # noqa: E402
from suspopt.spec.schema import StudyConfig  # noqa: E402
from suspopt.studies.run import optimize  # noqa: E402
from suspopt.verification.scales import resolve_scales  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--fidelity', choices=('low', 'mixed'), default='low')
    ap.add_argument('--segments', type=int, default=None, help="default: the study's")
    ap.add_argument('--car', choices=('half', 'full'), default='half')
    ap.add_argument('--cpu', action='store_true', help='profile CPU time, not wall time')
    ap.add_argument('--hessian', choices=('limited-memory', 'exact', 'auto'), default='auto')
    ap.add_argument('--top', type=int, default=25)
    ap.add_argument('--sort', choices=('tottime', 'cumulative'), default='tottime')
    args = ap.parse_args()
    cfg = StudyConfig() if args.car == 'half' else full_car_defaults()
    if args.segments is None:
        args.segments = auto_segments(cfg, cfg.scenarios()[0], cfg.transcription.order)
    cfg = config_from_dict({**cfg.to_dict(), 'transcription': {'segments': args.segments}})
    scales = resolve_scales(cfg)
    start = cfg.design.initial()
    if args.fidelity == 'mixed':
        start = optimize(cfg, 'low', scales=scales).design
    h = args.hessian
    timed_optimize(cfg, args.fidelity, scales, start, hessian=h)['problem'].cleanup()  # warm-up
    prof = cProfile.Profile(time.process_time) if args.cpu else cProfile.Profile()
    prof.enable()
    out = timed_optimize(cfg, args.fidelity, scales, start, hessian=h)
    prof.disable()
    out.pop('problem').cleanup()
    print(
        f'# {args.car} car, {args.fidelity}-fidelity optimize, {args.segments} x 5, '
        f'hessian {h} — {machine()}, '
        f'suspopt {git_revision()}'
    )
    print(
        f'setup {out["setup"]:.3f} s, guess {out["guess"]:.3f} s, solve {out["solve"]:.3f} s '
        f'(CPU {out["solve_cpu"]:.3f} s) '
        f'(under the profiler), {out["iterations"]} IPOPT iterations, multibody calls '
        f'{out["calls"] or "—"}\n'
    )
    pstats.Stats(prof).sort_stats(args.sort).print_stats(args.top)


if __name__ == '__main__':
    main()
