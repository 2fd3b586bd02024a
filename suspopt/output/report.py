"""Tables and figures of a run, rendered from its results directory (``suspopt report DIR``).

It reads only what the run wrote: ``study.json`` (or ``result.json`` of an optimize run,
``pareto.json`` of a Pareto front), the SQLite case recorders (the trajectories of every
design in each model), ``time_marching.npz`` and the study description inside them (the
road as used, with copies of its files under ``inputs/``); never the user's original
files, and it does not validate the study again (a directory written by an older suspopt
renders as it was). A damaged or incomplete directory is a one-line
:class:`~suspopt.errors.ConfigError`. What did not converge is shown as such, never with
a value as a result; trajectories are drawn only of converged results. It writes
``table.md`` and ``figures/*.png``:

* ``road.png`` — road input under every wheel (paper Figure 3);
* ``initial_design.png`` — low- vs mixed-fidelity trajectories at the initial design
  (paper Figure 4): chassis heave and pitch (and roll) accelerations, wheel travel;
* ``optima.png`` — the same at the low- and mixed-fidelity optima (paper Figure 5);
* ``cross_evaluation.png`` — every design in the mixed-fidelity model (beyond the paper);
* ``verification.png`` — collocation against time marching, both models;
* ``convergence.png`` — objective and constraint violation per IPOPT iteration.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from suspopt.errors import ConfigError
from suspopt.models.objective import term_units
from suspopt.output.figures import (
    corner_labels,
    panel_figure,
    panel_specs,
    plot_curves,
    plot_set,
    road_figure,
    save_figure,
)
from suspopt.output.rundir import (
    COUPLING_DESIGN_LABELS,
    COUPLING_DESIGNS,
    COUPLING_MODEL_LABELS,
    STUDY_DESIGNS,
    read_json,
    read_trajectory,
    write_text,
)

DESIGN_LABELS = dict(
    zip(STUDY_DESIGNS, ('Initial guess', 'Low-fidelity optimum', 'Mixed-fidelity optimum'))
)
FIDELITY_LABELS = {'low': 'low-fidelity', 'mixed': 'mixed-fidelity (multibody)'}


def _fmt(x: float | None, digits: int = 4) -> str:
    return '—' if x is None else f'{x:.{digits}g}'


def _obj(x: float | None) -> str:
    """An objective value (normalized: f = 1 at the reference), to four decimals."""
    return '—' if x is None else f'{x:.4f}'


def _design_unit(name: str) -> str:
    return {'k_S': 'N/m', 'c_S': 'N·s/m', 'k_R': 'N·m/rad'}[name[:3]]


def _verdict(rec: dict[str, Any] | None) -> str:
    """How a result is to be read: verified, NOT verified, unchecked or failed."""
    if not rec:
        return '—'
    if not rec.get('success', True):
        return 'NOT converged'
    v = rec.get('verified')
    return {True: 'verified', False: '**NOT verified**', None: 'not checked'}[v]


# ---------------------------------------------------------------------------- tables
def _scales_line(
    terms: list[str], scales: list[dict[str, float]], normalization: str, weights: dict[str, float]
) -> str:
    s = scales[0]
    objective = ' + '.join(f'{weights[t]:g} J_{t}/s_{t}' for t in terms if weights.get(t))
    return (
        f'Normalization: `{normalization}`, s = ('
        + ', '.join(f'{t} {s[t]:.6g}' for t in terms)
        + f'); f = {objective}.'
    )


def table_markdown(study: dict[str, Any]) -> str:
    """Table 4 of the paper, every design in both models, terms, verification, statistics."""
    ev, steps = study.get('evaluations', {}), study.get('steps', {})
    designs = study.get('designs') or {
        'initial': (ev.get('low/initial') or {}).get('design'),
        'low_optimum': (steps.get('low') or {}).get('design'),
        'mixed_optimum': (steps.get('mixed') or {}).get('design'),
    }
    names, terms = study['design_names'], study['terms']
    weights = study.get('config', {}).get('objective', {}).get('weights', {})
    lines = [f'**Warning:** {w}' for w in study.get('warnings', [])]
    if not study.get('verify', True):
        lines.append('**Not checked:** time-marching verification was skipped (--no-verify).')
    lines += ([''] if lines else []) + [
        _scales_line(terms, study['scales'], study['normalization'], weights),
        '',
        '**Table 4 (paper): design and f, each f in the model that produced it**',
        '',
        '| | ' + ' | '.join(f'{n} [{_design_unit(n)}]' for n in names) + ' | f | model | |',
        '|---|' + '---|' * (len(names) + 3),
    ]
    own = {
        'initial': 'low/initial',
        'low_optimum': 'low/low_optimum',
        'mixed_optimum': 'mixed/mixed_optimum',
    }
    for name, label in DESIGN_LABELS.items():
        d, e = designs.get(name), ev.get(own[name])
        if not d or not e:
            continue
        lines.append(
            f'| {label} | '
            + ' | '.join(f'{d[n]:.0f}' for n in names)
            + f' | **{_obj(e["objective"])}** | {own[name].split("/")[0]} | '
            f'{_verdict(e)} |'
        )
    lines += [
        '',
        '**Every design in both models (collocation; time marching in brackets)**',
        '',
        '| design | f, low-fidelity | f, mixed-fidelity |',
        '|---|---|---|',
    ]
    for name, label in DESIGN_LABELS.items():
        cells = []
        for fid in ('low', 'mixed'):
            e = ev.get(f'{fid}/{name}')
            v = (e or {}).get('verification') or {}
            cells.append(
                '—'
                if e is None
                else _obj(e['objective'])
                + (f' ({v["objective"]:.4f})' if 'objective' in v else '')
                + ('' if e.get('verified') is not False else ' **NOT verified**')
            )
        lines.append(f'| {label} | {cells[0]} | {cells[1]} |')
    lines += [
        '',
        '**Objective terms J_k (collocation)**',
        '',
        '| design | model | ' + ' | '.join(f'J_{t} [{term_units(t)}]' for t in terms) + ' |',
        '|---|---|' + '---|' * len(terms),
    ]
    for name, label in DESIGN_LABELS.items():
        for fid in ('low', 'mixed'):
            e = ev.get(f'{fid}/{name}')
            if e:
                lines.append(
                    f'| {label} | {fid} | '
                    + ' | '.join(f'{e["terms"][t]:.5g}' if e.get('terms') else '—' for t in terms)
                    + (' |' if e.get('terms') else ' (NOT converged) |')
                )
    checked = [
        (name, fid)
        for name in DESIGN_LABELS
        for fid in ('low', 'mixed')
        if 'max_rel_diff' in ((ev.get(f'{fid}/{name}') or {}).get('verification') or {})
    ]
    if checked:
        lines += [
            '',
            '**Collocation vs time marching** (largest relative difference over '
            'the weighted J_k; verified if at most the tolerance '
            f'{100 * ev[f"{checked[0][1]}/{checked[0][0]}"]["verification"]["tolerance"]:g} %)',
            '',
            '| design | low-fidelity | mixed-fidelity | max constraint residual (mixed) |',
            '|---|---|---|---|',
        ]
        for name, label in DESIGN_LABELS.items():
            cells = []
            for fid in ('low', 'mixed'):
                v = (ev.get(f'{fid}/{name}') or {}).get('verification') or {}
                cells.append(_fmt(v.get('max_rel_diff'), 2))
            vm = (ev.get(f'mixed/{name}') or {}).get('verification') or {}
            res = [s.get('max_constraint_residual_m') for s in vm.get('scenarios', [])]
            lines.append(
                f'| {label} | {cells[0]} | {cells[1]} | {_fmt(max(res) if res else None, 2)} m |'
            )
    if steps:
        lines += [
            '',
            '**Optimization statistics** (each step starts from the collocation '
            'solution of its starting design)',
            '',
            '| step | success | IPOPT status | iterations | function / gradient '
            'evaluations | solve [s] | multibody solver calls, each batched over all '
            'nodes and corners |',
            '|---|---|---|---|---|---|---|',
        ]
        for fid in ('low', 'mixed'):
            st = steps.get(fid)
            if st:
                calls = st.get('multibody_calls') or {}
                mbd = (
                    (
                        f'{calls.get("augmented", 0)} augmented solves (eq. 11), '
                        f'{calls.get("positions", 0)} position analyses'
                        + (
                            f', {calls["factorizations"]} factorizations of C_q,dep (one per pose)'
                            if 'factorizations' in calls
                            else ''
                        )
                    )
                    if calls
                    else '—'
                )
                lines.append(
                    f'| {fid} | {st["success"]} | {st["status"]} | {st["iterations"]} | '
                    f'{st["function_evaluations"]} / {st["gradient_evaluations"]} | '
                    f'{st["times"]["solve_s"]:.2f} | {mbd} |'
                )
        probs = study.get('problems') or {}
        if probs:
            lines += [
                '',
                '| model | NLP variables × constraints | Jacobian nonzeros '
                '(colors) | setup [s] | sparsity + coloring [s] |',
                '|---|---|---|---|---|',
            ]
            for fid, pr in probs.items():
                nlp = pr.get('nlp', {})
                lines.append(
                    f'| {fid} | {nlp.get("variables")} × {nlp.get("constraints")} | '
                    f'{nlp.get("jacobian_nonzeros")} ({nlp.get("colors")}) | '
                    f'{pr["setup_s"]:.2f} | {pr["coloring_s"]:.2f}'
                    f'{" (from cache)" if pr["coloring_from_cache"] else ""} |'
                )
    if 'wall_time_s' in study:
        lines += ['', f'Whole study: {study["wall_time_s"]:.1f} s.']
    return '\n'.join(lines) + '\n'


def run_markdown(res: dict[str, Any]) -> str:
    """The result of one ``suspopt optimize`` run, as Markdown."""
    ok = bool(res.get('success'))
    d, J = res.get('design') or {}, (res.get('terms') if ok else res.get('terms_at_stop')) or {}
    names = list(d)
    lines = [
        f'**{res["fidelity"]}-fidelity {res.get("mode", "optimize")}** — '
        f'{"converged" if ok else "NOT converged"} ({res.get("status", "?")}), '
        + (f'{_verdict(res)}, ' if ok else '')
        + f'{res.get("iterations", "—")} '
        f'IPOPT iterations, {_fmt(res.get("wall_time_s"), 3)} s',
        '',
        '| | ' + ' | '.join(f'{n} [{_design_unit(n)}]' for n in names) + ' | f |',
        '|---|' + '---|' * (len(names) + 1),
    ]
    for label, design, f in (
        ('start', res.get('start') or {}, None),
        ('result' if ok else 'stopped at (not a result)', d, res.get('objective')),
    ):
        if design:
            lines.append(
                f'| {label} | '
                + ' | '.join(f'{design[n]:.0f}' for n in names)
                + f' | {"—" if f is None else f"{f:.4f}"} |'
            )
    if J:
        if not ok:
            lines += ['', 'Objective terms where IPOPT stopped (NOT converged: not a result):']
        lines += [
            '',
            '| ' + ' | '.join(f'J_{t} [{term_units(t)}]' for t in J) + ' |',
            '|' + '---|' * len(J),
            '| ' + ' | '.join(_fmt(J[t], 5) for t in J) + ' |',
        ]
    v = res.get('verification') or {}
    if 'max_rel_diff' in v:
        lines += [
            '',
            f'Time marching: f = {v["objective"]:.4f}; largest relative difference '
            f'{v["max_rel_diff"]:.2g} (tolerance {v["tolerance"]:g}) — '
            f'{"verified" if v["verified"] else "NOT verified"}.',
        ]
    elif v.get('note'):
        lines += ['', v['note']]
    scales = res.get('scales') or {}
    if scales:
        lines += [
            '',
            f'Normalization `{res.get("normalization")}`: s = ('
            + ', '.join(f'{k} {_fmt(s, 6)}' for k, s in scales.items())
            + ').',
        ]
    if res.get('message') and not res.get('success'):
        lines += ['', f'Message: {res["message"]}']
    return '\n'.join(lines) + '\n'


def pareto_markdown(front: dict[str, Any]) -> str:
    """A comfort/road-holding front (:mod:`suspopt.pareto`), as Markdown."""
    names = front['design_names']
    lines = [
        f'Pareto front of the {FIDELITY_LABELS[front["fidelity"]]} model: comfort C '
        '(mean of the normalized chassis terms) against road holding R (mean of the '
        f'normalized wheel terms), `{front["normalization"]}` normalization; weights '
        'α/n_C on each chassis term and (1−α)/n_R on each wheel term for comfort share α.',
        '',
        '| α | '
        + ' | '.join(f'{n} [{_design_unit(n)}]' for n in names)
        + ' | C | R | f_α | IPOPT | iterations | |',
        '|---|' + '---|' * (len(names) + 6),
    ]
    for pt in front['points']:
        d = pt['design']
        lines.append(
            f'| {pt["alpha"]:.3f} | '
            + ' | '.join(f'{d[n]:.0f}' for n in names)
            + f' | {_obj(pt.get("comfort"))} | {_obj(pt.get("road_holding"))} | '
            f'{_obj(pt["objective"])} | {pt["status"]} | {pt["iterations"]} | '
            f'{_verdict(pt)} |'
        )
    init = front.get('initial')
    if init and init.get('comfort') is not None:
        d = init['design']
        lines.append(
            '| initial design | '
            + ' | '.join(f'{d[n]:.0f}' for n in names)
            + f' | {init["comfort"]:.4f} | {init["road_holding"]:.4f} | | | | |'
        )
    if front.get('wall_time_s') is not None:
        lines += [
            '',
            f'{len(front["points"])} optimizations on one problem: '
            f'{front["wall_time_s"]:.1f} s in all.',
        ]
    return '\n'.join(lines) + '\n'


def robust_markdown(data: dict[str, Any]) -> str:
    """The robustness table (:mod:`suspopt.robust`), as Markdown."""
    names, scen = data['design_names'], data['scenarios']
    agg = 'max_s f_s' if data['aggregate'] == 'max' else 'Σ_s w_s f_s'
    lines = [
        f'Robust design, {FIDELITY_LABELS[data["fidelity"]]} model: {len(scen)} scenarios '
        f'({", ".join(f"{n} (w = {w:g})" for n, w in zip(scen, data["weights"]))}), '
        f'objective {agg}, each f_s normalized by its own scales.',
        '',
        '**Optima** (collocation, each in its own problem)',
        '',
        '| optimum | '
        + ' | '.join(f'{n} [{_design_unit(n)}]' for n in names)
        + ' | f | IPOPT | iterations | |',
        '|---|' + '---|' * (len(names) + 4),
    ]
    for label, res in data['optima'].items():
        d = res['design']
        lines.append(
            f'| {label} | '
            + ' | '.join(f'{d[n]:.0f}' for n in names)
            + f' | {_obj(res["objective"])} | {res["status"]} | {res["iterations"]} '
            f'| {_verdict(res)} |'
        )
    lines += [
        '',
        '**Every optimum on every scenario** (f_s by time marching; the best on each '
        'scenario in bold)',
        '',
        '| optimum | ' + ' | '.join(scen) + f' | {agg} |',
        '|---|' + '---|' * (len(scen) + 1),
    ]
    cross = data.get('cross', {})
    best = {s: min((c['scenarios'][s] for c in cross.values()), default=None) for s in scen}
    best_agg = min((c['aggregate'] for c in cross.values()), default=None)
    for label, c in cross.items():
        cells = [
            (
                f'**{c["scenarios"][s]:.4f}**'
                if c['scenarios'][s] == best[s]
                else f'{c["scenarios"][s]:.4f}'
            )
            for s in scen
        ]
        a = f'**{c["aggregate"]:.4f}**' if c['aggregate'] == best_agg else f'{c["aggregate"]:.4f}'
        lines.append(f'| {label} | ' + ' | '.join(cells) + f' | {a} |')
    if data.get('wall_time_s') is not None:
        lines += ['', f'{len(data["optima"])} optimizations: {data["wall_time_s"]:.1f} s in all.']
    return '\n'.join(lines) + '\n'


def render_robust(out_dir: str | Path) -> list[Path]:
    """Write ``table.md`` and ``figures/robustness.png`` of a robust-design directory."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    data = read_json(out / 'robust.json')
    write_text(out / 'table.md', robust_markdown(data))
    figs = out / 'figures'
    figs.mkdir(exist_ok=True)
    cross, scen = data.get('cross', {}), data['scenarios']
    fig, ax = plt.subplots(figsize=(max(6.0, 1.6 * len(scen) + 2), 4), constrained_layout=True)
    width = 0.8 / max(len(cross), 1)
    for k, (label, c) in enumerate(cross.items()):
        x = np.arange(len(scen)) + (k - (len(cross) - 1) / 2) * width
        ax.bar(
            x,
            [c['scenarios'][s] for s in scen],
            width,
            label=f'{label} optimum',
            hatch='//' if label == 'robust' else None,
        )
    ax.set_xticks(np.arange(len(scen)), scen)
    ax.set(
        ylabel='f_s by time marching (normalized per scenario)',
        title='Every optimum on every scenario (lower is better)',
    )
    ax.grid(alpha=0.3, axis='y')
    ax.legend(fontsize=8)
    save_figure(fig, figs / 'robustness.png', dpi=110)
    plt.close(fig)
    return [out / 'table.md', figs / 'robustness.png']


