"""Run (or resume) a sweep on Dask distributed: :func:`run_sweep` (``suspopt sweep``).

At most as many tasks are submitted as the cluster has worker threads, so a worker holds
only the task it runs. A worker process that dies mid-task (killed, out of memory) is
noticed by the scheduler, which reruns the task on another worker (the record's
``attempts`` is the scheduler's own count of deaths plus one); the scheduler's
``distributed.scheduler.allowed-failures`` is how many deaths a task may survive (set to
``retries`` for a local cluster; an external scheduler has its own, default 3), after
which the task errs with ``KilledWorker`` and is recorded as failed. (Dask's ``retries=``
of ``submit`` is for tasks that *raise*; a task here never raises: its failure is its
record.) Each finished task is appended to the directory's records as it comes back
(:mod:`suspopt.sweep.store`); the summary is rendered once, at the end
(:mod:`suspopt.sweep.summary`).

Ctrl-C / SIGTERM cancel what is pending, close client and cluster, keep what finished. On
an external cluster a task already running finishes on its worker (Dask cannot stop a
running thread) and its result is dropped; the rerun starts clean. A full or unwritable
disk (a task's output, or the records) stops the sweep: no new task starts, the running
ones finish and are recorded if they can be, and the sweep ends with a
:class:`~suspopt.errors.RunError` (exit 4); the tasks not recorded stay pending and a
rerun runs them. Workers write ``tasks/<task>/output/`` themselves: remote workers need
the same file system (the records, written by the client, are complete either way).
The directory is locked for the sweep's whole run with the lock every suspopt command
takes (:class:`~suspopt.output.rundir.DirectoryLock`).
"""

from __future__ import annotations

import os
import queue
import re
import signal
import sys
import time
import traceback
import uuid
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from suspopt.errors import ConfigError, RunError, SuspoptError
from suspopt.output.rundir import DirectoryLock
from suspopt.sweep.cluster import (
    deaths,
    main_thread,
    quiet_dask_logs,
    shutdown,
    start_cluster,
    sweep_sigterm,
)
from suspopt.sweep.spec import Sweep, load_sweep
from suspopt.sweep.store import RecordLog, prepare
from suspopt.sweep.summary import write_summary
from suspopt.sweep.tasks import ENVIRONMENT, Task, TaskPayload, TaskRecord, final_step, run_task

TaskFn = Callable[[TaskPayload], TaskRecord]


@dataclass
class Outcome:
    """What a sweep run did; ``exit_code`` 0 all done (and verified), 1 some failed or not
    run, 3 some not verified by time marching, 130 interrupted (a full disk raises
    :class:`RunError` instead: exit 4)."""

    counts: dict[str, int]
    exit_code: int
    wall_time_s: float
    ran: int = 0
    retried: list[str] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)
    #: bytes appended to the records by this run (its whole per-task bookkeeping)
    record_bytes: int = 0


def _stderr_line(msg: str) -> None:
    """A progress line on stderr, written past Python's stream buffer: a worker that a
    nanny forks (restarts) at that moment does not inherit the buffer's lock held, which
    its first warning on stderr would wait for forever (:func:`quiet_dask_logs`)."""
    line = f'[sweep] {msg}\n'
    try:
        fd = sys.stderr.fileno()
    except (AttributeError, OSError, ValueError):  # a stream without a file (captured)
        print(line, end='', file=sys.stderr, flush=True)
        return
    sys.stderr.flush()
    os.write(fd, line.encode())


def _check_args(workers: int | None, scheduler: str | None, worker_start: str) -> str:
    """The arguments' problems as a ConfigError; the worker start method to use."""
    if workers is not None and workers < 1:
        raise ConfigError(f'--workers: must be >= 1, got {workers}')
    if workers is not None and scheduler:
        raise ConfigError('--workers: not with --scheduler (the cluster has its workers)')
    if worker_start not in ('auto', 'fork', 'spawn'):
        raise ConfigError(f"worker_start: expected 'auto', 'fork' or 'spawn', got {worker_start!r}")
    if scheduler is not None and not re.match(r'^[a-z+]+://\S+$', scheduler):
        raise ConfigError(
            f'--scheduler: expected an address like tcp://HOST:PORT, got {scheduler!r}'
        )
    if worker_start == 'auto':
        return 'fork' if sys.platform.startswith('linux') else 'spawn'
    return worker_start


