"""Table and figures of the two-step study (:class:`~suspopt.records.twostep.TwoStepStudy`):

* ``road.png`` — road input under every wheel (paper Figure 3);
* ``initial_design.png`` — low- vs mixed-fidelity trajectories at the initial design
  (paper Figure 4): chassis heave and pitch (and roll) accelerations, wheel travel;
* ``optima.png`` — the same at the low- and mixed-fidelity optima (paper Figure 5);
* ``cross_evaluation.png`` — every design in the mixed-fidelity model (beyond the paper);
* ``verification.png`` — collocation against time marching, both models;
* ``convergence.png`` — objective and constraint violation per IPOPT iteration.

Trajectories are drawn only of converged results.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from pathlib import Path

import numpy as np

from suspopt.errors import ConfigError
from suspopt.output.figures import (
    Setting,
    panel_figure,
    panel_specs,
    plot_curves,
    plot_set,
    read_setting,
    road_figure,
    save_figure,
)
from suspopt.output.format import (
    constraint_table,
    design_columns,
    fmt,
    obj,
    scenario_terms,
    study_scales_line,
    term_columns,
    verdict,
)
from suspopt.output.rundir import fingerprint, read_trajectory, write_text
from suspopt.output.solve_report import convergence_figure
from suspopt.records.solve import SolveRecord
from suspopt.records.trajectory import Trajectory
from suspopt.records.twostep import FIDELITIES, OWN_MODEL, STUDY_DESIGNS, TwoStepStudy

DESIGN_LABELS = dict(
    zip(STUDY_DESIGNS, ('Initial guess', 'Low-fidelity optimum', 'Mixed-fidelity optimum'))
)
LOW_STYLE = {'color': 'tab:blue', 'lw': 1.3}
MIXED_STYLE = {'color': 'tab:red', 'lw': 1.1, 'ls': '--'}


# ---------------------------------------------------------------------------- the table
def table_markdown(study: TwoStepStudy) -> str:
    """Table 4 of the paper, every design in both models, terms, verification, statistics."""
    lines = [f'**Warning:** {w}' for w in study.warnings]
    if not study.verify:
        lines.append('**Not checked:** time-marching verification was skipped (--no-verify).')
    lines += ([''] if lines else []) + [
        study_scales_line(
            study.config, study.terms, study.scales, study.normalization, study.weights
        ),
        '',
        *_table4(study),
        '',
        *_both_models(study),
        '',
        *_terms(study),
        *_agreement(study),
        *_constraints(study),
        *_statistics(study),
    ]
    if study.wall_time_s is not None:
        lines += ['', f'Whole study: {study.wall_time_s:.1f} s.']
    return '\n'.join(lines) + '\n'


def _table4(study: TwoStepStudy) -> list[str]:
    names = study.design_names
    lines = [
        '**Table 4 (paper): design and f, each f in the model that produced it**',
        '',
        f'| | {design_columns(names)} | f | model | |',
        '|---|' + '---|' * (len(names) + 3),
    ]
    for name, label in DESIGN_LABELS.items():
        d, e = study.designs.get(name), study.evaluation(OWN_MODEL[name], name)
        if not d or e is None:
            continue
        lines.append(
            f'| {label} | '
            + ' | '.join(f'{d[n]:.0f}' for n in names)
            + f' | **{obj(e.objective)}** | {OWN_MODEL[name]} | {verdict(e)} |'
        )
    return lines


def _both_models(study: TwoStepStudy) -> list[str]:
    lines = [
        '**Every design in both models (collocation; time marching in brackets)**',
        '',
        '| design | f, low-fidelity | f, mixed-fidelity |',
        '|---|---|---|',
    ]
    for name, label in DESIGN_LABELS.items():
        cells = [_both_models_cell(study.evaluation(fid, name)) for fid in FIDELITIES]
        lines.append(f'| {label} | {cells[0]} | {cells[1]} |')
    return lines


def _both_models_cell(e: SolveRecord | None) -> str:
    if e is None:
        return '—'
    c = e.verification.comparison
    return (
        obj(e.objective)
        + (f' ({c.objective:.4f})' if c is not None else '')
        + ('' if e.verified is not False else ' **NOT verified**')
    )


def _terms(study: TwoStepStudy) -> list[str]:
    terms = study.terms
    several = len(study.scales) > 1
    lines = [
        '**Objective terms J_k (collocation' + (', every scenario' if several else '') + ')**',
        '',
        '| design | model | ' + ('scenario | ' if several else '') + f'{term_columns(terms)} |',
        '|---|---|' + ('---|' if several else '') + '---|' * len(terms),
    ]
    for name, label in DESIGN_LABELS.items():
        for fid in FIDELITIES:
            e = study.evaluation(fid, name)
            if e is None:
                continue
            for scenario, J in scenario_terms(e):
                lines.append(
                    f'| {label} | {fid} | '
                    + (f'{scenario} | ' if several else '')
                    + ' | '.join(f'{J[t]:.5g}' if J else '—' for t in terms)
                    + (' |' if J else ' (NOT converged) |')
                )
    return lines


def _agreement(study: TwoStepStudy) -> list[str]:
    compared = {
        (name, fid): e.verification.comparison
        for name in DESIGN_LABELS
        for fid in FIDELITIES
        for e in [study.evaluation(fid, name)]
        if e is not None and e.verification.comparison is not None
    }
    if not compared:
        return []
    tolerance = next(iter(compared.values())).tolerance
    lines = [
        '',
        '**Collocation vs time marching** (largest relative difference over '
        'the weighted J_k; verified if at most the tolerance '
        f'{100 * tolerance:g} %)',
        '',
        '| design | low-fidelity | mixed-fidelity | max constraint residual (mixed) |',
        '|---|---|---|---|',
    ]
    for name, label in DESIGN_LABELS.items():
        cells = []
        for fid in FIDELITIES:
            c = compared.get((name, fid))
            cells.append(fmt(c.max_rel_diff if c else None, 2))
        c = compared.get((name, 'mixed'))
        res = [s.max_constraint_residual_m for s in c.scenarios] if c else []
        worst = max((r for r in res if r is not None), default=None)
        lines.append(f'| {label} | {cells[0]} | {cells[1]} | {fmt(worst, 2)} m |')
    return lines


def _constraints(study: TwoStepStudy) -> list[str]:
    """The engineering constraints at each design in the model that produced it."""
    lines = []
    for name, label in DESIGN_LABELS.items():
        e = study.evaluation(OWN_MODEL[name], name)
        if e is None or not e.constraints:
            continue
        lines += ['', f'**Constraints: {label}** ({OWN_MODEL[name]} fidelity)', '']
        lines += constraint_table(e)
    return lines


def multibody_calls(calls: dict[str, int]) -> str:
    """The multibody solver calls of a solve, in words (``—``: none)."""
    if not calls:
        return '—'
    return (
        f'{calls.get("augmented", 0)} augmented solves (eq. 11), '
        f'{calls.get("positions", 0)} position analyses'
        + (
            f', {calls["factorizations"]} factorizations of C_q,dep (one per pose)'
            if 'factorizations' in calls
            else ''
        )
    )


def fmt_seconds(st: SolveRecord) -> str:
    return '—' if st.times is None else f'{st.times.solve_s:.2f}'


def _statistics(study: TwoStepStudy) -> list[str]:
    if not study.steps:
        return []
    lines = [
        '',
        '**Optimization statistics** (each step starts from the collocation '
        'solution of its starting design)',
        '',
        '| step | success | IPOPT status | iterations | function / gradient '
        'evaluations | solve [s] | multibody solver calls, each batched over all '
        'nodes and corners |',
        '|---|---|---|---|---|---|---|',
    ]
    for fid in FIDELITIES:
        st = study.steps.get(fid)
        if st is not None:
            lines.append(
                f'| {fid} | {st.success} | {st.status} | {st.iterations} | '
                f'{st.function_evaluations} / {st.gradient_evaluations} | '
                f'{fmt_seconds(st)} | {multibody_calls(st.multibody_calls)} |'
            )
    if study.problems:
        lines += [
            '',
            '| model | NLP variables × constraints | Jacobian nonzeros '
            '(colors) | setup [s] | sparsity + coloring [s] |',
            '|---|---|---|---|---|',
        ]
        for fid, pr in study.problems.items():
            lines.append(
                f'| {fid} | {pr.nlp.variables} × {pr.nlp.constraints} | '
                f'{pr.nlp.jacobian_nonzeros} ({pr.nlp.colors}) | '
                f'{pr.setup_s:.2f} | {pr.coloring_s:.2f}'
                f'{" (from cache)" if pr.coloring_from_cache else ""} |'
            )
    return lines


# ---------------------------------------------------------------------------- figures
def render_study(out: Path, study: TwoStepStudy, file: str) -> list[Path]:
    """Write ``table.md`` and the figures of a (possibly partial) study directory (the
    figures drawn side by side in background processes, :func:`draw_figures`)."""
    write_text(out / 'table.md', table_markdown(study))
    figs = out / 'figures'
    figs.mkdir(exist_ok=True)
    setting = read_setting(out, study.config, file)
    traj = _trajectories(out, study)
    jobs: list[Callable[[], Path]] = [functools.partial(road_figure, figs / 'road.png', setting)]
    jobs += _trajectory_jobs(figs, traj, setting)
    tm_path = out / 'time_marching.npz'
    marched = _marched(tm_path, study) if tm_path.exists() and traj else None
    if marched is not None:
        jobs.append(
            functools.partial(
                verification_figure, figs / 'verification.png', traj, marched, setting
            )
        )
    steps = {fid: step for fid, step in study.steps.items()}
    if steps:
        jobs.append(functools.partial(convergence_figure, figs / 'convergence.png', steps))
    return [out / 'table.md'] + draw_figures(jobs)


#: the key of ``time_marching.npz`` holding the fingerprint of its study
FINGERPRINT = '_study'


def study_fingerprint(study: TwoStepStudy) -> str:
    """What ties ``time_marching.npz`` to its study: its description and designs."""
    return fingerprint(study.config, study.designs)


def _marched(path: Path, study: TwoStepStudy) -> dict[str, np.ndarray] | None:
    """The time-marched signals of ``path``, if they are this study's (None if another
    run's file was left in the directory: never drawn as this one's)."""
    try:
        with np.load(path) as data:
            marched = {k: np.asarray(data[k]) for k in data.files}
    except Exception as err:  # numpy's and zipfile's errors of a damaged file
        raise ConfigError(f'{path}: damaged ({err})') from None
    mark = marched.pop(FINGERPRINT, None)
    if mark is None or str(mark) != study_fingerprint(study):
        return None
    return marched


def _trajectories(out: Path, study: TwoStepStudy) -> dict[tuple[str, str], Trajectory]:
    """The recorded trajectory of every converged evaluation."""
    import openmdao.api as om

    traj = {}
    for fid in FIDELITIES:
        path = out / f'{fid}.sql'
        if not path.exists():
            continue
        try:
            rec = om.CaseReader(str(path))
        except Exception as err:  # sqlite's errors of a damaged file
            raise ConfigError(f'{path}: damaged case recorder ({err})') from None
        for name in STUDY_DESIGNS:  # recorded under the design's name in each model
            e = study.evaluation(fid, name)
            if e is None or not e.success:
                continue  # not a converged result (an interrupted or failed solve)
            tr = read_trajectory(rec, name)
            if tr is not None:
                traj[fid, name] = tr
    return traj


def _trajectory_jobs(
    figs: Path, traj: dict[tuple[str, str], Trajectory], setting: Setting
) -> list[Callable[[], Path]]:
    lay = setting.layout
    jobs: list[Callable[[], Path]] = []
    if ('low', 'initial') in traj and ('mixed', 'initial') in traj:
        curves = [
            ('low fidelity', traj['low', 'initial'], LOW_STYLE),
            ('mixed fidelity', traj['mixed', 'initial'], MIXED_STYLE),
        ]
        title = 'Initial design: low- vs mixed-fidelity model — paper Fig. 4'
        jobs.append(functools.partial(plot_set, figs / 'initial_design.png', title, curves, lay))
    if ('low', 'low_optimum') in traj and ('mixed', 'mixed_optimum') in traj:
        curves = [
            ('low-fidelity optimum, low-fidelity model', traj['low', 'low_optimum'], LOW_STYLE),
            (
                'mixed-fidelity optimum, mixed-fidelity model',
                traj['mixed', 'mixed_optimum'],
                MIXED_STYLE,
            ),
        ]
        title = (
            'Optimal designs: low-fidelity optimum (low-fidelity model) vs mixed-fidelity '
            'optimum (multibody) — paper Fig. 5'
        )
        jobs.append(functools.partial(plot_set, figs / 'optima.png', title, curves, lay))
    if ('mixed', 'low_optimum') in traj and ('mixed', 'mixed_optimum') in traj:
        styles = (
            ('initial', {'color': 'gray', 'lw': 1.0}),
            ('low_optimum', LOW_STYLE),
            ('mixed_optimum', MIXED_STYLE),
        )
        curves = [
            (DESIGN_LABELS[n].lower(), traj['mixed', n], st)
            for n, st in styles
            if ('mixed', n) in traj
        ]
        title = 'All three designs in the mixed-fidelity (multibody) model'
        jobs.append(functools.partial(plot_set, figs / 'cross_evaluation.png', title, curves, lay))
    return jobs


def verification_figure(
    path: Path,
    traj: dict[tuple[str, str], Trajectory],
    marched: dict[str, np.ndarray],
    setting: Setting,
) -> Path:
    """Collocation (markers) against time marching (lines) at both optima."""
    import matplotlib.pyplot as plt

    panels = panel_specs(setting.layout)
    corners = setting.layout.corners
    fig, axes = panel_figure('Collocation (markers) vs time marching (lines)', panels)
    for (fid, name), style in (
        (('low', 'low_optimum'), LOW_STYLE),
        (('mixed', 'mixed_optimum'), MIXED_STYLE),
    ):
        key = f'{fid}/{name}'
        if (fid, name) not in traj or f'{key}/t' not in marched:
            continue
        tm = {k.split('/')[-1]: v for k, v in marched.items() if k.startswith(key + '/')}
        coll = traj[fid, name]
        for ax, panel in zip(axes, panels):
            tm_style = dict(style, lw=0.9, ls='-')
            plot_curves(ax, panel, tm['t'], tm, corners, f'{fid} fidelity, time marching', tm_style)
            plot_curves(
                ax,
                panel,
                coll.t,
                coll.values,
                corners,
                f'{fid} fidelity, collocation nodes',
                style,
                marker=True,
            )
    axes[0].legend(fontsize=7)
    save_figure(fig, path, dpi=110)
    plt.close(fig)
    return path


def draw_figures(jobs: list[Callable[[], Path]]) -> list[Path]:
    """Run the figure-drawing ``jobs`` side by side, one background process per core
    (:mod:`suspopt.verification.background`; here, one after another, on one core or where
    that is not available); their paths, in order."""
    from suspopt.verification.background import Background, usable_cores

    cores = usable_cores()
    with Background(jobs=cores if len(jobs) > 1 and cores > 1 else 0) as bg:
        for k, job in enumerate(jobs):
            bg.submit(str(k), job)
        return [bg.result(str(k)) for k in range(len(jobs))]