# ---------------------------------------------------------------------------- figures
def _convergence_figure(path: Path, runs: dict[str, dict[str, Any]]) -> Path:
    """Objective and constraint violation per IPOPT iteration of each run (by fidelity)."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 3.8), constrained_layout=True)
    for fid, color in (('low', 'tab:blue'), ('mixed', 'tab:red')):
        hist = (runs.get(fid) or {}).get('history') or []
        if hist:
            it = [h['iteration'] for h in hist]
            a1.plot(
                it,
                [h['objective'] for h in hist],
                'o-',
                color=color,
                ms=3,
                label=FIDELITY_LABELS[fid],
            )
            a2.semilogy(
                it,
                [max(h['constraint_violation'], 1e-16) for h in hist],
                'o-',
                color=color,
                ms=3,
                label=FIDELITY_LABELS[fid],
            )
    a1.set(xlabel='IPOPT iteration', ylabel='objective f', title='Objective')
    a2.set(
        xlabel='IPOPT iteration',
        ylabel='constraint violation (scaled)',
        title='Collocation defects',
    )
    for a in (a1, a2):
        a.grid(alpha=0.3)
        a.legend(fontsize=9)
    save_figure(fig, path, dpi=110)
    plt.close(fig)
    return path


def render_run(out_dir: str | Path) -> list[Path]:
    """Write ``table.md`` and the figures of a ``suspopt optimize`` directory from its
    ``result.json`` and case recorder ``cases.sql``."""
    out = Path(out_dir)
    res = _read(out / 'result.json')
    write_text(out / 'table.md', run_markdown(res))
    figs = out / 'figures'
    figs.mkdir(exist_ok=True)
    written = [out / 'table.md']
    fid = res['fidelity']
    if res.get('config'):
        written.append(road_figure(figs / 'road.png', out, res['config']))
        tr = (
            read_trajectory(out / 'cases.sql', f'{fid}_optimum')
            if (out / 'cases.sql').exists() and res.get('success')
            else None
        )
        if tr is not None:  # only a converged result's trajectory
            terms = list(res.get('terms') or {})
            written.append(
                plot_set(
                    figs / 'trajectories.png',
                    f'The {FIDELITY_LABELS[fid]} model at the design found',
                    [
                        (
                            f'{fid} fidelity',
                            tr,
                            {'color': 'tab:blue' if fid == 'low' else 'tab:red', 'lw': 1.2},
                        )
                    ],
                    terms,
                    corner_labels(out, res['config']),
                )
            )
    if res.get('history'):
        written.append(_convergence_figure(figs / 'convergence.png', {fid: res}))
    return written


def render_pareto(out_dir: str | Path) -> list[Path]:
    """Write ``table.md`` and ``figures/pareto.png`` of a Pareto directory."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    front = _read(out / 'pareto.json')
    write_text(out / 'table.md', pareto_markdown(front))
    figs = out / 'figures'
    figs.mkdir(exist_ok=True)
    pts = front['points']
    ok = [p for p in pts if p['success']]
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
    a1.plot(
        [p['comfort'] for p in ok],
        [p['road_holding'] for p in ok],
        'o-',
        color='tab:blue',
        label='optima (IPOPT converged)',
    )
    for p in ok:
        a1.annotate(
            f'α={p["alpha"]:.2f}',
            (p['comfort'], p['road_holding']),
            textcoords='offset points',
            xytext=(5, 4),
            fontsize=8,
        )
    bad = [
        (
            p.get('comfort', p.get('comfort_at_stop')),
            p.get('road_holding', p.get('road_holding_at_stop')),
        )
        for p in pts
        if not p['success'] or p.get('verified') is False
    ]
    bad = [b for b in bad if None not in b]
    if bad:
        a1.plot(
            [c for c, _ in bad],
            [r for _, r in bad],
            'x',
            color='tab:red',
            label='not converged (where IPOPT stopped) or not verified',
        )
    init = front.get('initial')
    if init and init.get('comfort') is not None:
        a1.plot(
            [init['comfort']],
            [init['road_holding']],
            's',
            color='gray',
            label='initial design, same model',
        )
    a1.set(
        xlabel='comfort C (smaller: smoother ride)',
        ylabel='road holding R (smaller: better grip)',
        title=f'Pareto front, {FIDELITY_LABELS[front["fidelity"]]} model',
    )
    a1.grid(alpha=0.3)
    a1.legend(fontsize=8)
    bounds = front['bounds']
    for name, style in zip(front['design_names'], ('o-', 's-', '^--', 'v--', 'd-.', 'x-.')):
        lo, hi = bounds[name]
        a2.plot(
            [p['alpha'] for p in ok],
            [(p['design'][name] - lo) / (hi - lo) for p in ok],
            style,
            ms=4,
            label=name,
        )
    a2.set(
        xlabel='comfort share α',
        ylabel='design, scaled to its bounds [0, 1]',
        title='Settings along the front',
        ylim=(-0.05, 1.05),
    )
    a2.grid(alpha=0.3)
    a2.legend(fontsize=8)
    save_figure(fig, figs / 'pareto.png', dpi=110)
    plt.close(fig)
    return [out / 'table.md', figs / 'pareto.png']


