"""The Dask side of a sweep: a local cluster (tuned for these tasks) or an existing
scheduler, the worker preload, the scheduler's count of dead workers, and shutdown.

A ``LocalCluster`` has one single-threaded worker process per core (or ``workers``; on
Linux forked from the client, which has imported suspopt, so they start in a fraction of
a second instead of importing it each). ``dask worker --preload suspopt.sweep`` runs
:func:`dask_setup` on a worker of an external cluster (a local one's workers run it too).
"""

from __future__ import annotations

import contextlib
import gc
import logging
import os
import signal
import threading
from collections.abc import Callable, Iterator
from types import FrameType
from typing import Any

from suspopt.errors import SuspoptError


class Terminated(KeyboardInterrupt):
    """SIGTERM, handled like Ctrl-C."""


def sweep_sigterm(signum: int, frame: FrameType | None) -> None:
    """The sweep client's SIGTERM: stop like Ctrl-C (cancel pending, keep finished)."""
    raise Terminated()


@contextlib.contextmanager
def quiet_dask_logs() -> Iterator[None]:
    """Dask's log records off (its ``distributed`` logger at CRITICAL) while a sweep runs;
    a worker forked from this process inherits the level. Dask's own silencing raises its
    stream handler's level only: its records still reach the process's other handlers
    (the root logger's: an application's, pytest's), written by Dask's event-loop thread.
    A worker forked while that thread held a handler's stream (its buffer's lock) waits
    for that lock forever at its first log line, and the cluster never starts."""
    import distributed  # noqa: F401  (its logging configuration first, then ours)

    logger = logging.getLogger('distributed')
    old = logger.level
    logger.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        logger.setLevel(old)


def main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


def dask_setup(worker: Any) -> None:
    """Worker preload (``--preload suspopt.sweep``): Ctrl-C in a terminal reaches the
    whole process group; workers leave the interruption to the sweep's client. A worker
    forked from the sweep's client drops the client's SIGTERM handler. BLAS and OpenMP
    pools get one thread (Dask's environment variables do this for a spawned worker, too
    late for a forked one, whose libraries are already loaded). The modules a task needs
    (OpenMDAO, Dymos, the models) are imported here, as the worker starts, so that no
    task's time includes them (a forked worker has them already)."""
    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        if signal.getsignal(signal.SIGTERM) is sweep_sigterm:
            signal.signal(signal.SIGTERM, signal.SIG_DFL)
    except ValueError:  # not the main thread: nothing to do
        pass
    from threadpoolctl import threadpool_limits

    from suspopt.quiet import quiet_libraries

    threadpool_limits(limits=1)
    quiet_libraries()
    import suspopt.studies.run  # noqa: F401


def _connect(scheduler: str, say: Callable[[str], None]) -> Any:
    from distributed import Client

    try:
        client = Client(scheduler, timeout='10s')
    except (OSError, TimeoutError) as err:
        raise SuspoptError(f'--scheduler {scheduler}: cannot connect ({err})') from None
    allowed = client.run_on_scheduler(_allowed_failures)
    n = len(client.scheduler_info()['workers'])
    say(
        f'connected to {scheduler}: {n} worker(s); a task whose worker dies is rerun '
        f"up to {allowed} time(s) (that scheduler's allowed-failures)"
    )
    return client


def _settings(retries: int, worker_start: str) -> dict[str, Any]:
    """A local cluster's Dask settings. Two worker settings cost these (deep-stacked,
    allocation-heavy) tasks CPU time (``benchmarks/bench_sweep.py`` measures it): the
    statistical profiler sampling the task's stack every 10 ms, and the nanny's
    ``MALLOC_TRIM_THRESHOLD_`` (every large NumPy temporary mapped and unmapped afresh);
    both off, the BLAS single-thread settings kept. The event-loop health tick and the
    system monitor run in the client's process too, beside the workers, on a core they
    need: once a second and every 5 s."""
    import dask

    environ = {
        k: v
        for k, v in dask.config.get('distributed.nanny.pre-spawn-environ').items()
        if k != 'MALLOC_TRIM_THRESHOLD_'
    }
    return {
        'distributed.scheduler.allowed-failures': retries,
        'distributed.worker.profile.enabled': False,
        'distributed.nanny.pre-spawn-environ': environ,
        'distributed.admin.tick.interval': '1s',
        'distributed.admin.system-monitor.interval': '5s',
        'distributed.worker.multiprocessing-method': worker_start,
    }


