"""Tables and figure of a coupling comparison (:class:`~suspopt.records.coupling.CouplingStudy`):
the four designs in the three models."""

from __future__ import annotations

from pathlib import Path

from suspopt.output.figures import save_figure
from suspopt.output.format import design_columns, scenario_terms, study_scales_line
from suspopt.output.rundir import write_text
from suspopt.records.coupling import (
    COUPLING_DESIGN_LABELS as DESIGN_LABELS,
)
from suspopt.records.coupling import (
    COUPLING_DESIGNS as DESIGNS,
)
from suspopt.records.coupling import (
    COUPLING_MODEL_LABELS as MODEL_LABELS,
)
from suspopt.records.coupling import (
    CouplingStudy,
    CouplingSummary,
)


def _cell(res: CouplingStudy, m: str, d: str) -> str:
    e = res.evaluation(m, d)
    if e is None:
        return '—'
    c = e.verification.comparison
    tm = f' ({c.objective:.4f})' if c is not None else ''
    flag = '' if e.verified is not False else ' **NOT verified**'
    f = f'{e.objective:.4f}' if e.objective is not None else '—'
    return (f'**{f}**' if DESIGNS[d] == m else f) + tm + flag


def _summary_text(s: CouplingSummary) -> str:
    change = ', '.join(f'{n} {100 * v:+.1f} %' for n, v in s.design_change.items())
    return (
        f'**What the coupling assumption moves.** From the paper-coupling optimum '
        f'to the consistent one: {change}. The paper-coupling optimum has f = '
        f'{s.f_chassis_at_ground_optimum:.4f} in the chassis-mounted model, '
        f'{100 * s.loss_of_paper_optimum_in_chassis_model:+.1f} % against that '
        f"model's own optimum ({s.f_chassis_at_chassis_optimum:.4f}); the "
        'consistent optimum has f = '
        f'{s.f_ground_at_chassis_optimum:.4f} in the ground-mounted model '
        f'(its optimum: {s.f_ground_at_ground_optimum:.4f}).'
    )


def coupling_markdown(res: CouplingStudy) -> str:
    """The tables of a ``suspopt coupling`` directory (:mod:`suspopt.studies.coupling`)."""
    names, designs = res.design_names, res.designs
    out = [
        study_scales_line(res.config, res.terms, res.scales, res.normalization, res.weights),
        '',
        '**The four designs**',
        '',
        f'| design | {design_columns(names)} |',
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
    for d in DESIGNS:
        out.append(
            f'| {DESIGN_LABELS[d]} | ' + ' | '.join(_cell(res, m, d) for m in MODEL_LABELS) + ' |'
        )
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
            e = res.evaluation(m, d)
            c = e.verification.comparison if e is not None else None
            row.append(f'{c.max_rel_diff:.2g}' if c is not None else '—')
        out.append(f'| {DESIGN_LABELS[d]} | ' + ' | '.join(row) + ' |')
    several = len(res.scales) > 1
    out += [
        '',
        '**Objective terms J_k** (collocation' + (', every scenario)' if several else ')'),
        '',
        '| design | model | ' + ('scenario | ' if several else '') + ' | '.join(res.terms) + ' |',
        '|---|---|' + ('---|' if several else '') + '---|' * len(res.terms),
    ]
    for d in DESIGNS:
        for m in MODEL_LABELS:
            e = res.evaluation(m, d)
            if e is None:
                continue
            for scenario, J in scenario_terms(e):
                if J:
                    out.append(
                        f'| {DESIGN_LABELS[d]} | {m} | '
                        + (f'{scenario} | ' if several else '')
                        + ' | '.join(f'{J[t]:.5g}' for t in res.terms)
                        + ' |'
                    )
    if res.summary is not None:
        out += ['', _summary_text(res.summary)]
    if res.wall_time_s is not None:
        out += ['', f'Whole run: {res.wall_time_s:.1f} s.']
    for w in res.warnings:
        out += ['', f'**Warning:** {w}']
    return '\n'.join(out) + '\n'


def render_coupling(out: Path, res: CouplingStudy) -> list[Path]:
    """Write ``table.md`` and ``figures/coupling.png`` of a coupling directory."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    write_text(out / 'table.md', coupling_markdown(res))
    figs = out / 'figures'
    figs.mkdir(exist_ok=True)
    designs, names = res.designs, res.design_names
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 4.4), constrained_layout=True)
    width = 0.8 / len(MODEL_LABELS)
    for k, (m, label) in enumerate(MODEL_LABELS.items()):
        vals = [_objective(res, m, d) for d in DESIGNS]
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
    for d in DESIGNS:
        if d in designs:
            rel = [
                (designs[d][n] - res.bounds[n][0]) / (res.bounds[n][1] - res.bounds[n][0])
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


def _objective(res: CouplingStudy, m: str, d: str) -> float | None:
    e = res.evaluation(m, d)
    return e.objective if e is not None else None