#: what a results file of each kind must hold to be rendered
_REQUIRED = {
    'study.json': ('config', 'scales', 'terms', 'design_names', 'normalization'),
    'result.json': ('fidelity', 'design', 'success', 'status'),
    'pareto.json': ('config', 'fidelity', 'design_names', 'bounds', 'normalization', 'points'),
}


def _read(path: Path) -> dict[str, Any]:
    data = read_json(path)
    missing = [k for k in _REQUIRED[path.name] if k not in data]
    if missing:
        raise ConfigError(f'{path}: damaged or incomplete results file (no {", ".join(missing)})')
    return data


def render(out_dir: str | Path) -> list[Path]:
    """Write ``table.md`` and the figures of a (possibly partial) study directory, or of
    an optimize, Pareto, robust, coupling or topology-study (``compare.json``) directory. A
    damaged or incomplete one is a ConfigError."""
    out = Path(out_dir)
    if not out.is_dir():
        raise ConfigError(f'{out}: not a directory')
    try:
        if not (out / 'study.json').exists() and (out / 'compare.json').exists():
            from suspopt.output.compare_report import render_compare  # a topology study

            return render_compare(out)
        if not (out / 'study.json').exists() and (out / 'pareto.json').exists():
            return render_pareto(out)
        if not (out / 'study.json').exists() and (out / 'robust.json').exists():
            return render_robust(out)
        if not (out / 'study.json').exists() and (out / 'coupling.json').exists():
            return render_coupling(out)
        if not (out / 'study.json').exists() and (out / 'result.json').exists():
            return render_run(out)
        return render_study(out)
    except (KeyError, TypeError, ValueError, IndexError, AttributeError) as err:
        if isinstance(err, ConfigError):
            raise
        raise ConfigError(
            f'{out}: damaged or incomplete results ({type(err).__name__}: {err})'
        ) from None


