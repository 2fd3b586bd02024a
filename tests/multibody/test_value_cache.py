"""The solver's remembered partitionings are keyed by value (:class:`ValueCache`): an equal
array (another object) gets the remembered result, a changed one is computed afresh,
scratch (writable) arrays are not remembered; the suspension module hands what its
analysis found to the dynamics with the state (:class:`AnalysedState`), so that a
remembered state's dynamics equal a fresh module's bit for bit."""

from __future__ import annotations

import numpy as np

from suspopt.multibody.solver import ValueCache, freeze
from suspopt.multibody.suspension import AnalysedState, SuspensionModule


def test_value_cache_compares_values_not_objects():
    cache = ValueCache(size=2)
    key = freeze(np.arange(6.0).reshape(2, 3))
    value = cache.put(key, (np.ones(2),))
    assert not value[0].flags.writeable
    twin = freeze(key.copy())
    assert cache.get(twin) is value  # another object with the same values
    assert cache.get(key + np.array([[0.0, 0.0, 1e-12], [0.0, 0.0, 0.0]])) is None
    assert cache.get(key.reshape(3, 2)) is None
    scratch = np.zeros(3)
    cache.put(scratch, (np.ones(1),))  # writable: not remembered
    assert cache.get(scratch) is None
    for k in range(3):  # the two newest are kept
        cache.put(freeze(np.full(4, float(k))), (np.full(1, float(k)),))
    assert cache.get(key) is None and cache.get(np.full(4, 2.0))[0][0] == 2.0


def test_partition_of_an_equal_jacobian_is_remembered_and_of_a_changed_one_not():
    s = SuspensionModule('macpherson').solver
    Cq = freeze(s.constraint_jacobian(s.q0[None].repeat(3, 0)))
    first = s.partition(Cq)
    assert s.partition(freeze(Cq.copy())) is first
    other = Cq.copy()
    other[1] *= 2.0
    moved = s.partition(freeze(other))
    assert moved is not first
    assert np.array_equal(moved[0][1], 0.5 * first[0][1])


def test_the_state_carries_its_analysis_to_the_dynamics():
    mod = SuspensionModule('double_wishbone')
    z, v = np.array([0.01, -0.02, 0.03]), np.array([0.5, -1.0, 0.2])
    kin = mod.kinematics(z, v)
    assert isinstance(kin.state, AnalysedState)
    assert kin.state.partition is not None and kin.state.residual is not None
    args = (0.01 * z, 0.1 * v, np.full(3, 3e4), np.full(3, 2e3), np.full(3, 1e3))
    first = mod.dynamics(kin.state, *args)
    assert 'gamma' in kin.state.memo
    again = mod.kinematics(z.copy(), v.copy())  # equal inputs: the remembered state
    assert again.state.memo is kin.state.memo
    fresh = SuspensionModule('double_wishbone')
    for a, b in zip(
        mod.dynamics(again.state, *args), fresh.dynamics(fresh.kinematics(z, v).state, *args)
    ):
        assert np.array_equal(a, b)
    for a, b in zip(first, mod.dynamics(kin.state, *args)):
        assert np.array_equal(a, b)
