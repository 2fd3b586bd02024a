"""Many optimizations or studies side by side on Dask distributed (``suspopt sweep``).

A *sweep file* (TOML) names a base study file and what to vary; every task is one
independent :func:`suspopt.studies.run.optimize` (or :func:`~suspopt.studies.twostep.run_study`) of a
study description built from the base and the task's overrides. Tasks travel to the
workers as plain dictionaries and are built there (a set-up ``om.Problem`` cannot be
pickled); results come back as plain dictionaries and are written to the output
directory as they finish. ``examples/sweep.toml`` is an annotated sweep file.

Output directory::

    sweep.json            the sweep description, its hash, every task and its state
    summary.csv, table.md one row per task, rewritten (atomically) after every finished task
    figures/              objective against each swept axis; multistart: the optima found
    tasks/<task>/task.json   the task's record: overrides, state, error (one line and
                          traceback), attempts, worker, and the result dictionary
    tasks/<task>/output/  what optimize/run_study wrote (result.json, case recorders)

Rerunning with the same directory resumes: finished tasks (succeeded or failed) are
kept and skipped (``retry_failed`` reruns the failed ones). A sweep file may gain tasks
(new axis values, new list entries): the new tasks run, the finished ones are kept. Any
other change (a task removed or changed, a changed base study) is refused, naming what
changed. A task is identified by its full canonical study description, fidelity and
start, so a suspopt version whose study defaults differ also refuses an old directory.
One sweep per directory at a time (``.lock``, an advisory ``flock``).

Dask: a ``LocalCluster`` of one single-threaded worker process per core (or
``workers``; on Linux forked from the client, which has imported suspopt, so they start
in a fraction of a second instead of importing it each), or an existing scheduler
(``scheduler='tcp://host:port'``). At most as many tasks are submitted as the cluster has
worker threads, so a worker holds only the task it runs. A worker process that dies
mid-task (killed, out of memory) is noticed by the scheduler, which reruns the task on
another worker (the record's ``attempts`` is the scheduler's own count of deaths plus
one); the scheduler's ``distributed.scheduler.allowed-failures`` is how many deaths a
task may survive (set to ``retries`` for a local cluster; an external scheduler has its
own, default 3), after which the task errs with ``KilledWorker`` and is recorded as
failed. (Dask's ``retries=``
of ``submit`` is for tasks that *raise*; a task here never raises: its failure is its
result.) Ctrl-C / SIGTERM cancel what is pending, close client and cluster, keep what
finished. On an external cluster a task already running finishes on its worker (Dask
cannot stop a running thread) and its result is dropped; the rerun starts clean. Workers
write ``tasks/<task>/output/`` themselves: remote workers need the same file system (the
records, written by the client, are complete either way). ``dask worker --preload
suspopt.sweep`` makes a worker ignore Ctrl-C meant for the sweep (local workers do).

The only calls into the rest of suspopt are in :func:`suspopt_call`.
"""

from __future__ import annotations

import csv
import difflib
import fcntl
import gc
import hashlib
import io
import itertools
import json
import math
import os
import queue
import re
import shutil
import signal
import socket
import sys
import time
import tomllib
import traceback
import uuid
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from suspopt.errors import ConfigError, SuspoptError

SWEEP_KEYS = (
    'study',
    'command',
    'fidelity',
    'mode',
    'axes',
    'tasks',
    'multistart',
    'retries',
    'verify',
)
COMMANDS = ('optimize', 'study')
FIDELITIES = ('low', 'mixed')
MODES = ('product', 'list')
MULTISTART_KEYS = ('n', 'seed', 'method')
MULTISTART_METHODS = ('lhs', 'sobol', 'halton', 'random')
#: axes that are not study-file keys
SPECIAL_AXES = ('start', 'fidelity')
#: below these tables any key is accepted here (config_from_dict checks them)
OPEN_TABLES = ('road', 'optimizer.options')
#: two optima count as one when every design variable agrees to this fraction of its range
DISTINCT_TOL = 1e-3
TASK_STATES = ('pending', 'running', 'done', 'failed')


# ================================================================ the suspopt interface
def _variables(design: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """The design variables of a plain study description's ``design`` table (without its
    ``per_corner`` flag)."""
    return {k: v for k, v in design.items() if isinstance(v, dict)}


def suspopt_call(action: str, **kw: Any) -> Any:
    """Every call into suspopt's own API, in one place (easy to re-point).

    ``load`` (path) → the study file's plain dict; ``validate`` (data, base_dir) → the
    canonical plain dict (raises ConfigError); ``optimize`` / ``study`` (data, out_dir,
    fidelity, start / verify) → the result dictionary.
    """
    from suspopt.spec.load import config_from_dict, load_config

    if action == 'load':
        return load_config(kw['path']).to_dict()
    if action == 'validate':
        return config_from_dict(kw['data'], base_dir=kw.get('base_dir')).to_dict()
    from suspopt.studies.run import optimize
    from suspopt.studies.twostep import run_study

    config = config_from_dict(kw['data'])
    if action == 'optimize':
        return optimize(
            config,
            kw['fidelity'],
            start=kw['start'],
            out_dir=kw['out_dir'],
            progress=None,
            verify=kw.get('verify', True),
        ).to_json()
    if action == 'study':
        return run_study(
            config, kw['out_dir'], progress=None, log=None, verify=kw['verify']
        ).to_json()
    raise ValueError(f'unknown action {action!r}')  # pragma: no cover


# ================================================================ the sweep description
@dataclass
class Task:
    """One task: plain data only (what a worker gets)."""

    name: str  # unique, file-system safe, stable (label + content hash)
    label: str  # human readable: the swept values
    values: dict[str, Any]  # axis (or override key) -> value, as in the sweep file
    command: str
    fidelity: str | None
    start: dict[str, float] | None
    config: dict[str, Any]  # canonical study description (absolute paths)
    verify: bool = True
    start_index: int | None = None  # which of the sweep's distinct starts

    def payload(self, out_dir: Path, topic: str | None) -> dict[str, Any]:
        return {
            'name': self.name,
            'command': self.command,
            'fidelity': self.fidelity,
            'start': self.start,
            'config': self.config,
            'verify': self.verify,
            'out_dir': str(out_dir / 'tasks' / self.name / 'output'),
            'topic': topic,
        }

    def describe(self) -> dict[str, Any]:
        return {
            'name': self.name,
            'label': self.label,
            'values': self.values,
            'command': self.command,
            'fidelity': self.fidelity,
            'start': self.start,
        }


@dataclass
class Sweep:
    """A parsed, validated sweep file."""

    path: Path
    description: dict[str, Any]  # the sweep file as read, plus the base study's dict
    tasks: list[Task]
    axes: list[str]  # swept keys in order (start/fidelity included)
    retries: int = 1

    @property
    def hash(self) -> str:
        return _digest(self.description)


def _digest(obj: Any) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, default=str).encode()).hexdigest()


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return f'{v:g}'
    if isinstance(v, dict):
        return '{' + ', '.join(f'{k}={_fmt(x)}' for k, x in v.items()) + '}'
    if isinstance(v, list):
        return '[' + ', '.join(_fmt(x) for x in v) + ']'
    return str(v)