def render_study(out: Path) -> list[Path]:
    """Write ``table.md`` and the figures of a (possibly partial) study directory (the
    figures drawn side by side in background processes, :func:`draw_figures`)."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    study = _read(out / 'study.json')
    write_text(out / 'table.md', table_markdown(study))
    figs = out / 'figures'
    figs.mkdir(exist_ok=True)
    written = [out / 'table.md']
    jobs: list[Callable[[], Path]] = [lambda: road_figure(figs / 'road.png', out, study['config'])]
    terms, labels = study['terms'], corner_labels(out, study['config'])

    import openmdao.api as om

    traj = {}
    ev = study.get('evaluations') or {}
    for fid in ('low', 'mixed'):
        if (out / f'{fid}.sql').exists():
            try:
                rec = om.CaseReader(str(out / f'{fid}.sql'))
            except Exception as err:  # sqlite's errors of a damaged file
                raise ConfigError(f'{out / f"{fid}.sql"}: damaged case recorder ({err})') from None
            for name in STUDY_DESIGNS:  # recorded under the design's name in each model
                if not (ev.get(f'{fid}/{name}') or {}).get('success'):
                    continue  # not a converged result (an interrupted or failed solve)
                tr = read_trajectory(rec, name)
                if tr is not None:
                    traj[fid, name] = tr
    low_style = {'color': 'tab:blue', 'lw': 1.3}
    mixed_style = {'color': 'tab:red', 'lw': 1.1, 'ls': '--'}
    if ('low', 'initial') in traj and ('mixed', 'initial') in traj:
        jobs.append(
            lambda: plot_set(
                figs / 'initial_design.png',
                'Initial design: low- vs mixed-fidelity model — paper Fig. 4',
                [
                    ('low fidelity', traj['low', 'initial'], low_style),
                    ('mixed fidelity', traj['mixed', 'initial'], mixed_style),
                ],
                terms,
                labels,
            )
        )
    if ('low', 'low_optimum') in traj and ('mixed', 'mixed_optimum') in traj:
        jobs.append(
            lambda: plot_set(
                figs / 'optima.png',
                'Optimal designs: low-fidelity optimum (low-fidelity model) vs mixed-fidelity '
                'optimum (multibody) — paper Fig. 5',
                [
                    (
                        'low-fidelity optimum, low-fidelity model',
                        traj['low', 'low_optimum'],
                        low_style,
                    ),
                    (
                        'mixed-fidelity optimum, mixed-fidelity model',
                        traj['mixed', 'mixed_optimum'],
                        mixed_style,
                    ),
                ],
                terms,
                labels,
            )
        )
    if ('mixed', 'low_optimum') in traj and ('mixed', 'mixed_optimum') in traj:
        curves = [
            (DESIGN_LABELS[n].lower(), traj['mixed', n], st)
            for n, st in (
                ('initial', {'color': 'gray', 'lw': 1.0}),
                ('low_optimum', low_style),
                ('mixed_optimum', mixed_style),
            )
            if ('mixed', n) in traj
        ]
        jobs.append(
            lambda: plot_set(
                figs / 'cross_evaluation.png',
                'All three designs in the mixed-fidelity (multibody) model',
                curves,
                terms,
                labels,
            )
        )
    tm_path = out / 'time_marching.npz'
    if tm_path.exists() and traj:
        try:
            data = np.load(tm_path)
        except Exception as err:  # numpy's and zipfile's errors of a damaged file
            raise ConfigError(f'{tm_path}: damaged ({err})') from None

        def verification_figure() -> Path:
            panels = panel_specs(terms)
            fig, axes = panel_figure('Collocation (markers) vs time marching (lines)', panels)
            for (fid, name), style in (
                (('low', 'low_optimum'), low_style),
                (('mixed', 'mixed_optimum'), mixed_style),
            ):
                key = f'{fid}/{name}'
                if (fid, name) not in traj or f'{key}/t' not in data:
                    continue
                tm = {k.split('/')[-1]: data[k] for k in data.files if k.startswith(key + '/')}
                for ax, (sig, _, _) in zip(axes, panels):
                    plot_curves(
                        ax,
                        sig,
                        tm['t'],
                        tm,
                        labels,
                        f'{fid} fidelity, time marching',
                        dict(style, lw=0.9, ls='-'),
                    )
                    plot_curves(
                        ax,
                        sig,
                        traj[fid, name].t,
                        traj[fid, name].values,
                        labels,
                        f'{fid} fidelity, collocation nodes',
                        style,
                        marker=True,
                    )
            axes[0].legend(fontsize=7)
            save_figure(fig, figs / 'verification.png', dpi=110)
            plt.close(fig)
            return figs / 'verification.png'

        jobs.append(verification_figure)
    steps = {fid: step for fid, step in study.get('steps', {}).items() if step}
    if steps:
        jobs.append(lambda: _convergence_figure(figs / 'convergence.png', steps))
    return written + draw_figures(jobs)


def draw_figures(jobs: list[Callable[[], Path]]) -> list[Path]:
    """Run the figure-drawing ``jobs`` side by side, one background process per core
    (:mod:`suspopt.background`; here, one after another, on one core or where that is not
    available); their paths, in order."""
    from suspopt.verification.background import Background, usable_cores

    cores = usable_cores()
    with Background(jobs=cores if len(jobs) > 1 and cores > 1 else 0) as bg:
        for k, job in enumerate(jobs):
            bg.submit(str(k), job)
        return [bg.result(str(k)) for k in range(len(jobs))]


# ---------------------------------------------------------------------------- coupling
def coupling_markdown(res: dict[str, Any]) -> str:
    """The tables of a ``suspopt coupling`` directory (:mod:`suspopt.coupling`)."""
    DESIGN_LABELS, DESIGNS, MODEL_LABELS = (
        COUPLING_DESIGN_LABELS,
        COUPLING_DESIGNS,
        COUPLING_MODEL_LABELS,
    )
    names, ev, designs = res['design_names'], res['evaluations'], res.get('designs', {})
    cfg = res['config']
    out = [
        _scales_line(
            res['terms'], res['scales'], res['normalization'], cfg['objective']['weights']
        ),
        '',
        '**The four designs**',
        '',
        '| design | ' + ' | '.join(f'{n} [{_design_unit(n)}]' for n in names) + ' |',
        '|---|' + '---|' * len(names),
    ]
    for d in DESIGNS:
        if d in designs:
            out.append(
                f'| {DESIGN_LABELS[d]} | '
                + ' | '.join(f'{designs[d][n]:.0f}' for n in names)
                + ' |'
            )
    out += [
        '',
        '**f of every design in every model** (collocation; time marching in '
        'brackets; bold: the optimum of that model)',
        '',
        '| design | ' + ' | '.join(MODEL_LABELS.values()) + ' |',
        '|---|' + '---|' * len(MODEL_LABELS),
    ]

    def cell(m: str, d: str) -> str:
        e = ev.get(m, {}).get(d)
        if not e:
            return '—'
        v = e.get('verification') or {}
        tm = f' ({v["objective"]:.4f})' if v.get('objective') is not None else ''
        flag = '' if e.get('verified') is not False else ' **NOT verified**'
        f = f'{e["objective"]:.4f}' if e.get('objective') is not None else '—'
        return (f'**{f}**' if DESIGNS[d] == m else f) + tm + flag

    for d in DESIGNS:
        out.append(f'| {DESIGN_LABELS[d]} | ' + ' | '.join(cell(m, d) for m in MODEL_LABELS) + ' |')
    out += [
        '',
        '**Collocation vs time marching** (largest relative difference over the J_k)',
        '',
        '| design | ' + ' | '.join(MODEL_LABELS) + ' |',
        '|---|' + '---|' * len(MODEL_LABELS),
    ]
    for d in DESIGNS:
        row = []
        for m in MODEL_LABELS:
            v = (ev.get(m, {}).get(d) or {}).get('verification') or {}
            row.append(f'{v["max_rel_diff"]:.2g}' if 'max_rel_diff' in v else '—')
        out.append(f'| {DESIGN_LABELS[d]} | ' + ' | '.join(row) + ' |')
    out += [
        '',
        '**Objective terms J_k** (collocation)',
        '',
        '| design | model | ' + ' | '.join(res['terms']) + ' |',
        '|---|---|' + '---|' * len(res['terms']),
    ]
    for d in DESIGNS:
        for m in MODEL_LABELS:
            e = ev.get(m, {}).get(d)
            if e and e.get('terms'):
                out.append(
                    f'| {DESIGN_LABELS[d]} | {m} | '
                    + ' | '.join(f'{e["terms"][t]:.5g}' for t in res['terms'])
                    + ' |'
                )
    s = res.get('summary')
    if s:
        change = ', '.join(f'{n} {100 * v:+.1f} %' for n, v in s['design_change'].items())
        out += [
            '',
            f'**What the coupling assumption moves.** From the paper-coupling optimum '
            f'to the consistent one: {change}. The paper-coupling optimum has f = '
            f'{s["f_chassis_at_ground_optimum"]:.4f} in the chassis-mounted model, '
            f'{100 * s["loss_of_paper_optimum_in_chassis_model"]:+.1f} % against that '
            f"model's own optimum ({s['f_chassis_at_chassis_optimum']:.4f}); the "
            'consistent optimum has f = '
            f'{s["f_ground_at_chassis_optimum"]:.4f} in the ground-mounted model '
            f'(its optimum: {s["f_ground_at_ground_optimum"]:.4f}).',
        ]
    if res.get('wall_time_s') is not None:
        out += ['', f'Whole run: {res["wall_time_s"]:.1f} s.']
    for w in res.get('warnings', []):
        out += ['', f'**Warning:** {w}']
    return '\n'.join(out) + '\n'


def render_coupling(out_dir: str | Path) -> list[Path]:
    """Write ``table.md`` and ``figures/coupling.png`` of a coupling directory."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    DESIGN_LABELS, DESIGNS, MODEL_LABELS = (
        COUPLING_DESIGN_LABELS,
        COUPLING_DESIGNS,
        COUPLING_MODEL_LABELS,
    )
    out = Path(out_dir)
    res = read_json(out / 'coupling.json')
    write_text(out / 'table.md', coupling_markdown(res))
    figs = out / 'figures'
    figs.mkdir(exist_ok=True)
    ev, designs, names = res['evaluations'], res.get('designs', {}), res['design_names']
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 4.4), constrained_layout=True)
    width = 0.8 / len(MODEL_LABELS)
    for k, (m, label) in enumerate(MODEL_LABELS.items()):
        vals = [(ev.get(m, {}).get(d) or {}).get('objective') for d in DESIGNS]
        xs = [i + (k - 1) * width for i in range(len(DESIGNS))]
        a1.bar(
            [x for x, v in zip(xs, vals) if v is not None],
            [v for v in vals if v is not None],
            width,
            label=label,
        )
    a1.set_xticks(range(len(DESIGNS)))
    a1.set_xticklabels(
        [DESIGN_LABELS[d].split(' (')[0].replace(' optimum', '\noptimum') for d in DESIGNS],
        fontsize=8,
    )
    a1.set_ylabel('f (collocation, verified by time marching)')
    a1.set_title('Every design in every model')
    a1.legend(fontsize=8)
    bounds = res['config']['design']
    for d in DESIGNS:
        if d in designs:
            rel = [
                (designs[d][n] - bounds[n]['lower']) / (bounds[n]['upper'] - bounds[n]['lower'])
                for n in names
            ]
            a2.plot(range(len(names)), rel, 'o-', label=DESIGN_LABELS[d])
    a2.set_xticks(range(len(names)))
    a2.set_xticklabels(names)
    a2.set_ylim(-0.05, 1.05)
    a2.set_ylabel('design within its bounds (0 lower, 1 upper)')
    a2.set_title('The designs')
    a2.legend(fontsize=7)
    path = figs / 'coupling.png'
    save_figure(fig, path, dpi=120)
    plt.close(fig)
    return [out / 'table.md', path]
