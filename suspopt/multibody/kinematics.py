"""Kinematic curves of a suspension mechanism over its wheel travel (K&C, front view).

The wheel travel ``w`` is the vertical displacement of the ``wheel_marker`` (the
vehicle's ``q^z_W``, eq. 13) from the reference pose. At each travel, position, velocity
and acceleration analysis with unit independent rate give ``q``, ``q' = dq/dz`` and
``q'' = d²q/dz²`` (``C_q q'' = γ``) of the independent coordinate ``z``, hence exact
derivatives along ``w`` by the chain rule. With ``s`` the deflection ``ℓ - ℓ0`` of the
suspension spring (the ``spring`` role):

* motion ratio ``MR = -ds/dw`` (spring compression per unit wheel travel);
* wheel rate ``K = d²V/dw² = k (s_w² + s s_ww)`` of the spring's potential ``V = ½ k s²``
  for a spring rate k: the vertical force at the wheel per unit wheel travel;
* camber ``-(φ_W - φ_W0)`` of the body carrying the wheel marker, in degrees, positive
  when the top of the wheel leans outboard (x is outboard, φ counter-clockwise in the
  x–z plane, so a positive φ tilts the top inboard);
* track change: lateral displacement of the tyre load's marker (the contact patch),
  positive outboard;
* wheel force ``dV/dw``: the vertical force at the wheel that holds the spring at travel
  ``w``;
* kinematic roll centre height: where the line from the contact patch ``P`` through the
  instant centre of the wheel's body relative to the body (the frame: the chassis side)
  meets the vehicle's centre line, above the ground (the contact patch's height at that
  travel). The line through ``P`` and the instant centre is the normal to ``P``'s
  velocity (``v_P = ω × (P - IC)``), so the height is ``(x_P - x_c) dx_P/dz_P`` with the
  derivatives along the travel: it needs no instant centre at a finite distance (a
  parallelogram's is at infinity), and it is the swing-arm construction of the roll
  centre (Milliken & Milliken, *Race Car Vehicle Dynamics*, 1995, ch. 17). The centre line
  ``x_c`` is the mechanism's ``[suspension] centre_line`` (default 0, the file's origin);
  the construction assumes a symmetric vehicle moving in heave, both sides alike, so the
  roll centre lies on the centre line. The instant centre itself (``instant_centre``, in
  the file's frame; infinite for a translating wheel, :data:`FAR`) is
  ``r + perp(ṙ)/φ̇`` of that body;
* roll centre migration: the roll centre's height less its height at the reference
  pose (zero travel, analysed with the others whatever the range).

A suspension spring with curves (:mod:`suspopt.curves`: a progressive spring,
bump and rebound stops) replaces ``½ k s²`` by its elastic energy ``E(x)``, ``x = -s``
the compression: wheel force ``-F(x) s_w`` and wheel rate ``F'(x) s_w² - F(x) s_ww``
(``F = dE/dx``, spring and stops), so the wheel rate jumps up smoothly where a stop makes
contact; its spring rate is then ``F'(0)``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from suspopt.errors import ConfigError, MultibodyError
from suspopt.multibody.elements import PointLoad, SpringSpec, is_spring
from suspopt.multibody.mechanism import Mechanism, load_mechanism
from suspopt.multibody.solver import PlanarMultibodySolver

#: spring rate used when neither the caller nor the file gives one: the initial k_S of
#: the study (docs/model.md)
DEFAULT_SPRING_RATE = 30000.0
#: an instant centre farther than this from the body [m] is at infinity (a translating
#: wheel, its rotation rate zero to rounding)
FAR = 1.0e6
#: columns of the table: key, heading, unit scale for printing
COLUMNS = (
    ('travel', 'wheel travel [mm]', 1e3),
    ('spring_deflection', 'spring deflection [mm]', 1e3),
    ('motion_ratio', 'motion ratio [-]', 1.0),
    ('wheel_rate', 'wheel rate [N/mm]', 1e-3),
    ('camber', 'camber [deg]', 1.0),
    ('track_change', 'track change [mm]', 1e3),
    ('wheel_force', 'wheel force [N]', 1.0),
    ('roll_centre_height', 'roll centre height [mm]', 1e3),
    ('roll_centre_migration', 'roll centre migration [mm]', 1e3),
)


def kinematic_curves(
    mechanism: Mechanism | str,
    travel: tuple[float, float] | None = None,
    k: float | None = None,
    points: int = 21,
    centre_line: float | None = None,
) -> dict[str, Any]:
    """The curves at ``points`` wheel travels spanning ``travel`` [m] (default: the
    mechanism's travel range), for spring rate ``k`` [N/m] (default: the spring's in the
    file, or :data:`DEFAULT_SPRING_RATE` if that is zero; for a spring with curves, ``k``
    replaces its ``k_S``). Returns plain arrays per column of :data:`COLUMNS`, the
    independent coordinate's displacement at each travel (``independent``), the instant
    centre (``instant_centre``, (points, 2)), and the inputs (``name``, ``spring_rate``,
    ``centre_line`` [m], default the mechanism's)."""
    mech = load_mechanism(mechanism, suspension=True) if isinstance(mechanism, str) else mechanism
    s = PlanarMultibodySolver(mech)
    roles = mech.roles
    span = mech.travel if travel is None else travel
    if span is None:
        raise ConfigError(f'travel: {mech.name} has no travel range ([suspension]); give one')
    lo, hi = span
    if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi) or points < 2:
        raise ConfigError(
            f'travel: need min < max and at least 2 points, got [{lo}, {hi}] with {points} points'
        )
    spring = mech.force(roles['spring'])
    tyre_load = mech.force(roles['tyre_load'])
    if not is_spring(spring) or not isinstance(tyre_load, PointLoad):
        raise ConfigError(
            f'suspension: {mech.name} needs a spring element as its spring and a point load '
            'as its tyre_load'
        )
    unit = spring.curves
    k, params = _spring_rate(spring, k, mech.name)
    x_c = float(mech.centre_line if centre_line is None else centre_line)
    wheel = s.marker_names.index(roles['wheel_marker'])
    patch = s.marker_names.index(tyre_load.marker)
    body = s.body_names.index(mech.marker(roles['wheel_marker']).body)
    hub = s.body_names.index(mech.marker(tyre_load.marker).body)
    ref = s.marker_reference()
    # and the reference pose (the roll centre's migration), analysed with them, then split
    target = np.append(np.linspace(lo, hi, points), 0.0)
    points += 1
    z, q, qd, qdd, w, w1 = _follow_travel(s, wheel, ref, target, (lo, hi))
    w2 = s.marker_accelerations(q, qd, qdd)[:, wheel, 1]
    sp = s.spring(
        roles['spring'], q, qd, {roles['spring']: {'stiffness': 0.0, 'damping': 0.0}}, qdd=qdd
    )
    s_w = sp.rate / w1
    s_ww = (sp.acceleration - s_w * w2) / w1**2
    if unit is None:  # V = ½ k s²
        force, rate = -k * sp.deflection, np.full(points, k)
    else:  # V = E(x), x = -s
        force, rate = unit.elastic_force(-sp.deflection, params)
    P = s.marker_positions(q)[:, patch]
    v_P = s.marker_velocities(q, qd)[:, patch] / w1[:, None]  # per unit wheel travel
    r, v = q[:, 3 * hub : 3 * hub + 2], qd[:, 3 * hub : 3 * hub + 2]
    omega = qd[:, 3 * hub + 2]
    with np.errstate(divide='ignore', invalid='ignore'):
        ic = r + np.stack([-v[:, 1], v[:, 0]], -1) / omega[:, None]
    # a translating wheel (to rounding): at infinity
    ic[~(np.abs(omega) * FAR > np.hypot(v[:, 0], v[:, 1]))] = np.inf
    height = (P[:, 0] - x_c) * v_P[:, 0] / v_P[:, 1]
    out = {
        'name': mech.name,
        'spring_rate': k,
        'centre_line': x_c,
        'travel': w,
        'independent': z - s.q0[s.ind[0]],
        'spring_deflection': sp.deflection,
        'motion_ratio': -s_w,
        'wheel_rate': rate * s_w**2 - force * s_ww,
        'camber': -np.degrees(q[:, 3 * body + 2] - s.q0[3 * body + 2]),
        'track_change': P[:, 0] - ref[patch, 0],
        'wheel_force': -force * s_w,
        'roll_centre_height': height,
        'roll_centre_migration': height - height[-1],
        'instant_centre': ic,
    }
    return {k: v[:-1] if isinstance(v, np.ndarray) else v for k, v in out.items()}