def _flatten(table: dict[str, Any], prefix: str = '') -> dict[str, Any]:
    """Nested TOML tables to dotted keys (``{maneuver = {speed = 1}}`` → ``maneuver.speed``,
    as TOML reads an unquoted ``maneuver.speed``); a task's ``start`` stays a table."""
    out = {}
    for k, v in table.items():
        key = f'{prefix}{k}'
        if isinstance(v, dict) and key != 'start':
            out.update(_flatten(v, key + '.'))
        else:
            out[key] = v
    return out


def _key_problem(key: str, tree: dict[str, Any]) -> str | None:
    """Why ``key`` is not a study-file key (None if it is)."""
    if any(key == t or key.startswith(t + '.') for t in OPEN_TABLES):
        return None
    node: Any = tree
    done = []
    for part in key.split('.'):
        if not isinstance(node, dict) or part not in node:
            where = '.'.join(done)
            options = (
                [f'{where}.{k}' if where else k for k in node] if isinstance(node, dict) else []
            )
            near = difflib.get_close_matches(key, options + list(SPECIAL_AXES), n=1)
            hint = f" (did you mean '{near[0]}'?)" if near else ''
            return f'not a study-file key{hint}'
        node = node[part]
        done.append(part)
    if isinstance(node, dict):
        return 'is a table, not a value: name one of its keys ' + ', '.join(
            f'{key}.{k}' for k in node
        )
    return None


def _apply(base: dict[str, Any], overrides: dict[str, Any]) -> dict[str, Any]:
    """``base`` with dotted-key ``overrides`` set. A new ``road.profile`` starts the road
    from that profile's defaults; a ``road`` table replaces the road."""
    data = json.loads(json.dumps(base))
    road = overrides.get('road.profile')
    if 'road' in overrides:
        data['road'] = dict(overrides['road'])
    elif road is not None and road != data['road'].get('profile'):
        data['road'] = {'profile': road}
    for key, val in overrides.items():
        if key == 'road':
            continue
        *parents, leaf = key.split('.')
        node = data
        for p in parents:
            node = node.setdefault(p, {})
        node[leaf] = val
    return data


def _starts_from(spec: Any, design: dict[str, Any], errs: list[str]) -> list[dict[str, float]]:
    """Starting designs spread over the design box (``multistart`` table)."""
    if not isinstance(spec, dict):
        errs.append(
            f'multistart: must be a table {{ n = 16, seed = 0, method = "lhs" }}, got {spec!r}'
        )
        return []
    for k in spec:
        if k not in MULTISTART_KEYS:
            errs.append(f'multistart.{k}: unknown key{_near(k, MULTISTART_KEYS)}')
    n, seed, method = spec.get('n'), spec.get('seed', 0), spec.get('method', 'lhs')
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        errs.append(f'multistart.n: must be an integer >= 1, got {n!r}')
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        errs.append(f'multistart.seed: must be an integer >= 0, got {seed!r}')
    if method not in MULTISTART_METHODS:
        errs.append(
            f'multistart.method: must be one of {", ".join(MULTISTART_METHODS)}, '
            f'got {method!r}{_near(str(method), MULTISTART_METHODS)}'
        )
    if errs:
        return []
    import numpy as np
    from scipy.stats import qmc

    free = [k for k, dv in design.items() if dv['optimize']]
    if not free:
        errs.append('multistart: no design variable has optimize = true')
        return []
    d = len(free)
    if method == 'lhs':
        u = qmc.LatinHypercube(d=d, seed=seed).random(n)
    elif method == 'sobol':
        u = qmc.Sobol(d=d, scramble=True, seed=seed).random(n)
    elif method == 'halton':
        u = qmc.Halton(d=d, scramble=True, seed=seed).random(n)
    else:
        u = np.random.default_rng(seed).random((n, d))
    x = qmc.scale(u, [design[k]['lower'] for k in free], [design[k]['upper'] for k in free])
    return [
        {
            k: (float(row[free.index(k)]) if k in free else float(dv['initial']))
            for k, dv in design.items()
        }
        for row in x
    ]


def _near(word: str, options) -> str:
    near = difflib.get_close_matches(word, list(options), n=1)
    return f" (did you mean '{near[0]}'?)" if near else ''


def _check_start(start: Any, design: dict[str, Any], where: str, errs: list[str]) -> None:
    if not isinstance(start, dict):
        errs.append(
            f'{where}: must be a table of design values '
            f'{{ {", ".join(f"{k} = ..." for k in design)} }}, got {start!r}'
        )
        return
    for k, v in start.items():
        if k not in design:
            errs.append(f'{where}.{k}: not a design variable{_near(k, design)}')
        elif isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            errs.append(f'{where}.{k}: must be a finite number, got {v!r}')
        elif not design[k]['lower'] <= v <= design[k]['upper']:
            errs.append(
                f'{where}.{k}: {v:g} is outside the bounds '
                f'[{design[k]["lower"]:g}, {design[k]["upper"]:g}]'
            )


def _label(values: dict[str, Any], start_index: int | None) -> str:
    parts = []
    for k, v in values.items():
        if k == 'start':
            parts.append(f'start={start_index}')
        else:
            short = k.rsplit('.', 1)[-1]
            parts.append(f'{short}={_fmt(v)}')
    return ','.join(parts) or 'base'


def _safe(label: str) -> str:
    return re.sub(r'[^A-Za-z0-9._=,+-]+', '_', label)[:60].strip('_') or 'task'


