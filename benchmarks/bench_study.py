"""Benchmark: the whole two-step study, everything included (issue 5).

    python benchmarks/bench_study.py [--repeat 3] [--no-verify]

Runs `run_study` on the default car into temporary directories: once with an empty
coloring cache (first run on a machine) and `--repeat` times with the cache, and prints
wall times and the steps' breakdown from study.json.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import fresh_cache, git_revision, machine, table  # noqa: E402

from suspopt.spec.schema import StudyConfig  # noqa: E402
from suspopt.studies.twostep import run_study  # noqa: E402


def once(verify: bool) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        study = run_study(StudyConfig(), Path(tmp) / 'study', verify=verify)
        wall = time.perf_counter() - t
    s = study.steps
    return {
        'wall': wall,
        'low_solve': s['low'].times.solve_s,
        'mixed_solve': s['mixed'].times.solve_s,
        'coloring': sum(p.coloring_s for p in study.problems.values()),
        'setup': sum(p.setup_s for p in study.problems.values()),
        'tm': sum(
            e.verification.comparison.time_s
            for e in study.evaluations.values()
            if e.verification.comparison is not None
        ),
        'f_low': s['low'].objective,
        'f_mixed': s['mixed'].objective,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--repeat', type=int, default=3)
    ap.add_argument('--no-verify', action='store_true')
    args = ap.parse_args()
    print(f'# two-step study, default car — {machine()}, suspopt {git_revision()}\n')
    with fresh_cache():
        cold = once(not args.no_verify)
        warm = [once(not args.no_verify) for _ in range(args.repeat)]
    print(
        f'first run (empty coloring cache): {cold["wall"]:.1f} s, of which total coloring '
        f'{cold["coloring"]:.1f} s\n'
    )
    print(f'with the coloring cache, {args.repeat} runs:\n')
    print(
        table(
            [
                ('whole study [s]', [w['wall'] for w in warm]),
                ('problem setup, both models [s]', [w['setup'] for w in warm]),
                ('low-fidelity optimization solve [s]', [w['low_solve'] for w in warm]),
                ('mixed-fidelity optimization solve [s]', [w['mixed_solve'] for w in warm]),
                ('time-marching verification, 6 runs [s]', [w['tm'] for w in warm]),
            ]
        )
    )
    print(
        f'\nf: low-fidelity optimum {warm[-1]["f_low"]:.6f}, mixed-fidelity optimum '
        f'{warm[-1]["f_mixed"]:.6f}'
    )


if __name__ == '__main__':
    main()
