"""Collocation against time marching on several grids (docs/model.md; the default-grid choice).

    python benchmarks/grid_convergence.py [--grids 16x5 32x5 64x5 80x5 64x6 96x5] [--mixed]
    python benchmarks/grid_convergence.py --mechanism double_wishbone,macpherson
        [--grids 80x5 88x5] [--optimum]

For each grid, the largest relative difference over the J_k between the collocation
solution (IPOPT solving the collocation equations at a fixed design) and adaptive time
marching, at the initial design, the low-fidelity optimum and three corners of the
design box (with ``--mechanism`` all four); and f at the initial design (exactly 1 by
time marching with the reference normalization, low fidelity). ``--mixed`` adds the
mixed-fidelity model with the configured mechanisms; ``--mechanism`` measures the
mixed-fidelity model once per listed mechanism (built-in name or TOML path, on both
axles) instead, and ``--optimum`` adds that topology's own mixed-fidelity optimum
(optimized on the default grid from the low-fidelity optimum) to the designs. The last
columns name the worst term and say whether the grid meets the 0.1 % tolerance on every J_k at
every design measured.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import git_revision, machine  # noqa: E402

from suspopt.spec.load import config_from_dict  # noqa: E402
from suspopt.spec.schema import StudyConfig  # noqa: E402
from suspopt.studies.run import optimize  # noqa: E402
from suspopt.transcription.problem import VehicleProblem  # noqa: E402
from suspopt.verification.scales import resolve_scales  # noqa: E402
from suspopt.verification.timemarching import simulate  # noqa: E402

DESIGNS = {
    'initial': {'k_S1': 30000.0, 'k_S2': 30000.0, 'c_S1': 3000.0, 'c_S2': 3000.0},
    'low optimum': {'k_S1': 37524.0, 'k_S2': 28102.9, 'c_S1': 1496.45, 'c_S2': 1234.9},
    'soft, light damping': {'k_S1': 1e4, 'k_S2': 1e4, 'c_S1': 1e3, 'c_S2': 1e3},
    'stiff, light damping': {'k_S1': 5e4, 'k_S2': 5e4, 'c_S1': 1e3, 'c_S2': 1e3},
    'stiff, heavy damping': {'k_S1': 5e4, 'k_S2': 5e4, 'c_S1': 5e3, 'c_S2': 5e3},
}
#: with --mechanism: the fourth corner too (softest, most damped)
EXTRA = {'soft, heavy damping': {'k_S1': 1e4, 'k_S2': 1e4, 'c_S1': 5e3, 'c_S2': 5e3}}
#: docs/model.md: collocation and time marching within this on every J_k
CRITERION = 1e-3


def with_mechanism(base: StudyConfig, mechanism: str) -> StudyConfig:
    d = base.to_dict()
    for axle in ('front', 'rear'):
        d['vehicle'][axle]['mechanism'] = mechanism
    return config_from_dict(d)


def with_grid(cfg: StudyConfig, segments: int, order: int) -> StudyConfig:
    return cfg.replace(
        transcription=dataclasses.replace(cfg.transcription, segments=segments, order=order)
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--grids', nargs='+', default=['16x5', '32x5', '64x5', '80x5', '64x6', '96x5'])
    ap.add_argument('--mixed', action='store_true', help='also the mixed-fidelity model')
    ap.add_argument(
        '--mechanism',
        metavar='NAME[,NAME...]',
        help='the mixed-fidelity model with each of these mechanisms on both axles '
        '(instead of --mixed)',
    )
    ap.add_argument(
        '--optimum',
        action='store_true',
        help="with --mechanism: also each topology's own mixed optimum",
    )
    args = ap.parse_args()
    base = StudyConfig()
    scales = resolve_scales(base)
    models: list[tuple[str, str, StudyConfig]] = []  # (label, fidelity, config)
    if args.mechanism:
        for mech in (m.strip() for m in args.mechanism.split(',') if m.strip()):
            models.append((f'mixed, {mech}', 'mixed', with_mechanism(base, mech)))
    else:
        models.append(('low', 'low', base))
        if args.mixed:
            models.append(('mixed', 'mixed', base))
    designs = {label: dict(DESIGNS, **(EXTRA if args.mechanism else {})) for label, _, _ in models}
    if args.mechanism and args.optimum:
        low = optimize(base, 'low', scales=scales, verify=False)
        for label, fid, cfg in models:
            res = optimize(cfg, fid, start=low.design, scales=scales, verify=False)
            if res.success:
                designs[label]['own mixed optimum'] = res.design
                print(
                    f'{label}: own mixed optimum (default grid) '
                    + ', '.join(f'{k} = {v:.1f}' for k, v in res.design.items())
                    + f', f = {res.objective:.6f}',
                    flush=True,
                )
            else:
                print(f'{label}: mixed optimization failed ({res.status})', flush=True)
    names = list(dict.fromkeys(n for d in designs.values() for n in d))
    print(f'\n# collocation vs time marching — {machine()}, suspopt {git_revision()}\n')
    print(
        'largest relative difference over J_k, collocation (IPOPT on the collocation '
        'equations at the fixed design) against time marching (DOP853, rtol 1e-8)\n'
    )
    print(
        '| grid | model | f at initial design | '
        + ' | '.join(names)
        + f' | worst term | every J_k within {100 * CRITERION:g} % |'
    )
    print('|---|---|---|' + '---|' * (len(names) + 2))
    tm = {
        (label, k): simulate(cfg, fid, d).J
        for label, fid, cfg in models
        for k, d in designs[label].items()
    }
    for grid in args.grids:
        n, order = (int(v) for v in grid.split('x'))
        for label, fid, cfg0 in models:
            cfg = with_grid(cfg0, n, order)
            errs, f0, worst = {}, None, (0.0, '')
            with VehicleProblem(cfg, fid, scales, optimize_design=False) as vp:
                for name, d in designs[label].items():
                    vp.set_design(d)
                    vp.set_initial_guess(None)
                    res = vp.solve(optimize=False)
                    J = np.array([res.scenarios[0].reached[1][t] for t in base.terms()])
                    rel = np.abs(J / tm[label, name] - 1.0)
                    errs[name] = float(np.max(rel))
                    if errs[name] > worst[0]:
                        worst = (errs[name], f'{base.terms()[int(np.argmax(rel))]} ({name})')
                    if name == 'initial':
                        f0 = res.scenarios[0].reached[0]
            cells = [f'{100 * errs[k]:.3f} %' if k in errs else '—' for k in names]
            ok = 'yes' if worst[0] <= CRITERION else '**no**'
            print(
                f'| {grid} | {label} | {f0:.4f} | ' + ' | '.join(cells) + f' | {worst[1]} | {ok} |',
                flush=True,
            )


if __name__ == '__main__':
    main()
