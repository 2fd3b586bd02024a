"""Benchmark: the full car against the half car, and what their checks cost.

    python benchmarks/bench_full_car.py [--repeat 2] [--segments auto] [--no-study]
                                        [--source LABEL=PATH ...]

On the default full car's road (ISO 8608 class C, 20 m/s, 5 s; the half car on the same
profile and grid), in one child process per suspopt source, ``--repeat`` rounds with the
coloring cache after a cold round that fills it:

* the reference scales of both cars (first with an empty cache, then again);
* half-car and full-car low-fidelity optimization from the initial design;
* full-car mixed-fidelity optimization from the full car's low-fidelity optimum;

each optimization timed by phase (setup, starting trajectory, IPOPT solve; coloring
separately) with IPOPT iterations, and its time-marching verification as a study runs it
(``verification.verify.march``: every scenario, the trajectory kept); medians, the ratios
full low / half low and full mixed / full low, and the checks' share: (reference scales +
verification) / optimization. Then the default full car's whole two-step study, first run
(empty caches, with the reference scales and every time-marching verification), as
``suspopt study --config FILE`` runs it.

``--source LABEL=PATH`` (repeatable) runs the children on the suspopt package found in
PATH (e.g. an export of another commit), side by side; by default this checkout.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _common import git_revision, machine, write_result  # noqa: E402

CHILD = r"""
import json, resource, sys, tempfile, time
from pathlib import Path
sys.path.insert(0, sys.argv[2])
from _common import fresh_cache, timed_optimize
from suspopt.spec.load import config_from_dict, full_car_defaults
from suspopt.spec.resolve import auto_segments
from suspopt.spec.schema import StudyConfig
from suspopt.verification.scales import resolve_scales
from suspopt.verification.verify import march
args = json.loads(sys.argv[1])
full = full_car_defaults()
segments = (auto_segments(full, full.scenarios()[0], full.transcription.order)
            if args['segments'] == 'auto' else int(args['segments']))
full = config_from_dict({**full.to_dict(), 'transcription': {'segments': segments}})
half = config_from_dict({**StudyConfig().to_dict(), 'road': dict(full.road),
                         'maneuver': full.maneuver.__dict__,
                         'transcription': {'segments': segments}})
out = {'segments': segments, 'road': full.road, 'speed': full.maneuver.speed,
       'horizon': full.maneuver.horizon, 'rounds': []}

def run(cfg, fidelity, scales, start):
    r = timed_optimize(cfg, fidelity, scales, start)
    r.pop('problem').cleanup()
    if not r['success']:
        raise SystemExit(f'{cfg.vehicle.model} {fidelity}: IPOPT did not converge')
    t0 = time.perf_counter()
    m = march(cfg, fidelity, r['design'], scales, keep=True)
    r['verify'] = time.perf_counter() - t0
    r['integrator'] = m[0].trajectory.info.get('integrator', 'DOP853')
    return {k: v for k, v in r.items() if k != 'design'} | {'design': r['design']}

with fresh_cache():
    scales = {}
    for name, cfg in (('half', half), ('full', full)):
        t0 = time.perf_counter(); scales[name] = resolve_scales(cfg)
        out[f'scales_{name}_first'] = time.perf_counter() - t0
        t0 = time.perf_counter(); resolve_scales(cfg)
        out[f'scales_{name}_cached'] = time.perf_counter() - t0
    for r in range(args['repeat'] + 1):
        hl = run(half, 'low', scales['half'], half.design.initial())
        fl = run(full, 'low', scales['full'], full.design.initial())
        fm = run(full, 'mixed', scales['full'], fl['design'])
        out['rounds'].append({'half_low': hl, 'full_low': fl, 'full_mixed': fm})
        done = ', '.join(f'{k} {v["total"]:.1f} s + verification {v["verify"]:.1f} s'
                         for k, v in out['rounds'][-1].items())
        print(f'round {r}: {done}', file=sys.stderr, flush=True)
if args['study']:
    from suspopt.studies.twostep import run_study
    with fresh_cache(), tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        study = run_study(full_car_defaults(), Path(tmp) / 'study')
        out['study_s'] = time.perf_counter() - t
    s = study.steps
    out['study_verified'] = all(e.verified for e in study.evaluations.values())
    out['study_f'] = [s['low'].objective, s['mixed'].objective]