def load_sweep(path: str | Path) -> Sweep:
    """Read and validate a sweep file; every task's study description is built and
    validated here, before anything runs. Raises :class:`ConfigError` naming each key."""
    path = Path(path)
    try:
        raw = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise ConfigError(f'sweep file not found: {path}') from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
        raise ConfigError(f'{path}: not valid TOML: {err}') from None
    except OSError as err:
        raise ConfigError(f'cannot read sweep file {path}: {err.strerror}') from None
    try:
        return _parse_sweep(raw, path)
    except ConfigError as err:
        raise ConfigError([f'{path}: {p}' for p in err.problems]) from None


def _parse_sweep(raw: dict[str, Any], path: Path) -> Sweep:
    errs: list[str] = []
    for k in raw:
        if k not in SWEEP_KEYS:
            errs.append(
                f'{k}: unknown key{_near(k, SWEEP_KEYS)} (a sweep file takes '
                f'{", ".join(SWEEP_KEYS)}; study-file keys go in [axes] or [[tasks]])'
            )
    command = raw.get('command', 'optimize')
    if command not in COMMANDS:
        errs.append(f'command: must be one of {", ".join(COMMANDS)}, got {command!r}')
    mode = raw.get('mode', 'product')
    if mode not in MODES:
        errs.append(f'mode: must be one of {", ".join(MODES)}, got {mode!r}')
    fidelity = raw.get('fidelity', 'low' if command == 'optimize' else None)
    if command == 'optimize' and fidelity not in FIDELITIES:
        errs.append(f'fidelity: must be one of {", ".join(FIDELITIES)}, got {fidelity!r}')
    if command == 'study' and 'fidelity' in raw:
        errs.append("fidelity: a study runs both fidelities; only for command = 'optimize'")
    retries = raw.get('retries', 1)
    if isinstance(retries, bool) or not isinstance(retries, int) or retries < 0:
        errs.append(
            f'retries: must be an integer >= 0 (reruns after a worker died), got {retries!r}'
        )
    verify = raw.get('verify', True)
    if not isinstance(verify, bool):
        errs.append(f'verify: must be true or false, got {verify!r}')
    study = raw.get('study')
    if study is not None and not isinstance(study, str):
        errs.append(f'study: must be the path of a study file, got {study!r}')
        study = None
    if errs:
        raise ConfigError(errs)

    base_file = None if study is None else (path.parent / study).resolve()
    if base_file is None:
        base = suspopt_call('validate', data={}, base_dir=None)
    else:
        try:
            base = suspopt_call('load', path=base_file)
        except ConfigError as err:
            raise ConfigError([f'study ({base_file}): {p}' for p in err.problems]) from None
    tree = suspopt_call('validate', data={}, base_dir=None)

    # ---- the task overrides: product of axes, or a list of override tables
    combos: list[dict[str, Any]] = []
    axes: list[str] = []
    if mode == 'product':
        if 'tasks' in raw:
            errs.append("tasks: only with mode = 'list' (mode = 'product' takes [axes])")
        table = raw.get('axes', {})
        if not isinstance(table, dict):
            errs.append(f'axes: must be a table of key = [values], got {table!r}')
            table = {}
        flat = _flatten(table)
        for key, vals in flat.items():
            where = f'axes.{key}'
            if key not in SPECIAL_AXES and (why := _key_problem(key, tree)):
                errs.append(f'{where}: {why}')
            elif not isinstance(vals, list):
                errs.append(f'{where}: must be a list of values, got {vals!r}')
            elif not vals:
                errs.append(f'{where}: empty list: an axis needs at least one value')
            elif len({json.dumps(v, sort_keys=True) for v in vals}) < len(vals):
                errs.append(f'{where}: repeated values {_fmt(vals)}')
        if not flat and 'multistart' not in raw:
            errs.append('axes: nothing to sweep (give [axes] key = [values], or multistart)')
        if errs:
            raise ConfigError(errs)
        axes = list(flat)
        combos = [dict(zip(axes, vals)) for vals in itertools.product(*flat.values())]
    else:
        if 'axes' in raw:
            errs.append("axes: only with mode = 'product' (mode = 'list' takes [[tasks]])")
        listed = raw.get('tasks')
        if not isinstance(listed, list) or not listed:
            errs.append(
                'tasks: mode = "list" needs a non-empty list of override tables ([[tasks]])'
            )
            listed = []
        for i, t in enumerate(listed):
            if not isinstance(t, dict):
                errs.append(f'tasks[{i}]: must be a table of overrides, got {t!r}')
                continue
            flat = _flatten(t)
            for key in flat:
                if key not in SPECIAL_AXES and (why := _key_problem(key, tree)):
                    errs.append(f'tasks[{i}].{key}: {why}')
            combos.append(flat)
            axes += [k for k in flat if k not in axes]
        if errs:
            raise ConfigError(errs)
    if 'multistart' in raw:
        if 'start' in axes:
            errs.append('multistart: give either multistart or a start axis, not both')
            raise ConfigError(errs)
        starts = _starts_from(raw['multistart'], _variables(base['design']), errs)
        if errs:
            raise ConfigError(errs)
        combos = [{**c, 'start': s} for c in combos for s in starts]
        axes.append('start')
    if command == 'study':
        for k in SPECIAL_AXES:
            if k in axes:
                errs.append(
                    f'{"multistart" if k == "start" and "multistart" in raw else k}: '
                    f"only for command = 'optimize' (a study starts from the "
                    f'configured initial design and runs both fidelities)'
                )
        if errs:
            raise ConfigError(errs)

    # ---- every task's study description, validated now
    start_ids: dict[str, int] = {}
    tasks: list[Task] = []
    seen: dict[str, int] = {}
    problems: dict[str, list[str]] = {}
    for i, values in enumerate(combos):
        where = (
            f'tasks[{i}]'
            if mode == 'list'
            else 'task ' + ', '.join(f'{k} = {_fmt(v)}' for k, v in values.items() if k != 'start')
        )
        overrides = {k: v for k, v in values.items() if k not in SPECIAL_AXES}
        fid = values.get('fidelity', fidelity)
        if 'fidelity' in values and fid not in FIDELITIES:
            errs.append(
                f'{"axes." if mode == "product" else where + "."}fidelity: must be '
                f'one of {", ".join(FIDELITIES)}, got {fid!r}'
            )
            continue
        try:
            cfg = suspopt_call('validate', data=_apply(base, overrides), base_dir=path.parent)
        except ConfigError as err:
            for p in err.problems:  # the same problem in many tasks: said once
                problems.setdefault(p, []).append(where)
            continue
        start = values.get('start')
        if start is not None:
            _check_start(
                start,
                _variables(cfg['design']),
                f'{where}.start' if mode == 'list' else 'start',
                errs,
            )
            start = {
                **{k: dv['initial'] for k, dv in _variables(cfg['design']).items()},
                **{k: float(v) for k, v in start.items()},
            }
            start_ids.setdefault(json.dumps(start, sort_keys=True), len(start_ids))
        ident = {
            'command': command,
            'fidelity': fid if command == 'optimize' else None,
            'start': start,
            'config': cfg,
            'verify': verify,
        }
        digest = _digest(ident)
        if digest in seen:
            errs.append(
                f'{where}: the same task as tasks[{seen[digest]}]'
                if mode == 'list'
                else f'{where}: the same task twice'
            )
            continue
        seen[digest] = i
        start_index = start_ids.get(json.dumps(start, sort_keys=True))
        label = _label(values, start_index)
        tasks.append(
            Task(
                name=f'{_safe(label)}-{digest[:8]}',
                label=label,
                values=values,
                command=command,
                fidelity=ident['fidelity'],
                start=start,
                config=cfg,
                verify=verify,
                start_index=start_index,
            )
        )
    for p, wheres in problems.items():
        errs.append(
            f'{p} (in {wheres[0]}'
            + (f' and {len(wheres) - 1} more task(s))' if len(wheres) > 1 else ')')
        )
    if errs:
        raise ConfigError(errs)
    description = {
        'sweep': raw,
        'base_study': None if base_file is None else str(base_file),
        'base_config': base,
    }
    return Sweep(path=path, description=description, tasks=tasks, axes=axes, retries=retries)


