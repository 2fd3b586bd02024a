"""Figure primitives shared by the reports: trajectory panels of the chassis and every
wheel, the road under every wheel (paper Figure 3), and the setting they need, read from
a results directory's study description."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from suspopt.errors import ConfigError
from suspopt.models.layout import Corner, VehicleLayout, full_car, half_car, quarter_car
from suspopt.output.rundir import atomic_path, resolve_inputs
from suspopt.records.codec import Node
from suspopt.records.trajectory import Trajectory

CHASSIS = (
    ('zdd_C', r'$\ddot z_C$ [m/s$^2$]', 'chassis heave acceleration'),
    ('thdd_C', r'$\ddot\theta_C$ [rad/s$^2$]', 'chassis pitch acceleration'),
    ('phidd_C', r'$\ddot\varphi_C$ [rad/s$^2$]', 'chassis roll acceleration'),
)
AXLE_NAMES = ('front', 'rear')
#: the wheel displacement of every corner (collocation and time marching alike)
WHEELS = 'wheel_z'


@dataclass(frozen=True)
class Panel:
    """One panel: the signal it shows (a chassis acceleration, or the wheels of ``axle``),
    its y label and its title."""

    signal: str
    ylabel: str
    title: str
    axle: int | None = None


def save_figure(fig: Any, path: str | Path, dpi: int = 110, **savefig: Any) -> Path:
    """Write ``fig`` to ``path`` atomically (:func:`suspopt.output.rundir.atomic_path`): a
    run stopped or failing while it writes never leaves a partial image. ``savefig``:
    further arguments of Matplotlib's ``Figure.savefig``."""
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format=path.suffix.lstrip('.') or 'png', **savefig)
    return path


def panel_specs(layout: VehicleLayout) -> list[Panel]:
    """Every panel of a car: chassis accelerations, then the wheels of each axle (one
    panel per axle, its corners as curves)."""
    out = [Panel(*c) for c in CHASSIS if layout.has_roll or c[0] != 'phidd_C']
    axles = sorted({c.axle for c in layout.corners})
    out += [Panel(WHEELS, r'$z_W$ [m]', f'{AXLE_NAMES[a]} wheel travel', a) for a in axles]
    return out


def panel_figure(title: str, panels: list[Panel]) -> tuple[Any, list[Any]]:
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    ncol = 2
    nrow = (len(panels) + 1) // 2
    fig, axes = plt.subplots(
        nrow, ncol, figsize=(11, 3.4 * nrow), sharex=True, constrained_layout=True, squeeze=False
    )
    fig.suptitle(title)
    for ax, panel in zip(axes.flat, panels):
        ax.set_ylabel(panel.ylabel)
        ax.set_title(panel.title, fontsize=10)
        ax.grid(alpha=0.3)
    for ax in axes.flat[len(panels) :]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel('time t [s]')
    return fig, list(axes.flat)


def plot_curves(
    ax: Any,
    panel: Panel,
    t: np.ndarray,
    values: dict[str, np.ndarray],
    corners: tuple[Corner, ...],
    label: str,
    style: dict[str, Any],
    marker: bool = False,
) -> None:
    """The curves of one panel: its signal, or each wheel of its axle (the right wheel
    dotted)."""
    if panel.axle is not None:
        z = np.asarray(values[WHEELS])
        z = z.reshape(z.shape[0], -1)  # one corner (a quarter car): a column
        for c, corner in enumerate(corners):
            if corner.axle != panel.axle:
                continue
            st = dict(style, ls=style.get('ls', '-') if corner.side >= 0 else ':')
            kw = {'label': f'{label} ({corner.label})' if corner.side else label}
            if marker:
                ax.plot(t[::3], z[::3, c], 'o', ms=2.2, alpha=0.7, color=style.get('color'), **kw)
            else:
                ax.plot(t, z[:, c], **st, **kw)
    elif panel.signal in values:
        y = np.asarray(values[panel.signal])
        if marker:
            ax.plot(t[::3], y[::3], 'o', ms=2.2, alpha=0.7, color=style.get('color'), label=label)
        else:
            ax.plot(t, y, label=label, **style)


