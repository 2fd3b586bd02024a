"""Tables and figures of a topology study (:class:`~suspopt.records.compare.CompareStudy`),
from its directory.

Reads only ``compare.json`` and the case recorders the study wrote (``suspopt report DIR``
dispatches here on a ``compare`` manifest). Writes ``table.md`` and

* ``figures/trajectories.png`` — chassis accelerations and wheel travel of every topology
  at its own optimum (and the low-fidelity model at its optimum);
* ``figures/kinematics.png`` — motion ratio, wheel rate, camber and track change of every
  mechanism over the common wheel travel;
* ``figures/cross.png`` — the cross table as a picture: each design's excess over the
  model's own optimum;
* ``figures/road.png`` — the road under every wheel.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from suspopt.output.figures import plot_set, read_setting, road_figure, save_figure
from suspopt.output.format import (
    design_columns,
    scenario_terms,
    study_scales_line,
    term_columns,
)
from suspopt.output.rundir import read_trajectory, write_text
from suspopt.records.compare import LOW, CompareStudy, Kinematics, MechanismCurves
from suspopt.records.solve import SolveRecord

COLORS = (
    'tab:red',
    'tab:green',
    'tab:purple',
    'tab:orange',
    'tab:brown',
    'tab:pink',
    'tab:olive',
    'tab:cyan',
)
MARK = {True: '✓', False: '✗', None: '·'}
LOW_STYLE = {'color': 'tab:blue', 'lw': 1.0, 'ls': ':'}


def model_label(data: CompareStudy, model: str) -> str:
    if model == LOW:
        return f'{data.vehicle_model.replace("_", " ")} (low fidelity)'
    return next(t.label for t in data.topologies if t.model == model)


def design_label(data: CompareStudy, design: str) -> str:
    if design == 'initial':
        return 'initial design'
    if design == 'low_optimum':
        return 'low-fidelity optimum'
    return next(f'{t.label} optimum' for t in data.topologies if t.optimum == design)


def _mark(rec: SolveRecord | None) -> str:
    if rec is None:
        return ''
    if not rec.success:
        return 'failed'
    return MARK[rec.verified]


def _range(c: MechanismCurves, key: str, scale: float, digits: int) -> str:
    lo, hi = (f'{scale * x:.{digits}f}' for x in (min(c.curve(key)), max(c.curve(key))))
    return ' … '.join(x if x.strip('-0.') else x.lstrip('-') for x in (lo, hi))


def _header(data: CompareStudy) -> list[str]:
    """Warnings, failures, and the normalization."""
    lines = [f'**Warning:** {w}' for w in data.warnings]
    if not data.complete:
        lines.append(
            '**Incomplete:** the study '
            + ('was interrupted' if data.interrupted else 'did not finish')
            + '; what finished is shown.'
        )
    if not data.verify:
        lines.append('**Not checked:** time-marching verification was skipped (--no-verify).')
    for f in data.failures:
        where = f.model + (f' at {f.design}' if f.design else '')
        lines.append(f'**Failed:** {f.what} in {where}: {f.status} {f.message}'.rstrip())
    return (
        lines
        + ([''] if lines else [])
        + [
            study_scales_line(
                data.config, data.terms, data.scales, data.normalization, data.weights
            ),
            '',
            'Every topology is optimized from the low-fidelity optimum.',
            '',
        ]
    )


def _linkages(kin: Kinematics | None) -> list[str]:
    if kin is None or not kin.curves:
        return []
    lo, hi = kin.travel_range
    lines = [
        f'**The linkages** (reference pose; wheel rate for k = {kin.spring_rate:g} '
        f'N/m; ranges over the wheel travel {1e3 * lo:g} … {1e3 * hi:g} mm)',
        '',
        '| mechanism | moving mass [kg] | motion ratio | wheel rate / k | motion '
        'ratio range | camber range [deg] | track change range [mm] |',
        '|---|---|---|---|---|---|---|',
    ]
    for lab, c in kin.curves.items():
        ref = c.at_reference
        lines.append(
            f'| {lab} | {c.moving_mass_kg:.1f} | {ref["motion_ratio"]:.4f} | '
            f'{ref["wheel_rate"] / kin.spring_rate:.4f} | '
            f'{_range(c, "motion_ratio", 1.0, 3)} | {_range(c, "camber", 1.0, 2)} | '
            f'{_range(c, "track_change", 1e3, 1)} |'
        )
    return lines + ['']


def _optima(data: CompareStudy) -> list[str]:
    names = data.design_names
    lines = [
        '**Optima** (each in its own model)',
        '',
        f'| model | {design_columns(names)} | f | IPOPT | iterations | solve [s] | verified |',
        '|---|' + '---|' * (len(names) + 5),
    ]
    for m in data.models:
        st = data.steps.get(m)
        if st is None:
            continue
        d, f = st.design, st.objective
        solve = st.times.solve_s if st.times is not None else None
        lines.append(
            f'| {model_label(data, m)} | '
            + ' | '.join(f'{d[n]:.0f}' if n in d else '—' for n in names)
            + f' | {"—" if f is None else f"{f:.4f}"} | {st.status} | '
            f'{st.iterations} | {"—" if solve is None else f"{solve:.2f}"} | '
            f'{_mark(st)} |'
        )
    return lines


def _cross_cell(data: CompareStudy, d: str, m: str) -> str:
    c = data.cell(d, m)
    if c is None:
        return '—'
    if not c.success:
        return f'failed ({c.status})'
    comparison = c.verification.comparison
    f = f'{c.objective:.4f}'
    best = data.best.get(m)
    if best is not None and best.best == d:
        f = f'**{f}**'
    tm = f' ({comparison.objective:.4f})' if comparison is not None else ''
    return f + tm + f' {_mark(c)}'


def _excess_cell(data: CompareStudy, d: str, m: str) -> str:
    best = data.best.get(m)
    e = best.excess.get(d) if best is not None else None
    return '—' if e is None else f'{100 * e:+.1f} %'


def _agreement_cell(data: CompareStudy, d: str, m: str) -> str:
    c = data.cell(d, m)
    comparison = c.verification.comparison if c is not None else None
    if comparison is None:
        return '—'
    return f'{100 * comparison.max_rel_diff:.3f} % ({comparison.scenarios[0].worst_term})' + (
        '' if comparison.agrees else ' **NOT verified**'
    )


def _design_by_model(
    data: CompareStudy, title: str, cell: Callable[[CompareStudy, str, str], str]
) -> list[str]:
    """A design × model table under ``title``, one cell per (design, model)."""
    models = data.models
    designs = [d for d in data.design_order if d in data.designs]
    return [
        '',
        title,
        '',
        '| design \\ model | ' + ' | '.join(model_label(data, m) for m in models) + ' |',
        '|---|' + '---|' * len(models),
    ] + [
        f'| {design_label(data, d)} | ' + ' | '.join(cell(data, d, m) for m in models) + ' |'
        for d in designs
    ]


def compare_markdown(data: CompareStudy) -> str:
    """The topology study as Markdown (see the module docstring)."""
    terms = data.terms
    lines = _header(data) + _linkages(data.kinematics) + _optima(data)
    lines += _design_by_model(
        data,
        '**Cross table: f of every design in every model** (collocation; time '
        'marching in brackets; ✓ verified by time marching within '
        f'{100 * data.tolerance:g} %, ✗ NOT verified, · not '
        'checked; bold: the best design in that model)',
        _cross_cell,
    )
    if data.best:
        lines += _design_by_model(
            data,
            "**Excess over the model's own optimum**, f / f* − 1 (what a design "
            'found on another model costs in this one)',
            _excess_cell,
        )
    lines += _design_by_model(
        data,
        '**Collocation vs time marching** (largest relative difference over the '
        'weighted J_k, and the term)',
        _agreement_cell,
    )
    several = len(data.scales) > 1
    lines += [
        '',
        "**Objective terms J_k at each model's own optimum** (collocation"
        + (', every scenario)**' if several else ')**'),
        '',
        '| model | ' + ('scenario | ' if several else '') + f'{term_columns(terms)} |',
        '|---|' + ('---|' if several else '') + '---|' * len(terms),
    ]
    for m in data.models:
        best = data.best.get(m)
        c = data.cell(best.own_optimum, m) if best is not None else None
        for scenario, J in scenario_terms(c):
            if J:
                lines.append(
                    f'| {model_label(data, m)} | '
                    + (f'{scenario} | ' if several else '')
                    + ' | '.join(f'{J[t]:.5g}' for t in terms)
                    + ' |'
                )
    if data.wall_time_s is not None:
        n = sum(1 for c in data.cells.values() if c.mode == 'evaluate')
        lines += [
            '',
            f'{len(data.steps)} optimizations and {n} evaluations, '
            f'{data.wall_time_s:.1f} s in all.',
        ]
    return '\n'.join(lines) + '\n'


# ---------------------------------------------------------------------------- figures
def _kinematics_figure(path: Path, kin: Kinematics) -> Path:
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    panels = (
        ('motion_ratio', 'motion ratio [-]', 1.0),
        ('wheel_rate', f'wheel rate [N/mm] (k = {kin.spring_rate:g} N/m)', 1e-3),
        ('camber', 'camber [deg]', 1.0),
        ('track_change', 'track change [mm]', 1e3),
    )
    fig, axes = plt.subplots(2, 2, figsize=(10, 6.6), sharex=True, constrained_layout=True)
    for (lab, c), color in zip(kin.curves.items(), COLORS):
        w = np.asarray(c.travel) * 1e3
        for ax, (key, _, scale) in zip(axes.flat, panels):
            ax.plot(w, np.asarray(c.curve(key)) * scale, '-', color=color, lw=1.6, label=lab)
    for ax, (_, head, _) in zip(axes.flat, panels):
        ax.set_ylabel(head)
        ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel('wheel travel [mm] (up: bump)')
    axes[0, 0].legend(fontsize=8)
    fig.suptitle('Kinematic curves of the linkages (front view)')
    save_figure(fig, path, dpi=100)
    plt.close(fig)
    return path


def _cross_text(c: SolveRecord | None, excess: float) -> str:
    if c is None:
        return '—'
    if not c.success or c.objective is None:
        return 'failed'
    if np.isfinite(excess):
        return f'{c.objective:.3f}\n{excess:+.1f} % {_mark(c)}'
    return f'{c.objective:.3f} {_mark(c)}'


def _cross_figure(path: Path, data: CompareStudy) -> Path:
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    models = data.models
    designs = [d for d in data.design_order if d in data.designs]
    E = np.full((len(designs), len(models)), np.nan)
    for i, d in enumerate(designs):
        for j, m in enumerate(models):
            best = data.best.get(m)
            e = best.excess.get(d) if best is not None else None
            if e is not None:
                E[i, j] = 100 * e
    fig, ax = plt.subplots(
        figsize=(1.9 * len(models) + 3, 0.65 * len(designs) + 1.8), constrained_layout=True
    )
    vmax = float(np.nanmax(E)) if np.isfinite(E).any() else 1.0
    im = ax.imshow(E, cmap='Reds', vmin=0.0, vmax=max(vmax, 1e-9), aspect='auto')
    for i, d in enumerate(designs):
        for j, m in enumerate(models):
            ax.text(
                j,
                i,
                _cross_text(data.cell(d, m), E[i, j]),
                ha='center',
                va='center',
                fontsize=8,
                color='white' if np.isfinite(E[i, j]) and E[i, j] > 0.6 * vmax else 'black',
            )
    ax.set_xticks(range(len(models)), [model_label(data, m) for m in models], rotation=15)
    ax.set_yticks(range(len(designs)), [design_label(data, d) for d in designs])
    ax.set_xlabel('model the design is evaluated in')
    ax.set_title(
        "f of every design in every model; colour: excess over the model's own optimum [%]",
        fontsize=10,
    )
    fig.colorbar(im, ax=ax, label='f / f* − 1 [%]')
    save_figure(fig, path, dpi=100)
    plt.close(fig)
    return path


def render_compare(out: Path, data: CompareStudy, file: str) -> list[Path]:
    """Write ``table.md`` and ``figures/`` of a topology-study directory."""
    import matplotlib

    matplotlib.use('Agg')

    write_text(out / 'table.md', compare_markdown(data))
    figs = out / 'figures'
    figs.mkdir(exist_ok=True)
    setting = read_setting(out, data.config, file)
    written = [out / 'table.md', road_figure(figs / 'road.png', setting)]
    if data.kinematics is not None and data.kinematics.curves:
        written.append(_kinematics_figure(figs / 'kinematics.png', data.kinematics))
    if data.cells:
        written.append(_cross_figure(figs / 'cross.png', data))
    own = [('low', 'low_optimum', 'low-fidelity model at its optimum', LOW_STYLE)]
    own += [
        (t.model, t.optimum, f'{t.label} at its optimum', {'color': c, 'lw': 1.2})
        for t, c in zip(data.topologies, COLORS)
    ]
    curves = []
    for model, design, label, style in own:
        rec = out / data.recorders[model]
        if rec.exists() and data.cell(design, model) is not None:
            tr = read_trajectory(rec, design)
            if tr is not None:
                curves.append((label, tr, style))
    if curves:
        title = 'Every topology at its own optimum (collocation)'
        written.append(plot_set(figs / 'trajectories.png', title, curves, setting.layout))
    return written
