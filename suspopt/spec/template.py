"""The study file written by ``suspopt init``: a default car as commented TOML."""

from __future__ import annotations

from typing import Any

from suspopt.spec.load import full_car_defaults
from suspopt.spec.schema import StudyConfig


def toml_value(v: Any) -> str:
    """A TOML literal of a plain value."""
    if isinstance(v, bool):
        return 'true' if v else 'false'
    if isinstance(v, str):
        return '"' + v.replace('\\', '\\\\').replace('"', '\\"') + '"'
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, (list, tuple)):
        return '[' + ', '.join(toml_value(x) for x in v) + ']'
    if isinstance(v, dict):
        return '{' + ', '.join(f'{k} = {toml_value(x)}' for k, x in v.items()) + '}'
    return str(v)


def default_config_toml(model: str = 'half_car') -> str:
    """The paper's case (``half_car``) or the default full car as a commented study file."""
    full = model == 'full_car'
    c = full_car_defaults() if full else StudyConfig()
    v = c.vehicle
    tv = toml_value
    if full:
        head = [
            '# suspopt study file: the default full car, a BMW E90 (330i, 2006) as',
            '# Chrono::Vehicle models it (data credited there to SAE 2007-01-0817/-0818;',
            '# see suspopt/vehicles.py). SI units throughout.',
        ]
    else:
        head = [
            '# suspopt study file: the paper\'s case (Cheong et al., "Optimal design of',
            '# vehicle dynamics using gradient-based, mixed-fidelity multidisciplinary',
            '# optimization", Table 1-3, and the two-bump road). SI units throughout.',
        ]
    lines = head + [
        '# Every key is optional; a missing key takes the value shown here.',
        '',
        '[vehicle]',
        f'model = {tv(v.model)}            # half_car | full_car',
        f'chassis_mass = {tv(v.chassis_mass)}          # M [kg] (sprung)',
        f'chassis_pitch_inertia = {tv(v.chassis_pitch_inertia)} # I [kg m^2]',
    ]
    if full:
        lines += [
            f'chassis_roll_inertia = {tv(v.chassis_roll_inertia)}  # I_x [kg m^2]',
            f'cg_height = {tv(v.cg_height)}          # CG above the ground [m] (roll gradient)',
        ]
    for axle, ax, sign in (('front', v.front, 'ahead of'), ('rear', v.rear, 'behind')):
        lines += [
            '',
            f'[vehicle.{axle}]',
            f'axle_position = {tv(ax.axle_position)}   # a [m] {sign} the CG (negative: behind)',
            f'wheel_mass = {tv(ax.wheel_mass)}       # [kg] per wheel (low fidelity)',
            f'tyre_stiffness = {tv(ax.tyre_stiffness)}  # k_T [N/m] per wheel',
            f'mechanism = {tv(ax.mechanism)}  # multibody module: built-in name or TOML path',
        ]
        if full:
            lines += [
                f'track = {tv(ax.track)}          # wheel track [m]',
                f'anti_roll_bar = {tv(ax.anti_roll_bar)}     # its rate k_R is designed',
                f'roll_centre_height = {tv(ax.roll_centre_height)}  # above the ground [m]',
            ]
    road = c.road
    lines += [
        '',
        '[maneuver]',
        f'speed = {tv(c.maneuver.speed)}     # v [m/s], constant',
        f'horizon = {tv(c.maneuver.horizon)}    # T [s]; zero initial state at t = 0',
        '',
        '[road]',
        '# profile = two_bumps | bump | step | iso8608 | csv | two_tracks; they take:',
        '#   two_bumps: height, length, starts    bump: height, length, start',
        '#   step: height, position, ramp_length',
        '#   iso8608: road_class ("A".."H"), seed, n_min, n_max [cycle/m], length [m],',
        '#            fade_in [m], coherence (isotropic | identical | independent:',
        '#            the right track of a full car)',
        '#   csv: file  (distance [m], height [m] per row; header allowed)',
        '#   two_tracks: left = { profile = ... }, right = { profile = ... } (full car)',
    ]
    lines += [f'{k} = {tv(val)}' for k, val in road.items()]
    lines += [
        '',
        '# design variables: initial value and bounds; optimize = false holds one at',
        '# its initial value' + (' (paper Table 3)' if not full else ''),
        '[design]',
        f'per_corner = {tv(c.design.per_corner)}'
        + ('   # true: one variable per wheel (k_S1L, ...)' if full else ''),
    ]
    for name, dv in c.design.variables.items():
        unit = {'k_S': 'N/m', 'c_S': 'N s/m', 'k_R': 'N m/rad'}[name[:3]]
        lines += [
            f'[design.{name}]  # [{unit}]',
            f'initial = {tv(dv.initial)}\nlower = {tv(dv.lower)}\nupper = {tv(dv.upper)}'
            f'\noptimize = {tv(dv.optimize)}',
        ]
    o, t, op, mb = c.objective, c.transcription, c.optimizer, c.multibody
    lines += [
        '',
        '[objective]                    # f = sum_k w_k J_k / s_k',
        f'normalization = {tv(o.normalization)}  # reference | '
        + ('paper | ' if not full else '')
        + 'custom (then set [objective.scales])',
        f'aggregate = {tv(o.aggregate)}           # several scenarios: sum | max',
        '[objective.weights]            # by term: chassis accelerations, wheel travel',
    ]
    lines += [f'{k} = {tv(w)}' for k, w in o.weights.items()]
    lines += [
        '',
        *_comfort_lines(c),
        *_constraint_lines(c),
        '[transcription]                # Dymos Radau collocation',
        f'segments = {tv(t.segments)}               # a number, or "auto" (from the '
        'horizon, wheel hop and road)',
        f'order = {t.order}',
        f'initial_guess = {tv(t.initial_guess)}   # auto | simulate | zero',
        '',
        '[optimizer]                    # IPOPT',
        f'max_iter = {op.max_iter}',
        f'tol = {tv(op.tol)}',
        f"print_level = {op.print_level}              # IPOPT's own console output (0-12)",
        'options = {}                   # further IPOPT options, e.g. { mu_strategy = "adaptive" }',
        '',
        '[multibody]                    # finite differences of the black-box module',
        f'fd_form = {tv(mb.fd_form)}         # forward | central',
        f'fd_step = {tv(mb.fd_step)}             # absolute step, SI units of each input',
        f'mount = {tv(mb.mount)}            # ground (the paper: frame fixed, chassis '
        'feels F_S) | chassis (frame on the chassis, all reactions)',
        '',
        '# Several load cases sharing the design (robust design): add tables like',
        '# [[scenario]]',
        '# name = "city"',
        '# weight = 1.0',
        '# speed = 8.0',
        '# road = { profile = "iso8608", road_class = "D", seed = 3 }',
        '',
    ]
    return '\n'.join(lines)


