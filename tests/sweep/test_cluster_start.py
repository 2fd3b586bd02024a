"""A local Dask cluster that fails to start (a nanny on a loaded machine) is tried once
more, and a cluster that cannot start is one error naming the cause (a real
LocalCluster; the failure injected before it)."""

from __future__ import annotations

import pytest

from suspopt.errors import SuspoptError
from suspopt.sweep.cluster import CLUSTER_ATTEMPTS, _local_cluster


def _failing(times: int):
    from distributed import LocalCluster

    calls: list[int] = []

    def start(**kw):
        calls.append(1)
        if len(calls) <= times:
            raise RuntimeError('Nanny failed to start.')
        return LocalCluster(**kw)

    return start, calls


def test_a_cluster_that_fails_to_start_once_is_tried_again():
    start, calls = _failing(1)
    said: list[str] = []
    cluster = _local_cluster(start, 1, said.append)
    try:
        assert len(calls) == 2 and len(cluster.workers) == 1
        assert said == ['local cluster did not start (Nanny failed to start.); trying again']
    finally:
        cluster.close()


def test_a_cluster_that_never_starts_is_one_error_naming_the_cause():
    start, calls = _failing(CLUSTER_ATTEMPTS)
    with pytest.raises(SuspoptError, match='cannot start a local Dask cluster: Nanny failed'):
        _local_cluster(start, 1, lambda m: None)
    assert len(calls) == CLUSTER_ATTEMPTS
