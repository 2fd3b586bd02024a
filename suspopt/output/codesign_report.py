"""Table and figure of a control co-design study
(:class:`~suspopt.records.codesign.CodesignStudy`, ``docs/codesign.md``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from suspopt.output.figures import save_figure
from suspopt.output.format import FIDELITY_LABELS, constraint_table, obj, verdict
from suspopt.output.rundir import write_text
from suspopt.records.codesign import FEEDBACK, OPEN_LOOP, PASSIVE, CodesignStudy

#: each entry as the table names it
LABELS = {
    PASSIVE: 'passive (no actuator)',
    OPEN_LOOP: 'open-loop control (the bound: full preview)',
    FEEDBACK: 'feedback law (realizable)',
}


def codesign_markdown(data: CodesignStudy) -> str:
    """The co-design table: each law's f by collocation and by time marching, its verdict
    and design; the share of the bound's gain the feedback law realizes; constraints."""
    kind = data.control.replace('_', '-')
    lines = [
        f'Control co-design, {FIDELITY_LABELS[data.fidelity]} model, {kind} suspension: '
        'the same objective and scales for every law (the passive car has no effort '
        'term), each optimum verified by time marching.',
        '',
        '| design | f (collocation) | f (time marching) | | IPOPT | iterations | design |',
        '|---|---|---|---|---|---|---|',
    ]
    for law, res in data.entries.items():
        c = res.verification.comparison
        design = ', '.join(f'{n} = {v:.4g}' for n, v in res.design.items())
        lines.append(
            f'| {LABELS.get(law, law)} | {obj(res.objective)} | '
            f'{obj(c.objective if c is not None else None)} | {verdict(res)} | {res.status} | '
            f'{res.iterations} | {design} |'
        )
    share = data.recovered()
    unverified = [law for law, r in data.entries.items() if r.verified is False]
    if share is not None and unverified:  # e.g. an unstable closed loop: meaningless
        lines += ['', 'No share of the bound is given: a law is NOT verified.']
    elif share is not None:
        lines += [
            '',
            f'The feedback law realizes **{100 * share:.0f} %** of the gain of the open-loop '
            'bound over the passive optimum ((f_passive − f_feedback) / (f_passive − '
            'f_open_loop), by time marching).',
        ]
    elif not data.complete:
        lines += ['', '**Incomplete:** the study was stopped before every law was solved.']
    for law, res in data.entries.items():
        c = res.verification.comparison
        if res.verified is False and c is not None:
            lines += ['', f'**NOT verified, {LABELS.get(law, law)}:** {c.disagreement()}.']
    for law, res in data.entries.items():
        table = constraint_table(res)
        if table:
            lines += ['', f'**Constraints: {LABELS.get(law, law)}**', '', *table]
    lines += ['', f'Wall time: {data.wall_time_s:.1f} s.'] if data.complete else []
    return '\n'.join(lines) + '\n'


def render_codesign(out: Path, data: CodesignStudy) -> list[Path]:
    """Write ``table.md`` and ``figures/codesign.png`` (each law's f by time marching, and
    the open-loop control's history at each controlled corner) of a co-design directory."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    write_text(out / 'table.md', codesign_markdown(data))
    figs = out / 'figures'
    figs.mkdir(exist_ok=True)
    fig, (bars, hist) = plt.subplots(
        1, 2, figsize=(12, 4), constrained_layout=True, gridspec_kw={'width_ratios': [1, 2]}
    )
    laws = [law for law in data.entries if data.objective(law) is not None]
    bars.bar(np.arange(len(laws)), [data.objective(law) or 0.0 for law in laws])
    bars.set_xticks(np.arange(len(laws)), [law.replace('_', '-') for law in laws])
    bars.set(ylabel='f by time marching (lower is better)', title='each law, same objective')
    bars.grid(alpha=0.3, axis='y')
    open_loop = data.entries.get(OPEN_LOOP)
    shown = False
    if open_loop is not None and open_loop.success:
        for control in open_loop.controls:
            t = np.linspace(control.segment_ends[0], control.segment_ends[-1], 2001)
            u = control(t)
            for i, corner in enumerate(control.corners):
                hist.plot(t, u[:, i], lw=0.9, label=f'{control.name}, corner {corner}')
                hist.set_ylabel(f'{control.name} [{control.units}]')
                shown = True
    if shown:
        hist.set(xlabel='t [s]', title='the open-loop optimum: the control as it acts')
        hist.legend(fontsize=8)
        hist.grid(alpha=0.3)
    else:
        hist.set_axis_off()
        hist.text(0.5, 0.5, 'no converged open-loop control', ha='center', va='center')
    save_figure(fig, figs / 'codesign.png', dpi=110)
    plt.close(fig)
    return [out / 'table.md', figs / 'codesign.png']
