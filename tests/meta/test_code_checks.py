"""The code checks every change passes: Ruff's lint rules and its formatting, with the
project's configuration (``pyproject.toml``). mypy, slower, runs with
``pip install -e '.[lint]' && mypy suspopt`` (docs/architecture.md)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
TREES = ['suspopt', 'tests', 'benchmarks', 'docs']


def _ruff(*args: str) -> subprocess.CompletedProcess[str]:
    exe = shutil.which('ruff', path=str(Path(sys.executable).parent)) or shutil.which('ruff')
    if exe is None:
        pytest.fail("ruff is not installed: pip install -e '.[test]'")
    return subprocess.run([exe, *args, *TREES], cwd=ROOT, capture_output=True, text=True)


def test_ruff_finds_nothing():
    res = _ruff('check', '--output-format', 'concise')
    assert res.returncode == 0, res.stdout + res.stderr


def test_the_code_is_formatted():
    res = _ruff('format', '--check')
    assert res.returncode == 0, res.stdout + res.stderr
