"""The sweep file (TOML; ``examples/sweep.toml``): its schema and validation.

A sweep file names a base study file and what to vary: ``[axes]`` of study-file keys (every
combination, ``mode = "product"``) or a ``[[tasks]]`` list of overrides (``mode =
"list"``), and a ``[multistart]`` of starting designs spread over the design box. Every
task's study description is built and validated here, before anything runs; every problem
of the file is reported at once, each naming its key (the study file's typed values and
their messages are :mod:`suspopt.spec.values`')."""

from __future__ import annotations

import itertools
import json
import math
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from suspopt.errors import ConfigError
from suspopt.spec.values import Problems, check, did_you_mean, parse_dataclass
from suspopt.sweep.tasks import (
    InputFile,
    InputFiles,
    Task,
    config_identity,
    digest,
    fmt,
    identity,
    safe,
)

COMMANDS = ('optimize', 'study')
FIDELITIES = ('low', 'mixed')
MODES = ('product', 'list')
MULTISTART_METHODS = ('lhs', 'sobol', 'halton', 'random')
#: axes that are not study-file keys
SPECIAL_AXES = ('start', 'fidelity')
#: below these tables any key is accepted here (config_from_dict checks them)
OPEN_TABLES = ('road', 'optimizer.options')


@dataclass(frozen=True)
class MultistartSpec:
    """``[multistart]``: starting designs spread over the design box (``scipy.stats.qmc``)."""

    n: int = field(metadata={**check('positive'), 'doc': 'number of starting designs'})
    seed: int = field(default=0, metadata={'doc': 'seed of the sequence (>= 0)'})
    method: str = field(default='lhs', metadata={'doc': 'lhs | sobol | halton | random'})


@dataclass(frozen=True)
class SweepFile:
    """The sweep file's own keys (study-file keys go in ``[axes]`` or ``[[tasks]]``)."""

    study: str = field(default='', metadata={'doc': 'base study file, relative to this file'})
    command: str = field(default='optimize', metadata={'doc': 'optimize | study'})
    fidelity: str = field(default='', metadata={'doc': 'optimize: low (default) | mixed'})
    mode: str = field(default='product', metadata={'doc': 'product of [axes] | list of [[tasks]]'})
    axes: dict[str, Any] = field(default_factory=dict, metadata={'doc': 'key = [values]'})
    tasks: Any = field(default=None, metadata={'doc': 'mode = "list": override tables'})
    multistart: Any = field(default=None, metadata={'doc': 'a MultistartSpec table'})
    retries: int = field(default=1, metadata={'doc': 'reruns of a task whose worker died'})
    verify: bool = field(default=True, metadata={'doc': 'verify every optimum by time marching'})


@dataclass
class Sweep:
    """A parsed, validated sweep file."""

    path: Path
    description: dict[str, Any]  # the sweep file as read, the base study and its dict
    tasks: list[Task]
    axes: list[str]  # swept keys in order (start/fidelity included)
    retries: int = 1
    inputs: dict[str, InputFile] = field(default_factory=dict)  # by path: what tasks read

    @property
    def hash(self) -> str:
        return digest(self.description)


# ------------------------------------------------------------------ reading
def load_sweep(path: str | Path) -> Sweep:
    """Read and validate a sweep file. Raises :class:`ConfigError` naming every key."""
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
        return _parse(raw, path)
    except ConfigError as err:
        raise ConfigError([f'{path}: {p}' for p in err.problems]) from None


def _parse(raw: dict[str, Any], path: Path) -> Sweep:
    from suspopt.spec.load import config_from_dict

    errs = Problems()
    spec = _settings(raw, errs)
    base_file, base = _base(spec, path, errs)
    tree = config_from_dict({}).to_dict()
    if spec.mode == 'list':
        combos, axes = _listed(spec, raw, tree, errs)
    else:
        combos, axes = _product(spec, raw, tree, errs)
    if spec.multistart is not None and base is not None:
        combos, axes = _with_starts(spec, combos, axes, base, errs)
    if spec.command == 'study':
        _only_optimize(axes, 'multistart' in raw, errs)
    if errs or base is None:
        raise ConfigError(list(dict.fromkeys(errs)))
    tasks = _tasks(spec, combos, base, path, InputFiles(), errs)
    if errs:  # one line per problem, each once
        raise ConfigError(list(dict.fromkeys(errs)))
    description = {
        'sweep': raw,
        'base_study': None if base_file is None else str(base_file),
        'base_config': base,
    }
    files = {f.path: f for t in tasks for f in t.inputs}
    return Sweep(path, description, tasks, axes, spec.retries, files)


