"""Results: the record of every run, its files, and reading them back.

* :func:`write_json` / :func:`read_json` — atomic JSON (a reader never sees half a file;
  a damaged file is a one-line :class:`~suspopt.errors.ConfigError` naming it);
* :class:`RunDirectory` — an output directory of one run: one run at a time (a lock
  file, a second run is refused at once: the one lock protocol of every command that
  writes into a directory, ``report`` and ``kinematics`` included), ``--overwrite``
  clears what a run writes before it starts (its manifest first, so a directory is never
  a run mixed of two), and the inputs it used (road CSV files, mechanism files) are
  copied in so a report never reads the user's original files;
* :func:`write_record` / :func:`read_record` — a run's typed record (:mod:`suspopt.records`)
  in its file, with ``manifest.json`` naming its kind and format; reading validates it (a
  damaged file is a ConfigError naming the file and the key);
* :func:`read_trajectory` — a trajectory recorded by OpenMDAO's case recorder.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any, TypeVar, overload

import numpy as np

from suspopt import interrupts
from suspopt.errors import ConfigError, RunError
from suspopt.inputs import read_bytes
from suspopt.records.codec import Record, read_document
from suspopt.records.manifest import DOCUMENTS, MANIFEST, Manifest
from suspopt.records.trajectory import Trajectory

#: files and folders a run may write into its directory (cleared by ``--overwrite``)
RUN_OUTPUTS = (
    MANIFEST,
    *(file for _, file in DOCUMENTS.values()),
    'table.md',
    'cases.sql',
    'low.sql',
    'mixed.sql',
    'time_marching.npz',
    'figures',
    'inputs',
    'sweep.json',
    'summary.csv',
    'tasks',
)
LOCK = '.suspopt.lock'


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    raise TypeError(f'not JSON serializable: {type(obj).__name__}')


def _new_file_mode() -> int:
    """The permissions a new file gets in this process (0o666 less the umask)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return 0o666 & ~mask


#: read once at import (reading the umask sets it, for a moment, in every thread)
NEW_FILE_MODE = _new_file_mode()


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary file beside ``path`` to write to. Leaving the block gives it the
    permissions of a newly created file (the umask's, not ``mkstemp``'s owner-only ones)
    and renames it over ``path``, so a reader never sees a half-written file; an error
    removes it and leaves ``path`` as it was. An OSError is a :class:`RunError` naming
    ``path`` (a full or unwritable disk)."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name + '.', suffix='.tmp')
        os.close(fd)
    except OSError as err:
        raise RunError(f'cannot write {path}: {err.strerror}') from None
    try:
        yield Path(tmp)
        interrupts.stage(f'write:{path.name}')  # a test's fault (a full disk) lands here
        os.chmod(tmp, NEW_FILE_MODE)
        os.replace(tmp, path)
    except BaseException as err:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if isinstance(err, OSError):
            raise RunError(f'cannot write {path}: {err.strerror}') from None
        raise


def write_json(path: str | Path, data: Any) -> None:
    """Write JSON atomically (:func:`atomic_path`)."""
    with atomic_path(path) as tmp, open(tmp, 'w') as fh:
        json.dump(data, fh, indent=2, default=_json_default)
        fh.write('\n')


def write_text(path: str | Path, text: str) -> None:
    """Write a text file atomically (:func:`atomic_path`; tables)."""
    with atomic_path(path) as tmp:
        tmp.write_text(text)


def read_json(path: str | Path) -> dict[str, Any]:
    """A results file; a missing or damaged one is a ConfigError naming it."""
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError:
        raise ConfigError(
            f'{path.parent}: no {path.name} (not a suspopt output directory, '
            'or the run wrote nothing yet)'
        ) from None
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise ConfigError(f'{path}: damaged results file ({err})') from None
    except OSError as err:
        raise ConfigError(f'cannot read {path}: {err.strerror}') from None
    if not isinstance(data, dict):
        raise ConfigError(f'{path}: damaged results file (not a JSON object)')
    return data


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version('suspopt')
    except PackageNotFoundError:  # pragma: no cover - not installed
        return ''


