"""Study: asymmetric two-stage dampers and bump stops against the best linear damper.

    python benchmarks/nonlinear_damper_study.py [--config examples/nonlinear_damper.toml]
                                                [--fidelity low|mixed] [--segments N]

Optimizes the study file's dampers (each axle's four slopes and bump-stop gap, the
springs and bars held) and two linear baselines — the same hardware with one linear
``c_S`` per axle in the slopes' bounds (the stops kept, their gaps designed), and the
file without any curve table (a linear damper and no stop) — from the car's own
dampers, with the same normalization (the stopless baseline's reference: f = 1 at the
car's dampers), verifies every optimum by time marching, and reports what the curves
buy in comfort (the seat's ISO 2631-1 Wk term) and road holding (the dynamic tyre
loads), with the largest travel and the least tyre load of each optimum against the
study's constraints. Writes
``benchmarks/results/nonlinear_damper.json`` (:func:`_common.write_result`) and the
figure ``docs/figures/nonlinear_damper.png``: each axle's damper force against velocity
and its springs' force against travel (the stop), with the ranges the time marching
reached, and the terms of both optima relative to the car's dampers.
"""

from __future__ import annotations

import argparse
import copy
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import git_revision, write_result  # noqa: E402

from suspopt.models.design import design_id  # noqa: E402
from suspopt.spec.hardware import study_units  # noqa: E402
from suspopt.spec.load import config_from_dict, load_config  # noqa: E402
from suspopt.studies.run import optimize  # noqa: E402
from suspopt.verification.scales import resolve_scales  # noqa: E402
from suspopt.verification.timemarching import simulate  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
AXLES = ('front', 'rear')
SLOTS = ('spring_curve', 'damper_curve', 'bump_stop', 'rebound_stop')


#: the cases, in the table's order: each baseline's curve tables removed (None: the study)
CASES: dict[str, tuple[str, ...] | None] = {
    'linear, no stop': SLOTS,
    'linear + stop': ('damper_curve',),
    'curves': None,
}


def linear_baseline(curves: dict, slots: tuple[str, ...] = SLOTS) -> dict:
    """The study without its curve tables ``slots`` (and their design variables): a
    linear damper ``c_S`` per axle, started at the curve's low bump slope and bounded as
    the slopes; the other variables as given."""
    data = copy.deepcopy(curves)
    design = data['design']
    for a, axle in enumerate(AXLES):
        table = data['vehicle'][axle]
        damper = table.get('damper_curve', {})
        for slot in slots:
            table[slot] = {}
        slopes = [v for n, v in design.items() if n.startswith('c_') and n.endswith(f'_{a + 1}')]
        name = f'c_S{a + 1}'
        design[name] = {
            'initial': damper.get('c_bump_low', design.get(name, {}).get('initial', 3000.0)),
            'lower': min(s['lower'] for s in slopes),
            'upper': max(s['upper'] for s in slopes),
            'optimize': True,
        }
    data['design'] = {n: v for n, v in design.items() if _curve_variable(n) not in slots}
    return data


def _curve_variable(name: str) -> str:
    """The curve table a design variable belongs to ('' if none)."""
    return '' if name == 'per_corner' else design_id(name).kind.slot


def marched(cfg, fidelity: str, design: dict[str, float]) -> dict[str, np.ndarray]:
    """The optimum's time-marched signals (the verification's tolerances)."""
    tr = simulate(cfg, fidelity, design, t_eval=np.linspace(0.0, cfg.maneuver.horizon, 1501))
    return {k: np.asarray(tr.values[k]) for k in ('travel', 'tyre_load_ratio', 'v_W', 'v_M')}