def _settings(raw: dict[str, Any], errs: Problems) -> SweepFile:
    """The sweep file's own keys, typed and checked."""
    own = SweepFile.__dataclass_fields__
    for k in raw:
        if k not in own:
            errs.add(
                k,
                f'unknown key{did_you_mean(k, own)} (a sweep file takes {", ".join(own)}; '
                'study-file keys go in [axes] or [[tasks]])',
            )
    spec: SweepFile = parse_dataclass(
        SweepFile, {k: v for k, v in raw.items() if k in own}, '', errs
    )
    choices = [('command', spec.command, COMMANDS), ('mode', spec.mode, MODES)]
    if spec.command == 'optimize':
        fidelity = spec.fidelity or 'low'
        spec = replace(spec, fidelity=fidelity)
        choices.append(('fidelity', fidelity, FIDELITIES))
    elif 'fidelity' in raw:
        errs.add('fidelity', "a study runs both fidelities; only for command = 'optimize'")
    for key, val, options in choices:
        if val not in options:
            errs.add(
                key, f'must be one of {", ".join(options)}, got {val!r}{did_you_mean(val, options)}'
            )
    if spec.retries < 0:
        errs.add('retries', f'must be >= 0 (reruns after a worker died), got {spec.retries}')
    return spec


def _base(spec: SweepFile, path: Path, errs: Problems) -> tuple[Path | None, dict | None]:
    """The base study file and its canonical description (None if it is bad)."""
    from suspopt.spec.load import config_from_dict, load_config

    if not spec.study:
        return None, config_from_dict({}).to_dict()
    base_file = (path.parent / spec.study).resolve()
    try:
        return base_file, load_config(base_file).to_dict()
    except ConfigError as err:
        errs.extend(f'study ({base_file}): {p}' for p in err.problems)
        return base_file, None


# ------------------------------------------------------------------ what varies
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
    """Why ``key`` is not a study-file key (None if it is, or a special axis)."""
    if key in SPECIAL_AXES or any(key == t or key.startswith(t + '.') for t in OPEN_TABLES):
        return None
    node: Any = tree
    done: list[str] = []
    for part in key.split('.'):
        if not isinstance(node, dict) or part not in node:
            where = '.'.join(done)
            options = (
                [f'{where}.{k}' if where else k for k in node] if isinstance(node, dict) else []
            )
            return 'not a study-file key' + did_you_mean(key, options + list(SPECIAL_AXES))
        node = node[part]
        done.append(part)
    if isinstance(node, dict):
        return 'is a table, not a value: name one of its keys ' + ', '.join(
            f'{key}.{k}' for k in node
        )
    return None


def _product(
    spec: SweepFile, raw: dict[str, Any], tree: dict[str, Any], errs: Problems
) -> tuple[list[dict[str, Any]], list[str]]:
    """``mode = "product"``: every combination of the axes' values."""
    if spec.tasks is not None:
        errs.add('tasks', "only with mode = 'list' (mode = 'product' takes [axes])")
    flat = _flatten(spec.axes)
    for key, vals in flat.items():
        where = f'axes.{key}'
        if why := _key_problem(key, tree):
            errs.add(where, why)
        elif not isinstance(vals, list):
            errs.add(where, f'must be a list of values, got {vals!r}')
        elif not vals:
            errs.add(where, 'empty list: an axis needs at least one value')
        elif len({json.dumps(v, sort_keys=True) for v in vals}) < len(vals):
            errs.add(where, f'repeated values {fmt(vals)}')
    if not flat and 'multistart' not in raw:
        errs.add('axes', 'nothing to sweep (give [axes] key = [values], or multistart)')
    if errs:
        return [], list(flat)
    return [dict(zip(flat, vals)) for vals in itertools.product(*flat.values())], list(flat)


