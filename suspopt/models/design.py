"""The design variables, in one table: their kinds (the setting each one sets, its units in
OpenMDAO's and in display spelling, its label) and every variable's identity — its kind
and the axle or corner it acts on — as data (``docs/model.md``, "Design variables").

A name (``k_S1``, ``c_S2L``, ``k_R1``; a curve parameter ``c_bump_low_1``, ``bump_gap_2R``)
is read once, by :func:`design_id`, into a :class:`DesignId`; everything else asks the
identity (no OpenMDAO here: the study file's checks import this).

Besides the linear spring rate, damping and bar rate, every scalar parameter of the
suspension's curves (``docs/nonlinear_hardware.md``: the damper's slopes and knees, a
polynomial spring's higher coefficients, the stops' gaps and coefficients) is a kind:
its variables are named ``<parameter>_<axle>[<side>]`` (the underscore keeps
``k_S2_1``, the front spring's quadratic coefficient, apart from ``k_S2``, the rear
spring's rate) and set the per-corner signal ``curve_<parameter>`` (:attr:`DesignKind.
setting`)."""

from __future__ import annotations

import functools
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
    #: the curve subtable a curve parameter belongs to (``damper_curve``, ``spring_curve``,
    #: ``bump_stop``, ``rebound_stop``); '' for the linear settings and the bar
    slot: str = ''

    @property
    def setting(self) -> str:
        """The per-corner (per-bar) signal of the vehicle this kind sets: ``k_S``,
        ``c_S``, ``k_R``, or ``curve_<parameter>``."""
        return f'curve_{self.symbol}' if self.slot else self.symbol


#: spring rate, damping (paper Table 3) and anti-roll bar rate (full car)
SPRING = DesignKind('k_S', 'spring rate', 'N/m', 'N/m', 'N/m')
DAMPER = DesignKind('c_S', 'damping', 'N*s/m', 'N·s/m', 'N s/m')
ANTI_ROLL_BAR = DesignKind('k_R', 'anti-roll bar rate', 'N*m/rad', 'N·m/rad', 'N m/rad', True)

#: the highest power of a polynomial spring's or a stop's coefficient that may be a design
#: variable (``k_S5``, ``bump_k5``)
MAX_POWER = 5
_SUPERSCRIPT = str.maketrans('0123456789', '⁰¹²³⁴⁵⁶⁷⁸⁹')


def _power_kind(symbol: str, label: str, power: int, slot: str) -> DesignKind:
    return DesignKind(
        symbol,
        label,
        f'N/m**{power}',
        f'N/m{str(power).translate(_SUPERSCRIPT)}',
        f'N/m^{power}',
        slot=slot,
    )


#: the curves' scalar parameters (:mod:`suspopt.curves`), each a kind of its own
CURVE_KINDS: tuple[DesignKind, ...] = (
    DesignKind(
        'c_bump_low', 'bump low-speed damping', 'N*s/m', 'N·s/m', 'N s/m', slot='damper_curve'
    ),
    DesignKind('v_bump_knee', 'bump knee velocity', 'm/s', 'm/s', 'm/s', slot='damper_curve'),
    DesignKind(
        'c_bump_high', 'bump high-speed damping', 'N*s/m', 'N·s/m', 'N s/m', slot='damper_curve'
    ),
    DesignKind(
        'c_rebound_low', 'rebound low-speed damping', 'N*s/m', 'N·s/m', 'N s/m', slot='damper_curve'
    ),
    DesignKind('v_rebound_knee', 'rebound knee velocity', 'm/s', 'm/s', 'm/s', slot='damper_curve'),
    DesignKind(
        'c_rebound_high',
        'rebound high-speed damping',
        'N*s/m',
        'N·s/m',
        'N s/m',
        slot='damper_curve',
    ),
    *(
        _power_kind(f'k_S{i}', f'spring coefficient of x^{i}', i, 'spring_curve')
        for i in range(2, MAX_POWER + 1)
    ),
    DesignKind('bump_gap', 'bump stop gap', 'm', 'm', 'm', slot='bump_stop'),
    *(
        _power_kind(f'bump_k{i}', f'bump stop coefficient of d^{i}', i, 'bump_stop')
        for i in range(2, MAX_POWER + 1)
    ),
    DesignKind('rebound_gap', 'rebound stop gap', 'm', 'm', 'm', slot='rebound_stop'),
    *(
        _power_kind(f'rebound_k{i}', f'rebound stop coefficient of d^{i}', i, 'rebound_stop')
        for i in range(2, MAX_POWER + 1)
    ),
)

