"""Benchmark: how much parallel throughput this machine's cores give (no suspopt code).

    python benchmarks/bench_cores.py [--task spin|optimize] [--processes 2] [--repeat 3]

Runs one task alone, then ``--processes`` copies at once (plain child processes, one BLAS
thread each, no Dask), and prints the throughput ratio (tasks per second in parallel over
tasks per second alone). ``spin``: a small CPU-bound task (NumPy matrix products and a
pure-Python loop, in cache); ``optimize``: the low-fidelity optimization of the paper's
case that ``benchmarks/bench_sweep.py`` runs (after a warm-up that fills the coloring
cache). A sweep on Dask can reach at most about the ``optimize`` ratio over a serial run.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import machine  # noqa: E402

TASKS = {
    'spin': r"""
import numpy as np
a = np.random.default_rng(0).random((200, 200))
for _ in range(1500):
    a = a @ a
    a /= np.abs(a).max()
x = 0
for i in range(3_000_000):
    x += i
""",
    'optimize': r"""
from suspopt.spec import StudyConfig
from suspopt.studies.run import optimize
optimize(StudyConfig(), 'low', verify=False)
""",
}


def _run(task: str, n: int) -> float:
    """Wall time of ``n`` copies of the task started together (child processes)."""
    env = dict(os.environ, OMP_NUM_THREADS='1', OPENBLAS_NUM_THREADS='1', MKL_NUM_THREADS='1')
    t0 = time.perf_counter()
    procs = [
        subprocess.Popen(
            [sys.executable, '-c', TASKS[task]],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        for _ in range(n)
    ]
    for p in procs:
        if p.wait() != 0:
            raise SystemExit('bench_cores: the task failed')
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--task', choices=sorted(TASKS), default='spin')
    ap.add_argument('--processes', type=int, default=2)
    ap.add_argument('--repeat', type=int, default=3)
    a = ap.parse_args()
    print(
        f'# parallel throughput of this machine, task {a.task!r} — {machine()}; '
        f'{os.cpu_count()} CPUs'
    )
    if a.task == 'optimize':
        _run(a.task, 1)  # warm-up: the coloring cache
    alone, together = [], []
    for _ in range(a.repeat):  # interleaved
        alone.append(_run(a.task, 1))
        together.append(_run(a.task, a.processes))
    t1, tn = statistics.median(alone), statistics.median(together)
    print(f'one task alone: {t1:.2f} s (median of {a.repeat}; {min(alone):.2f}–{max(alone):.2f})')
    print(f'{a.processes} tasks at once: {tn:.2f} s ({min(together):.2f}–{max(together):.2f})')
    print(f'throughput ratio: {a.processes * t1 / tn:.2f}x (ideal {a.processes}x)')


if __name__ == '__main__':
    main()