def _listed(
    spec: SweepFile, raw: dict[str, Any], tree: dict[str, Any], errs: Problems
) -> tuple[list[dict[str, Any]], list[str]]:
    """``mode = "list"``: one task per override table."""
    if 'axes' in raw:
        errs.add('axes', "only with mode = 'product' (mode = 'list' takes [[tasks]])")
    if not isinstance(spec.tasks, list) or not spec.tasks:
        errs.add('tasks', 'mode = "list" needs a non-empty list of override tables ([[tasks]])')
        return [], []
    combos, axes = [], []
    for i, t in enumerate(spec.tasks):
        if not isinstance(t, dict):
            errs.add(f'tasks[{i}]', f'must be a table of overrides, got {t!r}')
            continue
        flat = _flatten(t)
        for key in flat:
            if why := _key_problem(key, tree):
                errs.add(f'tasks[{i}].{key}', why)
        combos.append(flat)
        axes += [k for k in flat if k not in axes]
    return combos, axes


def _with_starts(
    spec: SweepFile,
    combos: list[dict[str, Any]],
    axes: list[str],
    base: dict[str, Any],
    errs: Problems,
) -> tuple[list[dict[str, Any]], list[str]]:
    """Every combination from every starting design of ``[multistart]``."""
    if 'start' in axes:
        errs.add('multistart', 'give either multistart or a start axis, not both')
        return combos, axes
    starts = _starts(spec.multistart, _variables(base['design']), errs)
    return [{**c, 'start': s} for c in combos for s in starts], [*axes, 'start']


