"""suspopt sweep end to end: real Dask clusters (a LocalCluster, and a scheduler and
workers started as subprocesses), real optimizations, real signals and killed workers."""

from __future__ import annotations

import json
import multiprocessing as mp
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from suspopt.errors import ConfigError
from suspopt.output.rundir import DirectoryLock
from suspopt.sweep import TaskPayload, load_sweep, noop_task, run_sweep, run_task
from suspopt.sweep.store import read_records
from suspopt.sweep.summary import distinct_optima

DASK = str(Path(sys.executable).parent / 'dask')
STUDY = """
[maneuver]
speed = 10.0
horizon = 2.0
[road]
profile = "iso8608"
seed = 0
[transcription]
segments = 10
[objective]
normalization = "custom"
scales = [2.4, 1.56, 4.5e-4, 4.7e-4]
"""
PRODUCT = """
study = "study.toml"
command = "optimize"
fidelity = "low"
verify = false           # engine tests: 10 segments are quick, too coarse to verify
[axes]
"maneuver.speed" = [10.0, 15.0]
road.seed = [0, 1]
"""


def _files(tmp_path: Path, sweep: str, name: str = 'sweep.toml') -> Path:
    (tmp_path / 'study.toml').write_text(STUDY)
    path = tmp_path / name
    path.write_text(sweep)
    return path


def _cli(args, capsys):
    from suspopt.cli.main import main  # here: the cache test's spawned writers import this module

    code = main(args)
    out = capsys.readouterr()
    return code, out.err


def _records(out: Path) -> dict:
    return read_records(out)


def _log(out: Path) -> bytes:
    return (out / 'tasks' / 'records.jsonl').read_bytes()


# --------------------------------------------------------------------------- local cluster
@pytest.mark.slow
def test_product_sweep_equals_serial_resumes_and_refuses_a_changed_file(tmp_path, capsys, cluster):
    """On the external cluster (--scheduler); then, extended, on a local one (Ctrl-C)."""
    from suspopt.spec.load import config_from_dict, load_config
    from suspopt.studies.run import optimize

    address, client = cluster
    path = _files(tmp_path, PRODUCT)
    out = tmp_path / 'out'
    code, err = _cli(['sweep', str(path), '--out', str(out), '--scheduler', address], capsys)
    assert code == 0, err
    recs = _records(out)
    assert len(recs) == 4 and all(r.state == 'done' for r in recs.values())
    assert all((out / 'tasks' / n / 'output' / 'cases.sql').exists() for n in recs)
    assert f'connected to {address}: 2 worker(s)' in err and 'done 4, running 0' in err
    assert {r.worker for r in recs.values()} == set(client.scheduler_info()['workers'])
    rows = (out / 'summary.csv').read_text().splitlines()
    assert len(rows) == 5 and rows[0].startswith('task,state,maneuver.speed,road.seed')
    assert (out / 'figures' / 'maneuver.speed.png').exists()
    assert (out / 'figures' / 'road.seed.png').exists()
    assert json.loads((out / 'manifest.json').read_text()) == {'kind': 'sweep', 'format': 1}
    assert len(json.loads((out / 'sweep.json').read_text())['hash']) == 64

    base = load_config(tmp_path / 'study.toml').to_dict()
    for rec in recs.values():  # two of the configurations (both axes vary), serially here
        speed, seed = rec.task['values']['maneuver.speed'], rec.task['values']['road.seed']
        if (speed, seed) not in ((10.0, 0), (15.0, 1)):
            continue
        data = json.loads(json.dumps(base))
        data['maneuver']['speed'], data['road']['seed'] = speed, seed
        serial = optimize(config_from_dict(data), 'low')
        assert rec.result['objective'] == pytest.approx(serial.objective, rel=1e-9, abs=0)

    # resume: nothing reruns, no record is rewritten
    log = _log(out)
    outcome = run_sweep(path, out, workers=2, log=lambda m: None)
    assert outcome.exit_code == 0 and outcome.ran == 0 and outcome.counts['done'] == 4
    assert _log(out) == log

    # a changed sweep file is refused, naming what changed
    path.write_text(PRODUCT.replace('road.seed = [0, 1]', 'road.seed = [0, 2]'))
    code, err = _cli(['sweep', str(path), '--out', str(out)], capsys)
    assert code == 2 and 'road.seed: [0, 1] -> [0, 2]' in err and 'only adding tasks' in err
    assert _log(out) == log

    # a sweep file that only gains tasks is accepted; on a local cluster of one worker,
    # Ctrl-C (SIGINT to `suspopt sweep`) once one new task has finished: exit 130, the
    # cluster's processes gone, finished tasks kept, the other new ones still pending
    # six new tasks: after the first is done, five are still to run (a window of several
    # tasks for the interrupt to land in, even on a loaded machine)
    path.write_text(PRODUCT.replace('[10.0, 15.0]', '[10.0, 15.0, 11.0, 12.0, 13.0]'))
    _interrupt(path, out, lambda: len(_records(out)) > 4)
    recs = _records(out)
    assert _log(out).startswith(log)  # appended to, never rewritten
    assert len(recs) == 5 and all(r.state == 'done' for r in recs.values())
    table = (out / 'table.md').read_text()
    assert table.startswith('Sweep sweep.toml: 10 tasks, 5 done, 0 failed, 5 pending.')


