"""The record of an open-loop control (:class:`suspopt.records.control.ControlHistory`):
its polynomial per segment, its JSON round trip inside a solve record, and a damaged
file refused naming the key."""

from __future__ import annotations

import json

import numpy as np
import pytest
from dymos.utils.lgr import lgr

from suspopt.errors import ConfigError
from suspopt.records.control import ControlHistory
from suspopt.records.solve import SolveRecord


def history(order: int = 3, segments: int = 4, horizon: float = 2.0) -> ControlHistory:
    """Two corners: a polynomial of degree order - 1 in time on every segment (a different
    one each), and a constant."""
    ends = np.linspace(0.0, horizon, segments + 1)
    tau = lgr(order)[0]
    t = (ends[:-1, None] + 0.5 * np.diff(ends)[:, None] * (tau + 1.0)).ravel()
    seg = np.repeat(np.arange(segments), order)
    u = (seg + 1.0) * (t - 0.3) ** (order - 1) + seg
    return ControlHistory.radau(
        name='u_A',
        units='N',
        corners=('1', '2'),
        scenario='main',
        segment_ends=ends,
        tau=tau,
        values=np.stack([u, np.full_like(u, 7.0)], axis=1),
    )


def test_the_polynomial_of_each_segment_is_exact():
    h = history()
    for j in range(4):
        t = np.linspace(0.5 * j, 0.5 * (j + 1), 9)
        got = h(t, segment=j)
        np.testing.assert_allclose(got[:, 0], (j + 1.0) * (t - 0.3) ** 2 + j, rtol=1e-12)
        np.testing.assert_allclose(got[:, 1], 7.0, rtol=1e-14)
    # at a shared end, by time alone: the segment starting there (its first point);
    # the marching's piece before it takes the left segment's polynomial up to its end
    assert h(np.array([0.5]))[0, 0] == pytest.approx(2.0 * 0.2**2 + 1.0, rel=1e-12)
    assert h(np.array([0.5]), segment=0)[0, 0] == pytest.approx(1.0 * 0.2**2 + 0.0, rel=1e-12)
    np.testing.assert_allclose(h(h.times()), h.values_at_points(), rtol=1e-13)  # its points
    assert h.segment_of(0.75) == 1 and h.segment_of(0.5) == 1 and h.segment_of(2.0) == 3


def test_a_constant_history():
    h = ControlHistory.constant(
        name='c_A', units='N*s/m', corners=('1L', '1R'), scenario='s', horizon=3.0, value=250.0
    )
    np.testing.assert_array_equal(h(np.array([0.0, 1.3, 3.0])), np.full((3, 2), 250.0))


def test_round_trip_in_a_solve_record():
    rec = SolveRecord(
        fidelity='low',
        mode='optimize',
        method='collocation',
        start={'k_S1': 1.0},
        design={'k_S1': 2.0},
        success=True,
        status='Solve_Succeeded',
        objective=1.0,
        controls=(history(),),
    )
    data = json.loads(json.dumps(rec.to_json()))
    back = SolveRecord.from_json(data)
    assert back.controls == rec.controls
    assert 'Lagrange polynomial' in data['controls'][0]['described']
    data['controls'][0]['values'][1] = data['controls'][0]['values'][1][:-1]
    with pytest.raises(ConfigError, match=r'controls\[0\]\.values\[1\]: expected 12 values'):
        SolveRecord.from_json(data, 'result.json')
    # a record written before controls existed reads as a passive one
    del data['controls']
    assert SolveRecord.from_json(data).controls == ()