#: the gains of a state-feedback controller (``docs/codesign.md``): skyhook (on the body's
#: velocity above the corner), groundhook (on the wheel's), travel and travel rate
SKYHOOK = DesignKind('g_sky', 'skyhook gain', 'N*s/m', 'N·s/m', 'N s/m')
GROUNDHOOK = DesignKind('g_gnd', 'groundhook gain', 'N*s/m', 'N·s/m', 'N s/m')
TRAVEL_GAIN = DesignKind('g_tr', 'travel gain', 'N/m', 'N/m', 'N/m')
RATE_GAIN = DesignKind('g_rt', 'travel-rate gain', 'N*s/m', 'N·s/m', 'N s/m')
#: the feedback gains' kinds (per-corner settings of the controller block)
GAIN_KINDS = ('g_sky', 'g_gnd', 'g_tr', 'g_rt')
KINDS: dict[str, DesignKind] = {
    k.symbol: k
    for k in (
        SPRING,
        DAMPER,
        ANTI_ROLL_BAR,
        SKYHOOK,
        GROUNDHOOK,
        TRAVEL_GAIN,
        RATE_GAIN,
        *CURVE_KINDS,
    )
}

#: OpenMDAO units of each kind (by symbol)
DESIGN_UNITS: dict[str, str] = {s: k.units for s, k in KINDS.items()}

#: side letter of a per-corner variable → the layout's side (+1 left, -1 right)
_SIDE_OF_LETTER = {letter: side for side, letter in SIDES.items() if letter}
_WHERE = r'(?P<axle>[' + ''.join(AXLES) + r'])(?P<side>[LR]?)'
_NAME = re.compile(
    r'(?P<kind>' + '|'.join(k.symbol for k in KINDS.values() if not k.slot) + r')' + _WHERE
)
_CURVE_NAME = re.compile(r'(?P<kind>' + '|'.join(k.symbol for k in CURVE_KINDS) + r')_' + _WHERE)


@dataclass(frozen=True)
class DesignId:
    """What a design variable is: its kind, its axle (0 front, 1 rear) and, for a
    per-corner variable, its side (+1 left, -1 right; 0: every corner of the axle)."""

    kind: DesignKind
    axle: int
    side: int = 0

    @property
    def name(self) -> str:
        sep = '_' if self.kind.slot else ''
        return f'{self.kind.symbol}{sep}{AXLES[self.axle]}{SIDES[self.side]}'

    @property
    def axle_name(self) -> str:
        """The per-axle variable of the same kind (``c_bump_low_1`` of ``c_bump_low_1L``)."""
        sep = '_' if self.kind.slot else ''
        return f'{self.kind.symbol}{sep}{AXLES[self.axle]}'

    def acts_on(self, axle: int, side: int) -> bool:
        """True if this variable sets the corner on ``axle`` at ``side``."""
        return axle == self.axle and self.side in (0, side)

    def heading(self) -> str:
        """A table's column heading: ``k_S1 [N/m]``."""
        return f'{self.name} [{self.kind.display}]'


@functools.lru_cache(maxsize=1024)
def design_id(name: str) -> DesignId:
    """The identity of a design variable's name (ValueError if it is none)."""
    m = _NAME.fullmatch(name) or _CURVE_NAME.fullmatch(name)
    if m is None:
        raise ValueError(f'not a design variable name: {name!r}')
    return DesignId(KINDS[m['kind']], AXLES.index(m['axle']), _SIDE_OF_LETTER.get(m['side'], 0))


def curve_variable(symbol: str, axle: int, side: int = 0) -> str:
    """The name of the variable of curve parameter ``symbol`` on an axle or a corner:
    ``c_bump_low_1``, ``bump_gap_2L``."""
    return DesignId(KINDS[symbol], axle, side).name


def design_kind(name: str) -> str:
    """``k_S``, ``c_S``, ``k_R``, a feedback gain (``g_sky``) or the curve parameter
    (``c_bump_low``) of a design variable's name (``k_S1``, ``c_S2L``, ``k_R1``, ``g_sky1``,
    ``c_bump_low_1``)."""
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
    ``k_S``/``c_S``/a gain/``curve_<parameter>`` (index: a corner) or ``k_R`` (index: a bar, in
    axle order). A per-axle variable (``k_S1``) acts on every corner of its axle, a
    per-corner one (``k_S1L``) on its own."""
    ids = {n: design_id(n) for n in names}
    bars = sorted((d.axle, n) for n, d in ids.items() if d.kind.per_bar)
    corners = [_corner(lab) for lab in labels]
    out = {}
    for n, d in ids.items():
        if d.kind.per_bar:
            out[n] = [(d.kind.setting, bars.index((d.axle, n)))]
        else:
            out[n] = [(d.kind.setting, i) for i, c in enumerate(corners) if d.acts_on(*c)]
    return out
