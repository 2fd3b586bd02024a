"""A sweep's directory on disk: what is written once, what is appended, how a rerun resumes.

::

    .suspopt.lock         the lock every suspopt command takes (output.rundir.DirectoryLock)
    manifest.json         {"kind": "sweep", "format": 1}: written once, first of all
    sweep.json            the sweep: its file, description and hash, axes, the input files'
                          hashes, every task's description; written when the task set is
                          new or grows, never per finished task
    inputs/<sha>/<name>   a copy of every file the tasks read (what they do read)
    tasks/records.jsonl   one JSON line per finished task (TaskRecord), appended as it
                          finishes; a task's last line is its record
    tasks/<task>/output/  what the task's optimize/run_study wrote (its worker writes it)
    summary.csv, table.md, figures/   rendered from the above (suspopt.sweep.summary)

The cost of recording a finished task is one appended line, whatever the sweep's size.
A line cut short (the process killed while writing it, a full disk) is not a record: its
task reruns, and the next run removes the cut line before appending. A rerun into the
directory resumes: the finished tasks are kept; a sweep file that only gains tasks is
accepted; a removed or changed task, or a changed input file (by content), is refused,
naming what changed (``docs/sweeps.md``).
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

from suspopt.errors import ConfigError, RunError
from suspopt.output.rundir import LOCK, atomic_path, write_json
from suspopt.records.manifest import MANIFEST
from suspopt.sweep.spec import Sweep
from suspopt.sweep.tasks import FINISHED, InputFile, Task, TaskRecord, fmt

KIND = 'sweep'
FORMAT = 1
SWEEP = 'sweep.json'
RECORDS = 'tasks/records.jsonl'


# ------------------------------------------------------------------ reading
def manifest_kind(directory: str | Path) -> str | None:
    """The ``kind`` of a results directory's manifest (None: no readable manifest)."""
    try:
        data = json.loads((Path(directory) / MANIFEST).read_text())
    except (OSError, ValueError):
        return None
    return data.get('kind') if isinstance(data, dict) else None


def _read_json(path: Path, what: str) -> dict[str, Any]:
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError:
        raise ConfigError(f'{path.parent}: no {path.name} ({what})') from None
    except (OSError, ValueError) as err:
        raise ConfigError(f'{path}: damaged ({err}); choose another directory') from None
    if not isinstance(data, dict):
        raise ConfigError(f'{path}: damaged (not a JSON object)')
    return data


def read_manifest(directory: Path) -> None:
    """Refuse a directory that is not a sweep's of this format."""
    data = _read_json(directory / MANIFEST, 'not a suspopt output directory')
    if data.get('kind') != KIND:
        raise ConfigError(
            f'{directory}: holds the results of a {data.get("kind")!r} run, not a sweep; '
            'choose another directory'
        )
    if data.get('format') != FORMAT:
        raise ConfigError(
            f'{directory}: a sweep of format {data.get("format")!r} (this suspopt reads and '
            f'writes format {FORMAT}); use another directory'
        )


def read_sweep(directory: str | Path) -> Sweep:
    """The sweep recorded in ``directory`` (its tasks' descriptions, no study
    descriptions: what the summary needs)."""
    directory = Path(directory)
    read_manifest(directory)
    data = _read_json(directory / SWEEP, 'the sweep has not started')
    try:
        return Sweep(
            path=Path(data['sweep_file']),
            description=data['description'],
            tasks=[Task.from_description(t) for t in data['tasks']],
            axes=list(data['axes']),
            retries=int(data.get('retries', 1)),
            inputs={p: InputFile(p, f['sha256'], f['builtin']) for p, f in data['inputs'].items()},
        )
    except (KeyError, TypeError, ValueError) as err:
        raise ConfigError(f'{directory / SWEEP}: damaged ({err!r})') from None


def read_records(
    directory: str | Path, warn: Callable[[str], None] | None = None
) -> dict[str, TaskRecord]:
    """Every task's last record, by task name (a cut or unreadable line: no record)."""
    path = Path(directory) / RECORDS
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        return {}
    except OSError as err:
        raise ConfigError(f'cannot read {path}: {err.strerror}') from None
    lines = data.split(b'\n')
    records: dict[str, TaskRecord] = {}
    for i, line in enumerate(lines[:-1], 1):  # the last piece has no newline: cut short
        try:
            rec = TaskRecord.from_dict(json.loads(line))
        except (ValueError, TypeError, AttributeError):
            if warn:
                warn(f'{path}: line {i} unreadable, ignored (its task reruns)')
            continue
        records[rec.name] = rec
    return records