# ================================================================ the task (on a worker)
def run_task(payload: dict[str, Any]) -> dict[str, Any]:
    """Run one task from its plain description; never raises for a failed task: the
    failure (one line and its traceback) is the record returned."""
    t0, cpu0 = time.time(), time.process_time()
    worker = _announce(
        payload.get('topic'),
        {'op': 'start', 'task': payload['name'], 'pid': os.getpid(), 'time': t0},
    )
    _quiet_libraries()
    out = Path(payload['out_dir'])
    rec: dict[str, Any] = {
        'name': payload['name'],
        'worker': worker,
        'pid': os.getpid(),
        'host': socket.gethostname(),
        'started': t0,
    }
    try:
        shutil.rmtree(out, ignore_errors=True)  # a rerun starts clean
        out.mkdir(parents=True, exist_ok=True)
        if payload['command'] == 'optimize':
            res = suspopt_call(
                'optimize',
                data=payload['config'],
                out_dir=out,
                fidelity=payload['fidelity'],
                start=payload['start'],
                verify=payload['verify'],
            )
        else:
            res = suspopt_call(
                'study', data=payload['config'], out_dir=out, verify=payload['verify']
            )
        rec['result'] = res
        final = final_step(payload['command'], res)
        if final.get('success'):
            rec['state'], rec['error'] = 'done', None
        else:
            rec['state'] = 'failed'
            rec['error'] = f'IPOPT {final.get("status")} after {final.get("iterations")} iterations'
    except Exception as err:  # noqa: BLE001 - a failed task is a result, not a crash
        rec['state'] = 'failed'
        first = (str(err).strip().splitlines() or [''])[0]
        rec['error'] = f'{type(err).__name__}: {first}' if first else type(err).__name__
        rec['traceback'] = traceback.format_exc()
    rec['finished'] = time.time()
    rec['wall_time_s'] = rec['finished'] - t0
    rec['cpu_time_s'] = time.process_time() - cpu0
    return json.loads(json.dumps(rec, default=_plain))  # plain data (numpy → lists/floats)


def _quiet_libraries() -> None:
    """OpenMDAO/Dymos warnings about their own internals are noise in a worker's log."""
    import warnings

    for module in ('openmdao', 'dymos'):
        warnings.filterwarnings('ignore', module=module)
    warnings.filterwarnings('ignore', category=DeprecationWarning)


def noop_task(payload: dict[str, Any]) -> dict[str, Any]:
    """A task that does nothing (measures the engine's own cost per task)."""
    t0 = time.time()
    worker = _announce(
        payload.get('topic'),
        {'op': 'start', 'task': payload['name'], 'pid': os.getpid(), 'time': t0},
    )
    return {
        'name': payload['name'],
        'worker': worker,
        'pid': os.getpid(),
        'started': t0,
        'finished': time.time(),
        'wall_time_s': time.time() - t0,
        'state': 'done',
        'error': None,
        'result': {'objective': 0.0, 'success': True},
    }


def _plain(obj: Any) -> Any:
    if hasattr(obj, 'tolist'):
        return obj.tolist()
    return str(obj)


def _announce(topic: str | None, msg: dict[str, Any]) -> str | None:
    """Tell the sweep's client this task started (a Dask event); outside a worker: None."""
    try:
        from distributed import get_worker

        w = get_worker()
    except (ImportError, ValueError):
        return None
    if topic:
        w.log_event(topic, {**msg, 'worker': w.address})
    return w.address


def final_step(command: str, res: dict[str, Any]) -> dict[str, Any]:
    """The result dictionary that stands for the task (a study: its last optimization)."""
    if command == 'optimize':
        return res
    steps = res.get('steps', {})
    return steps.get('mixed') or steps.get('low') or {}


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
        if signal.getsignal(signal.SIGTERM) is _sweep_sigterm:
            signal.signal(signal.SIGTERM, signal.SIG_DFL)
    except ValueError:  # not the main thread: nothing to do
        pass
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=1)
    import suspopt.studies.run  # noqa: F401


# ================================================================ output directory
def atomic_write(path: Path, text: str) -> None:
    """Write a text file atomically (:func:`suspopt.output.rundir.atomic_path`)."""
    from suspopt.output.rundir import atomic_path

    with atomic_path(path) as tmp, open(tmp, 'w', newline='') as fh:
        fh.write(text)


def _write_json(path: Path, data: Any) -> None:
    atomic_write(path, json.dumps(data, indent=2, default=_plain) + '\n')


