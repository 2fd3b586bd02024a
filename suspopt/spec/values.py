"""Typed values of the study file: every value read through one place that names the key
of every problem (``vehicle.front.wheel_mass: must be > 0, got -5``), all at once.

A field's metadata says how its value is checked: ``check='positive'``, a plausible
``range`` (lower, upper, unit, what, hint) outside which the value is a typo, and ``doc``
(its one-line description, also used by the study-file reference in the docs)."""

from __future__ import annotations

import dataclasses
import difflib
import functools
import math
import typing
from typing import Any


def check(kind: str, **kw: Any) -> dict[str, Any]:
    return {'check': kind, **kw}


def plausible(
    lo: float, hi: float, unit: str, what: str, hint: str = '', **kw: Any
) -> dict[str, Any]:
    """A number that must lie in [lo, hi] (a road vehicle's range): outside it, it is a
    typo (a unit, a missing digit), refused before any work."""
    return {'range': (lo, hi, unit, what, hint), **kw}


def range_problem(val: float, limits: tuple) -> str | None:
    lo, hi, unit, what, hint = limits
    if lo <= val <= hi:
        return None
    u = f' {unit}' if unit else ''
    return f'{val:g}{u} is implausible for {what}: expected {lo:g} to {hi:g}{u}' + (
        f' ({hint})' if hint else ' (a typo?)'
    )


class Problems(list):
    def add(self, key: str, msg: str) -> None:
        self.append(f'{key}: {msg}')


def did_you_mean(word: str, options) -> str:
    near = difflib.get_close_matches(word, list(options), n=1)
    return f" (did you mean '{near[0]}'?)" if near else ''


def is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def parse_value(tp: Any, val: Any, key: str, errs: Problems, meta: dict) -> Any:
    origin = typing.get_origin(tp)
    if isinstance(tp, type) and dataclasses.is_dataclass(tp):
        return parse_dataclass(tp, val, key, errs)
    if tp is Any:
        return val
    if tp is float:
        if not is_number(val):
            errs.add(key, f'must be a number, got {val!r}')
            return math.nan
        val = float(val)
        if not math.isfinite(val):
            errs.add(key, f'must be a finite number, got {val}')
        elif meta.get('check') == 'positive' and val <= 0.0:
            errs.add(key, f'must be > 0, got {val:g}')
        elif 'range' in meta and (problem := range_problem(val, meta['range'])):
            errs.add(key, problem)
        return val
    if tp is int:
        if isinstance(val, bool) or not isinstance(val, int):
            errs.add(key, f'must be an integer, got {val!r}')
            return 0
        if meta.get('check') == 'positive' and val <= 0:
            errs.add(key, f'must be > 0, got {val}')
        return val
    if tp is bool:
        if not isinstance(val, bool):
            errs.add(key, f'must be true or false, got {val!r}')
        return bool(val)
    if tp is str:
        if not isinstance(val, str):
            errs.add(key, f'must be a string, got {val!r}')
            return ''
        return val
    if origin is tuple:
        item = typing.get_args(tp)[0]
        if isinstance(item, type) and dataclasses.is_dataclass(item):
            if not isinstance(val, list):
                errs.add(key, f'must be an array of tables ([[{key}]]), got {val!r}')
                return ()
            return tuple(parse_dataclass(item, v, f'{key}[{i}]', errs) for i, v in enumerate(val))
        if item is str:
            if not isinstance(val, (list, tuple)) or not all(isinstance(v, str) for v in val):
                errs.add(key, f'must be a list of strings, got {val!r}')
                return ()
            return tuple(val)
        if not isinstance(val, (list, tuple)) or not all(is_number(v) for v in val):
            errs.add(key, f'must be a list of numbers, got {val!r}')
            return ()
        out = tuple(float(v) for v in val)
        if not all(math.isfinite(v) for v in out):
            errs.add(key, f'must contain finite numbers only, got {list(val)}')
        return out
    if origin is dict or tp is dict:
        if not isinstance(val, dict):
            errs.add(key, f'must be a table, got {val!r}')
            return {}
        return dict(val)
    raise TypeError(f'unsupported config type {tp!r}')  # pragma: no cover


@functools.cache
def type_hints(cls: type) -> dict[str, Any]:
    """The (evaluated) field types of a config dataclass, once per class."""
    return typing.get_type_hints(cls)


def parse_dataclass(cls: type, data: Any, key: str, errs: Problems) -> Any:
    if not isinstance(data, dict):
        errs.add(key, f'must be a table, got {data!r}')
        data = {}
    hints = type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    for k in data:
        if k not in fields:
            errs.add(f'{key}.{k}' if key else k, 'unknown key' + did_you_mean(k, fields))
    kwargs = {}
    for name, f in fields.items():
        sub = f'{key}.{name}' if key else name
        if name in data:
            kwargs[name] = parse_value(hints[name], data[name], sub, errs, dict(f.metadata))
        elif f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
            errs.add(sub, 'missing value')
            kwargs[name] = math.nan if hints[name] is float else hints[name]()
    return cls(**kwargs)
