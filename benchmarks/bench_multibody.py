"""Benchmark: batched multibody evaluations, double wishbone against MacPherson strut.

    python benchmarks/bench_multibody.py [--states 400 4000] [--repeat 15]

Per mechanism and batch size N (random wheel travels within ±50 mm, rates ±0.5 m/s,
tyre loads ±3 kN, a spring of 30 kN/m and 3 kN s/m as element parameters): the time of
one batched position analysis (Newton from the reference pose moved along its tangent,
as the vehicle interface calls it), velocity analysis, generalized forces and augmented
solve (eq. 11: coordinate partitioning, Schur elimination and dense), medians (min–max)
of ``--repeat`` calls.
Process CPU time, so that other jobs on a shared machine disturb it less.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import git_revision, machine, stats  # noqa: E402

from suspopt.multibody.mechanism import load_mechanism  # noqa: E402
from suspopt.multibody.solver import PlanarMultibodySolver  # noqa: E402

MECHANISMS = ('double_wishbone', 'macpherson')


def timings(name: str, N: int, repeat: int) -> dict[str, list[float]]:
    mech = load_mechanism(name, suspension=True)
    s = PlanarMultibodySolver(mech)
    rng = np.random.default_rng(N)
    z = s.q0[s.ind] + rng.uniform(-0.05, 0.05, (N, 1))
    v = rng.uniform(-0.5, 0.5, (N, 1))
    loads = np.zeros((N, len(s.load_names)))
    loads[:, s.load_names.index(mech.roles['tyre_load'])] = rng.uniform(-3e3, 3e3, N)
    params = {mech.roles['spring']: {'stiffness': 3.0e4, 'damping': 3.0e3}}
    q = s.positions(z)
    Cq = s.constraint_jacobian(q)
    qd = s.velocities(q, v, Cq)
    Q = s.generalized_forces(q, loads, qd, params)
    calls = {
        'position analysis': lambda: s.positions(z),
        'velocity analysis': lambda: s.velocities(q, v, s.constraint_jacobian(q)),
        'generalized forces': lambda: s.generalized_forces(q, loads, qd, params),
        'augmented solve (partitioned)': lambda: s.solve_augmented(q, qd, Q, Cq=Cq),
        'augmented solve (Schur)': lambda: s.solve_augmented(q, qd, Q, Cq=Cq, method='schur'),
        'augmented solve (dense)': lambda: s.solve_augmented(q, qd, Q, Cq=Cq, method='dense'),
    }
    out = {}
    for label, f in calls.items():
        f()
        t = []
        for _ in range(repeat):
            t0 = time.process_time()
            f()
            t.append((time.process_time() - t0) * 1e3)
        out[label] = t
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--states', type=int, nargs='+', default=[400, 4000])
    ap.add_argument('--repeat', type=int, default=15)
    args = ap.parse_args()
    print(
        f'# batched multibody evaluations [ms per call] — {machine()}, suspopt {git_revision()}\n'
    )
    for N in args.states:
        res = {name: timings(name, N, args.repeat) for name in MECHANISMS}
        print(f'\n## N = {N} states\n')
        print('| call | ' + ' | '.join(MECHANISMS) + ' |')
        print('|---|' + '---|' * len(MECHANISMS))
        for label in res[MECHANISMS[0]]:
            print(f'| {label} | ' + ' | '.join(stats(res[m][label]) for m in MECHANISMS) + ' |')


if __name__ == '__main__':
    main()
