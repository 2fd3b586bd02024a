"""Where the wheels are: the corner axis of every vehicle model.

Every per-wheel quantity in suspopt (wheel travel, suspension and tyre forces, design
settings, road input, objective terms) is an array over the vehicle's *corners*, like
Dymos' arrays over nodes. The quarter car has one corner (``1``) under a sprung mass that
only heaves; the half car of the paper has two corners on one wheel track (``1`` front,
``2`` rear axle, paper eqs. 5-10) under a chassis that heaves and pitches; the full car has
four on two tracks (``1L``, ``1R``, ``2L``, ``2R``) under a chassis that also rolls.

Sign conventions (docs/model.md, extended): z up; pitch θ positive nose down; roll φ positive
left side up; ``a`` measured forward from the chassis centre of gravity (``a < 0`` at the
rear axle), ``y`` to the left of it. The chassis point above corner c moves by
``z_C - a_c θ_C + y_c φ_C``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: axle index → the paper's subscript (1 front, 2 rear)
AXLES = ('1', '2')
SIDES = {0: '', 1: 'L', -1: 'R'}


@dataclass(frozen=True)
class Corner:
    """One wheel: its axle (0 front, 1 rear), side (0 on the half car's centre line, +1
    left, -1 right), position ``a`` ahead of and ``y`` left of the chassis CG [m], and
    the road track it runs on (0 left or only, 1 right)."""

    axle: int
    side: int
    a: float
    y: float

    @property
    def label(self) -> str:
        """``1``/``2`` (half car) or ``1L``, ``1R``, ``2L``, ``2R`` (full car)."""
        return AXLES[self.axle] + SIDES[self.side]

    @property
    def track(self) -> int:
        return 1 if self.side == -1 else 0


@dataclass(frozen=True)
class VehicleLayout:
    """The corners of one vehicle model and the quantities that depend only on them."""

    model: str
    corners: tuple[Corner, ...]

    @property
    def n(self) -> int:
        return len(self.corners)

    @property
    def labels(self) -> tuple[str, ...]:
        return tuple(c.label for c in self.corners)

    @property
    def has_pitch(self) -> bool:
        return self.model != 'quarter_car'

    @property
    def has_roll(self) -> bool:
        return self.model == 'full_car'

    @property
    def dofs(self) -> tuple[str, ...]:
        """The chassis' degrees of freedom: ``heave``, ``pitch`` (not the quarter car),
        ``roll`` (the full car)."""
        return (
            ('heave',)
            + (('pitch',) if self.has_pitch else ())
            + (('roll',) if self.has_roll else ())
        )

    @property
    def n_tracks(self) -> int:
        return 2 if self.has_roll else 1

    @property
    def a(self) -> np.ndarray:
        return np.array([c.a for c in self.corners])

    @property
    def y(self) -> np.ndarray:
        return np.array([c.y for c in self.corners])

    def offsets(self) -> tuple[float, ...]:
        """Distance of each wheel behind the front axle [m] (its road delay × speed)."""
        a0 = max(c.a for c in self.corners)
        return tuple(a0 - c.a for c in self.corners)

    def track_separation(self) -> float:
        """Mean lateral distance between the left and right wheels [m] (0: one track)."""
        pairs = [
            (c, d)
            for c in self.corners
            for d in self.corners
            if c.axle == d.axle and c.side == 1 and d.side == -1
        ]
        return float(np.mean([c.y - d.y for c, d in pairs])) if pairs else 0.0

    def anti_roll_pairs(self, axles: tuple[int, ...]) -> list[tuple[int, int, int]]:
        """(axle, left corner index, right corner index) of each axle in ``axles``."""
        out = []
        for ax in axles:
            left = [i for i, c in enumerate(self.corners) if c.axle == ax and c.side == 1]
            right = [i for i, c in enumerate(self.corners) if c.axle == ax and c.side == -1]
            if left and right:
                out.append((ax, left[0], right[0]))
        return out


def quarter_car() -> VehicleLayout:
    """The quarter car: one wheel under its share of the sprung mass, which only heaves."""
    return VehicleLayout('quarter_car', (Corner(0, 0, 0.0, 0.0),))


def half_car(a_front: float, a_rear: float) -> VehicleLayout:
    """The paper's half car: one wheel per axle on the centre line (paper Figure 1)."""
    return VehicleLayout('half_car', (Corner(0, 0, a_front, 0.0), Corner(1, 0, a_rear, 0.0)))


def full_car(a_front: float, a_rear: float, track_front: float, track_rear: float) -> VehicleLayout:
    """Four wheels: front left, front right, rear left, rear right."""
    return VehicleLayout(
        'full_car',
        (
            Corner(0, 1, a_front, 0.5 * track_front),
            Corner(0, -1, a_front, -0.5 * track_front),
            Corner(1, 1, a_rear, 0.5 * track_rear),
            Corner(1, -1, a_rear, -0.5 * track_rear),
        ),
    )
