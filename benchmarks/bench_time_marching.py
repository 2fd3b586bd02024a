"""Benchmark: the multibody module at time-marching batch sizes, and mixed time marching.

    python benchmarks/bench_time_marching.py [--compare OLD_CHECKOUT] [--repeat 5]
        [--states 1 2 4 2000] [--cases micro half full] [--horizon T]

``micro``: per-call wall time [µs] of ``SuspensionModule.kinematics`` and ``.dynamics``
(double wishbone, ground mount) at N states. Small N is the time-marching pattern: each
call's wheel travels are the last call's moved along a sine (1 ms steps), the position
analysis started from the last pose moved along its tangent (as
``suspopt.verification.timemarching`` does); N = 2000 is the collocation's pattern, from the
reference pose. ``half``/``full``: wall time of ``simulate(config, 'mixed')`` (the half car
``StudyConfig()`` and ``full_car_defaults()``, the configured horizon unless
``--horizon``), its RHS calls and the objective integrals J.

With ``--compare``, every measurement runs in a fresh subprocess of each code version
(the checkout given, then this one's, the order alternating from repeat to repeat), and
the table gives medians over the repeats of each and their ratio; the J of both are
printed side by side with their largest relative difference.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
MECHANISM = 'double_wishbone'


def micro(N: int, calls: int, loops: int) -> dict:
    import numpy as np

    from suspopt.multibody.suspension import SuspensionModule

    mod = SuspensionModule(MECHANISM)
    rng = np.random.default_rng(N)
    phase = rng.uniform(0.0, 2 * np.pi, N)
    amp = rng.uniform(0.01, 0.05, N)
    small = N <= 16
    dt = 1e-3

    def inputs(k):
        t = k * dt
        z = amp * np.sin(2 * np.pi * 1.5 * t + phase)
        v = amp * 2 * np.pi * 1.5 * np.cos(2 * np.pi * 1.5 * t + phase)
        return z, v, 0.2 * z, 0.3 * v, np.full(N, 3.0e4), np.full(N, 3.0e3), -5e4 * z

    t_kin, t_dyn = [], []
    k0 = 0
    for _ in range(loops):
        prev = None
        tk = td = 0.0
        for k in range(k0, k0 + calls):  # fresh inputs every loop: no remembered analysis
            z, v, z_M, v_M, k_S, c_S, F_T = inputs(k)
            guess = None
            if small and prev is not None:  # timemarching._kinematics' warm start
                q, qd, z_prev, v_prev = prev
                safe = np.abs(v_prev) > 1e-9
                step = np.where(safe, (z - z_prev) / np.where(safe, v_prev, 1.0), 0.0)
                guess = q + qd * step[:, None]
            t0 = time.perf_counter()
            kin = mod.kinematics(z, v, guess)
            t1 = time.perf_counter()
            mod.dynamics(kin.state, z_M, v_M, k_S, c_S, F_T)
            t2 = time.perf_counter()
            prev = (kin.state.q, kin.state.qd, z, v)
            tk += t1 - t0
            td += t2 - t1
        k0 += calls
        t_kin.append(tk / calls * 1e6)
        t_dyn.append(td / calls * 1e6)
    return {'kinematics': statistics.median(t_kin), 'dynamics': statistics.median(t_dyn)}


def march(car: str, horizon: float | None) -> dict:
    import dataclasses

    import numpy as np

    from suspopt.spec.load import full_car_defaults
    from suspopt.spec.schema import StudyConfig
    from suspopt.verification.timemarching import simulate

    cfg = StudyConfig() if car == 'half' else full_car_defaults()
    if horizon is not None:
        cfg = dataclasses.replace(cfg, maneuver=dataclasses.replace(cfg.maneuver, horizon=horizon))
    T = cfg.maneuver.horizon
    t0 = time.perf_counter()
    tr = simulate(cfg, 'mixed', t_eval=np.array([0.0, T]))
    wall = time.perf_counter() - t0
    n = tr.info['rhs_evaluations']
    return {'wall_s': wall, 'rhs': n, 'us_per_rhs': wall / n * 1e6, 'J': [float(x) for x in tr.J]}


def worker(args) -> None:
    import suspopt

    out = {'suspopt': suspopt.__file__}
    if args.case == 'micro':
        out['micro'] = {
            str(N): micro(N, 200 if N <= 16 else 4, 5 if N <= 16 else 3) for N in args.states
        }
    else:
        out[args.case] = march(args.case, args.horizon)
    print(json.dumps(out))


def run(root: Path, case: str, args) -> dict:
    cmd = [
        sys.executable,
        str(HERE / 'bench_time_marching.py'),
        '--worker',
        '--case',
        case,
        '--states',
        *map(str, args.states),
    ]
    if args.horizon is not None:
        cmd += ['--horizon', str(args.horizon)]
    env = dict(os.environ, PYTHONPATH=str(root))
    res = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
    if res.returncode != 0:
        raise SystemExit(f'worker failed ({root}, {case}):\n{res.stderr}')
    out = json.loads(res.stdout.strip().splitlines()[-1])
    expect = str(root / 'suspopt' / '__init__.py')
    if os.path.realpath(out['suspopt']) != os.path.realpath(expect):
        raise SystemExit(f'worker imported {out["suspopt"]}, not {expect}')
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        '--compare',
        type=Path,
        default=None,
        help='a checkout of the code to compare with (e.g. a worktree of main)',
    )
    ap.add_argument('--repeat', type=int, default=5)
    ap.add_argument('--states', type=int, nargs='+', default=[1, 2, 4, 2000])
    ap.add_argument(
        '--cases', nargs='+', default=['micro', 'half', 'full'], choices=['micro', 'half', 'full']
    )
    ap.add_argument('--horizon', type=float, default=None)
    ap.add_argument('--worker', action='store_true', help=argparse.SUPPRESS)
    ap.add_argument('--case', default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        worker(args)
        return

    sys.path.insert(0, str(HERE))
    from _common import git_revision, machine

    versions = (
        {'new': ROOT} if args.compare is None else {'old': args.compare.resolve(), 'new': ROOT}
    )
    names = list(versions)
    rows: dict[str, dict[str, list[float]]] = {}
    J: dict[str, dict[str, list[float]]] = {}
    for rep in range(args.repeat):
        order = names if rep % 2 == 0 else names[::-1]
        for case in args.cases:
            for v in order:
                out = run(versions[v], case, args)
                if case == 'micro':
                    for N, r in out['micro'].items():
                        for what, us in r.items():
                            rows.setdefault(f'{what}, N = {N} [µs/call]', {}).setdefault(
                                v, []
                            ).append(us)
                else:
                    r = out[case]
                    label = f'{case} car mixed TM'
                    rows.setdefault(f'{label}: wall [s]', {}).setdefault(v, []).append(r['wall_s'])
                    rows.setdefault(f'{label}: per RHS call [µs]', {}).setdefault(v, []).append(
                        r['us_per_rhs']
                    )
                    rows.setdefault(f'{label}: RHS calls', {}).setdefault(v, []).append(r['rhs'])
                    J.setdefault(case, {})[v] = r['J']
        print(f'# repeat {rep + 1}/{args.repeat} done', file=sys.stderr, flush=True)

    print(
        f'# multibody at time-marching batch sizes — {machine()}, suspopt '
        f'{git_revision()}; medians of {args.repeat} interleaved repeats\n'
    )
    head = '| quantity | ' + ' | '.join(names) + (' | old / new |' if len(names) > 1 else ' |')
    print(head)
    print('|---|' + '---|' * (len(names) + (len(names) > 1)))
    for label, vals in rows.items():
        med = [statistics.median(vals[v]) for v in names]
        cells = [f'{m:.4g}' for m in med]
        if len(names) > 1:
            cells.append(f'{med[0] / med[1]:.2f}')
        print(f'| {label} | ' + ' | '.join(cells) + ' |')
    for case, byv in J.items():
        print(f'\n{case} car J:')
        for v in names:
            print(f'  {v:>4}: ' + '  '.join(f'{x:.16e}' for x in byv[v]))
        if len(names) > 1:
            rel = max(
                abs(a - b) / max(abs(a), abs(b), 1e-300) for a, b in zip(byv['old'], byv['new'])
            )
            print(f'  max relative difference: {rel:.3g}')


if __name__ == '__main__':
    main()
