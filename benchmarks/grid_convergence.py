"""Collocation against time marching on several grids (SPEC §6; the default-grid choice).

    python benchmarks/grid_convergence.py [--grids 16x5 32x5 64x5 80x5 64x6 96x5] [--mixed]

For each grid, the largest relative difference over the J_k between the collocation
solution (IPOPT solving the collocation equations at a fixed design) and adaptive time
marching, at the initial design, the low-fidelity optimum and three corners of the
design box; and f at the initial design (exactly 1 by time marching with the reference
normalization).
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import git_revision, machine  # noqa: E402

from suspopt.config import StudyConfig  # noqa: E402
from suspopt.transcription.problem import VehicleProblem  # noqa: E402
from suspopt.study import resolve_scales  # noqa: E402
from suspopt.timemarching import simulate  # noqa: E402

DESIGNS = {
    'initial': {'k_S1': 30000.0, 'k_S2': 30000.0, 'c_S1': 3000.0, 'c_S2': 3000.0},
    'low optimum': {'k_S1': 37524.0, 'k_S2': 28102.9, 'c_S1': 1496.45, 'c_S2': 1234.9},
    'soft, light damping': {'k_S1': 1e4, 'k_S2': 1e4, 'c_S1': 1e3, 'c_S2': 1e3},
    'stiff, light damping': {'k_S1': 5e4, 'k_S2': 5e4, 'c_S1': 1e3, 'c_S2': 1e3},
    'stiff, heavy damping': {'k_S1': 5e4, 'k_S2': 5e4, 'c_S1': 5e3, 'c_S2': 5e3},
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--grids', nargs='+', default=['16x5', '32x5', '64x5', '80x5', '64x6',
                                                   '96x5'])
    ap.add_argument('--mixed', action='store_true', help='also the mixed-fidelity model')
    args = ap.parse_args()
    base = StudyConfig()
    scales = resolve_scales(base)
    fids = ['low', 'mixed'] if args.mixed else ['low']
    print(f'# collocation vs time marching — {machine()}, suspopt {git_revision()}\n')
    print('| grid | model | f at initial design | ' + ' | '.join(DESIGNS) + ' |')
    print('|---|---|---|' + '---|' * len(DESIGNS))
    tm = {(fid, k): simulate(base, fid, d).J for fid in fids for k, d in DESIGNS.items()}
    for grid in args.grids:
        n, order = (int(v) for v in grid.split('x'))
        cfg = base.replace(transcription=dataclasses.replace(base.transcription, segments=n,
                                                             order=order))
        for fid in fids:
            errs, f0 = [], None
            with VehicleProblem(cfg, fid, scales, optimize_design=False) as vp:
                for name, d in DESIGNS.items():
                    vp.set_design(d)
                    vp.set_initial_guess(None)
                    res = vp.solve(optimize=False)
                    J = np.array([res.terms[0][t] for t in base.terms()])
                    errs.append(np.max(np.abs(J / tm[fid, name] - 1.0)))
                    if name == 'initial':
                        f0 = res.objective
            print(f'| {grid} | {fid} | {f0:.4f} | ' + ' | '.join(f'{100 * e:.3f} %' for e in errs)
                  + ' |', flush=True)


if __name__ == '__main__':
    main()
