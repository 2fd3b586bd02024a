"""The design variables, in one table: their kinds (the setting each one sets, its units in
OpenMDAO's and in display spelling, its label) and every variable's identity — its kind
and the axle or corner it acts on — as data (``docs/model.md``, "Design variables").

A name (``k_S1``, ``c_S2L``, ``k_R1``) is read once, by :func:`design_id`, into a
:class:`DesignId`; everything else asks the identity (no OpenMDAO here: the study file's
checks import this)."""

from __future__ import annotations

import re
from dataclasses import dataclass

from suspopt.models.layout import AXLES, SIDES


@dataclass(frozen=True)
class DesignKind:
    """One kind of design variable: ``symbol`` is the start of its names and the
    per-corner (per-bar) setting it sets; ``units`` OpenMDAO's spelling, ``display`` the
    tables' and figures', ``plain`` ASCII text's (study-file comments)."""

    symbol: str
    label: str
    units: str
    display: str
    plain: str
    per_bar: bool = False


#: spring rate, damping (paper Table 3) and anti-roll bar rate (full car)
SPRING = DesignKind('k_S', 'spring rate', 'N/m', 'N/m', 'N/m')
DAMPER = DesignKind('c_S', 'damping', 'N*s/m', 'N·s/m', 'N s/m')
ANTI_ROLL_BAR = DesignKind('k_R', 'anti-roll bar rate', 'N*m/rad', 'N·m/rad', 'N m/rad', True)
#: the gains of a state-feedback controller (``docs/codesign.md``): skyhook (on the body's
#: velocity above the corner), groundhook (on the wheel's), travel and travel rate
SKYHOOK = DesignKind('g_sky', 'skyhook gain', 'N*s/m', 'N·s/m', 'N s/m')
GROUNDHOOK = DesignKind('g_gnd', 'groundhook gain', 'N*s/m', 'N·s/m', 'N s/m')
TRAVEL_GAIN = DesignKind('g_tr', 'travel gain', 'N/m', 'N/m', 'N/m')
RATE_GAIN = DesignKind('g_rt', 'travel-rate gain', 'N*s/m', 'N·s/m', 'N s/m')
KINDS: dict[str, DesignKind] = {
    k.symbol: k
    for k in (SPRING, DAMPER, ANTI_ROLL_BAR, SKYHOOK, GROUNDHOOK, TRAVEL_GAIN, RATE_GAIN)
}
#: the feedback gains' kinds (per-corner settings of the controller block)
GAIN_KINDS = ('g_sky', 'g_gnd', 'g_tr', 'g_rt')

#: OpenMDAO units of each kind (by symbol)
DESIGN_UNITS: dict[str, str] = {s: k.units for s, k in KINDS.items()}

#: side letter of a per-corner variable → the layout's side (+1 left, -1 right)
_SIDE_OF_LETTER = {letter: side for side, letter in SIDES.items() if letter}
_NAME = re.compile(
    r'(?P<kind>' + '|'.join(KINDS) + r')(?P<axle>[' + ''.join(AXLES) + r'])(?P<side>[LR]?)'
)


@dataclass(frozen=True)
class DesignId:
    """What a design variable is: its kind, its axle (0 front, 1 rear) and, for a
    per-corner variable, its side (+1 left, -1 right; 0: every corner of the axle)."""

    kind: DesignKind
    axle: int
    side: int = 0

    @property
    def name(self) -> str:
        return f'{self.kind.symbol}{AXLES[self.axle]}{SIDES[self.side]}'

    def acts_on(self, axle: int, side: int) -> bool:
        """True if this variable sets the corner on ``axle`` at ``side``."""
        return axle == self.axle and self.side in (0, side)

    def heading(self) -> str:
        """A table's column heading: ``k_S1 [N/m]``."""
        return f'{self.name} [{self.kind.display}]'


def design_id(name: str) -> DesignId:
    """The identity of a design variable's name (ValueError if it is none)."""
    m = _NAME.fullmatch(name)
    if m is None:
        raise ValueError(f'not a design variable name: {name!r}')
    return DesignId(KINDS[m['kind']], AXLES.index(m['axle']), _SIDE_OF_LETTER.get(m['side'], 0))


def design_kind(name: str) -> str:
    """``k_S``, ``c_S``, ``k_R`` or a gain's symbol of a design variable's name
    (``k_S1``, ``c_S2L``, ``k_R1``, ``g_sky1``)."""
    return design_id(name).kind.symbol


def design_units(name: str) -> str:
    """OpenMDAO units of a design variable."""
    return design_id(name).kind.units


def design_heading(name: str) -> str:
    """A table's column heading of a design variable: ``c_S1 [N·s/m]``."""
    return design_id(name).heading()


def on_axle(name: str, axle: int) -> bool:
    """True if design variable ``name`` acts on axle ``axle`` (0 front, 1 rear)."""
    return design_id(name).axle == axle


def _corner(label: str) -> tuple[int, int]:
    """(axle, side) of a corner label (``1``, ``2L``; :mod:`suspopt.models.layout`)."""
    for axle, a in enumerate(AXLES):
        for side, s in SIDES.items():
            if label == a + s:
                return axle, side
    raise ValueError(f'not a corner label: {label!r}')


def corner_of_design(
    names: tuple[str, ...], labels: tuple[str, ...]
) -> dict[str, list[tuple[str, int]]]:
    """Where each design variable acts: ``{name: [(setting, index), ...]}`` with setting
    ``k_S``/``c_S``/a gain (index: a corner) or ``k_R`` (index: a bar, in axle order). A per-axle
    variable (``k_S1``) acts on every corner of its axle, a per-corner one (``k_S1L``) on
    its own."""
    ids = {n: design_id(n) for n in names}
    bars = sorted((d.axle, n) for n, d in ids.items() if d.kind.per_bar)
    corners = [_corner(lab) for lab in labels]
    out = {}
    for n, d in ids.items():
        if d.kind.per_bar:
            out[n] = [(d.kind.symbol, bars.index((d.axle, n)))]
        else:
            out[n] = [(d.kind.symbol, i) for i, c in enumerate(corners) if d.acts_on(*c)]
    return out