@pytest.mark.slow
def test_forked_and_spawned_local_workers_give_the_same_results(tmp_path, capsys):
    """A local cluster forks its workers on Linux (spawn elsewhere): both ways, the same
    optima bit for bit (spawned: through the command line's --worker-start)."""
    path = _files(
        tmp_path,
        PRODUCT.replace('road.seed = [0, 1]', 'road.seed = [0]').replace('[10.0, 15.0]', '[12.0]'),
    )
    fork_log: list[str] = []
    outcome = run_sweep(path, tmp_path / 'fork', workers=1, log=fork_log.append)
    assert outcome.exit_code == 0 and outcome.counts['done'] == 1
    assert 'local cluster: 1 worker process(es), one thread each (forked)' in fork_log
    code, err = _cli(
        [
            'sweep',
            str(path),
            '--out',
            str(tmp_path / 'spawn'),
            '--workers',
            '1',
            '--worker-start',
            'spawn',
        ],
        capsys,
    )
    assert code == 0 and 'local cluster: 1 worker process(es), one thread each (spawned)' in err, (
        err
    )
    logs = ('fork', 'spawn')
    objectives = {
        start: sorted((n, r.result['objective']) for n, r in _records(tmp_path / start).items())
        for start in logs
    }
    assert objectives['fork'] == objectives['spawn']
    with pytest.raises(ConfigError, match="worker_start: expected 'auto', 'fork' or 'spawn'"):
        run_sweep(path, tmp_path / 'x', worker_start='forkserver')


def _setup_in_forked_child(queue) -> None:
    from threadpoolctl import threadpool_info

    from suspopt.sweep import dask_setup

    dask_setup(None)
    queue.put(
        (
            signal.getsignal(signal.SIGTERM) == signal.SIG_DFL,
            signal.getsignal(signal.SIGINT) == signal.SIG_IGN,
            sorted({p['num_threads'] for p in threadpool_info()}),
        )
    )


def test_worker_setup_drops_the_clients_sigterm_and_limits_blas_threads():
    """A worker forked from the sweep's client inherits its SIGTERM handler (which raises
    in the client) and its BLAS pools: the preload resets one, limits the other."""
    from threadpoolctl import threadpool_limits

    from suspopt.sweep.cluster import sweep_sigterm

    ctx = mp.get_context('fork')
    queue = ctx.Queue()
    old = signal.signal(signal.SIGTERM, sweep_sigterm)
    try:
        with threadpool_limits(limits=2):  # a client whose BLAS runs two threads
            proc = ctx.Process(target=_setup_in_forked_child, args=(queue,))
            proc.start()
        term_default, int_ignored, threads = queue.get(timeout=60)
        proc.join(timeout=30)
    finally:
        signal.signal(signal.SIGTERM, old)
    assert term_default and int_ignored and threads == [1]


