"""Benchmark: cost against the horizon (issue 11): long ISO 8608 roads, both fidelities.

    python benchmarks/bench_horizon.py [--horizons 5 10 20 40 80] [--fidelity low mixed]
                                       [--density 16] [--speed 20] [--road-class C]

For each horizon T: an ISO 8608 road of the class at the speed, ``density × T`` uniform
segments of order 5 (16 per second is the density of the default 80 × 5 grid on the
paper's 5 s road), one optimization from the initial design in a fresh child process,
first with an empty coloring cache, then again with the cache it filled. Each child
reports its phases (reference scales by time marching, problem setup, sparsity and
coloring, starting trajectory, IPOPT solve, the time-marching verification of the
optimum), IPOPT iterations and its peak resident memory (``resource.getrusage``).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import git_revision, machine  # noqa: E402

CHILD = r"""
import json, resource, sys, time, dataclasses
t_import = time.perf_counter()
from suspopt.spec import config_from_dict
from suspopt.studies.run import initial_guess
from suspopt.verification.scales import resolve_scales
from suspopt.transcription.problem import VehicleProblem
from suspopt.verification.timemarching import simulate
args = json.loads(sys.argv[1])
T = args['horizon']
cfg = config_from_dict({
    'maneuver': {'speed': args['speed'], 'horizon': T},
    'road': {'profile': 'iso8608', 'road_class': args['road_class'], 'seed': 1},
    'transcription': {'segments': int(round(args['density'] * T))},
})
fid = args['fidelity']
out = {}
t0 = time.perf_counter()
scales = resolve_scales(cfg)
out['scales_s'] = time.perf_counter() - t0
t0 = time.perf_counter()
vp = VehicleProblem(cfg, fid, scales)
out['setup_s'] = time.perf_counter() - t0
start = cfg.design.initial()
vp.set_design(start)
t0 = time.perf_counter()
vp.set_initial_guess(initial_guess(cfg, fid, start))
out['guess_s'] = time.perf_counter() - t0
res = vp.solve()
out['coloring_s'] = res.times.coloring_s
out['solve_s'] = res.times.solve_s
out['iterations'] = res.iterations
out['success'] = res.success
out['f'] = res.objective
out['from_cache'] = vp.coloring_from_cache
lay = vp.driver.layout()
out['nlp'] = [lay.n, lay.m, vp.driver.coloring.nnz if vp.driver.coloring else 0,
              vp.driver.coloring.n_colors if vp.driver.coloring else 0]
t0 = time.perf_counter()
tr = simulate(cfg, fid, res.design, t_eval=[0.0, T])
out['verify_s'] = time.perf_counter() - t0
J = res.scenarios[0].reached[1]
out['verify_rel_diff'] = max(abs(J[t] / b - 1.0) for t, b in zip(cfg.terms(), tr.J))
vp.cleanup()
out['peak_rss_mb'] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
print('RESULT ' + json.dumps(out))
"""


def run_child(args: dict, cache: str) -> dict:
    env = dict(
        os.environ,
        SUSPOPT_CACHE_DIR=cache,
        OMP_NUM_THREADS='1',
        OPENBLAS_NUM_THREADS='1',
        PYTHONWARNINGS='ignore',
    )
    import time

    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, '-c', CHILD, json.dumps(args)], env=env, capture_output=True, text=True
    )
    wall = time.perf_counter() - t0
    line = [ln for ln in proc.stdout.splitlines() if ln.startswith('RESULT ')]
    if proc.returncode != 0 or not line:
        tail = (proc.stderr or proc.stdout).strip().splitlines()[-3:]
        return {'error': ' | '.join(tail), 'wall_s': wall}
    res = json.loads(line[0][len('RESULT ') :])
    res['wall_s'] = wall
    return res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--horizons', type=float, nargs='+', default=[5, 10, 20, 40, 80])
    ap.add_argument('--fidelity', nargs='+', default=['low', 'mixed'], choices=('low', 'mixed'))
    ap.add_argument('--density', type=float, default=16.0, help='segments per second')
    ap.add_argument('--speed', type=float, default=20.0)
    ap.add_argument('--road-class', default='C')
    a = ap.parse_args()
    print(
        f'# cost against the horizon: ISO 8608 class {a.road_class} road at {a.speed:g} m/s, '
        f'{a.density:g} segments/s of order 5 — {machine()}, suspopt {git_revision()}\n'
    )
    print(
        '| model | horizon [s] | segments | NLP n × m (Jacobian nonzeros, colors) | run | '
        'wall [s] | reference scales [s] | setup [s] | sparsity + coloring [s] | '
        'starting trajectory [s] | solve [s] | iterations | verification [s] (max rel. '
        'diff.) | peak RSS [MB] |'
    )
    print('|---|---|---|---|---|---|---|---|---|---|---|---|---|---|')
    for fid in a.fidelity:
        for T in a.horizons:
            args = {
                'horizon': T,
                'speed': a.speed,
                'road_class': a.road_class,
                'density': a.density,
                'fidelity': fid,
            }
            with tempfile.TemporaryDirectory(prefix='suspopt-bench-horizon-') as cache:
                for run in ('first', 'cached'):
                    r = run_child(args, cache)
                    if 'error' in r:
                        print(
                            f'| {fid} | {T:g} | {round(a.density * T)} | | {run} | '
                            f'{r["wall_s"]:.1f} | failed: {r["error"]} |',
                            flush=True,
                        )
                        break
                    n, m, nnz, colors = r['nlp']
                    print(
                        f'| {fid} | {T:g} | {round(a.density * T)} | {n} × {m} ({nnz}, '
                        f'{colors}) | {run} | {r["wall_s"]:.1f} | {r["scales_s"]:.2f} | '
                        f'{r["setup_s"]:.2f} | {r["coloring_s"]:.2f} | {r["guess_s"]:.2f} | '
                        f'{r["solve_s"]:.2f} | {r["iterations"]}'
                        f'{"" if r["success"] else " (not converged)"} | '
                        f'{r["verify_s"]:.2f} ({r["verify_rel_diff"]:.1e}) | '
                        f'{r["peak_rss_mb"]:.0f} |',
                        flush=True,
                    )


if __name__ == '__main__':
    main()
