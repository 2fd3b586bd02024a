"""Benchmark: a 16-task sweep on 2 local Dask workers against the same 16 tasks run
serially in one process, measured side by side in one run.

    python benchmarks/bench_sweep.py [--tasks 16] [--workers 2] [--segments 80]
                                     [--starts fork,spawn]

The tasks: a multistart of low-fidelity optimizations of the paper's case
(default car and road, `reference` normalization, 80 x 5 grid), Latin-hypercube
starts over the design box. Serial: `run_task` on each task's plain description in this
process, one after the other (the same function a worker runs, writing the same result
and recorder files). Sweep: `run_sweep` on a LocalCluster, end to end (cluster start and
shutdown included). Bare processes: the same tasks on as many forked processes of this
one (a ``multiprocessing`` pool, one task at a time each, no Dask): what this machine's
cores give without any engine, the ceiling of the sweep's ratio. Engine overhead per
task: (a) the sweep's worker-seconds not spent in tasks, per task (b) the same sweep of
no-op tasks through the engine, its run time per task; each against one optimization
(the serial median).
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import machine  # noqa: E402

from suspopt.sweep import load_sweep, noop_task, run_sweep, run_task  # noqa: E402
from suspopt.sweep.store import read_records  # noqa: E402


def _sweep_file(root: Path, n: int, segments: int) -> Path:
    (root / 'study.toml').write_text(f'[transcription]\nsegments = {segments}\n')
    path = root / 'sweep.toml'
    path.write_text(
        f'study = "study.toml"\nfidelity = "low"\n[multistart]\nn = {n}\nseed = 0\nmethod = "lhs"\n'
    )
    return path


def _one_thread() -> None:
    """A bare process's BLAS/OpenMP pools at one thread, as a sweep worker's."""
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)


def _records(out: Path) -> list:
    return list(read_records(out).values())


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--tasks', type=int, default=16)
    ap.add_argument('--workers', type=int, default=2)
    ap.add_argument('--segments', type=int, default=80)
    ap.add_argument(
        '--starts',
        default='fork,spawn',
        help='how the local workers start, comma-separated (first: the default)',
    )
    args = ap.parse_args()
    starts = args.starts.split(',')
    quiet = lambda msg: None  # noqa: E731
    with tempfile.TemporaryDirectory(prefix='suspopt-bench-sweep-') as tmp:
        root = Path(tmp)
        path = _sweep_file(root, args.tasks, args.segments)
        sweep = load_sweep(path)
        print(f'{machine()}; load average {os.getloadavg()[0]:.2f} at start')
        print(
            f'{len(sweep.tasks)} low-fidelity optimizations, {args.segments} x 5 grid, '
            f"multistart (LHS) of the paper's case"
        )
        # warm-up: this process's imports and the coloring (cache) for both sides
        run_task(sweep.tasks[0].payload(root / 'warm', None))

        t = time.perf_counter()
        serial = [run_task(task.payload(root / 'serial', None)) for task in sweep.tasks]
        serial_wall = time.perf_counter() - t
        assert all(r.state == 'done' for r in serial), [r.error for r in serial]
        serial_times = [r.wall_time_s for r in serial]

        payloads = [task.payload(root / 'bare', None) for task in sweep.tasks]
        t = time.perf_counter()
        with mp.get_context('fork').Pool(args.workers, initializer=_one_thread) as pool:
            bare = list(pool.imap_unordered(run_task, payloads, chunksize=1))
        bare_wall = time.perf_counter() - t
        assert all(r.state == 'done' for r in bare), [r.error for r in bare]

        sweeps = {}
        for start in starts:
            t = time.perf_counter()
            par = run_sweep(
                path, root / f'sweep-{start}', workers=args.workers, log=quiet, worker_start=start
            )
            sweeps[start] = (par, time.perf_counter() - t, _records(root / f'sweep-{start}'))
            assert par.exit_code == 0, par.counts

        t = time.perf_counter()
        noop = run_sweep(
            path,
            root / 'noop',
            workers=args.workers,
            log=quiet,
            task_fn=noop_task,
            worker_start=starts[0],
        )
        noop_wall = time.perf_counter() - t

    one = statistics.median(serial_times)
    print(
        f'\nserial, one process: {serial_wall:.2f} s ({len(serial)} tasks; median task '
        f'{one:.3f} s, min {min(serial_times):.3f}, max {max(serial_times):.3f}); CPU '
        f'time per task: median {statistics.median(r.cpu_time_s for r in serial):.3f} s'
    )
    print(
        f'bare processes, {args.workers} forked (no engine): {bare_wall:.2f} s; task '
        f'times median {statistics.median(r.wall_time_s for r in bare):.3f} s; '
        f'throughput ratio {serial_wall / bare_wall:.2f}x (the ceiling on this machine)'
    )
    for start, (par, par_wall, par_recs) in sweeps.items():
        par_times = [r.wall_time_s for r in par_recs]
        run_s = par.timings['run_s']
        idle = (run_s * args.workers - sum(par_times)) / len(par_times)
        rest = par_wall - run_s - par.timings['cluster_start_s'] - par.timings['shutdown_s']
        print(
            f'sweep, {args.workers} local workers ({start}ed): {par_wall:.2f} s end to end '
            f'= cluster start {par.timings["cluster_start_s"]:.2f} s + tasks {run_s:.2f} s '
            f'+ shutdown {par.timings["shutdown_s"]:.2f} s + validation, records, figures '
            f'{rest:.2f} s'
        )
        print(
            f'  task times in the workers: median {statistics.median(par_times):.3f} s, '
            f'sum {sum(par_times):.2f} s (serial sum {sum(serial_times):.2f} s); CPU time '
            f'per task: median {statistics.median(r.cpu_time_s for r in par_recs):.3f} s'
        )
        print(
            f'  throughput ratio: {serial_wall / par_wall:.2f}x end to end, '
            f'{serial_wall / run_s:.2f}x while the tasks run (target >= 1.8x); '
            f"{bare_wall / par_wall:.2f} of the bare processes' throughput"
        )
        print(
            f'  idle worker time per task {idle * 1e3:.1f} ms = {100 * idle / one:.1f} % '
            'of one optimization'
        )
    noop_per_task = noop.timings['run_s'] / len(sweep.tasks)
    print(
        f'engine overhead per task, no-op tasks ({starts[0]}ed workers): '
        f'{noop_per_task * 1e3:.1f} ms per task ({noop_wall:.2f} s for '
        f'{len(sweep.tasks)} incl. cluster) = {100 * noop_per_task / one:.2f} % '
        '(target < 5 %)'
    )
    print(f'load average {os.getloadavg()[0]:.2f} at the end')
    return 0


if __name__ == '__main__':
    sys.exit(main())
