"""A sweep's summary: ``summary.csv`` and ``table.md`` (one row per task) and the figures
(the objective against each swept axis; a multistart: the optima found and how many
distinct ones), rendered from the directory's records (:mod:`suspopt.sweep.store`) at the
end of a run and on demand: :func:`render` is what ``suspopt report DIR`` calls for a
sweep's directory (one whose ``manifest.json`` says ``"kind": "sweep"``). Nothing here is
written per finished task. A live sweep's directory can be rendered too: it shows the
tasks finished so far."""

from __future__ import annotations

import csv
import io
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

from suspopt.output.rundir import write_text
from suspopt.sweep.spec import Sweep
from suspopt.sweep.store import read_records, read_sweep
from suspopt.sweep.tasks import Task, TaskRecord, final_step, fmt, safe

#: two optima count as one when every design variable agrees to this fraction of its range
DISTINCT_TOL = 1e-3
STATES = ('pending', 'done', 'failed')


def render(directory: str | Path) -> list[Path]:
    """Re-render ``summary.csv``, ``table.md`` and ``figures/`` of a sweep's directory
    from its records; the paths written. Raises :class:`ConfigError` if ``directory`` is
    not a sweep's."""
    directory = Path(directory)
    sweep = read_sweep(directory)
    return write_summary(directory, sweep, read_records(directory))


def write_summary(
    out: Path,
    sweep: Sweep,
    records: dict[str, TaskRecord],
    warn: Callable[[str], None] | None = None,
) -> list[Path]:
    """Write the summary files (atomically); figures that cannot be drawn are reported
    to ``warn`` if given (they are a view of the records), raised otherwise."""
    rows = [summary_row(t, records.get(t.name)) for t in sweep.tasks]
    cols = columns(rows, sweep.axes)
    write_text(out / 'summary.csv', csv_text(rows, cols))
    write_text(out / 'table.md', table_markdown(sweep, rows, cols))
    written = [out / 'summary.csv', out / 'table.md']
    try:
        written += write_figures(out, sweep, rows)
    except Exception as err:
        if warn is None:
            raise
        warn(f'figures not written: {type(err).__name__}: {err}')
    return written


def summary_row(task: Task, rec: TaskRecord | None) -> dict[str, Any]:
    """One row of summary.csv / table.md (the one place a task's summary is computed)."""
    row: dict[str, Any] = {'task': task.name, 'state': rec.state if rec else 'pending'}
    for k, v in task.values.items():
        if k == 'start':  # its index; the design itself is in sweep.json and the record
            row[k] = task.start_index
        else:
            row[k] = fmt(v) if not isinstance(v, (int, float)) or isinstance(v, bool) else v
    if task.command == 'optimize':
        row['fidelity'] = task.fidelity
    final = final_step(task.command, rec.result if rec else None)
    row['objective'] = final.get('objective')
    row.update(final.get('design') or {})
    row.update(final.get('terms') or {})
    for k in ('success', 'verified', 'status', 'iterations'):
        row[k] = final.get(k)
    row['wall_time_s'] = rec.wall_time_s if rec else None
    row['attempts'] = rec.attempts if rec else None
    row['error'] = rec.error if rec else None
    return row


def columns(rows: list[dict[str, Any]], axes: list[str]) -> list[str]:
    cols: list[str] = ['task', 'state', *axes]
    seen = set(cols)
    for r in rows:
        for k in r:
            if k not in seen:
                cols.append(k)
                seen.add(k)
    return cols


def counts(rows: list[dict[str, Any]]) -> dict[str, int]:
    return {s: sum(r['state'] == s for r in rows) for s in STATES} | {'total': len(rows)}


def csv_text(rows: list[dict[str, Any]], cols: list[str]) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=cols, lineterminator='\n')
    w.writeheader()
    for r in rows:
        w.writerow({k: '' if r.get(k) is None else r.get(k) for k in cols})
    return buf.getvalue()


def _cell(v: Any) -> str:
    if v is None:
        return ''
    if isinstance(v, float):
        return f'{v:.6g}'
    return str(v).replace('|', '\\|')


def table_markdown(sweep: Sweep, rows: list[dict[str, Any]], cols: list[str]) -> str:
    c = counts(rows)
    show = [k for k in cols if k != 'task' and not re.fullmatch(r'J\d', k)]
    lines = [
        f'Sweep {sweep.path.name}: {c["total"]} tasks, {c["done"]} done, '
        f'{c["failed"]} failed, {c["pending"]} pending.',
        '',
        '| ' + ' | '.join(show) + ' |',
        '|' + '---|' * len(show),
    ]
    lines += ['| ' + ' | '.join(_cell(r.get(k)) for k in show) + ' |' for r in rows]
    return '\n'.join(lines) + '\n'