def _variables(design: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """The design variables of a plain description's ``design`` (not ``per_corner``)."""
    return {k: v for k, v in design.items() if isinstance(v, dict)}


def _starts(table: Any, design: dict[str, Any], errs: Problems) -> list[dict[str, float]]:
    """Starting designs spread over the design box (``[multistart]``)."""
    before = len(errs)
    ms: MultistartSpec = parse_dataclass(MultistartSpec, table, 'multistart', errs)
    if ms.seed < 0:
        errs.add('multistart.seed', f'must be >= 0, got {ms.seed}')
    if ms.method not in MULTISTART_METHODS:
        errs.add(
            'multistart.method',
            f'must be one of {", ".join(MULTISTART_METHODS)}, got '
            f'{ms.method!r}{did_you_mean(ms.method, MULTISTART_METHODS)}',
        )
    free = [k for k, dv in design.items() if dv['optimize']]
    if not free:
        errs.add('multistart', 'no design variable has optimize = true')
    if len(errs) > before:
        return []
    import numpy as np
    from scipy.stats import qmc

    d = len(free)
    if ms.method == 'lhs':
        u = qmc.LatinHypercube(d=d, seed=ms.seed).random(ms.n)
    elif ms.method == 'sobol':
        u = qmc.Sobol(d=d, scramble=True, seed=ms.seed).random(ms.n)
    elif ms.method == 'halton':
        u = qmc.Halton(d=d, scramble=True, seed=ms.seed).random(ms.n)
    else:
        u = np.random.default_rng(ms.seed).random((ms.n, d))
    x = qmc.scale(u, [design[k]['lower'] for k in free], [design[k]['upper'] for k in free])
    return [
        {
            k: float(row[free.index(k)]) if k in free else float(dv['initial'])
            for k, dv in design.items()
        }
        for row in x
    ]


def _only_optimize(axes: list[str], multistart: bool, errs: Problems) -> None:
    for k in SPECIAL_AXES:
        if k in axes:
            errs.add(
                'multistart' if k == 'start' and multistart else k,
                "only for command = 'optimize' (a study starts from the configured "
                'initial design and runs both fidelities)',
            )


# ------------------------------------------------------------------ the tasks
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


def _check_start(start: Any, design: dict[str, Any], where: str, errs: Problems) -> None:
    if not isinstance(start, dict):
        names = ', '.join(f'{k} = ...' for k in design)
        errs.add(where, f'must be a table of design values {{ {names} }}, got {start!r}')
        return
    for k, v in start.items():
        if k not in design:
            errs.add(f'{where}.{k}', 'not a design variable' + did_you_mean(k, design))
        elif isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            errs.add(f'{where}.{k}', f'must be a finite number, got {v!r}')
        elif not design[k]['lower'] <= v <= design[k]['upper']:
            lo, hi = design[k]['lower'], design[k]['upper']
            errs.add(f'{where}.{k}', f'{v:g} is outside the bounds [{lo:g}, {hi:g}]')


def _label(values: dict[str, Any], start_index: int | None) -> str:
    parts = [
        f'start={start_index}' if k == 'start' else f'{k.rsplit(".", 1)[-1]}={fmt(v)}'
        for k, v in values.items()
    ]
    return ','.join(parts) or 'base'


class _Validated:
    """Each distinct set of overrides validated once (the starts of a multistart share it);
    a problem common to many tasks is said once, with how many tasks have it."""

    def __init__(self, base: dict[str, Any], base_dir: Path):
        self.base, self.base_dir = base, base_dir
        self.memo: dict[str, dict[str, Any] | list[str]] = {}
        self.problems: dict[str, list[str]] = {}

    def config(self, overrides: dict[str, Any], where: str) -> dict[str, Any] | None:
        from suspopt.spec.load import config_from_dict

        key = json.dumps(overrides, sort_keys=True, default=str)
        if key not in self.memo:
            try:
                data = _apply(self.base, overrides)
                self.memo[key] = config_from_dict(data, base_dir=self.base_dir).to_dict()
            except ConfigError as err:
                self.memo[key] = err.problems
        got = self.memo[key]
        if isinstance(got, list):
            for p in got:
                self.problems.setdefault(p, []).append(where)
            return None
        return got

    def report(self, errs: Problems) -> None:
        for p, wheres in self.problems.items():
            more = f' and {len(wheres) - 1} more task(s)' if len(wheres) > 1 else ''
            errs.append(f'{p} (in {wheres[0]}{more})')


def _tasks(
    spec: SweepFile,
    combos: list[dict[str, Any]],
    base: dict[str, Any],
    path: Path,
    inputs: InputFiles,
    errs: Problems,
) -> list[Task]:
    """Every task, its study description validated and its identity computed."""
    listed = spec.mode == 'list'
    valid = _Validated(base, path.parent)
    start_ids: dict[str, int] = {}
    seen: dict[str, int] = {}
    configs: dict[int, tuple[str, tuple[InputFile, ...]]] = {}  # by id: valid.memo holds them
    tasks: list[Task] = []
    for i, values in enumerate(combos):
        where = (
            f'tasks[{i}]'
            if listed
            else 'task ' + ', '.join(f'{k} = {fmt(v)}' for k, v in values.items() if k != 'start')
        )
        fid = values.get('fidelity', spec.fidelity) if spec.command == 'optimize' else None
        if 'fidelity' in values and fid not in FIDELITIES:
            key = f'{where}.fidelity' if listed else 'axes.fidelity'
            errs.add(key, f'must be one of {", ".join(FIDELITIES)}, got {fid!r}')
            continue
        overrides = {k: v for k, v in values.items() if k not in SPECIAL_AXES}
        cfg = valid.config(overrides, where)
        if cfg is None:
            continue
        start = _start(values.get('start'), cfg, f'{where}.start' if listed else 'start', errs)
        sid = json.dumps(start, sort_keys=True)
        if start is not None:
            start_ids.setdefault(sid, len(start_ids))
        if id(cfg) not in configs:
            configs[id(cfg)] = config_identity(cfg, inputs)
        cfg_id, files = configs[id(cfg)]
        ident = identity(spec.command, fid, start, cfg_id, spec.verify)
        if ident in seen:
            errs.add(
                where, f'the same task as tasks[{seen[ident]}]' if listed else 'the same task twice'
            )
            continue
        seen[ident] = i
        label = _label(values, start_ids.get(sid))
        tasks.append(
            Task(
                name=f'{safe(label)}-{ident[:8]}',
                label=label,
                values=values,
                command=spec.command,
                fidelity=fid,
                start=start,
                start_index=start_ids.get(sid),
                config=cfg,
                verify=spec.verify,
                inputs=files,
            )
        )
    valid.report(errs)
    return tasks


def _start(start: Any, cfg: dict[str, Any], where: str, errs: Problems) -> dict[str, float] | None:
    """A task's full starting design (unlisted variables at their initial values)."""
    if start is None:
        return None
    design = _variables(cfg['design'])
    _check_start(start, design, where, errs)
    if not isinstance(start, dict):
        return None
    return {
        **{k: dv['initial'] for k, dv in design.items()},
        **{k: float(v) for k, v in start.items() if k in design and isinstance(v, (int, float))},
    }
