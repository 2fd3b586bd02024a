"""Ride metrics (``docs/metrics.md``): what a ride engineer measures of a design.

Every metric is a named signal of the vehicle assembly, per node (and per corner or
seat), with units. An objective term is the integral of its square over the horizon
(``J = ∫ s² dt``; its r.m.s. value is ``sqrt(J / T)``), weighted and normalized like the
paper's (eq. 4); a constraint bounds it at every node (a path constraint) or, for the
design-only metrics (roll gradient, ride frequencies), bounds a function of the design.

* ``heave``, ``pitch``, ``roll``: the chassis accelerations (the paper's comfort terms);
* ``wheel_<c>``: the wheel's vertical displacement (the paper's road-holding terms);
* ``tyre_load_<c>``: the dynamic tyre load (the tyre force about its static value);
* ``travel_<c>``: the suspension travel, the wheel relative to the body above it
  (positive in bump);
* ``comfort_<seat>``: the ISO 2631-1 Wk-weighted vertical acceleration at a seat, and
  ``comfort_pitch``, ``comfort_roll``: the We-weighted rotational accelerations
  (:mod:`suspopt.models.iso2631`; filter states integrated with the vehicle's);
* ``control_<c>``: the force of an active or semi-active actuator at a controlled corner
  (its integral of squares is the control effort, ``docs/codesign.md``).

This module is the metrics' table (no OpenMDAO: the study file's checks use it); their
components are in :mod:`suspopt.models.metric_components`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from suspopt.models.layout import VehicleLayout

#: standard gravity [m/s²] (static wheel loads; the dynamics are about the static state)
GRAVITY = 9.80665


@dataclass(frozen=True)
class Metric:
    """A kind of metric: the signal it squares, the signal's units, a label, and the side
    of the ride-handling trade-off it belongs to (``comfort``, ``road_holding``,
    ``travel``)."""

    signal: str
    units: str
    label: str
    group: str

    @property
    def term_units(self) -> str:
        """Units of its term ``∫ s² dt``."""
        return f'({self.units})²·s'


#: every metric kind by the prefix of its terms
METRICS: dict[str, Metric] = {
    'heave': Metric('zdd_C', 'm/s²', 'heave acceleration', 'comfort'),
    'pitch': Metric('thdd_C', 'rad/s²', 'pitch acceleration', 'comfort'),
    'roll': Metric('phidd_C', 'rad/s²', 'roll acceleration', 'comfort'),
    'wheel': Metric('wheel_z', 'm', 'wheel displacement', 'road_holding'),
    'tyre_load': Metric('F_T', 'N', 'dynamic tyre load', 'road_holding'),
    'travel': Metric('travel', 'm', 'suspension travel', 'travel'),
    'comfort': Metric('a_w', 'm/s²', 'ISO 2631-1 Wk-weighted seat acceleration', 'comfort'),
    'control': Metric('u_F', 'N', 'actuator force', 'control'),
}


def term_kind(term: str) -> str:
    """The metric kind of a term (``tyre_load_1L`` → ``tyre_load``)."""
    for kind in sorted(METRICS, key=len, reverse=True):
        if term == kind or term.startswith(kind + '_'):
            return kind
    raise KeyError(term)


def term_units(term: str) -> str:
    """Units of a term's integral."""
    if term in ('comfort_pitch', 'comfort_roll'):
        return '(rad/s²)²·s'
    return METRICS[term_kind(term)].term_units


def objective_terms(
    layout: VehicleLayout,
    seats: tuple[str, ...] = (),
    rotational: bool = False,
    controlled: tuple[str, ...] = (),
) -> tuple[str, ...]:
    """Every term of a model: the chassis accelerations, each wheel's displacement (the
    paper's eq. 4, extended), each corner's dynamic tyre load and suspension travel, the
    comfort at each seat (with ``rotational``, also the weighted pitch and roll), and the
    actuator force at each ``controlled`` corner."""
    corners = layout.labels
    return (
        layout.dofs
        + tuple(f'wheel_{c}' for c in corners)
        + tuple(f'tyre_load_{c}' for c in corners)
        + tuple(f'travel_{c}' for c in corners)
        + tuple(f'comfort_{s}' for s in seats)
        + (tuple(f'comfort_{d}' for d in layout.dofs[1:]) if rotational else ())
        + tuple(f'control_{c}' for c in controlled)
    )


def term_groups(terms: tuple[str, ...]) -> dict[str, tuple[str, ...]]:
    """The terms by group name, for weights given by group (``tyre_load = 0.5`` is split
    equally among every corner's ``tyre_load_<c>``): each kind with per-corner or per-seat
    terms (``wheel``, ``tyre_load``, ``travel``, ``comfort``, ``control``)."""
    out: dict[str, tuple[str, ...]] = {}
    for kind in ('wheel', 'tyre_load', 'travel', 'comfort', 'control'):
        members = tuple(t for t in terms if t.startswith(kind + '_'))
        if members:
            out[kind] = members
    return out


def static_loads(layout: VehicleLayout, sprung_mass: float, wheel_mass: np.ndarray) -> np.ndarray:
    """The static vertical load on each tyre [N]: the sprung mass shared by the axles in
    inverse proportion to their distance from the centre of gravity, equally between an
    axle's wheels, plus the wheel's own mass, times gravity."""
    a = layout.a
    if layout.n == 1:
        share = np.ones(1)
    else:
        front, rear = a.max(), a.min()
        axle_share = np.where(a == front, -rear, front) / (front - rear)
        per_axle = np.array([np.sum(a == ai) for ai in a])
        share = axle_share / per_axle
    return GRAVITY * (sprung_mass * share + np.asarray(wheel_mass, dtype=float))
