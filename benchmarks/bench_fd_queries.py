"""Benchmark: the dynamic queries of one finite-difference Jacobian at one remembered
state, with the partitioning (C_q,dep⁻¹ and the tangent) and γ that come with the
module's analysed state against both computed afresh.

    python benchmarks/bench_fd_queries.py [--states 960] [--repeat 15]

What ``SuspensionDynamicsComp.compute_partials`` asks of a ground-mounted module at one
state: the base loads, then z_M, v_M, F_T, k_S and c_S each perturbed (the state, so
C_q and γ, unchanged). "afresh" passes the state's positions and velocities alone. The
results are checked to be bit for bit the same; wall-time medians, interleaved.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import git_revision, machine  # noqa: E402

from suspopt.multibody.solver import MultibodyState  # noqa: E402
from suspopt.multibody.suspension import SuspensionModule  # noqa: E402


def queries(mod: SuspensionModule, z, v, loads, keep: bool):
    out = None
    for args in loads:
        state = mod.kinematics(z, v).state
        if not keep:  # the same positions and velocities without what came with them
            state = MultibodyState(q=state.q, qd=state.qd, Cq=state.Cq)
            mod.solver.partitions.clear()
        out = mod.dynamics(state, *args)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--states', type=int, default=960)
    ap.add_argument('--repeat', type=int, default=15)
    args = ap.parse_args()
    N = args.states
    print(
        f"# one FD Jacobian's dynamic queries at one state, N = {N} — {machine()}, "
        f'suspopt {git_revision()}\n'
    )
    rng = np.random.default_rng(0)
    z, v = rng.uniform(-0.05, 0.05, N), rng.uniform(-0.5, 0.5, N)
    base = [
        rng.uniform(-0.02, 0.02, N),
        rng.uniform(-0.2, 0.2, N),
        np.full(N, 3e4),
        np.full(N, 2e3),
        rng.uniform(1e3, 3e3, N),
    ]
    loads = [tuple(base)]
    for i, h in enumerate([1e-6, 1e-6, 3e4 * 1e-6, 2e3 * 1e-6, 1e-6]):
        pert = list(base)
        pert[i] = pert[i] + h
        loads.append(tuple(pert))
    print('| mechanism | kept [ms] | afresh [ms] | kept / afresh |\n|---|---|---|---|')
    for name in ('double_wishbone', 'macpherson'):
        mod = SuspensionModule(name)
        a, b = queries(mod, z, v, loads, True), queries(mod, z, v, loads, False)
        assert all(np.array_equal(x, y) for x, y in zip(a, b)), 'not bit for bit'
        times: dict[bool, list[float]] = {True: [], False: []}
        for _ in range(args.repeat):
            for keep in (True, False):
                t = time.perf_counter()
                queries(mod, z, v, loads, keep)
                times[keep].append(time.perf_counter() - t)
        kept, fresh = statistics.median(times[True]), statistics.median(times[False])
        print(f'| {name} | {kept * 1e3:.2f} | {fresh * 1e3:.2f} | {kept / fresh:.2f} |')


if __name__ == '__main__':
    main()