def run_sweep(
    sweep_file: str | Path,
    out_dir: str | Path,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    retry_failed: bool = False,
    log: Callable[[str], None] | None = None,
    task_fn: TaskFn = run_task,
    worker_start: str = 'auto',
) -> Outcome:
    """Run (or resume) a sweep into ``out_dir``. Raises :class:`ConfigError` for bad input
    (before anything runs) and :class:`RunError` for a full or unwritable disk; returns
    the :class:`Outcome` otherwise. ``worker_start``: how a local cluster starts its
    workers: ``fork`` (from this process, suspopt imported), ``spawn`` (a fresh
    interpreter each, Dask's default) or ``auto`` (fork on Linux)."""
    t0 = time.perf_counter()
    say = log or _stderr_line
    worker_start = _check_args(workers, scheduler, worker_start)
    sweep = load_sweep(sweep_file)
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise ConfigError(f'--out {out}: exists and is not a directory')
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise RunError(f'--out: cannot create {out}: {err.strerror}') from None
    with DirectoryLock(out, 'suspopt sweep'):
        records = prepare(out, sweep, say)
        if retry_failed:
            records = {k: r for k, r in records.items() if r.state == 'done'}
        todo = [t for t in sweep.tasks if t.name not in records]
        say(
            f'{len(sweep.tasks)} task(s) ({sweep.tasks[0].command}); '
            + (f'{len(records)} finished earlier, kept; ' if records else '')
            + f'{len(todo)} to run; results in {out}'
        )
        outcome = Outcome(counts={}, exit_code=0, wall_time_s=0.0)
        stopped = None
        try:
            if todo:
                engine = _Engine(sweep, todo, out, records, outcome, say, task_fn)
                stopped = engine.run(workers, scheduler, worker_start)
        finally:
            stopped = _render(out, sweep, records, say) or stopped
        outcome.wall_time_s = time.perf_counter() - t0
        _conclude(sweep, records, outcome, out, say)
    if stopped:
        pending = outcome.counts['pending']
        raise RunError(
            f'{stopped}; {pending} task(s) not finished stay pending: free space (or make '
            f'{out} writable) and rerun the same command to resume them'
        )
    return outcome


def _render(out: Path, sweep: Sweep, records: dict[str, TaskRecord], say: Callable) -> str | None:
    """Write the summary; a storage failure is said and returned (not raised)."""
    try:
        write_summary(out, sweep, records, warn=say)
    except RunError as err:
        say(f'summary not written ({err}); `suspopt report {out}` writes it later')
        return str(err)
    return None


def _conclude(
    sweep: Sweep, records: dict[str, TaskRecord], outcome: Outcome, out: Path, say: Callable
) -> None:
    """Counts, exit code and the closing lines."""
    c = {'pending': 0, 'done': 0, 'failed': 0, 'total': len(sweep.tasks)}
    failed, unverified = [], []
    for t in sweep.tasks:
        rec = records.get(t.name)
        c[rec.state if rec else 'pending'] += 1
        if rec and rec.state == 'failed':
            failed.append(f'  failed: {t.name}: {rec.error}')
        elif rec and final_step(t.command, rec.result).get('verified') is False:
            unverified.append(f'  NOT verified by time marching: {t.name}')
    outcome.counts = c
    if outcome.exit_code != 130:
        outcome.exit_code = 1 if c['failed'] or c['pending'] else 3 if unverified else 0
    say(
        f'{"interrupted" if outcome.exit_code == 130 else "finished"}: {c["done"]} done, '
        f'{c["failed"]} failed, {c["pending"]} not run, of {c["total"]} '
        f'({outcome.wall_time_s:.1f} s); {out}/summary.csv, {out}/table.md'
    )
    for line in failed + unverified:
        say(line)