# ------------------------------------------------------------------ appending
class RecordLog:
    """``tasks/records.jsonl``, open for appending (by the sweep's client, under the
    directory's lock). A line cut short by an earlier run is removed on opening; a line
    that cannot be written whole (a full disk) is removed again and is a
    :class:`RunError` naming the file."""

    def __init__(self, directory: Path):
        self.path = directory / RECORDS
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self.fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
            self._drop_cut_line()
        except OSError as err:
            raise RunError(f'cannot write {self.path}: {err.strerror}') from None
        self.bytes_written = 0

    def _drop_cut_line(self) -> None:
        size = os.fstat(self.fd).st_size
        if size == 0:
            return
        with open(self.path, 'rb') as fh:
            fh.seek(size - 1)
            if fh.read(1) == b'\n':
                return
            fh.seek(0)
            keep = fh.read().rfind(b'\n') + 1
        os.ftruncate(self.fd, keep)

    def _write(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            view = view[os.write(self.fd, view) :]

    def append(self, rec: TaskRecord) -> None:
        data = (rec.to_json() + '\n').encode()
        offset = os.fstat(self.fd).st_size
        try:
            self._write(data)
        except OSError as err:
            try:
                os.ftruncate(self.fd, offset)
            except OSError:
                pass  # the reader ignores a cut line
            raise RunError(f'cannot write {self.path}: {err.strerror}') from None
        self.bytes_written += len(data)

    def close(self) -> None:
        os.close(self.fd)


# ------------------------------------------------------------------ the directory
def _index(sweep: Sweep) -> dict[str, Any]:
    return {
        'sweep_file': str(sweep.path.resolve()),
        'hash': sweep.hash,
        'description': sweep.description,
        'axes': sweep.axes,
        'retries': sweep.retries,
        'inputs': {
            p: {'sha256': f.sha256, 'builtin': f.builtin, 'copy': f.copy}
            for p, f in sweep.inputs.items()
        },
        'tasks': [t.describe() for t in sweep.tasks],
    }


def _copy_inputs(out: Path, sweep: Sweep) -> None:
    """Copy each input file the tasks read (once; checked against its hash)."""
    for f in sweep.inputs.values():
        if f.copy is None or (out / f.copy).exists():
            continue
        try:
            data = Path(f.path).read_bytes()
        except OSError as err:
            raise ConfigError(f'cannot read {f.path}: {err.strerror}') from None
        if hashlib.sha256(data).hexdigest() != f.sha256:
            raise ConfigError(f'{f.path} changed while the sweep was starting; run it again')
        with atomic_path(out / f.copy) as tmp:
            tmp.write_bytes(data)


def _changes(old: Any, new: Any, key: str = '') -> list[str]:
    """Dotted keys whose value differs, as ``key: old -> new``."""
    if isinstance(old, dict) and isinstance(new, dict):
        out = []
        for k in list(old) + [k for k in new if k not in old]:
            sub = f'{key}.{k}' if key else str(k)
            if k not in new:
                out.append(f'{sub}: removed (was {_short(old[k])})')
            elif k not in old:
                out.append(f'{sub}: added ({_short(new[k])})')
            else:
                out += _changes(old[k], new[k], sub)
        return out
    return [] if old == new else [f'{key}: {_short(old)} -> {_short(new)}']


def _short(v: Any, n: int = 60) -> str:
    s = fmt(v)
    return s if len(s) <= n else s[: n - 3] + '...'


def _changed_inputs(out: Path, old: dict[str, Any], sweep: Sweep) -> list[str]:
    """A problem per input file whose content differs from the one the directory's
    finished tasks read."""
    problems = []
    for path, f in sweep.inputs.items():
        was = (old.get('inputs') or {}).get(path, {}).get('sha256')
        if was is not None and was != f.sha256:
            problems.append(
                f'--out {out}: {path} changed since this sweep started here (sha256 '
                f'{was[:12]}... -> {f.sha256[:12]}...): the tasks finished here read the '
                'old content. Restore the file, or run the sweep into a new --out'
            )
    return problems


def _check_tasks(out: Path, old: dict[str, Any], sweep: Sweep, say: Callable[[str], None]) -> bool:
    """Accept the same or a grown task set (True: the sweep's index must be rewritten)."""
    new_names = {t.name for t in sweep.tasks}
    old_names = [t['name'] for t in old.get('tasks', [])]
    missing = [n for n in old_names if n not in new_names]
    what = _changes(old.get('description', {}), sweep.description)
    if missing:
        raise ConfigError(
            f'--out {out}: holds another sweep; the sweep file changed '
            f'({"; ".join(what[:6]) or "task list"}{"; ..." if len(what) > 6 else ""}) '
            f'and {len(missing)} of its {len(old_names)} task(s) are not in the new '
            f'sweep (e.g. {missing[0]}). Restore the sweep file, or use a new --out '
            '(only adding tasks is accepted)'
        )
    if old.get('hash') == sweep.hash and len(old_names) == len(new_names):
        return False
    gained = len(new_names) - len(old_names)
    say(
        f'the sweep file changed ({"; ".join(what[:3])}): '
        + (f'{gained} new task(s); ' if gained else 'the same tasks; ')
        + f'the {len(old_names)} earlier task(s) are kept'
    )
    return True


def _fresh(out: Path) -> bool:
    """Whether ``out`` holds no sweep yet (refusing anything else that is not a sweep's)."""
    if (out / MANIFEST).exists():
        read_manifest(out)
        return not (out / SWEEP).exists() and not (out / RECORDS).exists()
    others = [p.name for p in out.iterdir() if p.name != LOCK]
    if (out / SWEEP).exists():
        raise ConfigError(
            f'--out {out}: a sweep of an earlier suspopt (no {MANIFEST}); use a new --out'
        )
    if others:
        raise ConfigError(
            f'--out {out}: not empty and not a sweep directory (no {MANIFEST}); '
            'choose another directory'
        )
    return True


def prepare(out: Path, sweep: Sweep, say: Callable[[str], None]) -> dict[str, TaskRecord]:
    """Make ``out`` (locked by the caller) this sweep's directory, new or resumed, and
    return the records of its tasks finished there, by name."""
    if _fresh(out):
        write_json(out / MANIFEST, {'kind': KIND, 'format': FORMAT})
        _copy_inputs(out, sweep)
        write_json(out / SWEEP, _index(sweep))
        return {}
    old = _read_json(out / SWEEP, 'damaged sweep directory')
    problems = _changed_inputs(out, old, sweep)
    if problems:
        raise ConfigError(problems)
    if _check_tasks(out, old, sweep, say):
        _copy_inputs(out, sweep)
        write_json(out / SWEEP, _index(sweep))
    else:
        _copy_inputs(out, sweep)  # a copy deleted by hand is restored
    names = {t.name for t in sweep.tasks}
    return {n: r for n, r in read_records(out, say).items() if n in names and r.state in FINISHED}