def _comfort_lines(c: StudyConfig) -> list[str]:
    """The seats where ride comfort is measured (ISO 2631-1 Wk; terms comfort_<seat>)."""
    tv = toml_value
    lines = ['[comfort]                      # seats: the terms comfort_<name> (ISO 2631-1 Wk)']
    if not c.comfort.seats:
        return lines + [
            'seats = []                     # e.g. [{ name = "driver", x = 0.3, y = 0.37 }]',
            '',
        ]
    lines.append('seats = [')
    lines += [
        f'  {{ name = {tv(s.name)}, x = {tv(s.x)}, y = {tv(s.y)} }},' for s in c.comfort.seats
    ]
    lines[-1] += '  # x ahead of, y left of the CG [m]'
    return lines + [']', '']


def _constraint_lines(c: StudyConfig) -> list[str]:
    """The engineering constraints (docs/metrics.md): each applies when its table is
    given; the others are shown commented out."""
    tv = toml_value
    k = c.constraints
    tables = {
        'travel': (
            k.travel.enabled,
            [f'bump = {tv(k.travel.bump or 0.08)}', f'rebound = {tv(k.travel.rebound or 0.08)}'],
            'suspension travel from static [m] (0: that side free), every node',
        ),
        'tyre_contact': (
            k.tyre_contact.enabled,
            [f'margin = {tv(k.tyre_contact.margin)}'],
            'share of the static load every tyre keeps, every node',
        ),
        'roll_gradient': (
            k.roll_gradient.enabled,
            [f'max = {tv(k.roll_gradient.max or 4.0)}']
            + ([f'min = {tv(k.roll_gradient.min)}'] if k.roll_gradient.min else [])
            + [f'front_share = {tv(list(k.roll_gradient.front_share) or [0.5, 0.75])}'],
            'full car: roll per g [deg/g]; front share of the roll stiffness',
        ),
        'ride_frequency': (
            k.ride_frequency.enabled,
            [
                f'heave = {tv(list(k.ride_frequency.heave) or [1.0, 1.5])}',
                f'pitch = {tv(list(k.ride_frequency.pitch) or [1.0, 1.8])}',
            ],
            'undamped frequencies of the sprung mass [Hz], [lower, upper]',
        ),
    }
    lines = ['# engineering constraints (docs/metrics.md): each applies when its table is given']
    for name, (on, body, what) in tables.items():
        mark = '' if on else '# '
        lines.append(f'{mark}[constraints.{name}]'.ljust(31) + f'# {what}')
        lines += [f'{mark}{line}' for line in body]
    return lines + ['']