def _eta(started: float, finished_now: int, remaining: int) -> str:
    if finished_now == 0:
        return 'ETA ?'
    s = (time.perf_counter() - started) / finished_now * remaining
    return f'ETA {s:.0f} s' if s < 120 else f'ETA {s / 60:.1f} min'


class _Engine:
    """Submits the tasks, collects and records what comes back. Constant work per
    finished task (one record appended, counts kept as they change)."""

    def __init__(
        self,
        sweep: Sweep,
        todo: list[Task],
        out: Path,
        records: dict[str, TaskRecord],
        outcome: Outcome,
        say: Callable[[str], None],
        task_fn: TaskFn,
    ):
        self.sweep, self.out, self.records = sweep, out, records
        self.outcome, self.say, self.task_fn = outcome, say, task_fn
        self.by_name = {t.name: t for t in todo}
        self.pending: deque[Task] = deque(todo)
        self.in_flight: dict[str, Any] = {}  # task name -> future
        self.attempts: dict[str, int] = {}
        self.running: set[str] = set()
        self.events: queue.Queue[tuple[str, Any]] = queue.Queue()
        self.token = uuid.uuid4().hex[:8]
        self.topic = f'suspopt-sweep-{self.token}'
        self.counts = {s: sum(r.state == s for r in records.values()) for s in ('done', 'failed')}
        self.stopped: str | None = None  # why no new task starts (storage failure)
        self.last_line = ''
        self.client: Any = None
        self.t_run = time.perf_counter()

    def run(self, workers: int | None, scheduler: str | None, worker_start: str) -> str | None:
        """Run the tasks; what stopped them early (a storage failure), or None."""
        with quiet_dask_logs():
            return self._run(workers, scheduler, worker_start)

    def _run(self, workers: int | None, scheduler: str | None, worker_start: str) -> str | None:
        from distributed import KilledWorker

        self.killed_type = KilledWorker
        log = RecordLog(self.out)
        old_term = None
        if main_thread():
            old_term = signal.signal(signal.SIGTERM, sweep_sigterm)
        cluster = None
        try:
            t = time.perf_counter()
            self.client, cluster = start_cluster(
                workers, scheduler, len(self.pending), self.sweep.retries, self.say, worker_start
            )
            self.outcome.timings['cluster_start_s'] = time.perf_counter() - t
            self.client.subscribe_topic(self.topic, lambda ev: self.events.put(('event', ev[1])))
            self._loop(log)
            self.outcome.timings['run_s'] = time.perf_counter() - self.t_run
        except KeyboardInterrupt:
            self.outcome.exit_code = 130
            self.say('interrupted: cancelling pending tasks; finished ones are kept')
        except RunError:
            raise
        except (OSError, TimeoutError) as err:  # CommClosedError is an OSError
            raise SuspoptError(
                f'lost the Dask cluster ({type(err).__name__}: {err}); finished '
                'tasks are kept, rerun to resume'
            ) from None
        finally:
            if old_term is not None:
                signal.signal(signal.SIGTERM, old_term)
            t = time.perf_counter()
            shutdown(self.client, cluster, list(self.in_flight.values()))
            self.outcome.timings['shutdown_s'] = time.perf_counter() - t
            self.outcome.record_bytes = log.bytes_written
            log.close()
        return self.stopped

    def _loop(self, log: RecordLog) -> None:
        self.t_run = time.perf_counter()
        self._refill()
        while self.in_flight or (self.pending and not self.stopped):
            try:
                kind, msg = self.events.get(timeout=2.0)
            except queue.Empty:
                self._refill()
                continue
            if kind == 'event' and msg.get('op') == 'start' and msg['task'] in self.in_flight:
                self._started(msg['task'], msg['worker'])
            elif kind == 'done':
                name, fut = msg
                self._done(name, fut, log)

    def _refill(self) -> None:
        """One task per worker thread (the cluster may have grown)."""
        if self.stopped:
            return
        slots = max(1, sum(self.client.nthreads().values())) - len(self.in_flight)
        while self.pending and slots > 0:
            t = self.pending.popleft()
            fut = self.client.submit(
                self.task_fn,
                t.payload(self.out, self.topic),
                key=f'{t.name}-{self.token}',
                pure=False,
                retries=0,
            )
            fut.add_done_callback(lambda f, n=t.name: self.events.put(('done', (n, f))))
            self.in_flight[t.name] = fut
            slots -= 1

    def _started(self, name: str, worker: str) -> None:
        died = deaths(self.client, self.in_flight[name].key)
        self.attempts[name] = max(self.attempts.get(name, 0) + 1, died + 1)
        self.running.add(name)
        if self.attempts[name] > 1:
            self.outcome.retried.append(name)
            self.say(
                f'{name}: its worker process died; rerun on {worker} '
                f'(attempt {self.attempts[name]})'
            )
        self._progress()

    def _done(self, name: str, fut: Any, log: RecordLog) -> None:
        key = fut.key
        if fut is not self.in_flight.get(name):  # an earlier submission's
            return
        del self.in_flight[name]
        self.running.discard(name)
        self._refill()  # the freed worker's next task first, then this one's record
        rec = self._collect(fut, self.by_name[name])
        if rec is None:  # cancelled from elsewhere, or interrupted: not a result
            self.say(f'{name}: cancelled; it stays pending')
            return
        if rec.state == ENVIRONMENT:
            self._stop(f'{name}: {rec.error}')
            return
        # the scheduler counts the deaths of a task's workers itself; a worker that dies
        # before the task's start event left it is counted there only. A task failed as
        # killed ran once per death; a finished one once more.
        died = deaths(self.client, key)
        killed = rec.state == 'failed' and (rec.error or '').startswith('KilledWorker')
        rec.attempts = max(self.attempts.get(name, 1), died + (not killed))
        rec.task = self.by_name[name].describe()
        try:
            log.append(rec)
        except RunError as err:
            self._stop(str(err))
            return
        self.records[name] = rec
        self.counts[rec.state] += 1
        self.outcome.ran += 1
        if rec.state == 'failed':
            self.say(f'{name} failed: {rec.error}')
        self._progress()

    def _stop(self, why: str) -> None:
        """A storage failure: no new task starts; the running ones finish."""
        if not self.stopped:
            self.stopped = why
            self.say(f'stopping: {why}; no new task starts, the running ones finish')

    def _collect(self, fut: Any, task: Task) -> TaskRecord | None:
        """The record of a finished future (a task failure or a dead worker is a failed
        record; a cancelled future is None)."""
        if fut.status == 'finished':
            rec = fut.result()
            return rec if isinstance(rec, TaskRecord) else TaskRecord.from_dict(rec)
        if fut.status != 'error':  # cancelled (or lost with the scheduler)
            return None
        exc = fut.exception()
        if isinstance(exc, KeyboardInterrupt):
            return None
        tb = ''.join(traceback.format_tb(fut.traceback())) if fut.traceback() else ''
        if isinstance(exc, self.killed_type):
            error = (
                f'KilledWorker: its worker process died on each of '
                f'{exc.allowed_failures + 1} attempts (last on {exc.last_worker.address})'
            )
        else:
            error = f'{type(exc).__name__}: {(str(exc).splitlines() or [""])[0]}'
        return TaskRecord(
            name=task.name, state='failed', error=error, traceback=tb, finished=time.time()
        )

    def _progress(self) -> None:
        c = self.counts
        head = (
            f'done {c["done"]}, running {len(self.running)}, failed {c["failed"]}, '
            f'total {len(self.sweep.tasks)}'
        )
        if head != self.last_line:
            remaining = len(self.pending) + len(self.in_flight)
            self.say(
                f'{head}; {time.perf_counter() - self.t_run:.1f} s, '
                f'{_eta(self.t_run, self.outcome.ran, remaining)}'
            )
            self.last_line = head
