"""The exit codes (suspopt.cli.exits): one table from the error classes to the codes, and
what the command line prints for each."""

from __future__ import annotations

import errno
import os

import pytest

import suspopt.cli.commands as commands
from suspopt.cli.exits import EXIT_CODES, exit_code
from suspopt.cli.main import main
from suspopt.errors import (
    ConfigError,
    ModelError,
    MultibodyError,
    NotVerified,
    RunError,
    SuspoptError,
)


def test_the_table_agrees_with_the_error_classes():
    """Each class of suspopt.errors has the code the table gives it (its ``exit_code``)."""
    for cls in (SuspoptError, ConfigError, ModelError, MultibodyError, NotVerified, RunError):
        assert exit_code(cls('x')) == cls.exit_code, cls.__name__
    assert exit_code(KeyboardInterrupt()) == 130 and exit_code(MemoryError()) == 4
    assert exit_code(OSError(errno.ENOSPC, 'full')) == 4 and exit_code(KeyError('x')) == 1
    assert [code for _, code in EXIT_CODES if _ is RunError] == [4]  # before OSError


@pytest.mark.parametrize(
    'err, code, line',
    [
        (ConfigError(['a.b: must be > 0, got -1', 'c: unknown key']), 2, 'a.b: must be > 0'),
        (MultibodyError('toggle position'), 1, 'toggle position'),
        (NotVerified('disagree'), 3, 'disagree'),
        (RunError('cannot write x: No space left'), 4, 'cannot write x'),
        (OSError(errno.EACCES, os.strerror(errno.EACCES), 'out'), 4, 'Permission denied: out'),
        (MemoryError(), 4, 'out of memory'),
        (KeyError('heave'), 1, "unexpected KeyError: 'heave' (this is a bug in suspopt"),
        (KeyboardInterrupt(), 130, None),
    ],
)
def test_every_error_of_a_command_is_its_code_and_one_line(monkeypatch, capsys, err, code, line):
    def fail(args):
        raise err

    monkeypatch.setattr(commands, 'init', fail)
    monkeypatch.delenv('SUSPOPT_DEBUG', raising=False)
    assert main(['init', 'x.toml']) == code
    printed = capsys.readouterr().err.strip().splitlines()
    if line is None:
        assert printed == ['suspopt: interrupted; results written so far are kept']
    else:
        assert printed[0] == f'suspopt: error: {line}' or printed[0].startswith(
            f'suspopt: error: {line}'
        )
        assert len(printed) == (2 if isinstance(err, ConfigError) else 1)
