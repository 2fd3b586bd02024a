"""Tables and figures of a study, rendered from its recorded data (``suspopt report DIR``).

(A ``suspopt optimize`` directory is rendered too, :func:`render_run`, and a
``suspopt pareto`` one, :func:`render_pareto`.)

Reads ``study.json`` (designs, objectives, IPOPT statistics), the SQLite case recorders
``low.sql``/``mixed.sql`` (the trajectories of every design in each model, as recorded by
OpenMDAO) and ``time_marching.npz``; writes ``table.md`` and ``figures/*.png``:

* ``road.png`` — road input under both wheels (paper Figure 3);
* ``initial_design.png`` — low- vs mixed-fidelity z̈_C, θ̈_C, z_W1, z_W2 at the initial
  design (paper Figure 4);
* ``optima.png`` — the same at the low- and mixed-fidelity optima (paper Figure 5);
* ``cross_evaluation.png`` — every design in both models (beyond the paper);
* ``verification.png`` — collocation against time marching, both models;
* ``convergence.png`` — objective and constraint violation per IPOPT iteration.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from suspopt.errors import ConfigError
from suspopt.timemarching import Trajectory

DESIGN_LABELS = {'initial': 'Initial guess', 'low_optimum': 'Low-fidelity optimum',
                 'mixed_optimum': 'Mixed-fidelity optimum'}
FIDELITY_LABELS = {'low': 'low-fidelity (half car)', 'mixed': 'mixed-fidelity (multibody)'}
SIGNALS = (('zdd_C', r'$\ddot z_C$ [m/s$^2$]', 'chassis heave acceleration'),
           ('thdd_C', r'$\ddot\theta_C$ [rad/s$^2$]', 'chassis pitch acceleration'),
           ('wheel_z1', r'$z_{W1}$ [m]', 'front wheel displacement'),
           ('wheel_z2', r'$z_{W2}$ [m]', 'rear wheel displacement'))


def read_trajectory(recorder: Any, label: str) -> Trajectory | None:
    """The trajectory recorded as problem case ``label`` (None if absent); ``recorder``
    is a case recorder file or an open ``CaseReader`` (opening one takes ~0.5 s: reuse)."""
    import openmdao.api as om
    cr = om.CaseReader(str(recorder)) if isinstance(recorder, (str, Path)) else recorder
    if label not in cr.list_cases('problem', recurse=False, out_stream=None):
        return None
    case = cr.get_case(label)
    ts = 'phase.timeseries.'
    outputs = case.list_outputs(out_stream=None, return_format='dict', prom_name=True)
    values: dict[str, np.ndarray] = {}
    for meta in outputs.values():
        prom = meta['prom_name']
        if prom.startswith(ts):
            val = np.asarray(meta['val'])
            values[prom[len(ts):]] = val[:, 0] if val.ndim == 2 and val.shape[1] == 1 else val
    J = np.asarray(case.get_val('quadrature.J'))
    wheel = 'q_W' if 'q_W1' in values else 'z_W'
    values['wheel_z1'], values['wheel_z2'] = values[wheel + '1'], values[wheel + '2']
    return Trajectory(t=values.pop('time'), values=values, J=J,
                      info={'method': 'collocation', 'label': label})


def _read_json(path: Path) -> dict[str, Any]:
    """A results file of a run; a missing or damaged one is a ConfigError naming it."""
    try:
        return json.loads(path.read_text())
    except FileNotFoundError:
        raise ConfigError(f'{path.parent}: no study.json, pareto.json or result.json (not a '
                          'suspopt output directory)') from None
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise ConfigError(f'{path}: unreadable ({err})') from None


def load_study(out_dir: str | Path) -> dict[str, Any]:
    return _read_json(Path(out_dir) / 'study.json')


# ---------------------------------------------------------------------------- tables
def _fmt(x: float | None, digits: int = 4) -> str:
    if x is None:
        return '—'
    return f'{x:.{digits}g}'


def table_markdown(study: dict[str, Any]) -> str:
    """Table 4 of the paper and the cross-evaluation tables, as Markdown."""
    ev, steps, tm = study.get('evaluations', {}), study.get('steps', {}), study.get('time_marching', {})
    designs = study.get('designs') or {
        'initial': (ev.get('low/initial') or {}).get('design'),
        'low_optimum': (steps.get('low') or {}).get('design'),
        'mixed_optimum': (steps.get('mixed') or {}).get('design')}
    s = study['scales']
    warnings = [f'**Warning:** {w}' for w in study.get('warnings', [])]
    w = study.get('config', {}).get('objective', {}).get('weights', [0.25] * 4)
    objective = ' + '.join(f'{wk:g} J{k + 1}/s{k + 1}' for k, wk in enumerate(w))
    lines = warnings + ([''] if warnings else []) + [
        f"Normalization: `{study['normalization']}`, s = "
        f"({', '.join(f'{v:.6g}' for v in s.values())}); f = {objective}.", '',
             '**Table 4 (paper): design and f, each f in the model that produced it**', '',
             '| | k_S1 [N/m] | k_S2 [N/m] | c_S1 [N·s/m] | c_S2 [N·s/m] | f | model |',
             '|---|---|---|---|---|---|---|']
    own = {'initial': 'low/initial', 'low_optimum': 'low/low_optimum',
           'mixed_optimum': 'mixed/mixed_optimum'}
    for name, label in DESIGN_LABELS.items():
        d = designs.get(name)
        e = ev.get(own[name])
        if not d or not e:
            continue
        lines.append(f"| {label} | {d['k_S1']:.0f} | {d['k_S2']:.0f} | {d['c_S1']:.0f} | "
                     f"{d['c_S2']:.0f} | **{e['objective']:.4f}** | {own[name].split('/')[0]} |")
    lines += ['', '**Every design in both models (collocation; time marching in brackets)**', '',
              '| design | f, low-fidelity | f, mixed-fidelity |', '|---|---|---|']
    for name, label in DESIGN_LABELS.items():
        cells = []
        for fid in ('low', 'mixed'):
            e, t = ev.get(f'{fid}/{name}'), tm.get(f'{fid}/{name}')
            cells.append('—' if e is None else f"{e['objective']:.4f}"
                         + ('' if t is None else f" ({t['objective']:.4f})"))
        lines.append(f'| {label} | {cells[0]} | {cells[1]} |')
    lines += ['', '**Objective terms J_k (collocation)**', '',
              '| design | model | J1 [(m/s²)²·s] | J2 [(rad/s²)²·s] | J3 [m²·s] | J4 [m²·s] |',
              '|---|---|---|---|---|---|']
    for name, label in DESIGN_LABELS.items():
        for fid in ('low', 'mixed'):
            e = ev.get(f'{fid}/{name}')
            if e:
                J = e['terms']
                lines.append(f"| {label} | {fid} | {J['J1']:.5g} | {J['J2']:.5g} | "
                             f"{J['J3']:.5g} | {J['J4']:.5g} |")
    if tm:
        lines += ['', '**Collocation vs time marching** (largest relative difference over J1..J4)',
                  '', '| design | low-fidelity | mixed-fidelity | max constraint residual (mixed) |',
                  '|---|---|---|---|']
        for name, label in DESIGN_LABELS.items():
            lo, mi = tm.get(f'low/{name}'), tm.get(f'mixed/{name}')
            lines.append(f"| {label} | {_fmt(lo and lo['max_rel_diff_collocation'], 2)} | "
                         f"{_fmt(mi and mi['max_rel_diff_collocation'], 2)} | "
                         f"{_fmt(mi and mi.get('max_constraint_residual_m'), 2)} m |")
    if steps:
        lines += ['', '**Optimization statistics** (each step starts from the collocation '
                  'solution of its starting design)', '',
                  '| step | success | IPOPT status | iterations | function / gradient '
                  'evaluations | solve [s] | multibody solver calls, each batched over all '
                  'nodes (both axles) |', '|---|---|---|---|---|---|---|']
        for fid in ('low', 'mixed'):
            st = steps.get(fid)
            if st:
                calls = st.get('multibody_calls') or {}
                mbd = (f"{calls.get('augmented', 0)} augmented solves (eq. 11), "
                       f"{calls.get('positions', 0)} position analyses") if calls else '—'
                lines.append(
                    f"| {fid} | {st['success']} | {st['status']} | {st['iterations']} | "
                    f"{st['function_evaluations']} / {st['gradient_evaluations']} | "
                    f"{st['times']['solve_s']:.2f} | {mbd} |")
        probs = study.get('problems') or {}
        if probs:
            lines += ['', '| model | setup [s] | total-coloring [s] |', '|---|---|---|']
            for fid, pr in probs.items():
                lines.append(f"| {fid} | {pr['setup_s']:.2f} | {pr['coloring_s']:.2f}"
                             f"{' (from cache)' if pr['coloring_from_cache'] else ''} |")
    if 'wall_time_s' in study:
        lines += ['', f"Whole study: {study['wall_time_s']:.1f} s."]
    return '\n'.join(lines) + '\n'


# ---------------------------------------------------------------------------- figures
def _axes_grid(title: str):
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(2, 2, figsize=(11, 7), sharex=True, constrained_layout=True)
    fig.suptitle(title)
    for ax, (_, ylabel, desc) in zip(axes.flat, SIGNALS):
        ax.set_ylabel(ylabel)
        ax.set_title(desc, fontsize=10)
        ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel('time t [s]')
    return fig, axes


def _plot_set(path: Path, title: str, curves: list[tuple[str, Trajectory, dict]]) -> None:
    import matplotlib.pyplot as plt
    fig, axes = _axes_grid(title)
    for label, tr, style in curves:
        for ax, (key, _, _) in zip(axes.flat, SIGNALS):
            ax.plot(tr.t, tr[key], label=label, **style)
    axes[0, 0].legend(fontsize=9)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _road_figure(path: Path, config_dict: dict[str, Any]) -> Path:
    """Road displacement under both wheels over the horizon (paper Figure 3)."""
    import matplotlib.pyplot as plt

    from suspopt.config import config_from_dict
    from suspopt.road import wheel_road_inputs
    config = config_from_dict(config_dict)
    t = np.linspace(0.0, config.maneuver.horizon, 2001)
    h, _ = wheel_road_inputs(config.road_profile(), t, config.maneuver.speed,
                             (0.0, config.vehicle.wheelbase))
    fig, ax = plt.subplots(figsize=(8, 3.5), constrained_layout=True)
    ax.plot(t, h[0] * 1e3, label=r'front wheel $\delta_1(t)$')
    ax.plot(t, h[1] * 1e3, '--', label=r'rear wheel $\delta_2(t)$')
    ax.set_xlabel('time t [s]')
    ax.set_ylabel('road displacement [mm]')
    ax.set_title(f"Road input ({config_dict['road']['profile']}, "
                 f"v = {config.maneuver.speed:g} m/s) — paper Fig. 3")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def _convergence_figure(path: Path, runs: dict[str, dict[str, Any]]) -> Path:
    """Objective and constraint violation per IPOPT iteration of each run (by fidelity)."""
    import matplotlib.pyplot as plt
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 3.8), constrained_layout=True)
    for fid, color in (('low', 'tab:blue'), ('mixed', 'tab:red')):
        hist = (runs.get(fid) or {}).get('history') or []
        if hist:
            it = [h['iteration'] for h in hist]
            a1.plot(it, [h['objective'] for h in hist], 'o-', color=color, ms=3,
                    label=FIDELITY_LABELS[fid])
            a2.semilogy(it, [max(h['constraint_violation'], 1e-16) for h in hist], 'o-',
                        color=color, ms=3, label=FIDELITY_LABELS[fid])
    a1.set(xlabel='IPOPT iteration', ylabel='objective f', title='Objective')
    a2.set(xlabel='IPOPT iteration', ylabel='constraint violation (scaled)',
           title='Collocation defects')
    for a in (a1, a2):
        a.grid(alpha=0.3)
        a.legend(fontsize=9)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def run_markdown(res: dict[str, Any]) -> str:
    """The result of one ``suspopt optimize`` run, as Markdown."""
    d, J = res.get('design') or {}, res.get('terms') or {}
    lines = [f"**{res['fidelity']}-fidelity {res.get('mode', 'optimize')}** — "
             f"{'converged' if res.get('success') else 'NOT converged'} "
             f"({res.get('status', '?')}), {res.get('iterations', '—')} IPOPT iterations, "
             f"{_fmt(res.get('wall_time_s'), 3)} s",
             '',
             '| | k_S1 [N/m] | k_S2 [N/m] | c_S1 [N·s/m] | c_S2 [N·s/m] | f |',
             '|---|---|---|---|---|---|']
    for label, design, f in (('start', res.get('start') or {}, None),
                             ('result', d, res.get('objective'))):
        if design:
            lines.append(f'| {label} | ' + ' | '.join(f'{design[n]:.0f}' for n in
                                                      ('k_S1', 'k_S2', 'c_S1', 'c_S2'))
                         + f' | {"—" if f is None else f"{f:.4f}"} |')
    if J:
        lines += ['', '| J1 [(m/s²)²·s] | J2 [(rad/s²)²·s] | J3 [m²·s] | J4 [m²·s] |',
                  '|---|---|---|---|',
                  '| ' + ' | '.join(_fmt(J.get(f'J{k}'), 5) for k in range(1, 5)) + ' |']
    scales = res.get('scales') or {}
    if scales:
        lines += ['', f"Normalization `{res.get('normalization')}`: s = ("
                  + ', '.join(_fmt(v, 6) for v in scales.values()) + ').']
    if res.get('message') and not res.get('success'):
        lines += ['', f"Message: {res['message']}"]
    return '\n'.join(lines) + '\n'


def render_run(out_dir: str | Path) -> list[Path]:
    """Write ``table.md`` and the figures of a ``suspopt optimize`` directory from its
    ``result.json`` and case recorder ``cases.sql``: the optimum's trajectories, the
    road, the convergence history."""
    import matplotlib
    matplotlib.use('Agg')
    out = Path(out_dir)
    res = _read_json(out / 'result.json')
    (out / 'table.md').write_text(run_markdown(res))
    figs = out / 'figures'
    figs.mkdir(exist_ok=True)
    written = [out / 'table.md']
    fid = res['fidelity']
    if res.get('config'):
        written.append(_road_figure(figs / 'road.png', res['config']))
    tr = read_trajectory(out / 'cases.sql', f'{fid}_optimum') \
        if (out / 'cases.sql').exists() else None
    if tr is not None:
        _plot_set(figs / 'trajectories.png',
                  f'The {FIDELITY_LABELS[fid]} model at the design found',
                  [(f'{fid} fidelity', tr, {'color': 'tab:blue' if fid == 'low'
                                            else 'tab:red', 'lw': 1.2})])
        written.append(figs / 'trajectories.png')
    if res.get('history'):
        written.append(_convergence_figure(figs / 'convergence.png', {fid: res}))
    return written


def pareto_markdown(front: dict[str, Any]) -> str:
    """A comfort/road-holding front (:mod:`suspopt.pareto`), as Markdown."""
    s = front['scales']
    lines = [f"Pareto front of the {FIDELITY_LABELS[front['fidelity']]} model: comfort "
             'C = (J1/s1 + J2/s2)/2 against road holding R = (J3/s3 + J4/s4)/2 '
             f"(`{front['normalization']}` normalization, s = "
             f"({', '.join(f'{v:.6g}' for v in s.values())})); weights "
             '(α/2, α/2, (1−α)/2, (1−α)/2) for comfort share α.', '',
             '| α | k_S1 [N/m] | k_S2 [N/m] | c_S1 [N·s/m] | c_S2 [N·s/m] | C | R | '
             'f_α | IPOPT | iterations |', '|---|---|---|---|---|---|---|---|---|---|']
    for pt in front['points']:
        d = pt['design']
        lines.append(f"| {pt['alpha']:.3f} | " + ' | '.join(
            f'{d[n]:.0f}' for n in ('k_S1', 'k_S2', 'c_S1', 'c_S2'))
            + f" | {pt['comfort']:.4f} | {pt['road_holding']:.4f} | {pt['objective']:.4f} | "
            f"{pt['status']} | {pt['iterations']} |")
    init = front.get('initial')
    if init:
        d = init['design']
        lines.append('| initial design | ' + ' | '.join(
            f'{d[n]:.0f}' for n in ('k_S1', 'k_S2', 'c_S1', 'c_S2'))
            + f" | {init['comfort']:.4f} | {init['road_holding']:.4f} | | | |")
    if front.get('wall_time_s') is not None:
        lines += ['', f"{len(front['points'])} optimizations on one problem: "
                  f"{front['wall_time_s']:.1f} s in all."]
    return '\n'.join(lines) + '\n'


def render_pareto(out_dir: str | Path) -> list[Path]:
    """Write ``table.md`` and ``figures/pareto.png`` of a Pareto directory from its
    ``pareto.json``: the front (C against R, each point labelled with α; the initial
    design for reference) and the designs along it."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    from suspopt.config import DESIGN_NAMES, config_from_dict
    out = Path(out_dir)
    front = _read_json(out / 'pareto.json')
    (out / 'table.md').write_text(pareto_markdown(front))
    figs = out / 'figures'
    figs.mkdir(exist_ok=True)
    pts = front['points']
    ok = [p for p in pts if p['success']]
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
    a1.plot([p['comfort'] for p in ok], [p['road_holding'] for p in ok], 'o-',
            color='tab:blue', label='optima (IPOPT converged)')
    for p in ok:
        a1.annotate(f"α={p['alpha']:.2f}", (p['comfort'], p['road_holding']),
                    textcoords='offset points', xytext=(5, 4), fontsize=8)
    bad = [p for p in pts if not p['success']]
    if bad:
        a1.plot([p['comfort'] for p in bad], [p['road_holding'] for p in bad], 'x',
                color='tab:red', label='not converged')
    init = front.get('initial')
    if init:
        a1.plot([init['comfort']], [init['road_holding']], 's', color='gray',
                label='initial design, same model')
    a1.set(xlabel='comfort C = (J1/s1 + J2/s2)/2  (smaller: smoother ride)',
           ylabel='road holding R = (J3/s3 + J4/s4)/2  (smaller: better grip)',
           title=f"Pareto front, {FIDELITY_LABELS[front['fidelity']]} model")
    a1.grid(alpha=0.3)
    a1.legend(fontsize=8)
    bounds = config_from_dict(front['config']).design.bounds()
    for name, style in zip(DESIGN_NAMES, ('o-', 's-', '^--', 'v--')):
        lo, hi = bounds[name]
        a2.plot([p['alpha'] for p in ok], [(p['design'][name] - lo) / (hi - lo) for p in ok],
                style, ms=4, label=name)
    a2.set(xlabel='comfort share α', ylabel='design, scaled to its bounds [0, 1]',
           title='Spring rates and damping along the front', ylim=(-0.05, 1.05))
    a2.grid(alpha=0.3)
    a2.legend(fontsize=8)
    fig.savefig(figs / 'pareto.png', dpi=120)
    plt.close(fig)
    return [out / 'table.md', figs / 'pareto.png']


