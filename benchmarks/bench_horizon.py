"""Benchmark: cost against the horizon: long ISO 8608 roads, both fidelities.

    python benchmarks/bench_horizon.py [--horizons 5 10 20 40 80] [--fidelity low mixed]
                                       [--density 16] [--speed 20] [--road-class C]
                                       [--source LABEL=PATH ...]

For each horizon T: an ISO 8608 road of the class at the speed, ``density × T`` uniform
segments of order 5 (16 per second is the density of the default 80 × 5 grid on the
paper's 5 s road), one optimization from the initial design in a fresh child process,
first with an empty cache (colorings and reference scales), then again with the cache it
filled. Each child reports its phases (reference scales, problem setup, sparsity and
coloring, starting trajectory, IPOPT solve, the time-marching verification of the optimum
as a study runs it: every scenario, its trajectory kept), IPOPT iterations and its peak
resident memory (``resource.getrusage``). The checks' share is (scales + verification) /
(setup + coloring + starting trajectory + solve).

``--source LABEL=PATH`` (repeatable) runs the children on the suspopt package found in
PATH (e.g. an export of another commit), side by side with the same script; by default
this checkout.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import git_revision, machine, write_result  # noqa: E402

CHILD = r"""
import json, resource, sys, time
from suspopt.spec import config_from_dict
from suspopt.studies.run import initial_guess
from suspopt.verification.scales import resolve_scales
from suspopt.transcription.problem import VehicleProblem
from suspopt.verification.verify import march
args = json.loads(sys.argv[1])
T = args['horizon']
cfg = config_from_dict({
    'maneuver': {'speed': args['speed'], 'horizon': T},
    'road': {'profile': 'iso8608', 'road_class': args['road_class'], 'seed': 1},
    'transcription': {'segments': int(round(args['density'] * T))},
})
fid = args['fidelity']
out = {}
clock = time.perf_counter
t0 = clock()
scales = resolve_scales(cfg)
out['scales_s'] = clock() - t0
t0 = clock()
vp = VehicleProblem(cfg, fid, scales)
out['setup_s'] = clock() - t0
start = cfg.design.initial()
vp.set_design(start)
t0 = clock()
vp.set_initial_guess(initial_guess(cfg, fid, start))
out['guess_s'] = clock() - t0
res = vp.solve()
out['coloring_s'] = res.times.coloring_s
out['solve_s'] = res.times.solve_s
out['iterations'] = res.iterations
out['success'] = res.success
out['f'] = res.objective
lay = vp.driver.layout()
out['nlp'] = [lay.n, lay.m, vp.driver.coloring.nnz if vp.driver.coloring else 0,
              vp.driver.coloring.n_colors if vp.driver.coloring else 0]
t0 = clock()
marched = march(cfg, fid, res.design, scales, keep=True)
out['verify_s'] = clock() - t0
tr = marched[0].trajectory
out['integrator'] = tr.info.get('integrator', 'DOP853')
J = res.scenarios[0].reached[1]
out['verify_rel_diff'] = max(abs(J[t] / b - 1.0) for t, b in marched[0].terms.items())
vp.cleanup()
out['peak_rss_mb'] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
import suspopt
out['suspopt'] = suspopt.__file__
print('RESULT ' + json.dumps(out))
"""


def run_child(args: dict, cache: str, source: str | None) -> dict:
    env = dict(
        os.environ,
        SUSPOPT_CACHE_DIR=cache,
        OMP_NUM_THREADS='1',
        OPENBLAS_NUM_THREADS='1',
        PYTHONWARNINGS='ignore',
    )
    if source:
        env['PYTHONPATH'] = os.pathsep.join(filter(None, [source, env.get('PYTHONPATH')]))
    t0 = time.perf_counter()
    proc = subprocess.run(  # not in a checkout: `import suspopt` finds the one asked for
        [sys.executable, '-c', CHILD, json.dumps(args)],
        env=env,
        capture_output=True,
        text=True,
        cwd=cache,
    )
    wall = time.perf_counter() - t0
    line = [ln for ln in proc.stdout.splitlines() if ln.startswith('RESULT ')]
    if proc.returncode != 0 or not line:
        tail = (proc.stderr or proc.stdout).strip().splitlines()[-3:]
        return {'error': ' | '.join(tail), 'wall_s': wall}
    res = json.loads(line[0][len('RESULT ') :])
    res['wall_s'] = wall
    return res


def short(integrator: str) -> str:
    """The integrator's name without its details."""
    for name in ('exact', 'waveform relaxation', 'DOP853'):
        if integrator.startswith(name):
            return name
    return integrator