class DirectoryLock:
    """One sweep per directory: an exclusive ``flock`` on ``DIR/.lock`` (released by the
    kernel if the process dies, so no stale locks)."""

    def __init__(self, directory: Path):
        self.path = directory / '.lock'
        self.fh = None

    def __enter__(self) -> DirectoryLock:
        self.fh = open(self.path, 'a+')
        try:
            fcntl.flock(self.fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            self.fh.seek(0)
            holder = self.fh.read().strip() or 'another process'
            self.fh.close()
            raise ConfigError(
                f'--out {self.path.parent}: another sweep is running in this '
                f'directory ({holder}); wait for it or choose another --out'
            )
        self.fh.seek(0)
        self.fh.truncate()
        self.fh.write(f'pid {os.getpid()} on {socket.gethostname()}\n')
        self.fh.flush()
        return self

    def __exit__(self, *exc) -> None:
        if self.fh:
            fcntl.flock(self.fh, fcntl.LOCK_UN)
            self.fh.close()


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
    s = _fmt(v)
    return s if len(s) <= n else s[: n - 3] + '...'


def _reconcile(sweep: Sweep, out: Path, say: Callable[[str], None]) -> dict[str, dict[str, Any]]:
    """Check ``out`` against ``sweep`` (new, same, or extended sweep) and return the
    records of the tasks already finished there, by task name."""
    meta = out / 'sweep.json'
    if not meta.exists():
        others = [p.name for p in out.iterdir() if p.name != '.lock']
        if others:
            raise ConfigError(
                f'--out {out}: not empty and not a sweep directory (no '
                f'sweep.json); choose another directory'
            )
        return {}
    try:
        old = json.loads(meta.read_text())
    except (OSError, json.JSONDecodeError) as err:
        raise ConfigError(
            f'--out {out}: unreadable sweep.json ({err}); choose another directory'
        ) from None
    new_names = {t.name for t in sweep.tasks}
    old_names = [t['name'] for t in old.get('tasks', [])]
    if old.get('hash') != sweep.hash:
        what = _changes(old.get('description', {}), sweep.description)
        missing = [n for n in old_names if n not in new_names]
        if missing:
            raise ConfigError(
                f'--out {out}: holds another sweep; the sweep file changed '
                f'({"; ".join(what[:6]) or "task list"}{"; ..." if len(what) > 6 else ""}) '
                f'and {len(missing)} of its {len(old_names)} task(s) are not in the new '
                f'sweep (e.g. {missing[0]}). Restore the sweep file, or use a new --out '
                '(only adding tasks is accepted)'
            )
        gained = len(new_names) - len(old_names)
        say(
            f'the sweep file changed ({"; ".join(what[:3])}): '
            + (f'{gained} new task(s); ' if gained else 'the same tasks; ')
            + f'the {len(old_names)} earlier task(s) are kept'
        )
    done = {}
    for name in old_names:
        if name in new_names:
            rec = _read_record(out / 'tasks' / name / 'task.json')
            if rec and rec.get('state') in ('done', 'failed'):
                done[name] = rec
    return done


def _read_record(path: Path) -> dict[str, Any] | None:
    try:
        return json.loads(path.read_text())
    except (OSError, json.JSONDecodeError):
        return None


# ---------------------------------------------------------------- summary and table


def summary_row(task: Task, rec: dict[str, Any] | None) -> dict[str, Any]:
    """One row of summary.csv / table.md (the one place a task's summary is computed)."""
    row: dict[str, Any] = {'task': task.name, 'state': (rec or {}).get('state', 'pending')}
    for k, v in task.values.items():
        if k == 'start':  # its index; the design itself is in task.json
            row[k] = task.start_index
        else:
            row[k] = _fmt(v) if not isinstance(v, (int, float)) or isinstance(v, bool) else v
    if task.command == 'optimize':
        row['fidelity'] = task.fidelity
    final = final_step(task.command, (rec or {}).get('result') or {})
    design = final.get('design') or {}
    row['objective'] = final.get('objective')
    for k, v in design.items():
        row[k] = v
    for k, v in (final.get('terms') or {}).items():
        row[k] = v
    row['success'] = final.get('success')
    row['verified'] = final.get('verified')
    row['status'] = final.get('status')
    row['iterations'] = final.get('iterations')
    row['wall_time_s'] = (rec or {}).get('wall_time_s')
    row['attempts'] = (rec or {}).get('attempts')
    row['error'] = (rec or {}).get('error')
    return row


def _rows(sweep: Sweep, records: dict[str, dict[str, Any]]) -> list[dict[str, Any]]:
    return [summary_row(t, records.get(t.name)) for t in sweep.tasks]


def _columns(rows: list[dict[str, Any]], axes: list[str]) -> list[str]:
    cols: list[str] = ['task', 'state', *axes]
    for r in rows:
        cols += [k for k in r if k not in cols]
    return cols


def write_summary(
    out: Path, sweep: Sweep, records: dict[str, dict[str, Any]], running: set[str] = frozenset()
) -> None:
    """Rewrite summary.csv, table.md and sweep.json (atomically)."""
    rows = _rows(sweep, records)
    for r in rows:
        if r['task'] in running and r['state'] == 'pending':
            r['state'] = 'running'
    cols = _columns(rows, sweep.axes)
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=cols, lineterminator='\n')
    w.writeheader()
    for r in rows:
        w.writerow({k: ('' if r.get(k) is None else r.get(k)) for k in cols})
    atomic_write(out / 'summary.csv', buf.getvalue())
    atomic_write(out / 'table.md', _table_md(sweep, rows, cols))
    _write_json(
        out / 'sweep.json',
        {
            'sweep_file': str(sweep.path.resolve()),
            'hash': sweep.hash,
            'description': sweep.description,
            'axes': sweep.axes,
            'counts': _counts(rows),
            'tasks': [
                {**t.describe(), 'state': r['state'], 'error': r['error']}
                for t, r in zip(sweep.tasks, rows)
            ],
        },
    )


def _counts(rows: list[dict[str, Any]]) -> dict[str, int]:
    return {s: sum(r['state'] == s for r in rows) for s in TASK_STATES} | {'total': len(rows)}


def _cell(v: Any) -> str:
    if v is None:
        return ''
    if isinstance(v, float):
        return f'{v:.6g}'
    return str(v).replace('|', '\\|')


def _table_md(sweep: Sweep, rows: list[dict[str, Any]], cols: list[str]) -> str:
    c = _counts(rows)
    show = [k for k in cols if k not in ('task',) and not re.fullmatch(r'J\d', k)]
    lines = [
        f'Sweep {sweep.path.name}: {c["total"]} tasks, {c["done"]} done, '
        f'{c["failed"]} failed, {c["running"]} running, {c["pending"]} pending.',
        '',
        '| ' + ' | '.join(show) + ' |',
        '|' + '---|' * len(show),
    ]
    lines += ['| ' + ' | '.join(_cell(r.get(k)) for k in show) + ' |' for r in rows]
    return '\n'.join(lines) + '\n'


