"""Timing helpers shared by the benchmark scripts: medians over repeats, Markdown tables."""

from __future__ import annotations

import datetime
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterable
from contextlib import contextmanager
from pathlib import Path
from typing import Any


def machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        with open('/proc/cpuinfo') as fh:
            names = [line.split(':', 1)[1].strip() for line in fh if line.startswith('model name')]
        if names:
            cpu = names[0]
    except OSError:
        pass
    return f'{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}'


@contextmanager
def fresh_cache():
    """A temporary, empty coloring cache (to measure the one-time coloring cost)."""
    old = os.environ.get('SUSPOPT_CACHE_DIR')
    with tempfile.TemporaryDirectory(prefix='suspopt-bench-cache-') as tmp:
        os.environ['SUSPOPT_CACHE_DIR'] = tmp
        try:
            yield tmp
        finally:
            if old is None:
                os.environ.pop('SUSPOPT_CACHE_DIR', None)
            else:
                os.environ['SUSPOPT_CACHE_DIR'] = old


def stats(values: Iterable[float]) -> str:
    v = list(values)
    if not v:
        return '—'
    if len(v) == 1:
        return f'{v[0]:.3g}'
    return f'{statistics.median(v):.3g} ({min(v):.3g}–{max(v):.3g})'


def table(rows: list[tuple[str, list[float]]], header=('quantity', 'median (min–max)')) -> str:
    out = [f'| {header[0]} | {header[1]} |', '|---|---|']
    out += [f'| {name} | {stats(vals)} |' for name, vals in rows]
    return '\n'.join(out)


def git_revision() -> str:
    try:
        return subprocess.run(
            ['git', 'rev-parse', '--short', 'HEAD'], capture_output=True, text=True, check=True
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return 'unknown'


def timed_optimize(
    cfg,
    fidelity: str,
    scales,
    start: dict[str, float],
    totals: str = 'auto',
    hessian: str = 'auto',
) -> dict[str, Any]:
    """One optimization as `suspopt optimize` does it, timed by phase: setup (building the
    Dymos/OpenMDAO problem), guess (the starting trajectory, `transcription.initial_guess`),
    coloring
    (zero when cached), solve (IPOPT, coloring excluded) and their total. ``totals``: the
    driver's total-derivative method (``'solves'``: one OpenMDAO linear solve per color);
    ``hessian``: the Hessian option of :class:`VehicleProblem`. ``solve_cpu`` is the
    process's CPU time of the solve (coloring excluded): less disturbed by other processes
    than the wall time."""
    from suspopt.studies.run import initial_guess
    from suspopt.transcription.problem import VehicleProblem

    t0 = time.perf_counter()
    vp = VehicleProblem(cfg, fidelity, scales, totals=totals, hessian=hessian)
    t1 = time.perf_counter()
    vp.set_design(start)
    vp.set_initial_guess(initial_guess(cfg, fidelity, start))
    t2 = time.perf_counter()
    mbd0 = sum(m.time_s for m in vp.modules.values())
    reused0 = sum(m.reused for m in vp.modules.values())
    c2 = time.process_time()
    res = vp.solve()
    t3 = time.perf_counter()
    c3 = time.process_time()
    out = {
        'setup': t1 - t0,
        'guess': t2 - t1,
        'coloring': res.times.coloring_s,
        'solve': t3 - t2 - res.times.coloring_s,
        'solve_cpu': c3 - c2 - res.times.coloring_cpu_s,
        'iterations': res.iterations,
        'fevals': res.function_evaluations,
        'gevals': res.gradient_evaluations,
        'calls': res.multibody_calls,
        'mbd_s': sum(m.time_s for m in vp.modules.values()) - mbd0,
        'reused': sum(m.reused for m in vp.modules.values()) - reused0,
        'design': res.design,
        'f': res.objective if res.success else res.objective_at_stop,
        'success': res.success,
        'problem': vp,
    }
    out['total'] = out['setup'] + out['guess'] + out['solve']
    return out


#: where every benchmark writes its measured figures (rendered into docs/performance.md by
#: benchmarks/render_performance.py)
RESULTS_DIR = Path(__file__).resolve().parent / 'results'


def versions() -> dict[str, str]:
    """Versions of suspopt and of the libraries whose speed the figures depend on."""
    from importlib import metadata

    out = {}
    for dist in ('suspopt', 'openmdao', 'dymos', 'cyipopt-wheels', 'numpy', 'scipy', 'casadi'):
        try:
            out[dist] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            pass
    return out


def write_result(name: str, title: str, markdown: str, data: Any = None) -> Path:
    """Write ``benchmarks/results/<name>.json``: the benchmark's section of the performance
    page (``markdown``: its tables and notes, rendered as measured) with the date, the
    machine, the versions and the command that produced it, and optional raw ``data``.
    Re-measuring is running the benchmark again; ``render_performance.py`` rebuilds the
    page from these files."""
    RESULTS_DIR.mkdir(exist_ok=True)
    record = {
        'benchmark': name,
        'title': title,
        'date': datetime.datetime.now().isoformat(timespec='seconds'),
        'machine': machine(),
        'versions': versions(),
        'command': 'python ' + ' '.join([os.path.relpath(sys.argv[0])] + sys.argv[1:]),
        'markdown': markdown,
        'data': data,
    }
    path = RESULTS_DIR / f'{name}.json'
    tmp = path.with_suffix('.json.tmp')
    tmp.write_text(json.dumps(record, indent=2, default=float) + '\n')
    os.replace(tmp, path)
    return path
