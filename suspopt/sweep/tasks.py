"""A sweep's tasks: their identity, the files they read, what a worker gets and returns.

A task is identified by a hash of everything that decides its result: the command,
fidelity, start, verification flag, its canonical study description, and the **content**
(SHA-256) of every file it reads (road CSVs, mechanism TOMLs, the built-in ones included),
each file standing in the description as ``<file name>#<sha256>`` instead of its path. An
edited file is a different task, whatever its path; a moved file with the same content and
name is the same one. The task's name is a readable label of its swept values plus the
first eight hex digits of that hash.

A task runs on a Dask worker from a :class:`TaskPayload` (plain data: a set-up
``om.Problem`` cannot be pickled) whose input files are the sweep directory's copies
(``inputs/<sha256[:16]>/<name>``, written once by :mod:`suspopt.sweep.store`): a task reads
exactly the content its identity names, even if the user's file changes during the sweep.
It returns a :class:`TaskRecord`; a failed task is a record, never an exception. A task
stopped by its environment (a full or unwritable disk) is not a result: its record says
``environment`` and the sweep stops without recording it (``docs/sweeps.md``).
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import re
import shutil
import socket
import time
import traceback
from collections.abc import Iterator
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

from suspopt.errors import RunError

#: a finished task's states (recorded); ``environment``: stopped by a full or unwritable
#: disk, not finished, never recorded
FINISHED = ('done', 'failed')
ENVIRONMENT = 'environment'
#: errno values that mean the output's file system, not the task, failed
STORAGE_ERRNOS = frozenset(
    {errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EIO, errno.EACCES, errno.EPERM}
)
#: SQLite's words for the same (OpenMDAO's case recorder)
SQLITE_STORAGE = ('disk is full', 'disk i/o error', 'readonly database', 'unable to open')


# ------------------------------------------------------------------ the files a task reads
@dataclass(frozen=True)
class InputFile:
    """A file a task reads, by content. ``builtin``: a mechanism shipped with suspopt
    (hashed, not copied: the task keeps its name)."""

    path: str
    sha256: str
    builtin: bool = False

    @property
    def copy(self) -> str | None:
        """Its copy in the sweep directory (relative), None for a built-in file."""
        return None if self.builtin else f'inputs/{self.sha256[:16]}/{Path(self.path).name}'

    @property
    def token(self) -> str:
        """How it stands in a task's identity: name and content, not path."""
        return f'{Path(self.path).name}#{self.sha256}'


def _slots(node: Any) -> Iterator[tuple[dict[str, Any], str]]:
    """``(table, key)`` of every file a plain study description names: a CSV road's
    ``file`` (the road, its tracks, a scenario's road) and an axle's ``mechanism``."""
    if isinstance(node, list):
        for item in node:
            yield from _slots(item)
    elif isinstance(node, dict):
        if node.get('profile') == 'csv' and isinstance(node.get('file'), str):
            yield node, 'file'
        for key, val in node.items():
            if key == 'mechanism' and isinstance(val, str):
                yield node, key
            else:
                yield from _slots(val)


def sha256_file(path: str | Path) -> str:
    h = hashlib.sha256()
    with open(path, 'rb') as fh:
        for block in iter(lambda: fh.read(1 << 20), b''):
            h.update(block)
    return h.hexdigest()


class InputFiles:
    """The files of many study descriptions, each read and hashed once."""

    def __init__(self) -> None:
        self.files: dict[str, InputFile] = {}  # by the value in the description
        self._builtin: set[str] | None = None

    def of(self, config: dict[str, Any]) -> dict[str, InputFile]:
        """The files ``config`` (canonical: absolute paths) reads, by their value in it. A
        file that cannot be read raises :class:`ConfigError` (validation read it)."""
        return {table[key]: self._file(table[key]) for table, key in _slots(config)}

    def _file(self, value: str) -> InputFile:
        if value not in self.files:
            from suspopt.errors import ConfigError
            from suspopt.multibody.mechanism import builtin_mechanisms, mechanism_path

            if self._builtin is None:
                self._builtin = set(builtin_mechanisms())
            builtin = value in self._builtin
            path = mechanism_path(value) if builtin else Path(value)
            try:
                self.files[value] = InputFile(str(path), sha256_file(path), builtin)
            except OSError as err:
                raise ConfigError(f'cannot read {path}: {err.strerror}') from None
        return self.files[value]