out['peak_rss_gb'] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2
import suspopt
out['suspopt'] = suspopt.__file__
print('RESULT ' + json.dumps(out, default=float))
"""

OPTIMIZATIONS = (
    ('half_low', 'half car, low fidelity', 'half'),
    ('full_low', 'full car, low fidelity', 'full'),
    ('full_mixed', 'full car, mixed fidelity (from the low optimum)', 'full'),
)


def run_child(args: dict, source: str | None) -> dict:
    env = dict(os.environ, OMP_NUM_THREADS='1', OPENBLAS_NUM_THREADS='1', PYTHONWARNINGS='ignore')
    if source:
        env['PYTHONPATH'] = os.pathsep.join(filter(None, [source, env.get('PYTHONPATH')]))
    with tempfile.TemporaryDirectory(prefix='suspopt-bench-full-') as cwd:
        proc = subprocess.run(  # not in a checkout: `import suspopt` finds the one asked for
            [sys.executable, '-c', CHILD, json.dumps(args), str(HERE)],
            env=env,
            stdout=subprocess.PIPE,
            text=True,
            cwd=cwd,
        )
    line = [ln for ln in proc.stdout.splitlines() if ln.startswith('RESULT ')]
    if proc.returncode != 0 or not line:
        raise SystemExit(f'bench_full_car: the child failed ({source or "this checkout"})')
    return json.loads(line[0][len('RESULT ') :])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--repeat', type=int, default=2)
    ap.add_argument(
        '--segments',
        default='auto',
        help="segments of both cars ('auto': the full car's automatic grid)",
    )
    ap.add_argument('--no-study', action='store_true')
    ap.add_argument(
        '--source',
        action='append',
        default=[],
        metavar='LABEL=PATH',
        help='run the children on the suspopt package in PATH (repeatable)',
    )
    a = ap.parse_args()
    sources = [tuple(s.split('=', 1)) for s in a.source] or [(git_revision(), '')]
    args = {'repeat': a.repeat, 'segments': a.segments, 'study': not a.no_study}
    results = {}
    for label, path in sources:
        print(f'running {label} ...', flush=True)
        results[label] = run_child(args, path or None)
    first = next(iter(results.values()))
    title = (
        f'{first["road"]["profile"]} class {first["road"]["road_class"]} at '
        f'{first["speed"]:g} m/s, {first["horizon"]:g} s, {first["segments"]} segments'
    )
    med = statistics.median
    md = [
        f'Full car against half car, {title} — {machine()}.',
        '',
        '| suspopt | optimization (cached coloring) | setup [s] | guess [s] | solve [s] | '
        'total [s] | IPOPT iterations | reference scales [s] (first, cached) | '
        'verification [s] (integrator) | (scales + verification) / total |',
        '|---|---|---|---|---|---|---|---|---|---|',
    ]
    for label, res in results.items():
        warm = res['rounds'][1:] or res['rounds']
        for key, name, car in OPTIMIZATIONS:
            xs = [w[key] for w in warm]
            total, verify = med(x['total'] for x in xs), med(x['verify'] for x in xs)
            first_s, cached_s = res[f'scales_{car}_first'], res[f'scales_{car}_cached']
            md.append(
                f'| {label} | {name} | '
                + ' | '.join(f'{med(x[k] for x in xs):.2f}' for k in ('setup', 'guess', 'solve'))
                + f' | {total:.2f} | {xs[-1]["iterations"]} | {first_s:.2f}, {cached_s:.2f} | '
                f'{verify:.2f} ({xs[-1]["integrator"].split(" (")[0]}) | '
                f'**{(first_s + verify) / total:.0%}** (cached scales '
                f'{(cached_s + verify) / total:.0%}) |'
            )
    md.append('')
    for label, res in results.items():
        warm = res['rounds'][1:] or res['rounds']
        r1 = [w['full_low']['total'] / w['half_low']['total'] for w in warm]
        r2 = [w['full_mixed']['total'] / w['full_low']['total'] for w in warm]
        md.append(
            f'{label}: full low / half low {med(r1):.2f}, full mixed / full low {med(r2):.2f}'
            + (
                f"; the default full car's two-step study, first run (empty caches, verified "
                f'{res["study_verified"]}): {res["study_s"]:.1f} s (f low '
                f'{res["study_f"][0]:.4f}, mixed {res["study_f"][1]:.4f})'
                if 'study_s' in res
                else ''
            )
            + f'; peak RSS {res["peak_rss_gb"]:.2f} GB.'
        )
        md.append('')
    md.append(
        'Medians over the warm rounds; each suspopt source in its own process, side by side '
        "in one run. The checks' share counts the scales computed (first) or reused "
        '(cached) and the verification of the optimum.'
    )
    text = '\n'.join(md)
    print(text)
    path = write_result('full_car', 'Full car against half car', text, results)
    print(f'\nwritten to {path}')


if __name__ == '__main__':
    main()
