"""Independent checks run beside the main work, in forked child processes.

A study's time-marching verifications need nothing from the optimizations that follow
them, so a study hands each one to a :class:`Background` (through a
:class:`~suspopt.verification.verify.Verifier`) and goes on: the check runs in a child
process (``fork``: it starts with everything already imported and built) while this
process optimizes, and its result is collected when needed. At most ``jobs`` checks run
at once (default: the cores this process may use, less one for the main work; all of
them while the main work waits).

Each child ignores Ctrl-C (this process decides what an interrupt stops), dies with its
parent where the platform allows it, and writes its result to a file atomically; a child
that dies without one is reported by name and exit code. Where ``fork`` is not available
(or this is a daemonic process, e.g. inside a Dask worker, or has other threads) the checks
run here, one after another, when they are collected — the same results.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import pickle
import shutil
import signal
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any


def usable_cores() -> int:
    """The CPU cores this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def forking_available() -> bool:
    """True if checks can run in forked children here: Linux, not a daemonic process, and
    no other thread (a fork copies no thread, and might copy a lock one of them held)."""
    return (
        'fork' in mp.get_all_start_methods()
        and sys.platform.startswith('linux')
        and not mp.current_process().daemon
        and threading.active_count() == 1
    )


class BackgroundError(RuntimeError):
    """A background check's process died without a result."""


@dataclass
class _Job:
    fn: Callable[..., Any]
    args: tuple
    process: Any = None
    path: str = ''
    outcome: tuple | None = None


def _die_with_parent() -> None:
    """Linux: SIGKILL this process when its parent dies (best effort)."""
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL))  # PR_SET_PDEATHSIG
    except Exception:  # pragma: no cover - not available: the check just runs to its end
        pass


def _child(fn: Callable[..., Any], args: tuple, path: str) -> None:
    # the parent's handlers (e.g. the IPOPT driver's, set while a solve forks this) are
    # not this process's: Ctrl-C is the parent's to handle, SIGTERM (close) ends it
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _die_with_parent()
    try:
        outcome = ('ok', fn(*args))
    except BaseException as err:  # reported in the parent, with its type
        outcome = ('error', err)
    tmp = path + '.tmp'
    try:
        with open(tmp, 'wb') as fh:
            pickle.dump(outcome, fh, protocol=pickle.HIGHEST_PROTOCOL)
    except Exception as err:  # an unpicklable result or exception: say what it was
        with open(tmp, 'wb') as fh:
            pickle.dump(('error', RuntimeError(f'{type(err).__name__}: {err}')), fh)
    os.replace(tmp, path)


class Background:
    """Run ``fn(*args)`` jobs in forked children, at most ``jobs`` at a time
    (None: usable cores − 1, at least 1; 0: no children, each job runs in
    :meth:`result`). Use as a context manager: leaving it stops every child."""

    def __init__(self, jobs: int | None = None):
        self.cores = usable_cores()
        self.jobs = max(1, self.cores - 1) if jobs is None else int(jobs)
        self.forking = self.jobs > 0 and forking_available()
        self._jobs: dict[str, _Job] = {}
        self._queue: list[str] = []
        self._started = 0
        self._dir = tempfile.mkdtemp(prefix='suspopt-bg-') if self.forking else None

    def __enter__(self) -> Background:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def submit(self, key: str, fn: Callable[..., Any], *args: Any) -> None:
        """Queue ``fn(*args)`` under ``key`` (started as soon as a slot is free)."""
        if key in self._jobs:
            raise ValueError(f'background job {key!r} submitted twice')
        self._jobs[key] = _Job(fn=fn, args=args)
        self._queue.append(key)
        self.pump()

    def pump(self, limit: int | None = None) -> None:
        """Collect finished children and start queued jobs (cheap: call it often)."""
        if not self.forking:
            return
        running = 0
        for job in self._jobs.values():
            if job.process is not None and job.outcome is None:
                if job.process.is_alive():
                    running += 1
                else:
                    self._collect(job)
        limit = self.jobs if limit is None else limit
        while self._queue and running < limit:
            key = self._queue.pop(0)
            job = self._jobs[key]
            self._started += 1
            assert self._dir is not None
            job.path = os.path.join(self._dir, f'job-{self._started}.pickle')
            job.process = mp.get_context('fork').Process(
                target=_child, args=(job.fn, job.args, job.path), daemon=True, name=f'suspopt {key}'
            )
            job.process.start()
            running += 1

    def _collect(self, job: _Job) -> None:
        job.process.join()
        try:
            with open(job.path, 'rb') as fh:
                job.outcome = pickle.load(fh)
        except FileNotFoundError:
            job.outcome = (
                'error',
                BackgroundError(
                    f'the background process of {job.process.name!r} died without a result '
                    f'(exit code {job.process.exitcode})'
                ),
            )

    def done(self, key: str) -> bool:
        """True if ``key``'s result can be taken without waiting."""
        self.pump()
        job = self._jobs[key]
        return job.outcome is not None

    def result(self, key: str) -> Any:
        """``key``'s result (waiting for it; the main work waits too, so every core may
        take a queued job meanwhile). Re-raises the job's exception."""
        job = self._jobs[key]
        if job.outcome is None and not self.forking:
            try:
                job.outcome = ('ok', job.fn(*job.args))
            except Exception as err:
                job.outcome = ('error', err)
        while True:
            self.pump(limit=self.cores)
            if job.outcome is not None:
                break
            if job.process is not None:
                job.process.join(timeout=0.05)
            else:  # queued behind running jobs
                time.sleep(0.05)
        del self._jobs[key]
        kind, value = job.outcome
        if kind == 'error':
            raise value
        return value

    def pending(self) -> list[str]:
        """The keys submitted and not yet taken, in submission order."""
        return list(self._jobs)

    def close(self) -> None:
        """Stop every child still running and drop what was not taken."""
        for job in self._jobs.values():
            if job.process is not None and job.process.is_alive():
                job.process.terminate()
        for job in self._jobs.values():
            if job.process is not None:
                job.process.join(timeout=5)
                if job.process.is_alive():  # pragma: no cover - ignores SIGTERM
                    job.process.kill()
                    job.process.join()
        self._jobs.clear()
        self._queue.clear()
        if self._dir is not None:
            shutil.rmtree(self._dir, ignore_errors=True)
            self._dir = None