def with_inputs(config: dict[str, Any], replace: dict[str, str]) -> dict[str, Any]:
    """``config`` (a copy) with every file value in ``replace`` replaced."""
    out = json.loads(json.dumps(config))
    for table, key in _slots(out):
        table[key] = replace.get(table[key], table[key])
    return out


# ------------------------------------------------------------------ tasks
def digest(obj: Any) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, default=str).encode()).hexdigest()


def fmt(v: Any) -> str:
    """A swept value as text (labels, tables)."""
    if isinstance(v, float):
        return f'{v:g}'
    if isinstance(v, dict):
        return '{' + ', '.join(f'{k}={fmt(x)}' for k, x in v.items()) + '}'
    if isinstance(v, list):
        return '[' + ', '.join(fmt(x) for x in v) + ']'
    return str(v)


def safe(label: str) -> str:
    """A label as a file name."""
    return re.sub(r'[^A-Za-z0-9._=,+-]+', '_', label)[:60].strip('_') or 'task'


@dataclass(frozen=True)
class TaskPayload:
    """What a worker gets: plain data (the study description, not a built problem)."""

    name: str
    command: str
    fidelity: str | None
    start: dict[str, float] | None
    config: dict[str, Any]
    verify: bool
    out_dir: str
    topic: str | None = None


@dataclass
class Task:
    """One task of a sweep. ``config`` is the canonical study description with the
    user's file paths; ``inputs`` the files it reads (empty for a task read back from a
    sweep directory, which needs only its description)."""

    name: str  # unique, file-system safe, stable (label + identity hash)
    label: str  # human readable: the swept values
    values: dict[str, Any]  # axis (or override key) -> value, as in the sweep file
    command: str
    fidelity: str | None
    start: dict[str, float] | None
    start_index: int | None = None  # which of the sweep's distinct starts
    config: dict[str, Any] = field(default_factory=dict)
    verify: bool = True
    inputs: tuple[InputFile, ...] = ()

    def payload(self, out_dir: Path, topic: str | None) -> TaskPayload:
        """Its payload, reading the copies of its input files in ``out_dir``."""
        out = Path(out_dir).resolve()
        copies = {
            f.path: str(out / f.copy) for f in self.inputs if f.copy is not None
        }  # canonical descriptions hold the absolute paths
        return TaskPayload(
            name=self.name,
            command=self.command,
            fidelity=self.fidelity,
            start=self.start,
            config=with_inputs(self.config, copies) if copies else self.config,
            verify=self.verify,
            out_dir=str(out / 'tasks' / self.name / 'output'),
            topic=topic,
        )

    def describe(self) -> dict[str, Any]:
        """What ``sweep.json`` lists and a record repeats (no study description)."""
        return {
            'name': self.name,
            'label': self.label,
            'values': self.values,
            'command': self.command,
            'fidelity': self.fidelity,
            'start': self.start,
            'start_index': self.start_index,
        }

    @classmethod
    def from_description(cls, d: dict[str, Any]) -> Task:
        return cls(
            name=d['name'],
            label=d['label'],
            values=d['values'],
            command=d['command'],
            fidelity=d.get('fidelity'),
            start=d.get('start'),
            start_index=d.get('start_index'),
        )


def config_identity(
    config: dict[str, Any], inputs: InputFiles
) -> tuple[str, tuple[InputFile, ...]]:
    """The hash of a study description with its files standing by name and content, and
    those files."""
    files = inputs.of(config)
    tokens = {value: f.token for value, f in files.items()}
    return digest(with_inputs(config, tokens)), tuple(dict.fromkeys(files.values()))


def identity(
    command: str,
    fidelity: str | None,
    start: dict[str, float] | None,
    config_identity: str,
    verify: bool,
) -> str:
    """A task's identity hash (see the module docstring)."""
    return digest(
        {
            'command': command,
            'fidelity': fidelity,
            'start': start,
            'config': config_identity,
            'verify': verify,
        }
    )


# ------------------------------------------------------------------ the record
@dataclass
class TaskRecord:
    """What a task did (one line of ``records.jsonl``). ``result``: the result record of
    :func:`suspopt.studies.run.optimize` or :func:`~suspopt.studies.twostep.run_study`;
    ``task``: the task's description (``Task.describe``), set by the sweep's client."""

    name: str
    state: str  # done | failed | environment
    error: str | None = None
    traceback: str | None = None
    result: dict[str, Any] | None = None
    worker: str | None = None
    pid: int | None = None
    host: str | None = None
    started: float | None = None
    finished: float | None = None
    wall_time_s: float | None = None
    cpu_time_s: float | None = None
    attempts: int | None = None
    task: dict[str, Any] | None = None

    def to_json(self) -> str:
        return json.dumps(asdict(self), default=_plain, separators=(',', ':'))

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> TaskRecord:
        known = {f.name for f in fields(cls)}
        return cls(**{k: v for k, v in data.items() if k in known})