def write_record(directory: str | Path, record: Record) -> Path:
    """Write a document record atomically to its file in ``directory`` (the kind's,
    :data:`~suspopt.records.manifest.DOCUMENTS`), and the manifest naming it (first).
    Returns the record's path."""
    d = Path(directory)
    manifest = Manifest.of(record, _version())
    path = d / MANIFEST
    try:
        same = json.loads(path.read_text()) == manifest.to_json()
    except (OSError, ValueError):
        same = False
    if not same:
        write_json(path, manifest.to_json())
    write_json(d / manifest.record, record.to_json())
    return d / manifest.record


def read_manifest(directory: str | Path) -> Manifest:
    """The manifest of a run directory (a ConfigError if there is none or it is damaged)."""
    d = Path(directory)
    if not d.is_dir():
        raise ConfigError(f'{d}: not a directory')
    path = d / MANIFEST
    if not path.exists():
        raise ConfigError(
            f'{d}: no {MANIFEST}: not a suspopt results directory, or one written by an '
            'older suspopt (run it again to render it)'
        )
    return Manifest.from_json(read_json(path), str(path))


R = TypeVar('R', bound=Record)


@overload
def read_record(directory: str | Path) -> Record: ...
@overload
def read_record(directory: str | Path, kind: type[R]) -> R: ...
def read_record(directory: str | Path, kind: type[Record] | None = None) -> Record:
    """The record of a run directory, of the kind its manifest names (``kind``: the record
    type expected, a ConfigError if the directory holds another), validated."""
    manifest = read_manifest(directory)
    cls = manifest.record_type
    if kind is not None and cls is not kind:
        raise ConfigError(f'{directory}: a {manifest.kind} run, not a {kind.KIND} run ({MANIFEST})')
    path = Path(directory) / manifest.record
    return read_document(cls, read_json(path), str(path))


#: the lock files this process holds (closed in a forked child: see DirectoryLock)
_HELD_LOCKS: set[int] = set()


def _close_inherited_locks() -> None:
    for fd in _HELD_LOCKS:
        with contextlib.suppress(OSError):
            os.close(fd)
    _HELD_LOCKS.clear()


os.register_at_fork(after_in_child=_close_inherited_locks)


class DirectoryLock:
    """One suspopt command at a time per output directory, whichever command: an exclusive
    ``flock`` on ``DIR/.suspopt.lock`` (:data:`LOCK`), taken without waiting (a second
    command is refused at once, naming the holder written into the file). The kernel
    releases it when its holder dies, so no lock is ever stale. A forked child (a Dask
    worker of a sweep) closes its copy, so a lock never outlives its holder in a child;
    the file is removed on release, and a lock taken on a file its previous holder had
    just removed is taken again on the new file."""

    def __init__(self, directory: str | Path, holder: str = 'suspopt', flag: str = '--out'):
        self.directory = Path(directory)
        self.holder = holder
        self.flag = flag
        self._fd: int | None = None

    def acquire(self) -> None:
        import fcntl
        import socket

        path = self.directory / LOCK
        while True:
            try:
                fd = os.open(path, os.O_CREAT | os.O_RDWR, 0o644)
            except OSError as err:
                raise RunError(f'{self.flag}: cannot create {path}: {err.strerror}') from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                holder = os.read(fd, 200).decode(errors='replace').strip() or 'another process'
                os.close(fd)
                raise ConfigError(
                    f'{self.flag}: {self.directory} is in use by another suspopt run ({holder}; '
                    f'lock {LOCK}); wait for it or choose another directory'
                ) from None
            try:
                same = os.path.samestat(os.fstat(fd), os.stat(path))
            except FileNotFoundError:
                same = False
            if same:
                break
            os.close(fd)  # removed by its previous holder after our open: take the new file
        os.ftruncate(fd, 0)
        os.write(fd, f'{self.holder}, pid {os.getpid()} on {socket.gethostname()}\n'.encode())
        self._fd = fd
        _HELD_LOCKS.add(fd)

    def release(self) -> None:
        import fcntl

        if self._fd is None:
            return
        with contextlib.suppress(OSError):
            (self.directory / LOCK).unlink()
        _HELD_LOCKS.discard(self._fd)
        fcntl.flock(self._fd, fcntl.LOCK_UN)
        os.close(self._fd)
        self._fd = None

    def __enter__(self) -> DirectoryLock:
        self.acquire()
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()


