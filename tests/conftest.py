"""Shared fixtures: an isolated coloring cache per test session, single-threaded BLAS."""

from __future__ import annotations

import os

os.environ.setdefault('OMP_NUM_THREADS', '1')
os.environ.setdefault('OPENBLAS_NUM_THREADS', '1')

import pytest  # noqa: E402

from suspopt.spec.schema import StudyConfig  # noqa: E402
from suspopt.verification.scales import resolve_scales  # noqa: E402


@pytest.fixture(scope='session', autouse=True)
def _isolated_outputs(tmp_path_factory):
    """Colorings computed by the tests go to a directory of this test run (shared by
    pytest-xdist workers), not the user's cache; OpenMDAO's own output folders of ad-hoc
    problems go to a temporary directory, not the working directory."""
    root = tmp_path_factory.getbasetemp()
    shared = root.parent if os.environ.get('PYTEST_XDIST_WORKER') else root
    os.environ.setdefault('SUSPOPT_CACHE_DIR', str(shared / 'suspopt-cache'))
    os.environ['OPENMDAO_WORKDIR'] = str(tmp_path_factory.mktemp('openmdao'))
    yield


@pytest.fixture(scope='session')
def cfg() -> StudyConfig:
    """The default study (the paper's case)."""
    return StudyConfig()


@pytest.fixture(scope='session')
def scales(cfg) -> tuple[float, ...]:
    """Its reference normalization (the half car's J_k at the initial design)."""
    return resolve_scales(cfg)
