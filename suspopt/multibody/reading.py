"""Validation helpers for reading mechanism TOML tables (one message per problem).

Every message names its key (``joints[1].axis``) and, for an element, the element
(``(joint 'strut')``), so that a file with several mistakes is fixed in one pass.
"""

from __future__ import annotations

import difflib
import math
from typing import Any

GROUND = 'ground'


def close(word: str, options: list[str]) -> str:
    """A "did you mean" hint for a misspelt name, or ''."""
    near = difflib.get_close_matches(word, options, n=1)
    return f" (did you mean '{near[0]}'?)" if near else ''


class Reader:
    """Collects the problems of one mechanism file; knows its bodies and markers (global
    reference positions) once they are read, so that elements can refer to them."""

    def __init__(self, source: str):
        self.source = source
        self.errors: list[str] = []
        self.body_names: list[str] = []
        self.markers: dict[str, tuple[str, tuple[float, float]]] = {}  # name -> body, point
        self.element = ''  # "(joint 'strut')" while an element is read

    def err(self, key: str, msg: str) -> None:
        suffix = f' {self.element}' if self.element else ''
        self.errors.append(f'{self.source}: {key}: {msg}{suffix}')

    def table(self, data: dict, key: str, allowed: dict[str, bool]) -> None:
        """Unknown keys and missing required keys (``allowed[k]`` True: required)."""
        for k in data:
            if k not in allowed:
                self.err(f'{key}.{k}' if key else k, 'unknown key' + close(k, list(allowed)))
        for k, required in allowed.items():
            if required and k not in data:
                self.err(f'{key}.{k}' if key else k, 'missing value')

    def number(
        self,
        data: dict,
        key: str,
        where: str,
        *,
        positive: bool = False,
        nonnegative: bool = False,
        default: float | None = None,
    ) -> float:
        val = data.get(key, default)
        if val is None:
            return math.nan
        if isinstance(val, bool) or not isinstance(val, (int, float)):
            self.err(f'{where}.{key}', f'must be a number, got {val!r}')
            return math.nan
        if not math.isfinite(val):
            self.err(f'{where}.{key}', f'must be finite, got {val}')
        elif positive and val <= 0.0:
            self.err(f'{where}.{key}', f'must be > 0, got {val}')
        elif nonnegative and val < 0.0:
            self.err(f'{where}.{key}', f'must be >= 0, got {val}')
        return float(val)

    def vec2(self, data: dict, key: str, where: str, default: Any = None) -> tuple[float, float]:
        val = data.get(key, default)
        where = f'{where}.{key}' if where else key
        if (
            not isinstance(val, (list, tuple))
            or len(val) != 2
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in val)
        ):
            self.err(where, f'must be two numbers [x, z], got {val!r}')
            return (math.nan, math.nan)
        if not all(math.isfinite(v) for v in val):
            self.err(where, f'must be finite, got {val!r}')
        return (float(val[0]), float(val[1]))

    def unit_axis(self, data: dict, key: str, where: str) -> tuple[float, float]:
        """A direction given by any non-zero finite vector, returned normalized."""
        val = data.get(key)
        if not (
            isinstance(val, (list, tuple))
            and len(val) == 2
            and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in val)
            and all(math.isfinite(v) for v in val)
            and math.hypot(*val) > 1e-12
        ):
            self.err(f'{where}.{key}', f'must be a non-zero finite vector [x, z], got {val!r}')
            return (math.nan, math.nan)
        norm = math.hypot(*val)
        return (val[0] / norm, val[1] / norm)

    def name(self, data: dict, where: str, seen: set[str]) -> str:
        val = data.get('name')
        if not isinstance(val, str) or not val:
            self.err(f'{where}.name', f'must be a non-empty string, got {val!r}')
            return f'?{where}'
        if val in seen:
            self.err(f'{where}.name', f'duplicate name {val!r}')
        seen.add(val)
        return val

    def body(self, val: Any, key: str, allow_ground: bool) -> str:
        ok = self.body_names + ([GROUND] if allow_ground else [])
        if val not in ok:
            self.err(key, f'unknown body {val!r}{close(str(val), ok)} (bodies: {", ".join(ok)})')
        return str(val)

    def body_pair(self, data: dict, where: str) -> tuple[str, str]:
        """``bodies = [a, b]``: two different bodies, either may be the ground."""
        pair = data.get('bodies')
        if not isinstance(pair, list) or len(pair) != 2:
            self.err(f'{where}.bodies', f'must be two body names, got {pair!r}')
            return ('?', '?')
        pair = [self.body(p, f'{where}.bodies', allow_ground=True) for p in pair]
        if pair[0] == pair[1]:
            self.err(f'{where}.bodies', f'a joint needs two different bodies, got {pair!r}')
        return (pair[0], pair[1])

    def marker(self, val: Any, key: str) -> str:
        names = list(self.markers)
        if not isinstance(val, str) or val not in self.markers:
            self.err(key, f'unknown marker {val!r}{close(str(val), names)}')
        return str(val)
