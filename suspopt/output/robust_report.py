"""Table and figure of a robust-design study (:class:`~suspopt.records.robust.RobustStudy`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from suspopt.output.figures import save_figure
from suspopt.output.format import (
    FIDELITY_LABELS,
    aggregate_formula,
    constraint_table,
    design_columns,
    obj,
    scales_line,
    verdict,
)
from suspopt.output.rundir import write_text
from suspopt.records.robust import ROBUST, RobustStudy


def _bold_if(x: float, best: float | None) -> str:
    return f'**{x:.4f}**' if x == best else f'{x:.4f}'


def robust_markdown(data: RobustStudy) -> str:
    """The robustness table (:mod:`suspopt.studies.robust`), as Markdown."""
    names, scen = data.design_names, data.scenarios
    agg = data.formula()
    weighted = data.aggregate != 'max'  # the worst case takes no weights (refused)
    named = list(zip(scen, data.weights))
    listed = ', '.join(f'{n} (w = {w:g})' if weighted else n for n, w in named)
    lines = [
        f'Robust design, {FIDELITY_LABELS[data.fidelity]} model: {len(scen)} scenarios '
        f'({listed}), objective {agg} = {aggregate_formula(named, data.aggregate)}'
        + ('' if weighted else ' (the worst case: no scenario weights)')
        + ', each f_s normalized by its own scales.',
        '',
        scales_line(
            tuple(data.scales[0]) if data.scales else (),
            data.scales,
            (data.config.get('objective') or {}).get('normalization', ''),
            (data.config.get('objective') or {}).get('weights', {}),
            list(zip(scen, data.weights)),
            data.aggregate,
        )
        if data.scales
        else '',
        '',
        '**Optima** (collocation, each in its own problem)',
        '',
        f'| optimum | {design_columns(names)} | f | IPOPT | iterations | |',
        '|---|' + '---|' * (len(names) + 4),
    ]
    for label, res in data.optima.items():
        d = res.design
        lines.append(
            f'| {label} | '
            + ' | '.join(f'{d[n]:.0f}' for n in names)
            + f' | {obj(res.objective)} | {res.status} | {res.iterations} '
            f'| {verdict(res)} |'
        )
    lines += [
        '',
        '**Every optimum on every scenario** (f_s by time marching; the best on each '
        'scenario in bold)',
        '',
        '| optimum | ' + ' | '.join(scen) + f' | {agg} |',
        '|---|' + '---|' * (len(scen) + 1),
    ]
    cross = data.cross
    best = {s: min((c.scenarios[s] for c in cross.values()), default=None) for s in scen}
    best_agg = min((c.aggregate for c in cross.values()), default=None)

    for label, c in cross.items():
        cells = [_bold_if(c.scenarios[s], best[s]) for s in scen]
        lines.append(
            f'| {label} | ' + ' | '.join(cells) + f' | {_bold_if(c.aggregate, best_agg)} |'
        )
    robust = data.optima.get(ROBUST)
    if robust is not None and robust.constraints:
        lines += ['', '**Constraints at the robust optimum** (over every scenario)', '']
        lines += constraint_table(robust)
    if data.wall_time_s is not None:
        lines += ['', f'{len(data.optima)} optimizations: {data.wall_time_s:.1f} s in all.']
    return '\n'.join(lines) + '\n'


def render_robust(out: Path, data: RobustStudy) -> list[Path]:
    """Write ``table.md`` and ``figures/robustness.png`` of a robust-design directory."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    write_text(out / 'table.md', robust_markdown(data))
    figs = out / 'figures'
    figs.mkdir(exist_ok=True)
    cross, scen = data.cross, data.scenarios
    fig, ax = plt.subplots(figsize=(max(6.0, 1.6 * len(scen) + 2), 4), constrained_layout=True)
    width = 0.8 / max(len(cross), 1)
    for k, (label, c) in enumerate(cross.items()):
        x = np.arange(len(scen)) + (k - (len(cross) - 1) / 2) * width
        ax.bar(
            x,
            [c.scenarios[s] for s in scen],
            width,
            label=f'{label} optimum',
            hatch='//' if label == ROBUST else None,
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
