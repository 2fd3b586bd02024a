"""The design variables' names: their kind, units and the corners they act on (no
OpenMDAO here: the study file's checks import this)."""

from __future__ import annotations

#: units of each kind of design variable: spring rate, damping, anti-roll bar rate
DESIGN_UNITS = {'k_S': 'N/m', 'c_S': 'N*s/m', 'k_R': 'N*m/rad'}


def design_kind(name: str) -> str:
    """``k_S``, ``c_S`` or ``k_R`` of a design variable's name (``k_S1``, ``c_S2L``, ``k_R1``)."""
    return name[:3]


def corner_of_design(
    names: tuple[str, ...], labels: tuple[str, ...]
) -> dict[str, list[tuple[str, int]]]:
    """Where each design variable acts: ``{name: [(setting, index), ...]}`` with setting
    ``k_S``/``c_S`` (index: a corner) or ``k_R`` (index: a bar, in axle order). A per-axle
    variable (``k_S1``) acts on every corner of its axle, a per-corner one (``k_S1L``) on
    its own."""
    bars = sorted(n for n in names if design_kind(n) == 'k_R')
    out = {}
    for n in names:
        kind, group = design_kind(n), n[3:]
        if kind == 'k_R':
            out[n] = [('k_R', bars.index(n))]
        else:
            out[n] = [
                (kind, i)
                for i, lab in enumerate(labels)
                if lab == group or (len(group) == 1 and lab[0] == group)
            ]
    return out
