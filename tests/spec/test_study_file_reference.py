"""The study file's reference page is generated from the schema and is current."""

from __future__ import annotations

import dataclasses
import typing
from pathlib import Path

from suspopt.spec.reference import FREE_FORM, study_file_reference
from suspopt.spec.schema import StudyConfig
from suspopt.spec.values import type_hints

PAGE = Path(__file__).parents[2] / 'docs' / 'study-file.md'


def _undocumented(cls: type, prefix: str) -> list[str]:
    missing = []
    hints = type_hints(cls)
    for f in dataclasses.fields(cls):
        key = f'{prefix}.{f.name}' if prefix else f.name
        tp = hints[f.name]
        items = [a for a in typing.get_args(tp) if dataclasses.is_dataclass(a)]
        if dataclasses.is_dataclass(tp):
            missing += _undocumented(tp, key)
        elif items:  # an array of tables, or a table of tables
            missing += _undocumented(items[0], f'{key}[]')
        elif key not in FREE_FORM and key not in ('road',) and not f.metadata.get('doc'):
            missing.append(key)
    return missing


def test_every_key_of_the_study_file_says_what_it_means():
    assert _undocumented(StudyConfig, '') == []


def test_the_reference_page_is_the_schemas():
    """Regenerate with ``python -m suspopt.spec.reference > docs/study-file.md``."""
    assert PAGE.read_text() == study_file_reference()
