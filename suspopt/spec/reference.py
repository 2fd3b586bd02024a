"""The study file's reference page (``docs/study-file.md``), generated from the schema.

Every key, its type, its default (the paper's half car) and its one-line description come
from the schema's dataclasses and their fields' metadata (``doc``, ``range``, ``check``),
so the page cannot drift from what the file accepts (a test compares them). Regenerate
with ``python -m suspopt.spec.reference > docs/study-file.md``.
"""

from __future__ import annotations

import dataclasses
import typing
from types import SimpleNamespace
from typing import Any

from suspopt.spec.schema import (
    AGGREGATES,
    MODELS,
    MOUNTS,
    NORMALIZATIONS,
    DesignVariable,
    ScenarioConfig,
    StudyConfig,
)
from suspopt.spec.values import type_hints

HEADER = """# The study file

A study file is TOML. Every key is optional: a missing key takes the value of the default
car of its vehicle model (`suspopt init FILE` writes the paper's half car,
`--model full_car` or `--model quarter_car` the others, commented). Unknown keys, wrong
types and implausible values are refused before any work, every problem on one line that
names its key (exit code 2). This page is generated from the schema
(`python -m suspopt.spec.reference > docs/study-file.md`); the defaults shown are the
paper's half car's.

Choices: `vehicle.model`: {models}; `objective.normalization`: {norms};
`objective.aggregate`: {aggregates}; `multibody.mount`: {mounts}.
"""

#: sections whose keys are not a fixed dataclass (documented by hand, briefly)
FREE_FORM = {
    'road': 'The road profile: `profile = "two_bumps" | "bump" | "step" | "iso8608" | "csv" | '
    '"two_tracks"` and its parameters (see `docs/roads.md`).',
    'design': 'The design variables by name (`k_S1`, `c_S2`, `k_R1` ...; per corner with '
    '`per_corner = true`: `k_S1L` ...), each a table of the keys below.',
    'objective.weights': 'Weights by term (`heave`, `pitch`, `roll`, `wheel_<c>`, '
    '`tyre_load_<c>`, `travel_<c>`, `comfort_<seat>`; `docs/metrics.md`) or by group '
    '(`wheel`, `tyre_load`, `travel`, `comfort`: split equally), or a list in term order.',
    'objective.scales': 'With `normalization = "custom"`: a positive scale for every '
    'weighted term, by term or as a list over the weighted terms.',
    'optimizer.options': 'Further IPOPT options by name, checked by IPOPT itself before any work.',
}


def _type_name(tp: Any) -> str:
    origin = typing.get_origin(tp)
    if origin is tuple:
        (item, *_) = typing.get_args(tp)
        if dataclasses.is_dataclass(item):
            return 'array of tables'
        return 'list of numbers'
    if origin is dict or tp is dict:
        return 'table'
    if tp is Any:
        return 'number or string'
    return {float: 'number', int: 'integer', bool: 'true/false', str: 'string'}.get(
        tp, getattr(tp, '__name__', str(tp))
    )


def _default(value: Any) -> str:
    if value is None:
        return "the kind's"
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, (tuple, list)):
        return '[' + ', '.join(_default(v) for v in value) + ']' if value else '[]'
    if isinstance(value, dict):
        return '{…}' if value else '{}'
    return f'{value:g}' if isinstance(value, float) else str(value)


def _describe(f: dataclasses.Field) -> str:
    meta = dict(f.metadata)
    text = meta.get('doc', '')
    if 'range' in meta:
        lo, hi, unit, _, _ = meta['range']
        text += f' (plausible {lo:g} … {hi:g}{" " + unit if unit else ""})'
    if meta.get('check') == 'positive':
        text += ' (> 0)'
    return text.strip()


def _rows(cls: type, instance: Any, prefix: str) -> list[tuple[str, list[str]]]:
    """(section, table rows) of a dataclass and its nested dataclasses."""
    hints = type_hints(cls)
    rows: list[str] = []
    nested: list[tuple[str, list[str]]] = []
    for f in dataclasses.fields(cls):
        key = f'{prefix}.{f.name}' if prefix else f.name
        tp, value = hints[f.name], getattr(instance, f.name)
        if isinstance(tp, type) and dataclasses.is_dataclass(tp):
            nested += _rows(tp, value, key)
        elif key in FREE_FORM:
            nested.append((key, [FREE_FORM[key]]))
        elif typing.get_origin(tp) is tuple and dataclasses.is_dataclass(typing.get_args(tp)[0]):
            item = typing.get_args(tp)[0]
            nested += _rows(item, item(), f'{key}[]')
        else:
            rows.append(f'| `{f.name}` | {_type_name(tp)} | {_default(value)} | {_describe(f)} |')
    out = [(prefix, rows)] if rows else []
    return out + nested


def study_file_reference() -> str:
    """The reference page, as Markdown."""
    parts = [
        HEADER.format(
            models=', '.join(f'`{m}`' for m in MODELS),
            norms=', '.join(f'`{m}`' for m in NORMALIZATIONS),
            aggregates=', '.join(f'`{m}`' for m in AGGREGATES),
            mounts=', '.join(f'`{m}`' for m in MOUNTS),
        )
    ]
    config = StudyConfig()
    sections = _rows(StudyConfig, config, '')
    sections.insert(
        next(i for i, (s, _) in enumerate(sections) if s == 'design') + 1,
        (
            'design.<name>',
            _field_rows(
                DesignVariable,
                SimpleNamespace(initial=None, lower=None, upper=None, optimize=True),
            ),
        ),
    )
    sections.append(('[[scenario]]', _field_rows(ScenarioConfig, ScenarioConfig())))
    for section, rows in sections:
        if section == 'scenario[]':
            continue
        title = f'[{section}]' if not section.startswith('[') else section
        parts += ['', f'## `{title}`', '']
        if rows and rows[0].startswith('|'):
            parts += ['| key | type | default | meaning |', '|---|---|---|---|', *rows]
        else:
            parts += rows
    return '\n'.join(parts) + '\n'


def _field_rows(cls: type, instance: Any) -> list[str]:
    hints = type_hints(cls)
    return [
        f'| `{f.name}` | {_type_name(hints[f.name])} | {_default(getattr(instance, f.name))} | '
        f'{_describe(f)} |'
        for f in dataclasses.fields(cls)
    ]


if __name__ == '__main__':
    print(study_file_reference(), end='')