#: suffixes of the files a run writes (cleared by ``--overwrite`` wherever they are)
RUN_SUFFIXES = ('.sql', '.json', '.md', '.npz', '.png', '.tmp')


def run_outputs(directory: Path) -> list[Path]:
    """What a run may have written into ``directory`` (not the lock, not a user's other
    files), its manifest and records first."""
    found = [
        q
        for q in directory.iterdir()
        if q.name != LOCK and (q.name in RUN_OUTPUTS or q.suffix in RUN_SUFFIXES)
    ]
    first = {MANIFEST: 0, **{file: 1 for _, file in DOCUMENTS.values()}}
    return sorted(found, key=lambda q: (first.get(q.name, 2), q.name))


class RunDirectory:
    """The output directory of one run (see the module docstring).

    Use as a context manager: entering takes the lock (refusing a directory another run
    holds) and prepares the directory; leaving releases the lock. ``fresh`` (every
    command that starts a run): the directory must hold no results, or ``overwrite``
    clears them first; without it (``report``, ``kinematics``) the lock only. ``flag``
    names the option in messages."""

    def __init__(
        self, path: str | Path, overwrite: bool = False, *, fresh: bool = True, flag: str = '--out'
    ):
        self.path = Path(path)
        self.overwrite = overwrite
        self.fresh = fresh
        self.flag = flag
        self._dirlock: DirectoryLock | None = None

    def __enter__(self) -> RunDirectory:
        p, flag = self.path, self.flag
        if p.exists() and not p.is_dir():
            raise ConfigError(f'{flag}: {p} exists and is not a directory')
        try:
            p.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            raise RunError(f'{flag}: cannot create {p}: {err.strerror}') from None
        if not os.access(p, os.W_OK):
            raise RunError(f'{flag}: {p} is not writable')
        self._lock()
        if not self.fresh:
            return self
        try:
            existing = [q for q in p.iterdir() if q.name != LOCK]
            if existing and not self.overwrite:
                raise ConfigError(
                    f'{flag}: {p} already contains results; choose another '
                    'directory or pass --overwrite'
                )
            for q in run_outputs(p):  # --overwrite: nothing of an earlier run survives
                shutil.rmtree(q) if q.is_dir() else q.unlink()
        except OSError as err:
            self._unlock()
            raise RunError(f'{flag}: cannot clear {p}: {err.strerror}') from None
        except BaseException:
            self._unlock()
            raise
        return self

    def __exit__(self, *exc) -> None:
        self._unlock()

    def _lock(self) -> None:
        self._dirlock = DirectoryLock(self.path, flag=self.flag)
        self._dirlock.acquire()

    def _unlock(self) -> None:
        if self._dirlock is not None:
            self._dirlock.release()
            self._dirlock = None

    def __truediv__(self, name: str) -> Path:
        return self.path / name

    def keep_inputs(self, config_dict: dict[str, Any]) -> dict[str, Any]:
        """Copy the files the study reads (road CSVs, mechanism files) into ``inputs/`` and
        return the study description pointing at those copies, by paths relative to the
        directory (self-contained results that can be moved: read them back with
        :func:`resolve_inputs`)."""
        return keep_inputs(self.path, config_dict)


