"""suspopt's low-fidelity vehicles as stationary systems (docs/spectral.md, section 9).

The quarter, half and full car of the vehicle assembly (:mod:`suspopt.models.assembly`),
with the seats' ISO 2631-1 Wk filters, are linear in their states and road heights and
affine in the design (:func:`suspopt.models.linear.affine_linearize` reads their matrices
off the assembly's own equations). :func:`vehicle_system` turns one into an
:class:`~suspopt.spectral.system.AffineLinearSystem` whose outputs are the objective terms
of the metrics table (:mod:`suspopt.models.metrics`) that have a finite stationary
variance on a random road:

* ``heave``, ``pitch``, ``roll``: the chassis accelerations;
* ``tyre_load_<c>``: the dynamic tyre load;
* ``travel_<c>``: the suspension travel (the wheel relative to the body above it);
* ``comfort_<seat>``: the Wk-weighted vertical acceleration at a seat.

The absolute wheel displacement ``wheel_<c>`` (the paper's road-holding terms) follows the
road height, a random walk at long wavelengths: its variance is infinite
(:data:`UNBOUNDED_KINDS`). :func:`random_road` reads the stationary road of an ISO 8608
road description; every other profile is refused.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from suspopt.errors import ConfigError
from suspopt.models.assembly import VehicleAssembly
from suspopt.models.layout import VehicleLayout
from suspopt.models.linear import affine_linearize
from suspopt.road import ISO8608Road, make_road
from suspopt.spectral.road import RandomRoad
from suspopt.spectral.system import AffineLinearSystem, RoadCorner

#: the assembly's signal of each metric kind with a finite stationary variance
STATIONARY_SIGNALS = {
    'heave': 'zdd_C',
    'pitch': 'thdd_C',
    'roll': 'phidd_C',
    'tyre_load': 'F_T',
    'travel': 'travel',
    'comfort': 'a_w',
}
#: metric kinds whose variance on a random road is infinite (they follow the road height)
UNBOUNDED_KINDS = ('wheel',)


def term_kind(term: str) -> str:
    """The metric kind of an objective term (``tyre_load_1L`` → ``tyre_load``)."""
    for kind in sorted((*STATIONARY_SIGNALS, *UNBOUNDED_KINDS), key=len, reverse=True):
        if term == kind or term.startswith(kind + '_'):
            return kind
    raise KeyError(term)


def is_unbounded(term: str) -> bool:
    """Whether a term's variance on a random road is infinite (``wheel_<c>``)."""
    return term_kind(term) in UNBOUNDED_KINDS


def _term_names(assembly: VehicleAssembly, signal: str, width: int) -> list[str]:
    """The objective terms of one signal's columns."""
    spec = assembly.spec
    kind = next(k for k, s in STATIONARY_SIGNALS.items() if s == signal)
    if kind in ('heave', 'pitch', 'roll'):
        return [kind]
    if kind == 'comfort':
        return [f'comfort_{name}' for name, _, _ in spec.seats]
    labels = spec.layout.labels
    if width != len(labels):  # a bug: the assembly's per-corner signal has another width
        raise ValueError(f'{signal}: {width} columns for {len(labels)} corners')
    return [f'{kind}_{c}' for c in labels]


def stationary_signals(assembly: VehicleAssembly) -> tuple[str, ...]:
    """The assembly's signals of the stationary metrics, in the metrics table's order."""
    lay = assembly.spec.layout
    chassis = {'heave': 'zdd_C', 'pitch': 'thdd_C', 'roll': 'phidd_C'}
    out = [chassis[d] for d in lay.dofs] + ['F_T', 'travel']
    if assembly.spec.seats:
        out.append('a_w')
    return tuple(out)


def corners(layout: VehicleLayout) -> tuple[RoadCorner, ...]:
    """Each corner's road track and offset behind the front axle."""
    return tuple(
        RoadCorner(track=c.track, offset=float(off))
        for c, off in zip(layout.corners, layout.offsets())
    )


def vehicle_system(
    assembly: VehicleAssembly, design: Sequence[str] | None = None
) -> AffineLinearSystem:
    """The stationary system of the low-fidelity ``assembly``: its matrices affine in the
    design variables ``design`` (default: all of the assembly's), its outputs the terms
    with a finite stationary variance (module docstring), its corners on their tracks
    at their offsets behind the front axle."""
    signals = stationary_signals(assembly)
    lin = affine_linearize(assembly, signals, design)
    base = lin.base
    names: list[str] = []
    for signal in signals:
        rows = base.signals[signal]
        names += _term_names(assembly, signal, rows.stop - rows.start)
    return AffineLinearSystem(
        base.A,
        base.B,
        base.C,
        base.D,
        lin.dA,
        lin.dB,
        lin.dC,
        lin.dD,
        design=lin.design,
        outputs=tuple(names),
        corners=corners(assembly.spec.layout),
    )


def random_road(
    description: Mapping[str, Any], speed: float, layout: VehicleLayout, where: str = 'road'
) -> RandomRoad:
    """The stationary road of an ISO 8608 road description (``profile = "iso8608"``: its
    class, and for a car with two tracks its coherence at the layout's track separation)
    driven at ``speed``. Any other profile is refused: a :class:`ConfigError` naming
    ``where``'s key."""
    profile = description.get('profile', 'two_bumps')
    if profile != ISO8608Road.kind:
        raise ConfigError(
            f'{where}.profile: the spectral method needs a stationary random road '
            f'(profile = "iso8608", an ISO 8608 class), got {profile!r}: a road of discrete '
            'features or a measured profile has no stationary spectrum; evaluate it by '
            'collocation or time marching'
        )
    road = make_road(dict(description))
    assert isinstance(road, ISO8608Road)
    two = layout.n_tracks == 2
    return RandomRoad(
        road_class=road.road_class.upper(),
        speed=float(speed),
        tracks=road.coherence if two else 'identical',
        separation=layout.track_separation() if two else 0.0,
    )


def road_band(description: Mapping[str, Any], speed: float) -> tuple[float, float]:
    """The circular frequencies [rad/s] ``2π v [n_min, n_max]`` between which suspopt's
    ISO 8608 generator (:class:`~suspopt.road.ISO8608Road`) puts the road's power at
    ``speed`` (the spectral model's road velocity is white over every frequency)."""
    road = make_road(dict(description))
    if not isinstance(road, ISO8608Road):
        raise ConfigError(f'road.profile: not an ISO 8608 road, got {road.kind!r}')
    return 2.0 * np.pi * speed * road.n_min, 2.0 * np.pi * speed * road.n_max