def group(terms: dict[str, float], prefix: str) -> float:
    return float(sum(v for k, v in terms.items() if k.startswith(prefix)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--config', default=str(ROOT / 'examples' / 'nonlinear_damper.toml'))
    ap.add_argument('--fidelity', default='low', choices=('low', 'mixed'))
    ap.add_argument('--segments', type=int, default=None)
    ap.add_argument('--figure', default=str(ROOT / 'docs' / 'figures' / 'nonlinear_damper.png'))
    args = ap.parse_args()
    curves = load_config(args.config).to_dict()
    if args.segments:
        curves['transcription']['segments'] = args.segments
    cfg = {
        name: config_from_dict(curves if slots is None else linear_baseline(curves, slots))
        for name, slots in CASES.items()
    }
    scales = resolve_scales(cfg['linear, no stop'])
    rec, sig, wall = {}, {}, {}
    for name in CASES:
        t0 = time.perf_counter()
        rec[name] = optimize(cfg[name], args.fidelity, scales=scales)
        wall[name] = time.perf_counter() - t0
        r = rec[name]
        print(
            f'{name}: {r.status}, f = {r.objective}, {r.iterations} iterations, '
            f'{wall[name]:.0f} s, verification {r.verification.state.value}'
        )
        sig[name] = marched(cfg[name], args.fidelity, r.design)
    start = {t: s for t, s in scales[0].items()}  # the reference: the car's own dampers
    con = cfg['curves'].constraints
    rows = []
    for label, terms, f, s in [("the car's dampers (start)", start, 1.0, None)] + [
        (n, rec[n].terms or {}, rec[n].objective, sig[n]) for n in CASES
    ]:
        if f is None:  # no design of this kind meets the constraints (IPOPT's verdict)
            why = rec[label].infeasibility
            what = why.describe() if why is not None else rec[label].status
            rows.append(f'| {label} | — | — | — | infeasible: {what} | — |')
            continue
        comfort = group(terms, 'comfort_') / group(start, 'comfort_')
        tyre = group(terms, 'tyre_load_') / group(start, 'tyre_load_')
        extra = (
            f'{1e3 * s["travel"].max():.1f} / {1e3 * -s["travel"].min():.1f} | '
            f'{s["tyre_load_ratio"].min():.3f}'
            if s is not None
            else '— | —'
        )
        rows.append(f'| {label} | {f:.4f} | {comfort:.4f} | {tyre:.4f} | {extra} |')
    c = rec['curves']
    verdicts = ', '.join(
        f'{n}: {rec[n].verification.state.value}'
        + (
            f' (largest term difference {comp.max_rel_diff:.1e})'
            if (comp := rec[n].verification.comparison) is not None
            else ''
        )
        for n in CASES
    )
    md = '\n'.join(
        [
            f'{args.fidelity}-fidelity optimizations of `{Path(args.config).name}` '
            f'({cfg["curves"].vehicle.model}, {cfg["curves"].road["profile"]} class '
            f'{cfg["curves"].road.get("road_class", "")}, {cfg["curves"].maneuver.speed:g} m/s, '
            f'{cfg["curves"].maneuver.horizon:g} s, {cfg["curves"].scenarios()[0].segments} '
            "segments), from the car's dampers, normalized by the reference of the car "
            'with linear dampers and no stop; comfort and road holding relative to the '
            'start. *linear + stop*: the same hardware as *curves* (the stops, their gaps '
            'designed) with a linear damper:',
            '',
            '| dampers | f | comfort (seat Wk) | road holding (tyre loads) | '
            'largest bump / rebound travel [mm] | least tyre load ratio |',
            '|---|---:|---:|---:|---:|---:|',
            *rows,
            '',
            f'Constraints of the study: travel bump {1e3 * con.travel.bump:g} mm, rebound '
            f'{1e3 * con.travel.rebound:g} mm; tyre load ratio >= {con.tyre_contact.margin - 1:g}'
            ' (path constraints of the collocation at every node; the columns show the '
            'time-marched extremes). Verification by time marching: '
            f'{verdicts}.',
            '',
            'Optimal curves: '
            + ', '.join(f'{n} = {v:.4g}' for n, v in c.design.items() if _curve_variable(n))
            + ''.join(
                f'; {n}'
                + ('' if rec[n].success else ', where IPOPT stopped')
                + ': '
                + ', '.join(
                    f'{d} = {v:.4g}'
                    for d, v in rec[n].design.items()
                    if 'c_S' in d or _curve_variable(d)
                )
                for n in CASES
                if n != 'curves'
            )
            + '.',
            '',
            'Wall time (optimization and verification) and IPOPT iterations: '
            + ', '.join(f'{n} {wall[n]:.0f} s, {rec[n].iterations}' for n in CASES)
            + f'. Figure: `docs/figures/{Path(args.figure).name}`.',
        ]
    )
    print(md)
    plot(cfg, rec, sig, scales, Path(args.figure))
    write_result(
        'nonlinear_damper' + ('' if args.fidelity == 'low' else f'_{args.fidelity}'),
        'Asymmetric two-stage dampers and bump stops against the best linear damper',
        md,
        {
            'revision': git_revision(),
            'fidelity': args.fidelity,
            'designs': {n: rec[n].design for n in rec},
            'objective': {n: rec[n].objective for n in rec},
            'terms': {n: rec[n].terms for n in rec},
            'scales': scales[0],
            'iterations': {n: rec[n].iterations for n in rec},
            'wall_s': wall,
        },
    )


def plot(cfg, rec, sig, scales, path: Path) -> None:
    """Each axle's damper force against velocity and its springs' (spring and stop)
    against travel at both optima, the time marching's ranges shaded; the terms."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6))
    lay = cfg['curves'].layout()
    units = {n: study_units(cfg[n]) for n in cfg}
    colours = dict(zip(CASES, ('tab:blue', 'tab:green', 'tab:red')))
    v = np.linspace(-1.0, 1.0, 401)
    x = np.linspace(-0.035, 0.035, 401)
    for a, (axle, style) in enumerate(zip(AXLES, ('-', '--'))):
        cols = [i for i, c in enumerate(lay.corners) if c.axle == a]
        for name in CASES:
            params = {
                design_id(n).kind.symbol: val
                for n, val in rec[name].design.items()
                if design_id(n).axle == a and not design_id(n).kind.per_bar
            }
            unit = units[name][a]
            if unit is None:
                F, E = params['c_S'] * v, params['k_S'] * x
            else:
                damper = {q.name for q in unit.damper.parameters()}
                F = unit.damper.value(v, {k: p for k, p in params.items() if k in damper})
                E = unit.elastic_force(x, params)[0]
            label = f'{name}, {axle}'
            axes[0].plot(v, F / 1e3, style, color=colours[name], label=label)
            axes[1].plot(1e3 * x, E / 1e3, style, color=colours[name], label=label)
            vel = (sig[name]['v_W'] - sig[name]['v_M'])[:, cols]
            tr = sig[name]['travel'][:, cols]
            if name == 'curves':
                axes[0].axvspan(vel.min(), vel.max(), color='grey', alpha=0.08 + 0.07 * a)
                axes[1].axvspan(1e3 * tr.min(), 1e3 * tr.max(), color='grey', alpha=0.08 + 0.07 * a)
    axes[0].set(xlabel='damper velocity [m/s] (bump +)', ylabel='damper force [kN]')
    axes[1].set(xlabel='travel [mm] (bump +)', ylabel='spring and bump stop force [kN]')
    axes[0].set_title('dampers (shaded: the velocities the curves met)')
    axes[1].set_title('springs and stops (shaded: the travel)')
    start = scales[0]
    groups = [('comfort', 'comfort_'), ('road holding', 'tyre_load_')]
    width = 0.27
    for k, name in enumerate(CASES):
        if rec[name].terms is None:  # infeasible: no optimum to show
            continue
        vals = [group(rec[name].terms, p) / group(start, p) for _, p in groups]
        axes[2].bar(np.arange(2) + (k - 1) * width, vals, width, color=colours[name], label=name)
    axes[2].axhline(1.0, color='k', lw=0.8)
    axes[2].set_xticks(np.arange(2), [g for g, _ in groups])
    axes[2].set(ylabel="term relative to the car's dampers", title='what the dampers buy')
    for ax in axes:
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    print(f'wrote {path}')


if __name__ == '__main__':
    main()
