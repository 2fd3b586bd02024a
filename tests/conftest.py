"""Shared fixtures: an isolated coloring cache per test session, single-threaded BLAS."""
from __future__ import annotations

import os

os.environ.setdefault('OMP_NUM_THREADS', '1')
os.environ.setdefault('OPENBLAS_NUM_THREADS', '1')

import pytest  # noqa: E402


@pytest.fixture(scope='session', autouse=True)
def _coloring_cache(tmp_path_factory):
    """Colorings computed by the tests go to a session directory, not the user's cache."""
    if 'SUSPOPT_CACHE_DIR' not in os.environ:
        os.environ['SUSPOPT_CACHE_DIR'] = str(tmp_path_factory.mktemp('suspopt-cache'))
    yield