def _start_methods(worker_start: str) -> tuple[str, ...]:
    """How to start the workers, in the order tried: a nanny can fail to start (seen in
    the suite beside busy processes, forking from a process that holds threads), and a
    second attempt then succeeds; the second by ``spawn``, which inherits nothing."""
    return (worker_start, 'spawn')


def _local_cluster(
    local_cluster: Any,
    n: int,
    say: Callable[[str], None],
    retries: int,
    worker_start: str,
) -> tuple[Any, str]:
    """A LocalCluster of ``n`` single-threaded worker processes and how its workers were
    started (:func:`_start_methods`, each tried once); a SuspoptError naming the last
    cause if none starts."""
    import dask

    methods = _start_methods(worker_start)
    for attempt, method in enumerate(methods, 1):
        with dask.config.set(_settings(retries, method)):
            if method == 'fork':  # the children's garbage collector leaves what this
                gc.freeze()  # process had alone (no copy-on-write of its pages)
            try:
                cluster = local_cluster(
                    n_workers=n,
                    processes=True,
                    threads_per_worker=1,
                    dashboard_address=None,
                    scheduler_kwargs=NO_DASHBOARD,
                    silence_logs=logging.CRITICAL,
                    preload=['suspopt.sweep'],
                )
                return cluster, method
            except Exception as err:  # noqa: BLE001 - e.g. no process could be started
                if attempt == len(methods):
                    raise SuspoptError(f'cannot start a local Dask cluster: {err}') from err
                say(f'local cluster did not start ({err}); trying again ({methods[attempt]})')
            finally:
                if method == 'fork':
                    gc.unfreeze()
    raise AssertionError('unreachable')


def start_cluster(
    workers: int | None,
    scheduler: str | None,
    n_tasks: int,
    retries: int,
    say: Callable[[str], None],
    worker_start: str,
) -> tuple[Any, Any]:
    """A Dask client and the LocalCluster it owns (None for an external scheduler)."""
    if scheduler:
        return _connect(scheduler, say), None
    import dask
    from distributed import Client, LocalCluster

    n = max(1, min(workers or len(os.sched_getaffinity(0)), n_tasks))
    if worker_start == 'fork':
        import suspopt.studies.run  # noqa: F401  (inherited by the forked workers)
    cluster, method = _local_cluster(LocalCluster, n, say, retries, worker_start)
    with dask.config.set(_settings(retries, method)):
        client = Client(cluster)
    say(f'local cluster: {n} worker process(es), one thread each ({method}ed)')
    return client, cluster


#: the scheduler's HTTP server (health, metrics) on a free port of the loopback: its
#: default, 8787, is often taken (another cluster's dashboard), and Dask then warns on
#: the terminal
NO_DASHBOARD = {'dashboard': False, 'dashboard_address': '127.0.0.1:0'}


def _allowed_failures(dask_scheduler: Any) -> int:
    return dask_scheduler.allowed_failures


def deaths(client: Any, key: str) -> int:
    """How many workers died while running task ``key`` (the scheduler's ``suspicious``
    count; 0 if the scheduler does not know the task). A lambda, so that an external
    scheduler needs no suspopt to run it."""
    try:
        return int(
            client.run_on_scheduler(
                lambda dask_scheduler, k=key: getattr(dask_scheduler.tasks.get(k), 'suspicious', 0)
            )
        )
    except Exception:  # noqa: BLE001 - the count is a detail of the record, never fatal
        return 0


class _Quiet:
    def __enter__(self) -> _Quiet:
        return self

    def __exit__(self, *exc: Any) -> bool:
        return exc[0] is not None and issubclass(exc[0], Exception)


def shutdown(client: Any, cluster: Any, futures: list[Any]) -> None:
    """Cancel our futures and close client and cluster, whatever happens (a second
    Ctrl-C during shutdown is ignored)."""
    old_int = signal.signal(signal.SIGINT, signal.SIG_IGN) if main_thread() else None
    try:
        if client is not None:
            with _Quiet():
                if futures:
                    client.cancel(futures, force=True)
            with _Quiet():
                client.close(timeout=10)
        if cluster is not None:
            with _Quiet():
                cluster.close(timeout=20)
    finally:
        if old_int is not None:
            signal.signal(signal.SIGINT, old_int)
