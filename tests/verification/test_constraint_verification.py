"""The engineering constraints along a trajectory and their verification by time
marching: the worst value of each side, where it is, and a violation beyond the
tolerance making the result not verified (crafted signals, no solve)."""

from __future__ import annotations

import numpy as np
import pytest

from suspopt.records.constraints import ConstraintValue
from suspopt.records.verification import Check, Comparison, ScenarioComparison, Verification
from suspopt.spec.load import config_from_dict
from suspopt.transcription.constraints import (
    bounds,
    distinct_nodes,
    path_constraints,
    worst_on_path,
)
from suspopt.transcription.grid import radau_grid
from suspopt.verification.verify import Marched, constraint_checks, constraint_tolerance

CFG = config_from_dict(
    {
        'constraints': {
            'travel': {'bump': 0.05, 'rebound': 0.04},
            'tyre_contact': {'margin': 0.2},
        }
    }
)
T = np.linspace(0.0, 1.0, 5)
#: travel (5 times x 2 corners): bump peak 0.03 at corner 2, t = 0.5; rebound -0.035 at
#: corner 1, t = 0.75
TRAVEL = np.array([[0, 0], [0.01, -0.02], [0.02, 0.03], [-0.035, 0.0], [0.0, 0.01]])
RATIO = np.array([[0, 0], [-0.1, 0.2], [-0.7, 0.1], [0.3, -0.2], [0.0, 0.0]])


def _bound(name):
    return next(b for b in bounds(CFG) if b.name == name)


def test_every_side_of_every_constraint_is_a_bound():
    assert [b.name for b in bounds(CFG)] == [
        'travel.bump',
        'travel.rebound',
        'tyre_contact.margin',
    ]
    pcs = {p.signal: p for p in path_constraints(CFG)}
    assert (pcs['travel'].lower, pcs['travel'].upper) == (-0.04, 0.05)
    # the total tyre load keeps 20 % of the static: F_T / F_static >= 0.2 - 1
    assert (
        pcs['tyre_load_ratio'].lower == pytest.approx(-0.8) and pcs['tyre_load_ratio'].upper is None
    )


@pytest.mark.parametrize(
    ('name', 'signal', 'value', 'corner', 'time'),
    [
        ('travel.bump', TRAVEL, 0.03, '2', 0.5),
        ('travel.rebound', TRAVEL, 0.035, '1', 0.75),
        ('tyre_contact.margin', RATIO, 0.3, '1', 0.5),  # 1 - 0.7 of the static load kept
    ],
)
def test_worst_value_and_where(name, signal, value, corner, time):
    w = worst_on_path(_bound(name), [('city', T, signal)], ['1', '2'])
    assert w is not None and w.value == pytest.approx(value)
    assert (w.corner, w.time, w.scenario) == (corner, time, 'city')


def test_worst_over_scenarios():
    b = _bound('travel.bump')
    w = worst_on_path(b, [('a', T, TRAVEL), ('b', T, 2.0 * TRAVEL)], ['1', '2'])
    assert w is not None
    assert (w.scenario, w.value) == ('b', pytest.approx(0.06))


def _marched(worst_bump: float) -> list[Marched]:
    b = _bound('travel.bump')
    w = worst_on_path(b, [('main', T, TRAVEL * worst_bump / 0.03)], ['1', '2'])
    assert w is not None
    return [Marched('main', {}, 1.0, 0.1, None, None, worst={'travel.bump': w})]


def _comparison(worst_bump: float, collocation_bump: float | None = None) -> Comparison:
    coll = ()
    if collocation_bump is not None:
        b = _bound('travel.bump')
        coll = (ConstraintValue(b.name, 'path', 'm', True, b.bound, collocation_bump, False),)
    checks = constraint_checks(CFG, _marched(worst_bump), coll)
    return Comparison('tm', 5e-3, (), 1.0, 1e-4, 0.1, checks)


def test_a_violation_within_the_tolerance_is_verified():
    tol = constraint_tolerance(_bound('travel.bump'))
    assert tol == pytest.approx(0.03 * 0.05)
    c = _comparison(0.05 + 0.9 * tol)
    assert c.constraints[0].margin < 0.0 and not c.violated
    assert Verification.of(c).state is Check.VERIFIED


def test_a_violation_beyond_the_tolerance_is_not_verified():
    """Collocation meets the bound at its nodes, time marching exceeds it between them:
    the objective terms agree, the result is still NOT verified."""
    tol = constraint_tolerance(_bound('travel.bump'))
    c = _comparison(0.05 + 1.1 * tol)
    assert c.max_rel_diff < c.tolerance
    assert [k.name for k in c.violated] == ['travel.bump']
    v = Verification.of(c)
    assert v.state is Check.NOT_VERIFIED and v.verified is False
    assert 'travel.bump' in c.violated[0].describe()
    # the one sentence every message of a study or command gives: the constraint, not a
    # difference of the terms that is within the tolerance
    assert 'violates constraints.travel.bump' in c.disagreement()
    assert 'differ by' not in c.disagreement()


def test_a_difference_of_the_terms_is_named_with_its_term():
    s = ScenarioComparison('main', {}, 1.0, 0.02, 'comfort_driver', 0.1)
    c = Comparison('tm', 5e-3, (s,), 1.0, 0.02, 0.1)
    assert c.disagreement() == (
        'collocation and time marching differ by 2 % on comfort_driver (tolerance 0.5 %)'
    )
    assert _comparison(0.05).disagreement() == ''


@pytest.mark.parametrize('collocation_bump', [0.05, 0.05 + 0.9 * 0.03 * 0.05])
def test_a_violation_the_collocation_meets_is_not_verified(collocation_bump):
    """The collocation's own value given: on or within the tolerance of the bound, a
    time-marching violation beyond it is still a disagreement of the two."""
    tol = constraint_tolerance(_bound('travel.bump'))
    c = _comparison(0.05 + 1.1 * tol, collocation_bump)
    assert [k.name for k in c.violated] == ['travel.bump']
    assert Verification.of(c).state is Check.NOT_VERIFIED


@pytest.mark.parametrize('factor', [1.1, 3.0])
def test_a_violation_the_collocation_also_has_is_verified(factor):
    """An evaluation reports its constraints instead of enforcing them: a design whose
    collocation already exceeds a bound, time marching agreeing, is verified — the
    constraint is reported exceeded, not as a disagreement."""
    tol = constraint_tolerance(_bound('travel.bump'))
    worst = 0.05 + factor * tol
    c = _comparison(worst, worst * (1 + 1e-6))
    (k,) = c.constraints
    assert k.exceeded and not k.collocation_met and not k.violated
    assert not c.violated and Verification.of(c).state is Check.VERIFIED
    assert Comparison.from_json(c.to_json()).constraints[0].exceeded


@pytest.mark.parametrize(('segments', 'order'), [(1, 3), (4, 3), (7, 5)])
def test_distinct_nodes_are_the_grid_less_its_repeats_and_start(segments, order):
    """The path constraints' nodes: one per distinct time of the compressed Radau grid (a
    segment's right end repeats the next one's start, with the same state), less t = 0
    (the fixed initial state)."""
    tau = radau_grid(segments, order)[0]
    nodes = distinct_nodes(segments, order)
    assert len(set(nodes)) == len(nodes)
    assert np.array_equal(np.sort(tau[nodes]), np.unique(tau)[1:])