def _spring_rate(spring: SpringSpec, k: float | None, name: str) -> tuple[float, dict[str, float]]:
    """The spring rate of :func:`kinematic_curves` (``k``, else the spring's, else
    :data:`DEFAULT_SPRING_RATE`; a spring with curves: its rate at zero compression, with
    ``k`` as its ``k_S``) and the curve parameters that give it (``name``: the
    mechanism's)."""
    unit = spring.curves
    params: dict[str, float] = {}
    if unit is not None:
        if k is not None:
            if 'k_S' not in unit.scalar_parameters():
                raise ConfigError(
                    f'k: the spring {spring.name!r} of {name} is a table; it has no rate '
                    'k_S to replace'
                )
            params['k_S'] = float(k)
        k = float(unit.elastic_force(0.0, params)[1])
    k = float(
        spring.stiffness
        if k is None and spring.stiffness > 0
        else DEFAULT_SPRING_RATE
        if k is None
        else k
    )
    return k, params


def _follow_travel(
    s: PlanarMultibodySolver,
    wheel: int,
    ref: np.ndarray,
    target: np.ndarray,
    span: tuple[float, float],
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The poses where the wheel marker (index ``wheel``, reference positions ``ref``) has
    travelled ``target`` (Newton on ``w(z) = target``, all at once): the independent
    coordinate ``z``, ``q``, ``q̇`` and ``q̈`` at unit ``ż`` and zero ``z̈``, the travel ``w``
    and ``∂w/∂z``. A ConfigError names the travel range ``span`` if the linkage cannot
    follow it."""
    name = s.mechanism.name
    points = target.size
    z = target + s.q0[s.ind[0]]  # the wheel marker moves about like z
    try:
        for _ in range(30):  # Newton on w(z) = target, all at once
            q = s.positions(z[:, None])
            qd = s.velocities(q, np.ones((points, 1)))
            w = s.marker_positions(q)[:, wheel, 1] - ref[wheel, 1]
            w1 = s.marker_velocities(q, qd)[:, wheel, 1]
            if np.max(np.abs(w - target)) < 1e-13:
                break
            z = z - (w - target) / w1
        else:
            raise MultibodyError(
                'the wheel travel does not follow the independent '
                'coordinate (Newton on the travel did not converge)'
            )
        qdd = s.accelerations(q, qd, np.zeros((points, 1)))
    except MultibodyError as err:
        raise ConfigError(
            f'travel: {name} cannot follow the wheel travel '
            f'[{span[0]:g}, {span[1]:g}] m: ' + str(err).removeprefix(f'{name}: ')
        ) from None
    return z, q, qd, qdd, w, w1


def curves_table(curves: dict[str, Any]) -> str:
    """A Markdown table of :func:`kinematic_curves`, then a line on the roll centre."""
    lines = [
        f'{curves["name"]}: kinematic curves (spring rate {curves["spring_rate"]:g} N/m)',
        '',
        '| ' + ' | '.join(h for _, h, _ in COLUMNS) + ' |',
        '|' + '|'.join('---:' for _ in COLUMNS) + '|',
    ]
    for i in range(len(curves['travel'])):
        lines.append(
            '| ' + ' | '.join(_fmt(curves[key][i] * scale) for key, _, scale in COLUMNS) + ' |'
        )
    h, w = curves['roll_centre_height'], curves['travel']
    h0 = h[0] - curves['roll_centre_migration'][0]
    lines += [
        '',
        f'roll centre: {1e3 * h0:.1f} mm above ground at the reference pose, '
        f'{1e3 * h.min():.1f} to {1e3 * h.max():.1f} mm over the travel '
        f'[{1e3 * w.min():.0f}, {1e3 * w.max():.0f}] mm (centre line x = '
        f'{curves["centre_line"]:g} m)',
    ]
    return '\n'.join(lines) + '\n'


def _fmt(x: float) -> str:
    text = f'{x:.4f}'
    return '0.0000' if text == '-0.0000' else text


#: the panels of :func:`plot_curves`
PLOTTED = (
    'motion_ratio',
    'wheel_rate',
    'wheel_force',
    'spring_deflection',
    'camber',
    'track_change',
    'roll_centre_height',
    'roll_centre_migration',
)


def plot_curves(curves: dict[str, Any], path: str | Path) -> Path:
    """Motion ratio, wheel rate, wheel force, spring deflection, camber, track change, roll
    centre height and its migration against wheel travel (PNG)."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 4, figsize=(15, 6.5), sharex=True)
    w = curves['travel'] * 1e3
    for ax, (key, head, scale) in zip(
        axes.ravel(), [c for key in PLOTTED for c in COLUMNS if c[0] == key]
    ):
        ax.plot(w, curves[key] * scale, 'o-', ms=3)
        ax.set_ylabel(head)
        ax.grid(True, alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel('wheel travel [mm] (up: bump)')
    fig.suptitle(f'{curves["name"]} (spring rate {curves["spring_rate"]:g} N/m)')
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def reference_wheel_rate(
    mechanism: Mechanism, solver: PlanarMultibodySolver | None = None
) -> tuple[float, float, float]:
    """The wheel rate at the reference pose as ``K(k) = a k + b`` for a suspension spring
    rate ``k``: ``(a, b, MR)``, ``MR`` the spring's motion ratio there. ``K = d²V/dw²`` of
    every spring's potential along the wheel travel ``w``: ``k_j (s_w² + s s_ww) + f_p s_ww``
    per spring (deflection ``s`` from its free length, preload ``f_p``), the suspension
    spring with rate ``k`` and no preload (the vehicle supplies both), the others as in the
    file. A static equilibrium at the reference pose is stable only if ``K > 0``."""
    s = PlanarMultibodySolver(mechanism) if solver is None else solver
    roles = mechanism.roles
    q = s.q0[None]
    qd = s.velocities(q, np.ones((1, 1)))
    qdd = s.accelerations(q, qd, np.zeros((1, 1)))
    wheel = s.marker_names.index(roles['wheel_marker'])
    w1 = s.marker_velocities(q, qd)[0, wheel, 1]
    w2 = s.marker_accelerations(q, qd, qdd)[0, wheel, 1]
    a = b = mr = np.float64(0.0)
    with np.errstate(all='ignore'):  # a degenerate linkage: refused below, not an error
        for spec in mechanism.forces:
            if not is_spring(spec):
                continue
            sp = s.spring(spec.name, q, qd, qdd=qdd)
            s_w = sp.rate[0] / w1
            s_ww = (sp.acceleration[0] - s_w * w2) / w1**2
            dfl = sp.deflection[0]
            if spec.name == roles['spring']:
                a, mr = s_w**2 + dfl * s_ww, -s_w
            elif spec.curves is not None:  # E(x), x = -s
                F, dF = spec.curves.elastic_force(-dfl)
                b = b + float(dF) * s_w**2 - float(F) * s_ww + spec.preload * s_ww
            else:
                b = b + spec.stiffness * (s_w**2 + dfl * s_ww) + spec.preload * s_ww
    if not (abs(w1) > 1e-9 and np.isfinite(a) and np.isfinite(b) and np.isfinite(mr)):
        raise ConfigError(
            f'{mechanism.name}: suspension.wheel_marker: '
            f'{roles["wheel_marker"]!r} does not move vertically with the '
            'independent coordinate at the reference pose'
        )
    return float(a), float(b), float(mr)