def plot_set(
    path: Path,
    title: str,
    curves: list[tuple[str, Trajectory, dict[str, Any]]],
    layout: VehicleLayout,
) -> Path:
    """One figure of every panel, each trajectory of ``curves`` (label, trajectory, style)."""
    import matplotlib.pyplot as plt

    panels = panel_specs(layout)
    fig, axes = panel_figure(title, panels)
    for label, tr, style in curves:
        for ax, panel in zip(axes, panels):
            plot_curves(ax, panel, tr.t, tr.values, layout.corners, label, style)
    axes[0].legend(fontsize=8)
    save_figure(fig, path, dpi=110)
    plt.close(fig)
    return path


# ---------------------------------------------------------------------------- the setting
@dataclass(frozen=True)
class Setting:
    """The car's corners and the first scenario's roads, speed and horizon, as a run used
    them."""

    layout: VehicleLayout
    tracks: tuple[Any, ...]
    speed: float
    horizon: float
    profile: str


def read_setting(out: Path, config: dict[str, Any], file: str) -> Setting:
    """The :class:`Setting` of the study description ``config`` of a results directory
    (its kept input copies), read from ``file``: a damaged one is a ConfigError naming
    the key."""
    from suspopt.road import road_tracks

    cfg = Node(resolve_inputs(out, config), file, 'config')
    v, man = cfg.get('vehicle'), cfg.get('maneuver')
    model = v.get('model').text()
    if model == 'quarter_car':  # one corner: no rear axle in its description
        lay = quarter_car()
    else:
        front, rear = v.get('front'), v.get('rear')
        a1, a2 = front.get('axle_position').number(), rear.get('axle_position').number()
        if model == 'full_car':
            lay = full_car(a1, a2, front.get('track').number(), rear.get('track').number())
        else:
            lay = half_car(a1, a2)
    scenarios = cfg.opt('scenario')
    sc = scenarios.items()[0] if scenarios is not None and scenarios.items() else None
    road = (sc.opt('road') if sc is not None else None) or cfg.get('road')
    speed = (sc.opt('speed') if sc is not None else None) or man.get('speed')
    horizon = (sc.opt('horizon') if sc is not None else None) or man.get('horizon')
    road.object()
    try:
        tracks = road_tracks(road.value, lay.n_tracks, lay.track_separation())
    except ConfigError:
        raise
    except (TypeError, ValueError, KeyError, AttributeError) as err:
        raise road.error(
            f'not a road this suspopt can build ({type(err).__name__}: {err})'
        ) from None
    profile = road.opt('profile')
    return Setting(
        lay, tracks, speed.number(), horizon.number(), '' if profile is None else profile.text()
    )


def road_figure(path: Path, setting: Setting) -> Path:
    """Road displacement under every wheel over the horizon (paper Figure 3)."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    lay, speed = setting.layout, setting.speed
    t = np.linspace(0.0, setting.horizon, 2001)
    fig, ax = plt.subplots(figsize=(8, 3.5), constrained_layout=True)
    for corner, off in zip(lay.corners, lay.offsets()):
        h = setting.tracks[corner.track].r(speed * t - off)
        ax.plot(
            t,
            h * 1e3,
            ls='-' if corner.axle == 0 else '--',
            label=rf'wheel {corner.label} $\delta_{{{corner.label}}}(t)$',
        )
    ax.set_xlabel('time t [s]')
    ax.set_ylabel('road displacement [mm]')
    ax.set_title(f'Road input ({setting.profile}, v = {speed:g} m/s) — paper Fig. 3')
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    save_figure(fig, path, dpi=110)
    plt.close(fig)
    return path
