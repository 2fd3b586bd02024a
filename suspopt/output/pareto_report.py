"""Table and figure of a comfort/road-holding Pareto front
(:class:`~suspopt.records.pareto.ParetoFront`)."""

from __future__ import annotations

from pathlib import Path

from suspopt.output.figures import save_figure
from suspopt.output.format import FIDELITY_LABELS, design_columns, obj, verdict
from suspopt.output.rundir import write_text
from suspopt.records.pareto import ParetoFront


def pareto_markdown(front: ParetoFront) -> str:
    """A comfort/road-holding front (:mod:`suspopt.studies.pareto`), as Markdown."""
    names = front.design_names
    lines = [
        f'Pareto front of the {FIDELITY_LABELS[front.fidelity]} model: comfort C '
        '(mean of the normalized chassis terms) against road holding R (mean of the '
        f'normalized wheel terms), `{front.normalization}` normalization; weights '
        'α/n_C on each chassis term and (1−α)/n_R on each wheel term for comfort share α.',
        '',
        f'| α | {design_columns(names)} | C | R | f_α | IPOPT | iterations | |',
        '|---|' + '---|' * (len(names) + 6),
    ]
    for pt in front.points:
        d, res = pt.result.design, pt.result
        lines.append(
            f'| {pt.alpha:.3f} | '
            + ' | '.join(f'{d[n]:.0f}' for n in names)
            + f' | {obj(pt.comfort)} | {obj(pt.road_holding)} | '
            f'{obj(res.objective)} | {res.status} | {res.iterations} | '
            f'{verdict(res)} |'
        )
    init = front.initial
    if init is not None and init.comfort is not None and init.road_holding is not None:
        d = init.design
        lines.append(
            '| initial design | '
            + ' | '.join(f'{d[n]:.0f}' for n in names)
            + f' | {init.comfort:.4f} | {init.road_holding:.4f} | | | | |'
        )
    if front.wall_time_s is not None:
        lines += [
            '',
            f'{len(front.points)} optimizations on one problem: {front.wall_time_s:.1f} s in all.',
        ]
    return '\n'.join(lines) + '\n'


def render_pareto(out: Path, front: ParetoFront) -> list[Path]:
    """Write ``table.md`` and ``figures/pareto.png`` of a Pareto directory."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    write_text(out / 'table.md', pareto_markdown(front))
    figs = out / 'figures'
    figs.mkdir(exist_ok=True)
    ok = [p for p in front.points if p.success]
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
    a1.plot(
        [p.comfort for p in ok],
        [p.road_holding for p in ok],
        'o-',
        color='tab:blue',
        label='optima (IPOPT converged)',
    )
    for p in ok:
        a1.annotate(
            f'α={p.alpha:.2f}',
            (p.comfort, p.road_holding),
            textcoords='offset points',
            xytext=(5, 4),
            fontsize=8,
        )
    bad = [p.reached for p in front.points if not p.success or p.result.verified is False]
    bad = [b for b in bad if None not in b]
    if bad:
        a1.plot(
            [c for c, _ in bad],
            [r for _, r in bad],
            'x',
            color='tab:red',
            label='not converged (where IPOPT stopped) or not verified',
        )
    init = front.initial
    if init is not None and init.comfort is not None:
        a1.plot(
            [init.comfort],
            [init.road_holding],
            's',
            color='gray',
            label='initial design, same model',
        )
    a1.set(
        xlabel='comfort C (smaller: smoother ride)',
        ylabel='road holding R (smaller: better grip)',
        title=f'Pareto front, {FIDELITY_LABELS[front.fidelity]} model',
    )
    a1.grid(alpha=0.3)
    a1.legend(fontsize=8)
    for name, style in zip(front.design_names, ('o-', 's-', '^--', 'v--', 'd-.', 'x-.')):
        lo, hi = front.bounds[name]
        a2.plot(
            [p.alpha for p in ok],
            [(p.result.design[name] - lo) / (hi - lo) for p in ok],
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
