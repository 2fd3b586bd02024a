"""Table and figures of one ``suspopt optimize`` run (:class:`~suspopt.records.solve.SolveRecord`
in ``result.json``, the case recorder ``cases.sql``): the road, the trajectories at the
design found (only of a converged result) and the convergence."""

from __future__ import annotations

from pathlib import Path

from suspopt.output.figures import plot_set, read_setting, road_figure, save_figure
from suspopt.output.format import (
    FIDELITY_LABELS,
    constraint_table,
    design_columns,
    fmt,
    record_scales_line,
    term_columns,
    verdict,
)
from suspopt.output.rundir import read_trajectory, write_text
from suspopt.records.solve import SolveRecord


def run_markdown(res: SolveRecord) -> str:
    """The result of one ``suspopt optimize`` run, as Markdown."""
    ok = res.success
    d = res.design
    names = list(d)
    lines = [
        f'**{res.fidelity}-fidelity {res.mode}** — '
        f'{"converged" if ok else "NOT converged"} ({res.status}), '
        + (f'{verdict(res)}, ' if ok else '')
        + f'{"—" if res.iterations is None else res.iterations} '
        f'IPOPT iterations, {fmt(res.wall_time_s, 3)} s',
        '',
        f'| | {design_columns(names)} | f |',
        '|---|' + '---|' * (len(names) + 1),
    ]
    for label, design, f in (
        ('start', res.start, None),
        ('result' if ok else 'stopped at (not a result)', d, res.objective),
    ):
        if design:
            lines.append(
                f'| {label} | '
                + ' | '.join(f'{design[n]:.0f}' for n in names)
                + f' | {"—" if f is None else f"{f:.4f}"} |'
            )
    rows: list[tuple[str, dict[str, float]]] = [
        (sc.name, terms) for sc in res.scenarios for terms in [sc.reached[1]] if terms
    ]
    if rows:
        several = len(res.scenarios) > 1
        if not ok:
            lines += ['', 'Objective terms where IPOPT stopped (NOT converged: not a result):']
        cols = list(rows[0][1])
        lines += [
            '',
            ('| scenario ' if several else '') + f'| {term_columns(cols)} |',
            ('|---' if several else '') + '|' + '---|' * len(cols),
        ]
        lines += [
            (f'| {name} ' if several else '') + '| ' + ' | '.join(fmt(J[t], 5) for t in cols) + ' |'
            for name, J in rows
        ]
    if res.constraints:
        lines += ['', 'Engineering constraints (collocation: its nodes; time marching: dense):', '']
        lines += constraint_table(res)
    c = res.verification.comparison
    if c is not None:
        lines += [
            '',
            f'Time marching: f = {c.objective:.4f}; largest relative difference '
            f'{c.max_rel_diff:.2g} (tolerance {c.tolerance:g}) — '
            f'{"verified" if c.agrees else "NOT verified"}.',
        ]
    elif res.verification.note:
        lines += ['', res.verification.note]
    if res.scales:
        lines += ['', record_scales_line(res)]
    if res.message and not res.success:
        lines += ['', f'Message: {res.message}']
    return '\n'.join(lines) + '\n'


def convergence_figure(path: Path, runs: dict[str, SolveRecord]) -> Path:
    """Objective and constraint violation per IPOPT iteration of each run (by fidelity)."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 3.8), constrained_layout=True)
    for fid, color in (('low', 'tab:blue'), ('mixed', 'tab:red')):
        run = runs.get(fid)
        hist = run.history if run is not None else ()
        if hist:
            it = [h.iteration for h in hist]
            style = {'color': color, 'ms': 3, 'label': FIDELITY_LABELS[fid]}
            a1.plot(it, [h.objective for h in hist], 'o-', **style)
            a2.semilogy(it, [max(h.constraint_violation, 1e-16) for h in hist], 'o-', **style)
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


def render_run(out: Path, res: SolveRecord, file: str) -> list[Path]:
    """Write ``table.md`` and the figures of a ``suspopt optimize`` directory."""
    write_text(out / 'table.md', run_markdown(res))
    figs = out / 'figures'
    figs.mkdir(exist_ok=True)
    written = [out / 'table.md']
    fid = res.fidelity
    if res.config is not None:
        setting = read_setting(out, res.config, file)
        written.append(road_figure(figs / 'road.png', setting))
        tr = (
            read_trajectory(out / 'cases.sql', f'{fid}_optimum')
            if (out / 'cases.sql').exists() and res.success
            else None
        )
        if tr is not None:  # only a converged result's trajectory
            style = {'color': 'tab:blue' if fid == 'low' else 'tab:red', 'lw': 1.2}
            title = f'The {FIDELITY_LABELS[fid]} model at the design found'
            curves = [(f'{fid} fidelity', tr, style)]
            written.append(plot_set(figs / 'trajectories.png', title, curves, setting.layout))
    if res.history:
        written.append(convergence_figure(figs / 'convergence.png', {fid: res}))
    return written
