"""Background checks in forked children (suspopt.verification.background): results come back as they
would here, a child's exception is re-raised with its type, a child that dies is named,
leaving the context stops the children, and without fork the jobs run in this process."""

from __future__ import annotations

import functools
import multiprocessing as mp
import os
import sys
import time

import pytest

from suspopt.verification.background import Background, BackgroundError, forking_available

pytestmark = pytest.mark.skipif(not sys.platform.startswith('linux'), reason='needs fork (Linux)')


def fresh(test):
    """Run ``test`` here, or, where forking is off in this process (an earlier test left a
    thread running, e.g. Dask's offload threads), in a fresh interpreter."""

    @functools.wraps(test)
    def run():
        if forking_available():
            return test()
        child = mp.get_context('spawn').Process(target=_run, args=(test.__name__,))
        child.start()
        child.join(120)
        assert child.exitcode == 0, f'{test.__name__} failed in a fresh interpreter'

    return run


def _run(name: str) -> None:
    globals()[name].__wrapped__()


def _square(x):
    return {'x': x, 'y': x * x, 'pid': os.getpid()}


def _fail(msg):
    raise ValueError(msg)


def _die():
    os._exit(3)


def _sleep(seconds):
    time.sleep(seconds)
    return seconds


@fresh
def test_results_come_back_from_children_in_any_order_of_taking():
    with Background(jobs=2) as bg:
        for k in range(4):
            bg.submit(f'job{k}', _square, k)
        assert bg.pending() == ['job0', 'job1', 'job2', 'job3']
        out = [bg.result(f'job{k}') for k in (3, 1, 0, 2)]
    assert [o['y'] for o in out] == [9, 1, 0, 4]
    assert all(o['pid'] != os.getpid() for o in out)


def test_in_process_when_no_jobs_gives_the_same():
    with Background(jobs=0) as bg:
        bg.submit('a', _square, 5)
        out = bg.result('a')
    assert out['y'] == 25 and out['pid'] == os.getpid()


@fresh
def test_a_childs_exception_and_death_are_reported():
    with Background(jobs=1) as bg:
        bg.submit('bad', _fail, 'no road file')
        bg.submit('dead', _die)
        with pytest.raises(ValueError, match='no road file'):
            bg.result('bad')
        with pytest.raises(
            BackgroundError,
            match=r"'suspopt dead' died without a result "
            r'\(exit code 3\)',
        ):
            bg.result('dead')


@fresh
def test_leaving_stops_running_children():
    with Background(jobs=1) as bg:
        bg.submit('long', _sleep, 60.0)
        bg.submit('queued', _sleep, 60.0)
        proc = bg._jobs['long'].process
        assert proc.is_alive() and bg._jobs['queued'].process is None
        assert not bg.done('long')
        t0 = time.perf_counter()
    assert not proc.is_alive() and time.perf_counter() - t0 < 5.0


@fresh
def test_a_time_marching_check_in_a_child_equals_the_one_here():
    """What a study's background verification returns is what the check returns here."""
    from suspopt.spec.schema import StudyConfig
    from suspopt.verification.scales import resolve_scales
    from suspopt.verification.verify import time_marching_check

    cfg = StudyConfig()
    scales = resolve_scales(cfg)
    terms = [dict.fromkeys(cfg.terms(), 1.0)]
    here, trajectories = time_marching_check(
        cfg, 'low', cfg.design.initial(), terms, scales, keep=True
    )
    with Background(jobs=1) as bg:
        bg.submit('tm', time_marching_check, cfg, 'low', cfg.design.initial(), terms, scales)
        there, none = bg.result('tm')
    assert there.scenarios[0].terms == here.scenarios[0].terms
    assert there.max_rel_diff == here.max_rel_diff
    assert len(trajectories) == 1 and none == []
