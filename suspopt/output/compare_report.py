"""Tables and figures of a topology study (:mod:`suspopt.compare`), from its directory.

Reads only ``compare.json`` and the case recorders the study wrote (``suspopt report DIR``
dispatches here when the directory holds a ``compare.json``). Writes ``table.md`` and

* ``figures/trajectories.png`` — chassis accelerations and wheel travel of every topology
  at its own optimum (and the low-fidelity model at its optimum);
* ``figures/kinematics.png`` — motion ratio, wheel rate, camber and track change of every
  mechanism over the common wheel travel;
* ``figures/cross.png`` — the cross table as a picture: each design's excess over the
  model's own optimum;
* ``figures/road.png`` — the road under every wheel.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from suspopt.models.objective import term_units
from suspopt.output.figures import corner_labels, plot_set, road_figure, save_figure
from suspopt.output.rundir import read_json, read_trajectory, write_text

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


def _unit(name: str) -> str:
    return {'k_S': 'N/m', 'c_S': 'N·s/m', 'k_R': 'N·m/rad'}[name[:3]]


def model_label(data: dict[str, Any], model: str) -> str:
    if model == 'low':
        return f'{data.get("vehicle_model", "half_car").replace("_", " ")} (low fidelity)'
    return model.split(':', 1)[1]


def design_label(design: str) -> str:
    if design == 'initial':
        return 'initial design'
    if design == 'low_optimum':
        return 'low-fidelity optimum'
    return f'{design.split(":", 1)[1]} optimum'


def _cell(data, design, model):
    return data['cells'].get(f'{design}|{model}')


def _mark(rec: dict[str, Any] | None) -> str:
    if not rec:
        return ''
    if not rec.get('success'):
        return 'failed'
    return MARK[rec.get('verified')]


def compare_markdown(data: dict[str, Any]) -> str:
    """The topology study as Markdown (see the module docstring)."""
    models, designs = (
        data['models'],
        [d for d in data['design_order'] if d in data.get('designs', {})],
    )
    names, terms = data['design_names'], data['terms']
    lines = [f'**Warning:** {w}' for w in data.get('warnings', [])]
    if not data.get('complete'):
        lines.append(
            '**Incomplete:** the study '
            + ('was interrupted' if data.get('interrupted') else 'did not finish')
            + '; what finished is shown.'
        )
    if not data.get('verify', True):
        lines.append('**Not checked:** time-marching verification was skipped (--no-verify).')
    for f in data.get('failures', []):
        where = f.get('model', '') + (f' at {f["design"]}' if f.get('design') else '')
        lines.append(
            f'**Failed:** {f["what"]} in {where}: {f.get("status")} {f.get("message", "")}'.rstrip()
        )
    s = data['scales'][0]
    weights = data.get('weights', {})
    lines += ([''] if lines else []) + [
        f'Normalization `{data["normalization"]}`, s = ('
        + ', '.join(f'{t} {s[t]:.6g}' for t in terms)
        + '); f = '
        + ' + '.join(f'{weights[t]:g} J_{t}/s_{t}' for t in terms if weights.get(t))
        + '. Every topology is optimized from the low-fidelity optimum.',
        '',
    ]
    kin = data.get('kinematics') or {}
    if kin.get('curves'):
        lo, hi = kin['travel_range']
        lines += [
            f'**The linkages** (reference pose; wheel rate for k = {kin["spring_rate"]:g} '
            f'N/m; ranges over the wheel travel {1e3 * lo:g} … {1e3 * hi:g} mm)',
            '',
            '| mechanism | moving mass [kg] | motion ratio | wheel rate / k | motion '
            'ratio range | camber range [deg] | track change range [mm] |',
            '|---|---|---|---|---|---|---|',
        ]
        for lab, c in kin['curves'].items():
            ref = c['at_reference']

            def rng(key: str, scale: float, digits: int) -> str:
                lo_, hi_ = (f'{scale * x:.{digits}f}' for x in (min(c[key]), max(c[key])))
                return ' … '.join(x if x.strip('-0.') else x.lstrip('-') for x in (lo_, hi_))

            lines.append(
                f'| {lab} | {c["moving_mass_kg"]:.1f} | {ref["motion_ratio"]:.4f} | '
                f'{ref["wheel_rate"] / kin["spring_rate"]:.4f} | '
                f'{rng("motion_ratio", 1.0, 3)} | {rng("camber", 1.0, 2)} | '
                f'{rng("track_change", 1e3, 1)} |'
            )
        lines.append('')
    lines += [
        '**Optima** (each in its own model)',
        '',
        '| model | '
        + ' | '.join(f'{n} [{_unit(n)}]' for n in names)
        + ' | f | IPOPT | iterations | solve [s] | verified |',
        '|---|' + '---|' * (len(names) + 5),
    ]
    for m in models:
        st = data['steps'].get(m)
        if not st:
            continue
        d = st.get('design') or {}
        f = st.get('objective')
        solve = (st.get('times') or {}).get('solve_s')
        lines.append(
            f'| {model_label(data, m)} | '
            + ' | '.join(f'{d[n]:.0f}' if n in d else '—' for n in names)
            + f' | {"—" if f is None else f"{f:.4f}"} | {st.get("status")} | '
            f'{st.get("iterations")} | {"—" if solve is None else f"{solve:.2f}"} | '
            f'{_mark(st)} |'
        )
    best = data.get('best') or {}

    def cross(d: str, m: str) -> str:
        c = _cell(data, d, m)
        if not c:
            return '—'
        if not c.get('success'):
            return f'failed ({c.get("status")})'
        v = c.get('verification') or {}
        f = f'{c["objective"]:.4f}'
        if (best.get(m) or {}).get('best') == d:
            f = f'**{f}**'
        return f + (f' ({v["objective"]:.4f})' if 'objective' in v else '') + f' {_mark(c)}'

    def excess(d: str, m: str) -> str:
        e = ((best.get(m) or {}).get('excess') or {}).get(d)
        return '—' if e is None else f'{100 * e:+.1f} %'

    def agreement(d: str, m: str) -> str:
        v = (_cell(data, d, m) or {}).get('verification') or {}
        if 'max_rel_diff' not in v:
            return '—'
        return f'{100 * v["max_rel_diff"]:.3f} % ({v["scenarios"][0]["worst_term"]})' + (
            '' if v['verified'] else ' **NOT verified**'
        )

    def table(title: str, cell) -> list[str]:
        """A design × model table under ``title``, one cell per (design, model)."""
        return [
            '',
            title,
            '',
            '| design \\ model | ' + ' | '.join(model_label(data, m) for m in models) + ' |',
            '|---|' + '---|' * len(models),
        ] + [
            f'| {design_label(d)} | ' + ' | '.join(cell(d, m) for m in models) + ' |'
            for d in designs
        ]

    lines += table(
        '**Cross table: f of every design in every model** (collocation; time '
        'marching in brackets; ✓ verified by time marching within '
        f'{100 * data.get("tolerance", 5e-3):g} %, ✗ NOT verified, · not '
        'checked; bold: the best design in that model)',
        cross,
    )
    if best:
        lines += table(
            "**Excess over the model's own optimum**, f / f* − 1 (what a design "
            'found on another model costs in this one)',
            excess,
        )
    lines += table(
        '**Collocation vs time marching** (largest relative difference over the '
        'weighted J_k, and the term)',
        agreement,
    )
    lines += [
        '',
        "**Objective terms J_k at each model's own optimum** (collocation)",
        '',
        '| model | ' + ' | '.join(f'J_{t} [{term_units(t)}]' for t in terms) + ' |',
        '|---|' + '---|' * len(terms),
    ]
    for m in models:
        c = _cell(data, (best.get(m) or {}).get('own_optimum') or '', m)
        if c and c.get('terms'):
            lines.append(
                f'| {model_label(data, m)} | '
                + ' | '.join(f'{c["terms"][t]:.5g}' for t in terms)
                + ' |'
            )
    if 'wall_time_s' in data:
        n = sum(1 for c in data['cells'].values() if c.get('mode') == 'evaluate')
        lines += [
            '',
            f'{len(data["steps"])} optimizations and {n} evaluations, '
            f'{data["wall_time_s"]:.1f} s in all.',
        ]
    return '\n'.join(lines) + '\n'


# ---------------------------------------------------------------------------- figures
def _kinematics_figure(path: Path, kin: dict[str, Any]) -> Path:
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    panels = (
        ('motion_ratio', 'motion ratio [-]', 1.0),
        ('wheel_rate', f'wheel rate [N/mm] (k = {kin["spring_rate"]:g} N/m)', 1e-3),
        ('camber', 'camber [deg]', 1.0),
        ('track_change', 'track change [mm]', 1e3),
    )
    fig, axes = plt.subplots(2, 2, figsize=(10, 6.6), sharex=True, constrained_layout=True)
    for (lab, c), color in zip(kin['curves'].items(), COLORS):
        w = np.asarray(c['travel']) * 1e3
        for ax, (key, _, scale) in zip(axes.flat, panels):
            ax.plot(w, np.asarray(c[key]) * scale, '-', color=color, lw=1.6, label=lab)
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


def _cross_figure(path: Path, data: dict[str, Any]) -> Path:
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    models = data['models']
    designs = [d for d in data['design_order'] if d in data.get('designs', {})]
    best = data.get('best') or {}
    E = np.full((len(designs), len(models)), np.nan)
    for i, d in enumerate(designs):
        for j, m in enumerate(models):
            e = ((best.get(m) or {}).get('excess') or {}).get(d)
            if e is not None:
                E[i, j] = 100 * e
    fig, ax = plt.subplots(
        figsize=(1.9 * len(models) + 3, 0.65 * len(designs) + 1.8), constrained_layout=True
    )
    vmax = float(np.nanmax(E)) if np.isfinite(E).any() else 1.0
    im = ax.imshow(E, cmap='Reds', vmin=0.0, vmax=max(vmax, 1e-9), aspect='auto')
    for i, d in enumerate(designs):
        for j, m in enumerate(models):
            c = _cell(data, d, m)
            if c and c.get('success') and c.get('objective') is not None:
                txt = (
                    f'{c["objective"]:.3f}\n{E[i, j]:+.1f} % {_mark(c)}'
                    if np.isfinite(E[i, j])
                    else f'{c["objective"]:.3f} {_mark(c)}'
                )
            else:
                txt = 'failed' if c else '—'
            ax.text(
                j,
                i,
                txt,
                ha='center',
                va='center',
                fontsize=8,
                color='white' if np.isfinite(E[i, j]) and E[i, j] > 0.6 * vmax else 'black',
            )
    ax.set_xticks(range(len(models)), [model_label(data, m) for m in models], rotation=15)
    ax.set_yticks(range(len(designs)), [design_label(d) for d in designs])
    ax.set_xlabel('model the design is evaluated in')
    ax.set_title(
        "f of every design in every model; colour: excess over the model's own optimum [%]",
        fontsize=10,
    )
    fig.colorbar(im, ax=ax, label='f / f* − 1 [%]')
    save_figure(fig, path, dpi=100)
    plt.close(fig)
    return path


def render_compare(out_dir: str | Path) -> list[Path]:
    """Write ``table.md`` and ``figures/`` of a topology-study directory."""
    import matplotlib

    matplotlib.use('Agg')
    import openmdao.api as om

    out = Path(out_dir)
    data = read_json(out / 'compare.json')
    write_text(out / 'table.md', compare_markdown(data))
    figs = out / 'figures'
    figs.mkdir(exist_ok=True)
    written = [out / 'table.md', road_figure(figs / 'road.png', out, data['config'])]
    if (data.get('kinematics') or {}).get('curves'):
        written.append(_kinematics_figure(figs / 'kinematics.png', data['kinematics']))
    if data.get('cells'):
        written.append(_cross_figure(figs / 'cross.png', data))
    curves = []
    own = [
        (
            'low',
            'low_optimum',
            'low-fidelity model at its optimum',
            {'color': 'tab:blue', 'lw': 1.0, 'ls': ':'},
        )
    ]
    own += [
        (t['model'], t['optimum'], f'{t["label"]} at its optimum', {'color': c, 'lw': 1.2})
        for t, c in zip(data['topologies'], COLORS)
    ]
    for model, design, label, style in own:
        rec = out / data['recorders'][model]
        if rec.exists() and f'{design}|{model}' in data['cells']:
            tr = read_trajectory(om.CaseReader(str(rec)), design)
            if tr is not None:
                curves.append((label, tr, style))
    if curves:
        written.append(
            plot_set(
                figs / 'trajectories.png',
                'Every topology at its own optimum (collocation)',
                curves,
                data['terms'],
                corner_labels(out, data['config']),
            )
        )
    return written