# ---------------------------------------------------------------- figures
def distinct_optima(
    designs: list[dict[str, float]],
    bounds: dict[str, tuple[float, float]],
    tol: float = DISTINCT_TOL,
) -> list[int]:
    """A cluster index per design: designs closer than ``tol`` of each variable's range
    (in every variable) are one optimum."""
    reps: list[dict[str, float]] = []
    out = []
    for d in designs:
        for i, r in enumerate(reps):
            if all(abs(d[k] - r[k]) <= tol * (hi - lo) for k, (lo, hi) in bounds.items()):
                out.append(i)
                break
        else:
            reps.append(d)
            out.append(len(reps) - 1)
    return out


def write_figures(out: Path, sweep: Sweep, records: dict[str, dict[str, Any]]) -> list[Path]:
    """One figure per swept axis (objective against its values); for a start axis, the
    optima found and how many distinct ones."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    from suspopt.output.figures import save_figure

    rows = [(t, summary_row(t, records.get(t.name))) for t in sweep.tasks]
    rows = [(t, r) for t, r in rows if r['state'] == 'done' and r['objective'] is not None]
    written = []
    if not rows:
        return written
    for axis in sweep.axes:
        others = [a for a in sweep.axes if a not in (axis, 'start')]
        groups: dict[str, list[tuple[Any, dict[str, Any]]]] = {}
        for t, r in rows:
            if axis in t.values:
                g = ', '.join(
                    f'{a.rsplit(".", 1)[-1]}={_fmt(t.values[a])}' for a in others if a in t.values
                )
                groups.setdefault(g, []).append((t.values[axis], r))
        fig, ax = plt.subplots(figsize=(6.4, 4.0))
        if axis == 'start':
            title = _plot_multistart(ax, groups, sweep)
        else:
            title = _plot_axis(ax, axis, groups)
        ax.set_title(title, fontsize=8)
        _readable_y(ax, [r['objective'] for _, r in rows])
        ax.grid(alpha=0.3)
        fig.tight_layout()
        path = save_figure(fig, out / 'figures' / f'{_safe(axis)}.png', dpi=110)
        plt.close(fig)
        written.append(path)
    return written


def _readable_y(ax, values: list[float]) -> None:
    """Plain tick labels; optima equal to many digits are not spread over the axis."""
    lo, hi = min(values), max(values)
    span = max(hi - lo, 1e-3 * max(abs(hi), abs(lo), 1e-12))
    mid = 0.5 * (lo + hi)
    ax.set_ylim(mid - 0.6 * span, mid + 0.6 * span)
    ax.ticklabel_format(axis='y', useOffset=False, style='plain')


def _plot_axis(ax, axis: str, groups) -> str:
    numeric = all(
        isinstance(v, (int, float)) and not isinstance(v, bool)
        for pts in groups.values()
        for v, _ in pts
    )
    cats: list[str] = []
    for g, pts in groups.items():
        if numeric:
            pts = sorted(pts, key=lambda p: p[0])
            xs = [p[0] for p in pts]
        else:
            cats += [_fmt(v) for v, _ in pts if _fmt(v) not in cats]
            xs = [cats.index(_fmt(v)) for v, _ in pts]
        ax.plot(xs, [r['objective'] for _, r in pts], 'o-' if numeric else 'o', label=g or None)
    if not numeric:
        ax.set_xticks(range(len(cats)), cats, rotation=20, fontsize=8)
    elif all(isinstance(v, int) for pts in groups.values() for v, _ in pts):
        from matplotlib.ticker import MaxNLocator

        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel(axis)
    ax.set_ylabel('objective f')
    if 1 < len(groups) <= 10:
        ax.legend(fontsize=7)
    return f'objective against {axis}'


def _plot_multistart(ax, groups, sweep: Sweep) -> str:
    bounds = {
        k: (dv['lower'], dv['upper'])
        for k, dv in _variables(sweep.description['base_config']['design']).items()
    }
    parts = []
    for g, pts in groups.items():
        pts = sorted(
            (p for p in pts if all(p[1].get(k) is not None for k in bounds)),
            key=lambda p: p[1]['objective'],
        )
        if not pts:
            continue
        cl = distinct_optima([{k: r[k] for k in bounds} for _, r in pts], bounds)
        n = max(cl) + 1
        parts.append(
            f'{g + ": " if g else ""}{n} distinct optim{"um" if n == 1 else "a"} '
            f'from {len(pts)} starts'
        )
        ax.scatter(
            range(len(pts)),
            [r['objective'] for _, r in pts],
            c=cl,
            cmap='tab10',
            vmin=0,
            vmax=9,
            s=28,
            label=g or None,
        )
    ax.set_xlabel('start (sorted by the objective of its optimum; colour: distinct optimum)')
    ax.set_ylabel('objective f of the optimum found')
    if 1 < len(groups) <= 10:
        ax.legend(fontsize=7)
    return '; '.join(parts) + f' (one optimum: within {DISTINCT_TOL:g} of each range)'


# ================================================================ the engine
@dataclass
class Outcome:
    """What a sweep run did; ``exit_code`` 0 all done (and verified), 1 some failed,
    3 some not verified by time marching, 130 interrupted."""

    counts: dict[str, int]
    exit_code: int
    wall_time_s: float
    ran: int = 0
    retried: list[str] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)


def _sweep_sigterm(signum, frame):
    """The sweep client's SIGTERM: stop like Ctrl-C (cancel pending, keep finished)."""
    raise _Terminated()


class _Terminated(KeyboardInterrupt):
    """SIGTERM, handled like Ctrl-C."""


def _eta(started: float, finished_now: int, remaining: int) -> str:
    if finished_now == 0:
        return 'ETA ?'
    s = (time.perf_counter() - started) / finished_now * remaining
    return f'ETA {s:.0f} s' if s < 120 else f'ETA {s / 60:.1f} min'


