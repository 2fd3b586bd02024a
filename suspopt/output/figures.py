"""Figure primitives shared by the reports (:mod:`suspopt.report`,
:mod:`suspopt.compare_report`): trajectory panels of the chassis and every wheel, the road
under every wheel (paper Figure 3), read from a results directory's study description."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from suspopt.output.rundir import atomic_path, resolve_inputs
from suspopt.records.trajectory import Trajectory

CHASSIS = (
    ('zdd_C', r'$\ddot z_C$ [m/s$^2$]', 'chassis heave acceleration'),
    ('thdd_C', r'$\ddot\theta_C$ [rad/s$^2$]', 'chassis pitch acceleration'),
    ('phidd_C', r'$\ddot\varphi_C$ [rad/s$^2$]', 'chassis roll acceleration'),
)
AXLE_NAMES = {'1': 'front', '2': 'rear'}


def save_figure(fig: Any, path: str | Path, dpi: int = 110, **savefig: Any) -> Path:
    """Write ``fig`` to ``path`` atomically (:func:`suspopt.results.atomic_path`): a run
    stopped or failing while it writes never leaves a partial image. ``savefig``: further
    arguments of Matplotlib's ``Figure.savefig``."""
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format=path.suffix.lstrip('.') or 'png', **savefig)
    return path


def panel_specs(terms: list[str]) -> list[tuple[str, str, str]]:
    """(signal, y label, title) of every panel: chassis accelerations, then the wheels of
    each axle (one panel per axle, its corners as curves)."""
    roll = 'roll' in terms
    out = [c for c in CHASSIS if roll or c[0] != 'phidd_C']
    axles = sorted({t.split('_')[1][0] for t in terms if t.startswith('wheel_')})
    out += [(f'wheel_{a}', r'$z_W$ [m]', f'{AXLE_NAMES[a]} wheel travel') for a in axles]
    return out


def panel_figure(title: str, panels):
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    ncol = 2
    nrow = (len(panels) + 1) // 2
    fig, axes = plt.subplots(
        nrow, ncol, figsize=(11, 3.4 * nrow), sharex=True, constrained_layout=True, squeeze=False
    )
    fig.suptitle(title)
    for ax, (_, ylabel, desc) in zip(axes.flat, panels):
        ax.set_ylabel(ylabel)
        ax.set_title(desc, fontsize=10)
        ax.grid(alpha=0.3)
    for ax in axes.flat[len(panels) :]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel('time t [s]')
    return fig, list(axes.flat)


def plot_curves(
    ax,
    key: str,
    tr_t,
    values: dict[str, np.ndarray],
    labels: list[str],
    label: str,
    style: dict,
    marker: bool = False,
):
    if key.startswith('wheel_'):
        axle = key.split('_')[1]
        z = np.asarray(values['wheel_z'])
        for c, lab in enumerate(labels):
            if lab[0] == axle:
                st = dict(
                    style, ls=style.get('ls', '-') if len(lab) == 1 or lab.endswith('L') else ':'
                )
                kw = {'label': f'{label} ({lab})' if len(lab) > 1 else label}
                if marker:
                    ax.plot(
                        tr_t[::3], z[::3, c], 'o', ms=2.2, alpha=0.7, color=style.get('color'), **kw
                    )
                else:
                    ax.plot(tr_t, z[:, c], **st, **kw)
    elif key in values:
        if marker:
            ax.plot(
                tr_t[::3],
                np.asarray(values[key])[::3],
                'o',
                ms=2.2,
                alpha=0.7,
                color=style.get('color'),
                label=label,
            )
        else:
            ax.plot(tr_t, values[key], label=label, **style)


def plot_set(
    path: Path,
    title: str,
    curves: list[tuple[str, Trajectory, dict]],
    terms: list[str],
    labels: list[str],
) -> Path:
    import matplotlib.pyplot as plt

    panels = panel_specs(terms)
    fig, axes = panel_figure(title, panels)
    for label, tr, style in curves:
        for ax, (key, _, _) in zip(axes, panels):
            plot_curves(ax, key, tr.t, tr.values, labels, label, style)
    axes[0].legend(fontsize=8)
    save_figure(fig, path, dpi=110)
    plt.close(fig)
    return path


def setting(out: Path, config_dict: dict[str, Any]):
    """The car's corners and the first scenario's roads, speed and horizon, from the
    study description of a results directory (its kept input copies; not validated)."""
    from suspopt.models.layout import full_car, half_car
    from suspopt.road import road_tracks

    cfg = resolve_inputs(out, config_dict)
    v, man = cfg['vehicle'], cfg['maneuver']
    a1, a2 = float(v['front']['axle_position']), float(v['rear']['axle_position'])
    lay = (
        full_car(a1, a2, float(v['front']['track']), float(v['rear']['track']))
        if v['model'] == 'full_car'
        else half_car(a1, a2)
    )
    sc = (cfg.get('scenario') or [{}])[0]
    road = sc.get('road') or cfg['road']
    return (
        lay,
        road_tracks(road, lay.n_tracks, lay.track_separation()),
        float(sc.get('speed') or man['speed']),
        float(sc.get('horizon') or man['horizon']),
        road.get('profile'),
    )


def road_figure(path: Path, out: Path, config_dict: dict[str, Any]) -> Path:
    """Road displacement under every wheel over the horizon (paper Figure 3)."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    lay, tracks, speed, horizon, profile = setting(out, config_dict)
    t = np.linspace(0.0, horizon, 2001)
    fig, ax = plt.subplots(figsize=(8, 3.5), constrained_layout=True)
    for c, (corner, off) in enumerate(zip(lay.corners, lay.offsets())):
        h = tracks[corner.track].r(speed * t - off)
        ax.plot(
            t,
            h * 1e3,
            ls='-' if corner.axle == 0 else '--',
            label=rf'wheel {corner.label} $\delta_{{{corner.label}}}(t)$',
        )
    ax.set_xlabel('time t [s]')
    ax.set_ylabel('road displacement [mm]')
    ax.set_title(f'Road input ({profile}, v = {speed:g} m/s) — paper Fig. 3')
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    save_figure(fig, path, dpi=110)
    plt.close(fig)
    return path


def corner_labels(out: Path, config_dict: dict[str, Any]) -> list[str]:
    return list(setting(out, config_dict)[0].labels)