def keep_inputs(directory: str | Path, config_dict: dict[str, Any]) -> dict[str, Any]:
    """:meth:`RunDirectory.keep_inputs` for any output directory."""
    from suspopt.multibody.mechanism import builtin_mechanisms

    inputs = Path(directory) / 'inputs'
    out = json.loads(json.dumps(config_dict))
    copied: dict[str, str] = {}

    def keep(src: str) -> str:
        if src not in copied:
            dst = inputs / f'{len(copied)}_{Path(src).name}'
            copy_input(src, dst)
            copied[src] = f'inputs/{dst.name}'
        return copied[src]

    def roads(road: dict[str, Any]) -> None:
        if road.get('profile') == 'csv' and road.get('file'):
            road['file'] = keep(road['file'])
        for side in ('left', 'right'):
            if isinstance(road.get(side), dict):
                roads(road[side])

    roads(out['road'])
    for sc in out.get('scenario', []):
        if sc.get('road'):
            roads(sc['road'])
    for axle in ('front', 'rear'):  # a quarter car has no rear axle
        if axle not in out['vehicle']:
            continue
        mech = out['vehicle'][axle]['mechanism']
        if mech not in builtin_mechanisms():
            out['vehicle'][axle]['mechanism'] = keep(mech)
    return out


def fingerprint(*parts: Any) -> str:
    """A short digest of plain data (a record's study description and designs): a file
    written beside a record carries it, and a report uses that file only if it matches
    (never another run's file left in the directory)."""
    text = json.dumps(parts, sort_keys=True, default=_json_default)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def copy_input(src: str | Path, dst: Path) -> Path:
    """Copy the input file ``src`` to ``dst`` atomically (:func:`atomic_path`): reading it
    is the input layer's (:func:`suspopt.inputs.read_bytes`: a ConfigError naming it),
    writing it a RunError naming ``dst``."""
    data = read_bytes(src, 'input file')
    with atomic_path(dst) as tmp:
        tmp.write_bytes(data)
    return dst


def resolve_inputs(directory: str | Path, config_dict: dict[str, Any]) -> dict[str, Any]:
    """A study description from a results directory with the paths of its kept inputs
    (``inputs/...``, :func:`keep_inputs`) made absolute: it reads the copies, wherever the
    directory now is, never the user's original files."""
    base = Path(directory)
    out = json.loads(json.dumps(config_dict))

    def fix(path: Any) -> Any:
        return str(base / path) if isinstance(path, str) and path.startswith('inputs/') else path

    def roads(road: Any) -> None:
        if isinstance(road, dict):
            if road.get('profile') == 'csv':
                road['file'] = fix(road.get('file'))
            for side in ('left', 'right'):
                roads(road.get(side))

    roads(out.get('road'))
    for sc in out.get('scenario') or []:
        if isinstance(sc, dict):
            roads(sc.get('road'))
    for axle in ('front', 'rear'):
        ax = (out.get('vehicle') or {}).get(axle)
        if isinstance(ax, dict):
            ax['mechanism'] = fix(ax.get('mechanism'))
    return out


def read_trajectory(recorder: Any, label: str, scenario: int = 0) -> Trajectory | None:
    """The trajectory of one scenario recorded as problem case ``label`` (None if absent);
    ``recorder`` is a case recorder file or an open ``CaseReader`` (open it once to read
    several cases)."""
    import openmdao.api as om

    try:
        cr = om.CaseReader(str(recorder)) if isinstance(recorder, (str, Path)) else recorder
        if label not in cr.list_cases('problem', recurse=False, out_stream=None):
            return None
        case = cr.get_case(label)
    except Exception as err:  # sqlite errors of a damaged file
        raise ConfigError(f'{recorder}: damaged case recorder ({err})') from None
    ts = f'traj.s{scenario}.timeseries.'
    outputs = case.list_outputs(out_stream=None, return_format='dict', prom_name=True)
    values: dict[str, np.ndarray] = {}
    for meta in outputs.values():
        prom = meta['prom_name']
        if prom.startswith(ts):
            val = np.asarray(meta['val'])
            name = prom[len(ts) :]
            values[name] = val[:, 0] if val.ndim == 2 and val.shape[1] == 1 else val
    if 'time' not in values:
        return None
    J = np.asarray(case.get_val(f'quadrature_{scenario}.J'))
    values['wheel_z'] = values['q_W'] if 'q_W' in values else values['z_W']
    return Trajectory(
        t=values.pop('time'), values=values, J=J, info={'method': 'collocation', 'label': label}
    )