def render(out_dir: str | Path) -> list[Path]:
    """Write ``table.md`` and the figures of a (possibly partial) study directory, or of
    a ``suspopt optimize`` directory (:func:`render_run`)."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    if not (out / 'study.json').exists() and (out / 'pareto.json').exists():
        return render_pareto(out)
    if not (out / 'study.json').exists() and (out / 'result.json').exists():
        return render_run(out)
    study = load_study(out)
    (out / 'table.md').write_text(table_markdown(study))
    figs = out / 'figures'
    figs.mkdir(exist_ok=True)
    written = [out / 'table.md']

    written.append(_road_figure(figs / 'road.png', study['config']))

    import openmdao.api as om

    from suspopt.study import STUDY_DESIGNS
    traj = {}
    for fid in ('low', 'mixed'):
        if (out / f'{fid}.sql').exists():
            rec = om.CaseReader(str(out / f'{fid}.sql'))
            for name in STUDY_DESIGNS:  # recorded under the design's name in each model
                tr = read_trajectory(rec, name)
                if tr is not None:
                    traj[fid, name] = tr
    low_style = {'color': 'tab:blue', 'lw': 1.3}
    mixed_style = {'color': 'tab:red', 'lw': 1.1, 'ls': '--'}
    if ('low', 'initial') in traj and ('mixed', 'initial') in traj:
        _plot_set(figs / 'initial_design.png',
                  'Initial design: low- vs mixed-fidelity model — paper Fig. 4',
                  [('low fidelity', traj['low', 'initial'], low_style),
                   ('mixed fidelity', traj['mixed', 'initial'], mixed_style)])
        written.append(figs / 'initial_design.png')
    if ('low', 'low_optimum') in traj and ('mixed', 'mixed_optimum') in traj:
        _plot_set(figs / 'optima.png',
                  'Optimal designs: low-fidelity optimum (half car) vs mixed-fidelity optimum '
                  '(multibody) — paper Fig. 5',
                  [('low-fidelity optimum, low-fidelity model', traj['low', 'low_optimum'],
                    low_style),
                   ('mixed-fidelity optimum, mixed-fidelity model',
                    traj['mixed', 'mixed_optimum'], mixed_style)])
        written.append(figs / 'optima.png')
    if ('mixed', 'low_optimum') in traj and ('mixed', 'mixed_optimum') in traj:
        curves = [(f'{DESIGN_LABELS[n].lower()}', traj['mixed', n], st) for n, st in
                  (('initial', {'color': 'gray', 'lw': 1.0}),
                   ('low_optimum', low_style), ('mixed_optimum', mixed_style))
                  if ('mixed', n) in traj]
        _plot_set(figs / 'cross_evaluation.png',
                  'All three designs in the mixed-fidelity (multibody) model', curves)
        written.append(figs / 'cross_evaluation.png')

    tm_path = out / 'time_marching.npz'
    if tm_path.exists() and traj:
        data = np.load(tm_path)
        fig, axes = _axes_grid('Collocation (markers) vs time marching (lines)')
        for (fid, name), style in ((('low', 'low_optimum'), low_style),
                                   (('mixed', 'mixed_optimum'), mixed_style)):
            key = f'{fid}/{name}'
            if (fid, name) not in traj or f'{key}/t' not in data:
                continue
            for ax, (sig, _, _) in zip(axes.flat, SIGNALS):
                ax.plot(data[f'{key}/t'], data[f'{key}/{sig}'], color=style['color'], lw=0.9,
                        label=f'{fid} fidelity at its optimum, time marching')
                tr = traj[fid, name]
                ax.plot(tr.t[::3], tr[sig][::3], 'o', ms=2.2, color=style['color'],
                        alpha=0.7, label=f'{fid} fidelity at its optimum, collocation nodes')
        axes[0, 0].legend(fontsize=8)
        fig.savefig(figs / 'verification.png', dpi=120)
        plt.close(fig)
        written.append(figs / 'verification.png')

    steps = {fid: step for fid, step in study.get('steps', {}).items() if step}
    if steps:
        written.append(_convergence_figure(figs / 'convergence.png', steps))
    return written
