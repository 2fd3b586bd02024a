"""Shipped mechanisms as the solver-level tests drive them: with the paper's external
suspension load added.

The vehicle applies the suspension through the mechanism's spring-damper element
(:mod:`suspopt.multibody.suspension`); the solver tests of the paper's module (docs/model.md)
drive the linkage with a given suspension force instead: a point load ``suspension`` of
magnitude ``F_S`` pointing down at the spring's linkage-end marker, as the shipped files
carried before the element library (paper Table 2's ``p_FS``)."""

from __future__ import annotations

import tomllib

from suspopt.multibody.mechanism import Mechanism, mechanism_from_dict, mechanism_path

#: the marker of the paper's suspension force on each shipped linkage
SPRING_POINT = {
    'double_wishbone': 'spring_point',
    'sla_double_wishbone': 'spring_point',
    'macpherson': 'spring_seat',
}


def raw(name: str) -> dict:
    with mechanism_path(name).open('rb') as fh:
        return tomllib.load(fh)


def with_suspension_load(name: str, data: dict | None = None) -> Mechanism:
    """The shipped mechanism ``name`` with a load ``suspension`` (direction down) at its
    spring point, listed before the tyre load (loads: ``suspension``, ``tyre``)."""
    data = raw(name) if data is None else data
    data['loads'] = [
        {'name': 'suspension', 'marker': SPRING_POINT[name], 'direction': [0.0, -1.0]}
    ] + data.get('loads', [])
    return mechanism_from_dict(data, source=name, suspension=True)