def _interrupt(path: Path, out: Path, when) -> None:
    """Run ``suspopt sweep`` on a local cluster of one worker, SIGINT it once ``when()``;
    check exit 130, the message, and that every process it started is gone."""
    import psutil

    # SIGINT at its default in the child, whatever this process inherited (a shell starts
    # a background job with SIGINT ignored, and an ignored signal stays ignored on exec)
    proc = subprocess.Popen(
        [
            sys.executable,
            '-m',
            'suspopt.cli',
            'sweep',
            str(path),
            '--out',
            str(out),
            '--workers',
            '1',
        ],
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    children: set[int] = set()
    deadline = time.monotonic() + 120
    while not when() and time.monotonic() < deadline:
        children |= {c.pid for c in psutil.Process(proc.pid).children(recursive=True)}
        time.sleep(0.02)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert 'local cluster: 1 worker process(es)' in err
    assert (
        'the sweep file changed (sweep.axes.maneuver.speed: [10, 15] -> '
        '[10, 15, 11, 12, 13]): 6 new task(s); the 4 earlier task(s) are kept' in err
    )
    assert 'interrupted: cancelling pending tasks' in err and 'Traceback' not in err
    assert children
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and [p for p in children if _alive(p)]:
        time.sleep(0.1)
    assert not [p for p in children if _alive(p)]


def _alive(pid: int) -> bool:
    """A process that runs (a zombie, dead but not yet reaped by whoever adopted it, is
    gone)."""
    import psutil

    try:
        return psutil.Process(pid).status() != psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return False


# --------------------------------------------------------------------------- input checks
BAD = [
    (
        '[axes]\n"maneuver.sped" = [1.0]\n',
        "axes.maneuver.sped: not a study-file key (did you mean 'maneuver.speed'?)",
    ),
    ('[axes]\n"road.seed" = []\n', 'axes.road.seed: empty list'),
    ('[axes]\n"road.seed" = 3\n', 'axes.road.seed: must be a list of values'),
    ('[axes]\n"maneuver.speed" = [10.0, -1.0]\n', 'maneuver.speed: must be > 0, got -1'),
    ('[axes]\n"vehicle.front" = [1]\n', 'axes.vehicle.front: is a table'),
    (
        'fidelty = "low"\n[axes]\n"road.seed" = [0]\n',
        "fidelty: unknown key (did you mean 'fidelity'?)",
    ),
    ('fidelity = "medium"\n[axes]\n"road.seed" = [0]\n', 'fidelity: must be one of low, mixed'),
    ('[axes]\n"road.height" = [0.1]\n', "road.height: unknown key for profile 'iso8608'"),
    ('[axes]\nstart = [{ k_S1 = 1.0 }]\n', 'start.k_S1: 1 is outside the bounds'),
    ('mode = "list"\n', 'tasks: mode = "list" needs a non-empty list'),
    (
        'mode = "list"\n[[tasks]]\n"road.seed" = 1\n[[tasks]]\n"road.seed" = 1\n',
        'tasks[1]: the same task as tasks[0]',
    ),
    ('[multistart]\nn = 0\n', 'multistart.n: must be > 0, got 0'),
    ('[multistart]\nn = 4\nseeds = 1\n', "multistart.seeds: unknown key (did you mean 'seed'?)"),
    ('[multistart]\nn = 4\nmethod = "grid"\n', 'multistart.method: must be one of'),
    ('command = "study"\n[multistart]\nn = 4\n', "multistart: only for command = 'optimize'"),
    ('[axes]\n', 'axes: nothing to sweep'),
    ('[axes\n', 'not valid TOML'),
]


@pytest.mark.parametrize('text, message', BAD, ids=[b[1][:30] for b in BAD])
def test_bad_sweep_files_exit_2_naming_the_key(tmp_path, capsys, text, message):
    path = _files(tmp_path, 'study = "study.toml"\n' + text)
    code, err = _cli(['sweep', str(path), '--out', str(tmp_path / 'out')], capsys)
    assert code == 2 and message in err, err
    assert 'Traceback' not in err and not (tmp_path / 'out').exists()


def test_every_problem_of_a_sweep_file_at_once(tmp_path):
    path = _files(
        tmp_path,
        'study = "study.toml"\ncommand = "optimise"\nretries = -1\nverify = 1\n'
        '[axes]\n"maneuver.sped" = [1.0]\n"road.seed" = []\n',
    )
    with pytest.raises(ConfigError) as err:
        load_sweep(path)
    problems = [p.split(': ', 1)[1] for p in err.value.problems]
    assert problems == [
        'verify: must be true or false, got 1',
        "command: must be one of optimize, study, got 'optimise' (did you mean 'optimize'?)",
        'retries: must be >= 0 (reruns after a worker died), got -1',
        "axes.maneuver.sped: not a study-file key (did you mean 'maneuver.speed'?)",
        'axes.road.seed: empty list: an axis needs at least one value',
    ], problems


def test_refusals_exit_2(tmp_path, capsys):
    path = _files(tmp_path, PRODUCT)
    code, err = _cli(['sweep', str(tmp_path / 'nope.toml'), '--out', str(tmp_path / 'o')], capsys)
    assert code == 2 and 'sweep file not found' in err
    (tmp_path / 'busy').mkdir()
    with DirectoryLock(tmp_path / 'busy'):  # another suspopt command in the same directory
        code, err = _cli(['sweep', str(path), '--out', str(tmp_path / 'busy')], capsys)
    assert code == 2 and f'is in use by another suspopt run (suspopt, pid {os.getpid()}' in err
    assert err.count('\n') == 1
    (tmp_path / 'other').mkdir()
    (tmp_path / 'other' / 'x.txt').write_text('x')
    code, err = _cli(['sweep', str(path), '--out', str(tmp_path / 'other')], capsys)
    assert code == 2 and 'not a sweep directory' in err
    (tmp_path / 'run').mkdir()
    (tmp_path / 'run' / 'manifest.json').write_text('{"kind": "optimize", "format": 1}')
    code, err = _cli(['sweep', str(path), '--out', str(tmp_path / 'run')], capsys)
    assert code == 2 and "holds the results of a 'optimize' run, not a sweep" in err
    (tmp_path / 'old').mkdir()  # a sweep directory of the format before the manifest
    (tmp_path / 'old' / 'sweep.json').write_text('{}')
    code, err = _cli(['sweep', str(path), '--out', str(tmp_path / 'old')], capsys)
    assert code == 2 and 'a sweep of an earlier suspopt (no manifest.json)' in err
    code, err = _cli(['sweep', str(path), '--out', str(tmp_path / 'o'), '--workers', '0'], capsys)
    assert code == 2 and '--workers: must be >= 1' in err


def test_multistart_spreads_starts_over_the_design_box(tmp_path):
    path = _files(
        tmp_path,
        'study = "study.toml"\n[axes]\n"road.seed" = [0, 1]\n[multistart]\nn = 8\nseed = 3\n',
    )
    sweep = load_sweep(path)
    assert len(sweep.tasks) == 16 and sweep.axes == ['road.seed', 'start']
    starts = [t.start for t in sweep.tasks if t.values['road.seed'] == 0]
    for k, (lo, hi) in {'k_S1': (1e4, 5e4), 'c_S2': (1e3, 5e3)}.items():
        strata = sorted(int((s[k] - lo) / (hi - lo) * 8) for s in starts)
        assert strata == list(range(8))  # Latin hypercube: one start per stratum
    assert len({t.name for t in sweep.tasks}) == 16 and sweep.tasks[0].label.endswith('start=0')
    assert distinct_optima([{'a': 1.0}, {'a': 1.0005}, {'a': 2.0}], {'a': (0.0, 10.0)}) == [0, 0, 1]


def test_a_failing_task_is_a_record_with_its_traceback(tmp_path):
    """run_task itself (no cluster): the worker-side build fails, the record says why."""
    bad = {'maneuver': {'speed': -1.0}}
    rec = run_task(TaskPayload('t', 'optimize', 'low', None, bad, True, str(tmp_path / 'o')))
    assert rec.state == 'failed' and rec.worker is None
    assert rec.error == 'ConfigError: maneuver.speed: must be > 0, got -1'
    assert 'Traceback' in rec.traceback and 'ConfigError' in rec.traceback


def test_a_storage_failure_is_not_a_task_failure():
    """What a full or unwritable disk raises, directly or as the cause of another error,
    is the environment's failure; anything else is the task's."""
    import errno
    import sqlite3

    from suspopt.errors import RunError
    from suspopt.sweep.tasks import storage_failure

    def caused(err: BaseException) -> BaseException:
        try:
            try:
                raise err
            except BaseException as inner:
                raise RuntimeError('Error calling compute()') from inner
        except RuntimeError as outer:
            return outer

    full = OSError(errno.ENOSPC, 'No space left on device')
    for err in (full, RunError('cannot write x: No space left on device'), caused(full)):
        assert storage_failure(err), err
    assert storage_failure(sqlite3.OperationalError('database or disk is full'))
    assert storage_failure(OSError(errno.EROFS, 'Read-only file system'))
    for err in (ValueError('x'), OSError(errno.ENOENT, 'x'), sqlite3.OperationalError('syntax')):
        assert not storage_failure(err), err


def _dies_at_speed_13(payload: TaskPayload):
    """A task function whose worker process dies when its task has speed 13 (a no-op
    task otherwise): a crash in native code, as the local cluster sees it."""
    time.sleep(0.2)
    if payload.config['maneuver']['speed'] == 13.0:
        os._exit(1)
    return noop_task(payload)


def test_a_dead_local_worker_charges_only_its_own_task_retry_failed_reruns_it(tmp_path):
    """The sweep gives each worker thread one task at a time (none waits on a worker that
    may die): a worker that dies charges its running task only, so with no retries that
    task fails as killed, after its one attempt, and every other task is done at its
    first attempt. A rerun keeps the failed task; ``retry_failed`` reruns it alone."""
    path = _files(
        tmp_path,
        'study = "study.toml"\nfidelity = "low"\nretries = 0\n'
        '[axes]\n"maneuver.speed" = [10.0, 11.0, 12.0, 13.0, 14.0, 15.0]\n',
    )
    out = tmp_path / 'out'
    res = run_sweep(
        path, out, workers=2, log=lambda m: None, task_fn=_dies_at_speed_13, worker_start='fork'
    )
    recs = _records(out)
    assert len(recs) == 6 and res.exit_code == 1
    states = {r.task['values']['maneuver.speed']: r.state for r in recs.values()}
    assert states == {v: 'done' if v != 13.0 else 'failed' for v in states}, [
        (r.task['values'], r.error) for r in recs.values() if r.state != 'done'
    ]
    dead = next(r for r in recs.values() if r.state == 'failed')
    assert dead.error.startswith('KilledWorker'), dead.error
    assert all(r.attempts == 1 for r in recs.values()), [r.attempts for r in recs.values()]

    again = run_sweep(path, out, workers=1, log=lambda m: None, task_fn=noop_task)
    assert again.ran == 0 and again.exit_code == 1 and again.counts['failed'] == 1
    again = run_sweep(
        path, out, workers=1, log=lambda m: None, task_fn=noop_task, retry_failed=True
    )
    assert again.ran == 1 and again.exit_code == 0 and again.counts['done'] == 6
    assert _records(out)[dead.name].state == 'done'


# --------------------------------------------------------------------------- external cluster
@pytest.fixture
def cluster(_cluster_processes):
    """The module's cluster with both workers up (a test before may have killed one: its
    nanny restarts it, on a loaded machine after a while)."""
    address, client = _cluster_processes
    client.wait_for_workers(2, timeout=120)
    return address, client


@pytest.fixture(scope='module')
def _cluster_processes(tmp_path_factory):
    """A real ``dask scheduler`` and two ``dask worker`` processes (nannies restart a
    killed worker; the scheduler lets a task survive one worker death)."""
    from distributed import Client

    root = tmp_path_factory.mktemp('cluster')
    env = {**os.environ, 'DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES': '1'}
    sched_file = root / 'scheduler.json'
    procs = [
        subprocess.Popen(
            [
                DASK,
                'scheduler',
                '--port',
                '0',
                '--no-dashboard',
                '--scheduler-file',
                str(sched_file),
            ],
            env=env,
            cwd=root,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
    ]
    try:
        deadline = time.monotonic() + 60
        while not sched_file.exists() and time.monotonic() < deadline:
            time.sleep(0.05)
        for i in range(2):
            procs.append(
                subprocess.Popen(
                    [
                        DASK,
                        'worker',
                        '--scheduler-file',
                        str(sched_file),
                        '--nthreads',
                        '1',
                        '--no-dashboard',
                        '--preload',
                        'suspopt.sweep',
                        '--name',
                        f'w{i}',
                    ],
                    env=env,
                    cwd=root,
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL,
                )
            )
        address = json.loads(sched_file.read_text())['address']
        client = Client(address, timeout='30s')
        client.wait_for_workers(2, timeout=60)
        yield address, client
        client.shutdown()  # scheduler and workers (nannies included) exit
    finally:
        for p in procs:
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                p.terminate()
                try:
                    p.wait(timeout=20)
                except subprocess.TimeoutExpired:
                    p.kill()
                    p.wait()


LIST = """
study = "study.toml"
mode = "list"
verify = false
[[tasks]]
"maneuver.speed" = 12.0
[[tasks]]
"maneuver.speed" = 14.0
"optimizer.max_iter" = 1
"""


@pytest.mark.slow
def test_scheduler_path_records_a_failed_task_others_finish(tmp_path, capsys, cluster):
    address, _ = cluster
    path = _files(tmp_path, LIST)
    out = tmp_path / 'out'
    code, err = _cli(['sweep', str(path), '--out', str(out), '--scheduler', address], capsys)
    assert code == 1, err
    assert f'connected to {address}: 2 worker(s)' in err and 'rerun up to 1 time(s)' in err
    recs = sorted(_records(out).values(), key=lambda r: r.task['values']['maneuver.speed'])
    assert [r.state for r in recs] == ['done', 'failed']
    assert recs[1].error == 'IPOPT Maximum_Iterations_Exceeded after 1 iterations'
    assert f'failed: {recs[1].name}: IPOPT Maximum_Iterations_Exceeded' in err
    assert 'done 1, running 0, failed 1, total 2' in err
    assert {r.worker for r in recs} <= set(cluster[1].scheduler_info()['workers'])
    table = (out / 'table.md').read_text()
    assert '2 tasks, 1 done, 1 failed' in table and 'Maximum_Iterations_Exceeded' in table


def _kill_running_worker(client, out: Path, kills: int, runner) -> list[int]:
    """SIGKILL the worker process running the sweep's only task, ``kills`` times: first
    once the task has started (its output directory exists), then each rerun as soon as
    it is on a live worker (its start event may not have left the worker yet; the
    scheduler's own count of deaths says it was an attempt). Which worker: the
    scheduler's ``processing``; its pid: asked of that worker through the client (the
    scheduler's identity of a worker has no pid); a killed worker's address is not asked
    again (the scheduler may list it a moment longer, and asking a dead worker waits for
    the connection to time out while the rerun finishes)."""
    killed: list[int] = []
    dead: set[str] = set()
    deadline = time.monotonic() + 90
    while len(killed) < kills and time.monotonic() < deadline and runner.is_alive():
        busy = [w for w, keys in client.processing().items() if keys and w not in dead]
        if busy and list((out / 'tasks').glob('*/output')):
            try:
                pid = client.run(os.getpid, workers=busy[:1], on_error='return')[busy[0]]
            except (KeyError, OSError):
                pid = None
            if isinstance(pid, int) and pid not in killed:
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)
                dead.add(busy[0])
        time.sleep(0.02)
    return killed


@pytest.mark.slow
@pytest.mark.parametrize('kills', [1, 2])
def test_killed_worker_task_is_retried_then_failed(tmp_path, cluster, kills):
    """The sweep runs in a thread here (its client is its own); this thread kills."""
    import threading

    address, client = cluster
    # the multibody model: a task of about 2 s, long enough to be found running
    path = _files(
        tmp_path,
        f'study = "study.toml"\nfidelity = "mixed"\nverify = false\n'
        f'[axes]\n"maneuver.speed" = [{11 + kills}.0]\n',
    )
    out = tmp_path / 'out'
    lines: list[str] = []
    done: dict = {}
    runner = threading.Thread(
        target=lambda: done.update(
            outcome=run_sweep(path, out, scheduler=address, log=lines.append)
        )
    )
    runner.start()
    killed = _kill_running_worker(client, out, kills, runner)
    runner.join(timeout=120)
    err = '\n'.join(lines)
    assert len(killed) == kills, err
    rec = next(iter(_records(out).values()))
    if kills == 1:  # rerun on another worker process, finished
        assert done['outcome'].exit_code == 0, err
        assert 'its worker process died; rerun on' in err and '(attempt 2)' in err
        assert rec.state == 'done' and rec.attempts == 2 and rec.pid not in killed
    else:  # died twice: recorded as failed with the cause
        assert done['outcome'].exit_code == 1, err
        assert rec.state == 'failed' and rec.error.startswith(
            'KilledWorker: its worker process died on each of 2 attempts'
        )
        assert rec.attempts == 2
        assert f'failed: {rec.name}: KilledWorker' in err
    client.wait_for_workers(2, timeout=60)  # the nannies restarted them


@pytest.mark.slow
def test_the_scheduler_counts_a_tasks_dead_workers(cluster):
    """A worker killed before a task could say it started still counts as an attempt:
    the record's count comes from the scheduler's own (``_deaths``)."""
    from suspopt.sweep.cluster import deaths as _deaths

    address, client = cluster
    fut = client.submit(time.sleep, 4, pure=False)  # short: a running rerun holds up
    # the cluster's shutdown (a cancelled task still runs to its end in its thread)
    try:
        deadline = time.monotonic() + 30
        while not any(client.processing().values()) and time.monotonic() < deadline:
            time.sleep(0.02)
        busy = [w for w, keys in client.processing().items() if keys]
        assert _deaths(client, fut.key) == 0
        os.kill(client.run(os.getpid, workers=busy)[busy[0]], signal.SIGKILL)
        while _deaths(client, fut.key) == 0 and time.monotonic() < deadline:
            time.sleep(0.05)
        assert _deaths(client, fut.key) == 1 and _deaths(client, 'no-such-task') == 0
    finally:
        client.cancel(fut, force=True)
    client.wait_for_workers(2, timeout=60)


# --------------------------------------------------------------------------- the directory
ROAD = 'distance,height\n0,0\n20,0\n21,0.02\n22,0\n300,0\n'
CSV_STUDY = STUDY.replace('profile = "iso8608"\nseed = 0', 'profile = "csv"\nfile = "road.csv"')
CSV_SWEEP = 'study = "study.toml"\nverify = false\n[axes]\n"maneuver.speed" = [10.0, 12.0]\n'


def test_a_changed_input_file_is_refused_naming_it(tmp_path, capsys):
    """A task is its inputs' content: the tasks read the directory's copy of the road CSV
    (what their identity hashes); the CSV edited between two runs into the same directory
    is refused, naming the file, nothing rerun or rewritten; restored, the sweep resumes."""
    (tmp_path / 'road.csv').write_text(ROAD)
    path = _files(tmp_path, CSV_SWEEP)
    (tmp_path / 'study.toml').write_text(CSV_STUDY)
    out = tmp_path / 'out'
    first = run_sweep(path, out, workers=1, log=lambda m: None, task_fn=noop_task)
    assert first.exit_code == 0 and first.ran == 2
    sweep = load_sweep(path)
    payload = sweep.tasks[0].payload(out, None)
    copy = Path(payload.config['road']['file'])
    assert copy.parent.parent == (out / 'inputs').resolve() and copy.read_text() == ROAD
    log = _log(out)

    (tmp_path / 'road.csv').write_text(ROAD.replace('0.02', '0.03'))
    assert {t.name for t in load_sweep(path).tasks}.isdisjoint(t.name for t in sweep.tasks)
    code, err = _cli(['sweep', str(path), '--out', str(out)], capsys)
    assert code == 2 and f'{tmp_path / "road.csv"} changed since this sweep started here' in err
    assert 'Restore the file, or run the sweep into a new --out' in err and err.count('\n') == 1
    assert _log(out) == log and copy.read_text() == ROAD

    (tmp_path / 'road.csv').write_text(ROAD)  # restored: the same tasks, nothing to run
    again = run_sweep(path, out, workers=1, log=lambda m: None, task_fn=noop_task)
    assert again.ran == 0 and again.exit_code == 0 and _log(out) == log


def test_a_task_is_identified_by_the_content_it_reads(tmp_path):
    """Mechanism files and the base study's description count by content: an edited
    mechanism is another task, a moved one with the same content and name the same, an
    edited comment of the study file changes nothing."""
    from suspopt.multibody.mechanism import mechanism_path

    mech = mechanism_path('double_wishbone').read_text()
    (tmp_path / 'a').mkdir()
    (tmp_path / 'a' / 'dw.toml').write_text(mech)
    path = _files(tmp_path, 'study = "study.toml"\nfidelity = "mixed"\n[multistart]\nn = 2\n')
    study = STUDY + '[vehicle.front]\nmechanism = "a/dw.toml"\n'
    (tmp_path / 'study.toml').write_text(study)
    names = [t.name for t in load_sweep(path).tasks]
    builtin = {Path(f.path).name for t in load_sweep(path).tasks for f in t.inputs if f.builtin}
    assert builtin == {'double_wishbone.toml'}  # the rear axle's, hashed too

    (tmp_path / 'study.toml').write_text('# a comment\n' + study)
    assert [t.name for t in load_sweep(path).tasks] == names
    (tmp_path / 'b').mkdir()
    (tmp_path / 'b' / 'dw.toml').write_text(mech)
    (tmp_path / 'study.toml').write_text(study.replace('a/dw.toml', 'b/dw.toml'))
    assert [t.name for t in load_sweep(path).tasks] == names
    (tmp_path / 'b' / 'dw.toml').write_text(mech + '\n# edited\n')
    assert set(t.name for t in load_sweep(path).tasks).isdisjoint(names)
    (tmp_path / 'study.toml').write_text(study.replace('horizon = 2.0', 'horizon = 1.5'))
    assert set(t.name for t in load_sweep(path).tasks).isdisjoint(names)


def _wait_for_go(payload: TaskPayload):
    """A no-op task that waits until the test creates ``go`` beside the sweep directory."""
    go = Path(payload.out_dir).parents[3] / 'go'
    deadline = time.monotonic() + 60
    while not go.exists() and time.monotonic() < deadline:
        time.sleep(0.02)
    return noop_task(payload)


@pytest.mark.timeout(180)
def test_another_command_on_a_live_sweeps_directory_is_refused(tmp_path, capsys):
    """Every command takes the same lock: ``optimize --out D --overwrite`` against a
    running sweep's D is refused at once (one line, exit 2), and nothing of D is deleted."""
    import threading

    path = _files(tmp_path, CSV_SWEEP)
    out = tmp_path / 'out'
    done: dict = {}

    def sweep() -> None:
        try:
            done['outcome'] = run_sweep(
                path, out, workers=1, log=lambda m: None, task_fn=_wait_for_go
            )
        except BaseException as err:  # noqa: BLE001 - reported by the test below
            done['error'] = err

    runner = threading.Thread(target=sweep)
    runner.start()
    try:
        deadline = time.monotonic() + 60
        while not (out / 'sweep.json').exists() and time.monotonic() < deadline:
            if 'error' in done:  # the sweep itself failed: say why, not a timeout
                raise AssertionError(f'the sweep failed: {done["error"]!r}')
            time.sleep(0.02)
        assert (out / 'sweep.json').exists(), 'the sweep did not start in 60 s'
        before = sorted(p.relative_to(out) for p in out.rglob('*'))
        t = time.perf_counter()
        code, err = _cli(
            [
                'optimize',
                '--fidelity',
                'low',
                '--config',
                str(tmp_path / 'study.toml'),
                '--out',
                str(out),
                '--overwrite',
                '--max-iter',
                '1',
            ],
            capsys,
        )
        # refused, not queued: the sweep cannot end before 'go', so a command that waited
        # for the lock would never return; the bound is loose for a loaded machine
        assert time.perf_counter() - t < 30
        assert code == 2 and err.count('\n') == 1, err
        assert (
            f'--out: {out} is in use by another suspopt run (suspopt sweep, pid {os.getpid()}'
            in err
        )
        assert set(before) <= {p.relative_to(out) for p in out.rglob('*')}
    finally:
        (tmp_path / 'go').touch()
        runner.join(timeout=60)
    assert done['outcome'].exit_code == 0 and len(_records(out)) == 2


def test_a_full_disk_while_recording_exits_4_and_leaves_the_rest_to_rerun(tmp_path, monkeypatch):
    """The records' writer hits a full disk (ENOSPC in the client) at the third task: the
    sweep stops with a RunError (exit 4), the two recorded tasks stay, no cut line is
    left; a plain rerun runs exactly the tasks not recorded."""
    import errno

    from suspopt.errors import RunError
    from suspopt.sweep.store import RecordLog

    path = _files(tmp_path, 'study = "study.toml"\nverify = false\n[multistart]\nn = 6\n')
    out = tmp_path / 'out'
    real, calls = RecordLog._write, []

    def write(self, data: bytes) -> None:
        calls.append(data)
        if len(calls) > 2:
            os.write(self.fd, data[:10])  # a part of the line reached the disk
            raise OSError(errno.ENOSPC, 'No space left on device')
        real(self, data)

    monkeypatch.setattr(RecordLog, '_write', write)
    lines: list[str] = []
    with pytest.raises(RunError) as err:
        run_sweep(path, out, workers=1, log=lines.append, task_fn=noop_task)
    assert err.value.exit_code == 4
    assert 'records.jsonl: No space left on device' in str(err.value), err.value
    assert '4 task(s) not finished stay pending' in str(err.value), err.value
    assert any(m.startswith('stopping: cannot write') for m in lines), lines
    assert _log(out).count(b'\n') == 2 and _log(out).endswith(b'\n')
    assert (
        'Sweep sweep.toml: 6 tasks, 2 done, 0 failed, 4 pending.' in (out / 'table.md').read_text()
    )

    monkeypatch.setattr(RecordLog, '_write', real)
    again = run_sweep(path, out, workers=1, log=lambda m: None, task_fn=noop_task)
    assert again.ran == 4 and again.exit_code == 0 and len(_records(out)) == 6


def _can_mount_tmpfs() -> bool:
    try:
        res = subprocess.run(
            ['unshare', '-rm', 'sh', '-c', 'mount -t tmpfs -o size=8k tmpfs /mnt'],
            capture_output=True,
            timeout=10,
        )
    except (OSError, subprocess.TimeoutExpired):
        return False
    return res.returncode == 0


FULL_DISK = """
import os, sys
from pathlib import Path
from suspopt.cli.main import main

disk, path = Path(sys.argv[1]), sys.argv[2]
args = ['sweep', path, '--out', str(disk / 'out'), '--workers', '1']
records = disk / 'out' / 'tasks' / 'records.jsonl'
first = main(args)
lines = records.read_bytes().count(b'\\n')
(disk / 'filler').unlink()
second = main(args)
print(first, lines, second, records.read_bytes().count(b'\\n'))
print((disk / 'out' / 'table.md').read_text().splitlines()[0])
"""


@pytest.mark.slow
@pytest.mark.skipif(not _can_mount_tmpfs(), reason='needs user and mount namespaces (unshare -rm)')
def test_a_full_disk_under_a_task_exits_4_and_a_rerun_runs_it(tmp_path):
    """A real full disk: a 2 MiB tmpfs (in a user and mount namespace of its own) filled
    up to 32 KiB, room for the sweep's own files, not for a task's recorder file. A real
    optimization fails to write its output: exit 4, nothing recorded (before, it was
    recorded as failed, exit 1, and a rerun skipped it); space freed, the same command
    runs it (both in one process: ``suspopt.cli.main.main``)."""
    (tmp_path / 'study.toml').write_text(STUDY)
    path = _files(tmp_path, 'study = "study.toml"\nverify = false\n[axes]\n"road.seed" = [3]\n')
    (tmp_path / 'driver.py').write_text(FULL_DISK)
    disk = tmp_path / 'disk'
    disk.mkdir()
    script = f"""
        mount -t tmpfs -o size=2048k tmpfs {disk} || exit 99
        head -c {2048 * 1024 - 32 * 1024} /dev/zero > {disk}/filler
        {sys.executable} {tmp_path / 'driver.py'} {disk} {path}
    """
    res = subprocess.run(
        ['unshare', '-rm', 'sh', '-c', script], capture_output=True, text=True, timeout=300
    )
    assert res.returncode == 0, res.stdout + res.stderr
    codes, table = res.stdout.splitlines()[-2:]
    assert codes == '4 0 0 1', res.stdout + res.stderr  # exit 4, 0 records; exit 0, 1 record
    # the first file that does not fit: the task's road inputs or its case recorder
    assert 'No space left on device' in res.stderr or 'disk is full' in res.stderr, res.stderr
    assert 'suspopt: error: ' in res.stderr and '1 task(s) not finished stay pending' in res.stderr
    assert table == 'Sweep sweep.toml: 1 tasks, 1 done, 0 failed, 0 pending.'


def _wchar() -> int:
    """Bytes this process has passed to write() and its kind (files, pipes), ever."""
    for line in Path('/proc/self/io').read_text().splitlines():
        if line.startswith('wchar:'):
            return int(line.split()[1])
    raise AssertionError('no wchar in /proc/self/io')


@pytest.mark.skipif(not Path('/proc/self/io').exists(), reason='needs /proc/self/io')
def test_bookkeeping_per_finished_task_does_not_grow_with_the_sweep(tmp_path):
    """No-op tasks through the real engine and bookkeeping, 10 and 100 of them: every
    byte the sweep's process writes (records, sweep.json, summary, figures) per task does
    not grow with the number of tasks (a summary rewritten per task: ten times more),
    and the records cost the same per task. ``render`` (what ``suspopt report DIR`` calls
    for a sweep's directory) writes the same summary again from the records alone."""
    from suspopt.sweep.store import manifest_kind
    from suspopt.sweep.summary import render

    written, appended = {}, {}
    for n in (10, 100):
        path = _files(tmp_path, f'study = "study.toml"\nverify = false\n[multistart]\nn = {n}\n')
        load_sweep(path)  # its imports and validation: not bookkeeping
        w0 = _wchar()
        outcome = run_sweep(
            path, tmp_path / f'o{n}', workers=2, log=lambda m: None, task_fn=noop_task
        )
        written[n] = (_wchar() - w0) / n
        appended[n] = outcome.record_bytes / n
        assert outcome.exit_code == 0 and outcome.ran == n
    assert written[100] < written[10], written
    assert appended[100] == pytest.approx(appended[10], rel=0.05), appended
    assert written[100] < 4096, written  # a record, a row, a task's description

    out = tmp_path / 'o10'
    assert manifest_kind(out) == 'sweep'
    table, csv = (out / 'table.md').read_text(), (out / 'summary.csv').read_text()
    for name in ('table.md', 'summary.csv'):
        (out / name).unlink()
    assert {p.name for p in render(out)} == {'table.md', 'summary.csv', 'start.png'}
    assert (out / 'table.md').read_text() == table and (out / 'summary.csv').read_text() == csv
    with pytest.raises(ConfigError, match='no manifest.json'):
        render(tmp_path)


def test_records_are_appended_a_cut_line_is_no_record(tmp_path):
    """The records file: a task's last line is its record; a last line cut short (a
    writer killed mid-line) is no record and is dropped before the next append; a damaged
    line elsewhere is said and skipped."""
    from suspopt.sweep.store import RecordLog
    from suspopt.sweep.tasks import TaskRecord

    log = RecordLog(tmp_path)
    for rec in (
        TaskRecord('a', 'failed', error='x'),
        TaskRecord('b', 'done'),
        TaskRecord('a', 'done'),
    ):
        log.append(rec)
    log.close()
    path = tmp_path / 'tasks' / 'records.jsonl'
    whole = path.read_bytes()
    assert {n: r.state for n, r in read_records(tmp_path).items()} == {'a': 'done', 'b': 'done'}
    path.write_bytes(whole + b'{"name": "c", "sta')
    assert set(read_records(tmp_path)) == {'a', 'b'}
    log = RecordLog(tmp_path)
    log.append(TaskRecord('c', 'done'))
    log.close()
    assert path.read_bytes().startswith(whole) and set(read_records(tmp_path)) == {'a', 'b', 'c'}
    path.write_bytes(whole.replace(b'"name":"b"', b'"name":"b', 1))
    said: list[str] = []
    assert set(read_records(tmp_path, said.append)) == {'a'}
    assert said == [f'{path}: line 2 unreadable, ignored (its task reruns)']


def test_a_forked_worker_does_not_log_into_a_stream_held_at_the_fork(tmp_path):
    """A log handler of this process (the root logger's, as pytest's or an application's),
    whose stream a thread holds (its write waits on a full pipe) while the local cluster
    forks its worker: the worker inherits the stream's lock held. Were Dask's records to
    reach the handler in the worker (Dask logs its preload at start), the worker would
    wait for that lock forever and the sweep would never start. (The handler takes the
    workers' records only: this process's own would wait here too.)"""
    import logging
    import threading

    read_end, write_end = os.pipe()
    stream = open(write_end, 'w')  # a TextIOWrapper on a BufferedWriter, as stderr
    handler = logging.StreamHandler(stream)
    me = os.getpid()
    handler.addFilter(lambda record: os.getpid() != me)
    root = logging.getLogger()
    old_level = root.level
    root.addHandler(handler)
    root.setLevel(logging.INFO)
    writer = threading.Thread(target=lambda: (stream.write('x' * (1 << 20)), stream.flush()))
    try:
        writer.start()  # fills the pipe, then waits inside write() holding the stream
        time.sleep(0.2)
        path = _files(tmp_path, 'study = "study.toml"\nverify = false\n[multistart]\nn = 2\n')
        done: dict = {}
        sweep = threading.Thread(
            target=lambda: done.update(
                outcome=run_sweep(
                    path, tmp_path / 'out', workers=1, log=lambda m: None, task_fn=noop_task
                )
            ),
            daemon=True,
        )
        sweep.start()
        sweep.join(timeout=60)
        assert not sweep.is_alive(), 'the forked worker waits for a lock held at the fork'
        assert done['outcome'].exit_code == 0
    finally:
        root.removeHandler(handler)
        root.setLevel(old_level)
        while writer.is_alive():
            os.read(read_end, 1 << 20)
            writer.join(timeout=0.1)
        stream.close()
        os.close(read_end)


def test_a_killed_commands_lock_is_not_held_by_its_forked_children(tmp_path):
    """The lock is the process's, not its children's: a process that takes it, forks
    (as a sweep forks its Dask workers) and is killed leaves the directory free at once,
    while its child lives on."""
    script = f"""
import os, signal, time
from suspopt.output.rundir import DirectoryLock
lock = DirectoryLock({str(tmp_path)!r}, 'suspopt sweep')
lock.acquire()
child = os.fork()
if child == 0:
    null = os.open(os.devnull, os.O_WRONLY)
    os.dup2(null, 1)
    os.dup2(null, 2)
    time.sleep(30)
    os._exit(0)
print('locked', child, flush=True)
os.kill(os.getpid(), signal.SIGKILL)
"""
    proc = subprocess.run([sys.executable, '-c', script], capture_output=True, text=True)
    word, child = proc.stdout.split()
    try:
        assert word == 'locked' and proc.returncode == -signal.SIGKILL, proc.stderr
        state = Path(f'/proc/{child}/stat').read_text().rsplit(')', 1)[1].split()[0]
        assert state in 'SR'  # the child lives on (sleeping or running)
        with DirectoryLock(tmp_path):
            pass
    finally:
        os.kill(int(child), signal.SIGKILL)


# --------------------------------------------------------------------------- coloring cache
def _store_many(key: str, barrier, rounds: int, cache: str, seed: int) -> None:
    """Store ``key`` ``rounds`` times, each time at the same moment as the other writer
    (the barrier), and check the file right after: always a whole coloring."""
    os.environ['SUSPOPT_CACHE_DIR'] = cache
    import suspopt.transcription.coloring_cache as cc

    coloring = _coloring(seed)
    for _ in range(rounds):
        barrier.wait()
        cc.store(key, coloring)
        got = cc.load(key)
        assert got is not None and got.shape == coloring.shape, 'partial coloring file'


def _coloring(seed: int):
    import numpy as np
    import scipy.sparse as sp

    from suspopt.driver.sparsity import Coloring, color_columns

    rng = np.random.default_rng(seed)
    pattern = sp.csc_matrix(rng.random((300, 300)) < 0.02)
    coo = pattern.tocoo()
    return Coloring(shape=(300, 300), rows=coo.row, cols=coo.col, colors=color_columns(pattern))


@pytest.mark.slow
def test_coloring_cache_concurrent_stores_are_atomic(tmp_path):
    """Two processes store the same key at the same moment, many times, and a third
    reads it all the while: it is always a whole, loadable coloring, never a partial one."""
    import suspopt.transcription.coloring_cache as cc

    ctx = mp.get_context('spawn')
    barrier = ctx.Barrier(2)
    key, rounds = 'f' * 32, 30
    writers = [
        ctx.Process(target=_store_many, args=(key, barrier, rounds, str(tmp_path), s))
        for s in (1, 2)
    ]
    for w in writers:
        w.start()
    path = tmp_path / 'colorings' / f'{key}.npz'
    reads = 0
    old = os.environ.get('SUSPOPT_CACHE_DIR')
    os.environ['SUSPOPT_CACHE_DIR'] = str(tmp_path)
    try:
        while any(w.is_alive() for w in writers):
            if path.exists():
                got = cc.load(key)
                assert got is not None and got.shape == (300, 300), 'partial coloring file'
                reads += 1
            time.sleep(0.001)
        for w in writers:
            w.join()
            assert w.exitcode == 0  # the writers' own checks held
        assert reads > 10 and cc.load(key) is not None
        assert not list(cc.cache_dir().glob('*.tmp'))
    finally:
        if old is None:
            del os.environ['SUSPOPT_CACHE_DIR']
        else:
            os.environ['SUSPOPT_CACHE_DIR'] = old