def run_sweep(
    sweep_file: str | Path,
    out_dir: str | Path,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    retry_failed: bool = False,
    log: Callable[[str], None] | None = None,
    task_fn: Callable[[dict], dict] = run_task,
    worker_start: str = 'auto',
) -> Outcome:
    """Run (or resume) a sweep into ``out_dir``. Raises :class:`ConfigError` for bad input
    (before anything runs); returns the :class:`Outcome` otherwise. ``worker_start``: how
    a local cluster starts its workers: ``fork`` (from this process, suspopt imported),
    ``spawn`` (a fresh interpreter each, Dask's default) or ``auto`` (fork on Linux)."""
    t0 = time.perf_counter()
    say = log or (lambda msg: print(f'[sweep] {msg}', file=sys.stderr, flush=True))
    if workers is not None and workers < 1:
        raise ConfigError(f'--workers: must be >= 1, got {workers}')
    if workers is not None and scheduler:
        raise ConfigError('--workers: not with --scheduler (the cluster has its workers)')
    if worker_start not in ('auto', 'fork', 'spawn'):
        raise ConfigError(f"worker_start: expected 'auto', 'fork' or 'spawn', got {worker_start!r}")
    if worker_start == 'auto':
        worker_start = 'fork' if sys.platform.startswith('linux') else 'spawn'
    if scheduler is not None and not re.match(r'^[a-z+]+://\S+$', scheduler):
        raise ConfigError(
            f'--scheduler: expected an address like tcp://HOST:PORT, got {scheduler!r}'
        )
    sweep = load_sweep(sweep_file)
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise ConfigError(f'--out {out}: exists and is not a directory')
    out.mkdir(parents=True, exist_ok=True)
    with DirectoryLock(out):
        records = _reconcile(sweep, out, say)
        if retry_failed:
            records = {k: r for k, r in records.items() if r.get('state') == 'done'}
        todo = [t for t in sweep.tasks if t.name not in records]
        skipped = len(records)
        say(
            f'{len(sweep.tasks)} task(s) ({sweep.tasks[0].command}); '
            + (f'{skipped} finished earlier, kept; ' if skipped else '')
            + f'{len(todo)} to run; results in {out}'
        )
        write_summary(out, sweep, records)
        outcome = Outcome(counts={}, exit_code=0, wall_time_s=0.0)
        if todo:
            try:
                _run_on_dask(
                    sweep,
                    todo,
                    out,
                    records,
                    outcome,
                    workers,
                    scheduler,
                    say,
                    task_fn,
                    worker_start,
                )
            finally:
                write_summary(out, sweep, records)
                _figures(out, sweep, records, say)
        else:
            _figures(out, sweep, records, say)
        rows = _rows(sweep, records)
        outcome.counts = _counts(rows)
        outcome.wall_time_s = time.perf_counter() - t0
        if outcome.exit_code != 130:
            unfinished = outcome.counts['pending'] + outcome.counts['running']
            unverified = [r for r in rows if r['state'] == 'done' and r.get('verified') is False]
            outcome.exit_code = (
                1 if outcome.counts['failed'] or unfinished else 3 if unverified else 0
            )
        c = outcome.counts
        say(
            f'{"interrupted" if outcome.exit_code == 130 else "finished"}: {c["done"]} done, '
            f'{c["failed"]} failed, {c["pending"] + c["running"]} not run, of {c["total"]} '
            f'({outcome.wall_time_s:.1f} s); {out}/summary.csv, {out}/table.md'
        )
        for r in rows:
            if r['state'] == 'failed':
                say(f'  failed: {r["task"]}: {r["error"]}')
            elif r['state'] == 'done' and r.get('verified') is False:
                say(f'  NOT verified by time marching: {r["task"]}')
        return outcome


def _figures(out: Path, sweep: Sweep, records: dict[str, dict], say) -> None:
    """Figures are a view of the records: a failure to draw them is reported, not fatal."""
    try:
        write_figures(out, sweep, records)
    except Exception as err:  # noqa: BLE001
        say(f'figures not written: {type(err).__name__}: {err}')


def _start_cluster(
    workers: int | None,
    scheduler: str | None,
    n_tasks: int,
    retries: int,
    say: Callable[[str], None],
    worker_start: str,
):
    """A Dask client (and the LocalCluster it owns, or None for an external scheduler)."""
    import logging

    import dask
    from distributed import Client, LocalCluster

    if scheduler:
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
        return client, None
    n = workers or len(os.sched_getaffinity(0))
    n = max(1, min(n, n_tasks))
    # Two worker settings cost these (deep-stacked, allocation-heavy) tasks CPU time
    # (benchmarks/bench_sweep.py measures it): the statistical profiler sampling the task's
    # stack every 10 ms, and the nanny's MALLOC_TRIM_THRESHOLD_ (every large NumPy
    # temporary mapped and unmapped afresh); both off, the BLAS single-thread settings kept.
    # The event-loop health tick (every 20 ms) and the system monitor (every 0.5 s) run in
    # the client's process too, beside the workers, on a core they need: once a second and
    # every 5 s. Forked workers start from this process, which has imported what a task
    # needs (the imports are most of a spawned worker's start).
    environ = {
        k: v
        for k, v in dask.config.get('distributed.nanny.pre-spawn-environ').items()
        if k != 'MALLOC_TRIM_THRESHOLD_'
    }
    settings = {
        'distributed.scheduler.allowed-failures': retries,
        'distributed.worker.profile.enabled': False,
        'distributed.nanny.pre-spawn-environ': environ,
        'distributed.admin.tick.interval': '1s',
        'distributed.admin.system-monitor.interval': '5s',
    }
    if worker_start == 'fork':
        import suspopt.studies.run  # noqa: F401  (inherited by the forked workers)
    settings['distributed.worker.multiprocessing-method'] = worker_start
    with dask.config.set(settings):
        if worker_start == 'fork':  # the children's garbage collector leaves what this
            gc.freeze()  # process had alone (no copy-on-write of its pages)
        try:
            cluster = LocalCluster(
                n_workers=n,
                processes=True,
                threads_per_worker=1,
                dashboard_address=None,
                silence_logs=logging.CRITICAL,
                preload=['suspopt.sweep'],
            )
        except Exception as err:  # noqa: BLE001 - e.g. no process could be spawned
            raise SuspoptError(f'cannot start a local Dask cluster: {err}') from None
        finally:
            if worker_start == 'fork':
                gc.unfreeze()
        client = Client(cluster)
    say(f'local cluster: {n} worker process(es), one thread each ({worker_start}ed)')
    return client, cluster


def _allowed_failures(dask_scheduler) -> int:
    return dask_scheduler.allowed_failures