def row(fid: str, T: float, density: float, label: str, run: str, r: dict) -> str:
    if 'error' in r:
        return f'| {fid} | {T:g} | {label} | {run} | {r["wall_s"]:.1f} | failed: {r["error"]} |'
    optimize = r['setup_s'] + r['coloring_s'] + r['guess_s'] + r['solve_s']
    checks = r['scales_s'] + r['verify_s']
    n, m, nnz, colors = r['nlp']
    return (
        f'| {fid} | {T:g} | {label} | {run} | {r["wall_s"]:.1f} | {r["scales_s"]:.2f} | '
        f'{r["setup_s"]:.2f} | {r["coloring_s"]:.2f} | {r["guess_s"]:.2f} | '
        f'{r["solve_s"]:.2f} | {r["iterations"]}{"" if r["success"] else " (not converged)"} '
        f'| {r["verify_s"]:.2f} ({short(r["integrator"])}, {r["verify_rel_diff"]:.1e}) | '
        f'**{checks / optimize:.0%}** | {n} × {m} ({nnz}, {colors}) | '
        f'{r["peak_rss_mb"]:.0f} |'
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--horizons', type=float, nargs='+', default=[5, 10, 20, 40, 80])
    ap.add_argument('--fidelity', nargs='+', default=['low', 'mixed'], choices=('low', 'mixed'))
    ap.add_argument('--density', type=float, default=16.0, help='segments per second')
    ap.add_argument('--speed', type=float, default=20.0)
    ap.add_argument('--road-class', default='C')
    ap.add_argument(
        '--source',
        action='append',
        default=[],
        metavar='LABEL=PATH',
        help='run the children on the suspopt package in PATH (repeatable)',
    )
    a = ap.parse_args()
    sources = [tuple(s.split('=', 1)) for s in a.source] or [(git_revision(), '')]
    title = (
        f'ISO 8608 class {a.road_class} road at {a.speed:g} m/s, {a.density:g} segments/s of '
        f'order 5'
    )
    print(f'# cost against the horizon: {title} — {machine()}\n')
    head = (
        '| model | horizon [s] | suspopt | run | wall [s] | reference scales [s] | setup [s] '
        '| sparsity + coloring [s] | starting trajectory [s] | solve [s] | iterations | '
        'verification [s] (integrator, max rel. diff.) | (scales + verification) / '
        'optimization | NLP n × m (Jacobian nonzeros, colors) | peak RSS [MB] |\n'
        '|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|'
    )
    print(head)
    rows, data = [], []
    for fid in a.fidelity:
        for T in a.horizons:
            args = {
                'horizon': T,
                'speed': a.speed,
                'road_class': a.road_class,
                'density': a.density,
                'fidelity': fid,
            }
            for label, path in sources:
                with tempfile.TemporaryDirectory(prefix='suspopt-bench-horizon-') as cache:
                    for run in ('first', 'cached'):
                        r = run_child(args, cache, path or None)
                        line = row(fid, T, a.density, label, run, r)
                        print(line, flush=True)
                        rows.append(line)
                        data.append({**args, 'source': label, 'run': run, **r})
                        if 'error' in r:
                            break
    notes = (
        '\nEach row is one optimization in a fresh process: "first" with an empty cache '
        '(colorings and reference scales), "cached" with the cache the first filled. The '
        'verification is `verification.verify.march` (every scenario, the trajectory kept) '
        'as a study runs it; its share is (reference scales + verification) / (setup + '
        'coloring + starting trajectory + solve). Rows of different suspopt sources were '
        'measured side by side in one run.'
    )
    md = f'{title}.\n\n{head}\n' + '\n'.join(rows) + '\n' + notes
    path = write_result('horizon', 'Cost against the horizon (ISO 8608 roads)', md, data)
    print(f'\nwritten to {path}')


if __name__ == '__main__':
    main()
