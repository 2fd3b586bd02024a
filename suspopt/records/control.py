"""The record of an open-loop control's time history, as the collocation represents it
(``docs/codesign.md``), and its evaluation at any time — what the time marching of an
open-loop result integrates.

On a Radau grid (Dymos' ``Radau``) a control has a value at each of the ``n`` LGR points
of every segment (``τ`` in ``[-1, 1)``, the left end included); within a segment it is
the degree-``(n - 1)`` Lagrange polynomial through those values, and it may jump at the
segment ends (no continuity is imposed). Marched with this representation, piece by
piece between the segment ends, the verification integrates exactly the control the
optimizer chose, independently of how the grid discretizes the states.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from suspopt.records.codec import Node, Record

#: how a history is interpolated between its points (the record's ``interpolation``)
RADAU = 'radau'
INTERPOLATIONS = {
    RADAU: 'per segment, the degree-(n - 1) Lagrange polynomial through the values at its '
    'n LGR points (barycentric form); it may jump at segment ends',
}


def barycentric_weights(nodes: np.ndarray) -> np.ndarray:
    """The barycentric weights ``1 / Π_{j≠i} (x_i - x_j)`` of interpolation points
    (Berrut & Trefethen, SIAM Rev. 46(3), 2004, eq. 3.2)."""
    diff = nodes[:, None] - nodes[None, :]
    np.fill_diagonal(diff, 1.0)
    return 1.0 / np.prod(diff, axis=1)


@dataclass(frozen=True)
class ControlHistory(Record):
    """One open-loop control of one scenario: ``name`` (``u_A`` [N], ``c_A`` [N s/m]),
    its ``units``, the controlled ``corners`` (labels), the segment ends [s], the ``tau``
    of the interpolation points in each segment (on [-1, 1)) and ``values``, one tuple per
    corner of every point's value, segment by segment."""

    name: str
    units: str
    corners: tuple[str, ...]
    scenario: str
    segment_ends: tuple[float, ...]
    tau: tuple[float, ...]
    values: tuple[tuple[float, ...], ...]
    interpolation: str = RADAU

    @classmethod
    def radau(
        cls,
        *,
        name: str,
        units: str,
        corners: tuple[str, ...],
        scenario: str,
        segment_ends: np.ndarray,
        tau: np.ndarray,
        values: np.ndarray,
    ) -> ControlHistory:
        """From ``values`` at the LGR points (segments × points, corners)."""
        v = np.asarray(values, dtype=float).reshape(-1, len(corners))
        return cls(
            name=name,
            units=units,
            corners=tuple(corners),
            scenario=scenario,
            segment_ends=tuple(float(x) for x in segment_ends),
            tau=tuple(float(x) for x in tau),
            values=tuple(tuple(float(x) for x in col) for col in v.T),
        )

    @classmethod
    def constant(
        cls,
        *,
        name: str,
        units: str,
        corners: tuple[str, ...],
        scenario: str,
        horizon: float,
        value: float,
    ) -> ControlHistory:
        """A control held at ``value`` over ``[0, horizon]`` (one segment, one point)."""
        return cls(
            name=name,
            units=units,
            corners=tuple(corners),
            scenario=scenario,
            segment_ends=(0.0, float(horizon)),
            tau=(-1.0,),
            values=tuple((float(value),) for _ in corners),
        )

    @property
    def segments(self) -> int:
        return len(self.segment_ends) - 1

    def values_at_points(self) -> np.ndarray:
        """The values at the points, (segments × points, corners)."""
        return np.array(self.values, dtype=float).T

    def times(self) -> np.ndarray:
        """The points' times [s], (segments × points,)."""
        ends = np.asarray(self.segment_ends)
        tau = np.asarray(self.tau)
        half = 0.5 * np.diff(ends)[:, None]
        return (ends[:-1, None] + half * (tau + 1.0)).ravel()

    def breakpoints(self) -> np.ndarray:
        """Where the control may jump or kink: the segment ends [s]."""
        return np.asarray(self.segment_ends)

    def segment_of(self, t: Any) -> Any:
        """The segment of times ``t``: the one whose interval ``[start, end)`` holds it (the
        segment that starts there, whose first point it is), the last at the horizon."""
        ends = np.asarray(self.segment_ends)
        return np.clip(np.searchsorted(ends, t, side='right') - 1, 0, self.segments - 1)

    def __call__(self, t: Any, segment: int | None = None) -> np.ndarray:
        """The control at times ``t`` (N,) → (N, corners): each time by its segment's
        polynomial (:meth:`segment_of`), or with ``segment`` by that segment's, for times on
        its closed interval (the time marching's piece: up to its end, where the next
        segment's polynomial may differ)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        ends = np.asarray(self.segment_ends)
        seg = self.segment_of(t) if segment is None else np.full(t.shape, segment)
        tau = np.asarray(self.tau)
        n = tau.size
        u = self.values_at_points().reshape(self.segments, n, -1)[seg]  # (N, n, corners)
        if n == 1:  # a constant per segment
            return u[:, 0]
        x = 2.0 * (t - ends[seg]) / (ends[seg + 1] - ends[seg]) - 1.0
        d = x[:, None] - tau[None, :]
        hit = np.abs(d) < 1e-14
        d = np.where(hit, 1.0, d)
        c = barycentric_weights(tau)[None, :] / d
        out = np.einsum('nk,nkc->nc', c, u) / c.sum(axis=1)[:, None]
        rows, cols = np.nonzero(hit)
        out[rows] = u[rows, cols]
        return out

    def check(self, node: Node) -> None:
        if self.interpolation not in INTERPOLATIONS:
            raise node.child('interpolation').error(
                f'expected one of {", ".join(INTERPOLATIONS)}, got {self.interpolation!r}'
            )
        expected = self.segments * len(self.tau)
        for k, col in enumerate(self.values):
            if len(col) != expected:
                raise (
                    node.child('values')
                    .child(k)
                    .error(
                        f'expected {expected} values ({self.segments} segments × '
                        f'{len(self.tau)} points), got {len(col)}'
                    )
                )
        if len(self.values) != len(self.corners):
            raise node.child('values').error(
                f'one list per corner ({len(self.corners)}), got {len(self.values)}'
            )

    def derived(self) -> dict[str, Any]:
        return {'described': INTERPOLATIONS.get(self.interpolation, '')}