def _run_on_dask(
    sweep: Sweep,
    todo: list[Task],
    out: Path,
    records: dict[str, dict],
    outcome: Outcome,
    workers: int | None,
    scheduler: str | None,
    say: Callable[[str], None],
    task_fn: Callable[[dict], dict],
    worker_start: str,
) -> None:
    from distributed import KilledWorker

    by_name = {t.name: t for t in todo}
    events: queue.Queue = queue.Queue()
    client = cluster = None
    in_flight: dict[str, Any] = {}  # task name -> future
    attempts: dict[str, int] = {}
    running: set[str] = set()
    pending = deque(todo)
    token = uuid.uuid4().hex[:8]
    topic = f'suspopt-sweep-{token}'
    old_term = None
    if hasattr(signal, 'SIGTERM') and _main_thread():
        old_term = signal.signal(signal.SIGTERM, _sweep_sigterm)
    total = len(sweep.tasks)
    last_line = ['']

    def progress() -> None:
        c = _counts(_rows(sweep, records))
        line = (
            f'done {c["done"]}, running {len(running)}, failed {c["failed"]}, '
            f'total {total}; {time.perf_counter() - t_run:.1f} s, '
            f'{_eta(t_run, outcome.ran, len(pending) + len(in_flight))}'
        )
        if line.split(';')[0] != last_line[0]:
            say(line)
            last_line[0] = line.split(';')[0]

    t_run = time.perf_counter()
    try:
        t_cl = time.perf_counter()
        client, cluster = _start_cluster(
            workers, scheduler, len(todo), sweep.retries, say, worker_start
        )
        outcome.timings['cluster_start_s'] = time.perf_counter() - t_cl
        client.subscribe_topic(topic, lambda ev: events.put(('event', ev[1])))
        t_run = time.perf_counter()

        def refill() -> None:  # one task per worker thread (the cluster may have grown)
            slots = max(1, sum(client.nthreads().values())) - len(in_flight)
            while pending and slots > 0:
                t = pending.popleft()
                fut = client.submit(
                    task_fn, t.payload(out, topic), key=f'{t.name}-{token}', pure=False, retries=0
                )
                fut.add_done_callback(lambda f, n=t.name: events.put(('done', (n, f))))
                in_flight[t.name] = fut
                slots -= 1

        refill()
        while pending or in_flight:
            try:
                kind, msg = events.get(timeout=2.0)
            except queue.Empty:
                refill()
                continue
            if kind == 'event' and msg.get('op') == 'start' and msg['task'] in in_flight:
                name = msg['task']
                attempts[name] = max(
                    attempts.get(name, 0) + 1, _deaths(client, in_flight[name].key) + 1
                )
                running.add(name)
                if attempts[name] > 1:
                    outcome.retried.append(name)
                    say(
                        f'{name}: its worker process died; rerun on {msg["worker"]} '
                        f'(attempt {attempts[name]})'
                    )
                progress()
            elif kind == 'done':
                name, fut = msg
                if in_flight.get(name) is not fut:
                    continue
                del in_flight[name]
                running.discard(name)
                refill()  # the freed worker's next task first, then this one's records
                rec = _collect(fut, by_name[name], KilledWorker)
                if rec is None:  # cancelled from elsewhere, or interrupted: not a result
                    say(f'{name}: cancelled; it stays pending')
                    continue
                # the scheduler counts the deaths of a task's workers itself; a worker
                # that dies before the task's start event left it is counted there only.
                # A task failed as killed ran once per death; a finished one once more.
                deaths = _deaths(client, fut.key)
                killed = rec['state'] == 'failed' and rec['error'].startswith('KilledWorker')
                rec['attempts'] = max(attempts.get(name, 1), deaths + (not killed))
                rec['task'] = by_name[name].describe()
                records[name] = rec
                outcome.ran += 1
                _write_json(out / 'tasks' / name / 'task.json', rec)
                write_summary(out, sweep, records, running)
                if rec['state'] == 'failed':
                    say(f'{name} failed: {rec["error"]}')
                progress()
        outcome.timings['run_s'] = time.perf_counter() - t_run
    except KeyboardInterrupt:
        outcome.exit_code = 130
        say('interrupted: cancelling pending tasks; finished ones are kept')
    except (OSError, TimeoutError) as err:  # CommClosedError is an OSError
        raise SuspoptError(
            f'lost the Dask cluster ({type(err).__name__}: {err}); finished '
            'tasks are kept, rerun to resume'
        ) from None
    finally:
        if old_term is not None:
            signal.signal(signal.SIGTERM, old_term)
        t_down = time.perf_counter()
        _shutdown(client, cluster, list(in_flight.values()))
        outcome.timings['shutdown_s'] = time.perf_counter() - t_down


def _deaths(client, key: str) -> int:
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


def _collect(fut, task: Task, killed_type) -> dict[str, Any] | None:
    """The record of a finished future (a task failure or a dead worker is a failed
    record; a cancelled future is None)."""
    if fut.status == 'finished':
        return fut.result()
    if fut.status != 'error':  # cancelled (or lost with the scheduler)
        return None
    exc = fut.exception()
    if isinstance(exc, KeyboardInterrupt):
        return None
    tb = ''.join(traceback.format_tb(fut.traceback())) if fut.traceback() else ''
    if isinstance(exc, killed_type):
        error = (
            f'KilledWorker: its worker process died on each of '
            f'{exc.allowed_failures + 1} attempts (last on {exc.last_worker.address})'
        )
    else:
        error = f'{type(exc).__name__}: {(str(exc).splitlines() or [""])[0]}'
    return {
        'name': task.name,
        'state': 'failed',
        'error': error,
        'traceback': tb,
        'finished': time.time(),
    }


def _shutdown(client, cluster, futures) -> None:
    """Cancel our futures and close client and cluster, whatever happens (a second
    Ctrl-C during shutdown is ignored)."""
    old_int = signal.signal(signal.SIGINT, signal.SIG_IGN) if _main_thread() else None
    try:
        if client is not None:
            with _quiet():
                if futures:
                    client.cancel(futures, force=True)
            with _quiet():
                client.close(timeout=10)
        if cluster is not None:
            with _quiet():
                cluster.close(timeout=20)
    finally:
        if old_int is not None:
            signal.signal(signal.SIGINT, old_int)


class _quiet:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return exc[0] is not None and issubclass(exc[0], Exception)


def _main_thread() -> bool:
    import threading

    return threading.current_thread() is threading.main_thread()
