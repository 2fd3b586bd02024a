"""A local Dask cluster that fails to start (a nanny on a loaded machine, forking from a
process that holds threads) is tried once more, by spawn, and a cluster that cannot
start is one error naming the cause (a real LocalCluster; the failure injected before
it)."""

from __future__ import annotations

import pytest

from suspopt.errors import SuspoptError
from suspopt.sweep.cluster import _local_cluster, _start_methods


def _failing(times: int):
    from distributed import LocalCluster

    calls: list[int] = []

    def start(**kw):
        calls.append(1)
        if len(calls) <= times:
            raise RuntimeError('Nanny failed to start.')
        return LocalCluster(**kw)

    return start, calls


def test_a_cluster_that_fails_to_start_by_fork_is_started_by_spawn():
    start, calls = _failing(1)
    said: list[str] = []
    cluster, method = _local_cluster(start, 1, said.append, 0, 'fork')
    try:
        assert len(calls) == 2 and len(cluster.workers) == 1 and method == 'spawn'
        assert said == [
            'local cluster did not start (Nanny failed to start.); trying again (spawn)'
        ]
    finally:
        cluster.close()


def test_a_cluster_that_never_starts_is_one_error_naming_the_cause():
    start, calls = _failing(len(_start_methods('fork')))
    with pytest.raises(SuspoptError, match='cannot start a local Dask cluster: Nanny failed'):
        _local_cluster(start, 1, lambda m: None, 0, 'fork')
    assert len(calls) == len(_start_methods('fork'))