def _plain(obj: Any) -> Any:
    if hasattr(obj, 'tolist'):
        return obj.tolist()
    return str(obj)


def final_step(command: str, res: dict[str, Any] | None) -> dict[str, Any]:
    """The result record that stands for the task (a study: its last optimization)."""
    res = res or {}
    if command == 'optimize':
        return res
    steps = res.get('steps', {})
    return steps.get('mixed') or steps.get('low') or {}


# ------------------------------------------------------------------ on a worker
def storage_failure(err: BaseException) -> bool:
    """Whether ``err`` (or what caused it) is the file system failing (a full or
    unwritable disk), not the task."""
    import sqlite3

    seen: set[int] = set()
    cur: BaseException | None = err
    while cur is not None and id(cur) not in seen:
        seen.add(id(cur))
        if isinstance(cur, RunError):
            return True
        if isinstance(cur, OSError) and cur.errno in STORAGE_ERRNOS:
            return True
        if isinstance(cur, sqlite3.OperationalError) and any(
            w in str(cur).lower() for w in SQLITE_STORAGE
        ):
            return True
        cur = cur.__cause__ or cur.__context__
    return False


def _error_line(err: BaseException) -> str:
    first = (str(err).strip().splitlines() or [''])[0]
    return f'{type(err).__name__}: {first}' if first else type(err).__name__


def _run(payload: TaskPayload, out: Path) -> dict[str, Any]:
    from suspopt.spec.load import config_from_dict

    config = config_from_dict(payload.config)
    if payload.command == 'optimize':
        from suspopt.studies.run import optimize

        return optimize(
            config,
            str(payload.fidelity),
            start=payload.start,
            out_dir=out,
            progress=None,
            verify=payload.verify,
        ).to_json()
    from suspopt.studies.twostep import run_study

    return run_study(config, out, progress=None, log=None, verify=payload.verify).to_json()


def run_task(payload: TaskPayload) -> TaskRecord:
    """Run one task (on a worker). A failure is the record returned (one line and its
    traceback); a full or unwritable disk gives an ``environment`` record."""
    t0, cpu0 = time.time(), time.process_time()
    worker = announce(payload.topic, payload.name, t0)
    from suspopt.quiet import quiet_libraries

    quiet_libraries()
    out = Path(payload.out_dir)
    rec = TaskRecord(
        name=payload.name,
        state='failed',
        worker=worker,
        pid=os.getpid(),
        host=socket.gethostname(),
        started=t0,
    )
    try:
        shutil.rmtree(out, ignore_errors=True)  # a rerun starts clean
        out.mkdir(parents=True, exist_ok=True)
        res = _run(payload, out)
        rec.result = json.loads(json.dumps(res, default=_plain))  # numpy -> plain
        final = final_step(payload.command, res)
        if final.get('success'):
            rec.state = 'done'
        else:
            rec.error = f'IPOPT {final.get("status")} after {final.get("iterations")} iterations'
    except Exception as err:  # noqa: BLE001 - a failed task is a result, not a crash
        rec.state = ENVIRONMENT if storage_failure(err) else 'failed'
        rec.error = _error_line(err)
        rec.traceback = traceback.format_exc()
    rec.finished = time.time()
    rec.wall_time_s = rec.finished - t0
    rec.cpu_time_s = time.process_time() - cpu0
    return rec


def noop_task(payload: TaskPayload) -> TaskRecord:
    """A task that does nothing (measures the engine's own cost per task)."""
    t0 = time.time()
    worker = announce(payload.topic, payload.name, t0)
    return TaskRecord(
        name=payload.name,
        state='done',
        worker=worker,
        pid=os.getpid(),
        started=t0,
        finished=time.time(),
        wall_time_s=time.time() - t0,
        result={'objective': 0.0, 'success': True},
    )


def announce(topic: str | None, name: str, t0: float) -> str | None:
    """Tell the sweep's client that task ``name`` started (a Dask event); the worker's
    address, or None outside a worker."""
    try:
        from distributed import get_worker

        w = get_worker()
    except (ImportError, ValueError):
        return None
    if topic:
        w.log_event(
            topic,
            {'op': 'start', 'task': name, 'pid': os.getpid(), 'time': t0, 'worker': w.address},
        )
    return w.address