# ------------------------------------------------------------------ figures
def distinct_optima(
    designs: list[dict[str, float]],
    bounds: dict[str, tuple[float, float]],
    tol: float = DISTINCT_TOL,
) -> list[int]:
    """A cluster index per design: designs closer than ``tol`` of each variable's range
    (in every variable) are one optimum."""
    reps: list[dict[str, float]] = []
    out = []
    for d in designs:
        for i, r in enumerate(reps):
            if all(abs(d[k] - r[k]) <= tol * (hi - lo) for k, (lo, hi) in bounds.items()):
                out.append(i)
                break
        else:
            reps.append(d)
            out.append(len(reps) - 1)
    return out


Groups = dict[str, list[tuple[Any, dict[str, Any]]]]


def write_figures(out: Path, sweep: Sweep, rows: list[dict[str, Any]]) -> list[Path]:
    """One figure per swept axis (objective against its values); for a start axis, the
    optima found and how many distinct ones."""
    pairs = [
        (t, r)
        for t, r in zip(sweep.tasks, rows)
        if r['state'] == 'done' and r['objective'] is not None
    ]
    if not pairs:
        return []
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    from suspopt.output.figures import save_figure

    written = []
    for axis in sweep.axes:
        fig, ax = plt.subplots(figsize=(6.4, 4.0))
        groups = _groups(pairs, axis, sweep.axes)
        if axis == 'start':
            title = _plot_multistart(ax, groups, _bounds(sweep))
        else:
            title = _plot_axis(ax, axis, groups)
        ax.set_title(title, fontsize=8)
        _readable_y(ax, [r['objective'] for _, r in pairs])
        ax.grid(alpha=0.3)
        fig.tight_layout()
        written.append(save_figure(fig, out / 'figures' / f'{safe(axis)}.png', dpi=110))
        plt.close(fig)
    return written


def _groups(pairs: list[tuple[Task, dict[str, Any]]], axis: str, axes: list[str]) -> Groups:
    """The tasks along ``axis``, grouped by their values of the other axes."""
    others = [a for a in axes if a not in (axis, 'start')]
    groups: Groups = {}
    for t, r in pairs:
        if axis in t.values:
            g = ', '.join(
                f'{a.rsplit(".", 1)[-1]}={fmt(t.values[a])}' for a in others if a in t.values
            )
            groups.setdefault(g, []).append((t.values[axis], r))
    return groups


def _bounds(sweep: Sweep) -> dict[str, tuple[float, float]]:
    design = sweep.description['base_config']['design']
    return {k: (dv['lower'], dv['upper']) for k, dv in design.items() if isinstance(dv, dict)}


def _readable_y(ax: Any, values: list[float]) -> None:
    """Plain tick labels; optima equal to many digits are not spread over the axis."""
    lo, hi = min(values), max(values)
    span = max(hi - lo, 1e-3 * max(abs(hi), abs(lo), 1e-12))
    mid = 0.5 * (lo + hi)
    ax.set_ylim(mid - 0.6 * span, mid + 0.6 * span)
    ax.ticklabel_format(axis='y', useOffset=False, style='plain')


def _plot_axis(ax: Any, axis: str, groups: Groups) -> str:
    values = [v for pts in groups.values() for v, _ in pts]
    numeric = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)
    cats: list[str] = []
    for g, pts in groups.items():
        if numeric:
            pts = sorted(pts, key=lambda p: p[0])
            xs = [p[0] for p in pts]
        else:
            cats += [fmt(v) for v, _ in pts if fmt(v) not in cats]
            xs = [cats.index(fmt(v)) for v, _ in pts]
        ax.plot(xs, [r['objective'] for _, r in pts], 'o-' if numeric else 'o', label=g or None)
    if not numeric:
        ax.set_xticks(range(len(cats)), cats, rotation=20, fontsize=8)
    elif all(isinstance(v, int) for v in values):
        from matplotlib.ticker import MaxNLocator

        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel(axis)
    ax.set_ylabel('objective f')
    if 1 < len(groups) <= 10:
        ax.legend(fontsize=7)
    return f'objective against {axis}'


def _plot_multistart(ax: Any, groups: Groups, bounds: dict[str, tuple[float, float]]) -> str:
    parts = []
    for g, pts in groups.items():
        pts = sorted(
            (p for p in pts if all(p[1].get(k) is not None for k in bounds)),
            key=lambda p: p[1]['objective'],
        )
        if not pts:
            continue
        cl = distinct_optima([{k: r[k] for k in bounds} for _, r in pts], bounds)
        n = max(cl) + 1
        parts.append(
            f'{g + ": " if g else ""}{n} distinct optim{"um" if n == 1 else "a"} '
            f'from {len(pts)} starts'
        )
        ax.scatter(
            range(len(pts)),
            [r['objective'] for _, r in pts],
            c=cl,
            cmap='tab10',
            vmin=0,
            vmax=9,
            s=28,
            label=g or None,
        )
    ax.set_xlabel('start (sorted by the objective of its optimum; colour: distinct optimum)')
    ax.set_ylabel('objective f of the optimum found')
    if 1 < len(groups) <= 10:
        ax.legend(fontsize=7)
    return '; '.join(parts) + f' (one optimum: within {DISTINCT_TOL:g} of each range)'
