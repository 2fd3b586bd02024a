"""The one input layer: every input file (study TOML, mechanism TOML, road CSV, sweep
file) and every command-line value is read here, and every way it can be wrong is one
line naming the key or the file (``docs/commands.md``, "Exit codes"):

* a value or a file the user can fix — a malformed or out-of-range value, an empty or
  whitespace-only entry, a missing, unreadable or non-UTF-8 file, bad TOML — is a
  :class:`~suspopt.errors.ConfigError` (exit 2);
* the machine failing to read a file that is there (an I/O error, too many open files,
  out of memory) is a :class:`~suspopt.errors.RunError` (exit 4).

Nothing here raises anything else: a reader's caller never sees an ``OSError``, a
``UnicodeDecodeError`` or a ``ValueError`` of a path with a NUL byte.

Files are UTF-8 (a byte-order mark, which spreadsheets and some editors write, is dropped):
:func:`read_text`, :func:`read_toml`. Command-line values: :func:`text_value`,
:func:`path_value`, :func:`integer`, :func:`number`, :func:`items`,
:func:`scheduler_address`.
"""

from __future__ import annotations

import codecs
import errno
import math
import re
import tomllib
from pathlib import Path
from typing import Any

from suspopt.errors import ConfigError, RunError

#: errors of the machine, not of the file the user named (exit 4)
ENVIRONMENT_ERRNOS = frozenset(
    {errno.EIO, errno.ENOMEM, errno.ENFILE, errno.EMFILE, errno.ENOSPC, errno.EAGAIN}
)

#: the address schemes Dask's ``distributed`` knows (``distributed.comm.registry``)
SCHEDULER_SCHEMES = ('tcp', 'tls', 'inproc', 'ucx', 'ws', 'wss')

#: the largest integer a command-line count may take (IPOPT's and NumPy's C integers)
MAX_INT = 2**31 - 1


def _where(key: str, text: str) -> str:
    return f'{key}: {text}' if key else text


def _show(value: str, limit: int = 60) -> str:
    """A value as the user typed it, quoted, shortened, non-printable bytes escaped."""
    shown = repr(value)
    return shown if len(shown) <= limit else shown[: limit - 4] + "...'"


def check_path(path: str | Path, what: str, key: str = '') -> Path:
    """``path`` as a :class:`~pathlib.Path`; an empty, whitespace-only or NUL-containing
    one is a ConfigError naming ``key`` (an empty string would otherwise mean ``.``)."""
    text = str(path) if isinstance(path, Path) else path
    if not isinstance(text, str):
        raise ConfigError(_where(key, f'{what}: expected a path, got {text!r}'))
    if not text.strip():
        raise ConfigError(_where(key, f'{what}: empty path'))
    if '\x00' in text:
        raise ConfigError(_where(key, f'{what}: {_show(text)} is not a valid path (a NUL byte)'))
    return Path(text)


def os_error(
    err: OSError, what: str, path: str | Path, key: str = '', hint: str = ''
) -> ConfigError | RunError:
    """The error of reading ``path`` (a ``what``): the user's (missing, a directory,
    permission, a name too long: ConfigError) or the machine's (:data:`ENVIRONMENT_ERRNOS`:
    RunError). ``hint`` follows the message of a missing file."""
    if isinstance(err, FileNotFoundError):
        return ConfigError(
            _where(key, f'{what} not found: {path}' + (f' ({hint})' if hint else ''))
        )
    if isinstance(err, IsADirectoryError):
        return ConfigError(_where(key, f'{what} {path} is a directory'))
    reason = err.strerror or str(err)
    if err.errno in ENVIRONMENT_ERRNOS:
        return RunError(_where(key, f'cannot read {what} {path}: {reason}'))
    return ConfigError(_where(key, f'cannot read {what} {path}: {reason}'))


def read_bytes(path: str | Path, what: str, key: str = '', hint: str = '') -> bytes:
    """The bytes of the file ``path`` (a ``what``: ``'config file'``, ``'road CSV'``);
    ``hint`` follows the message of a missing file."""
    p = check_path(path, what, key)
    try:
        return p.read_bytes()
    except OSError as err:
        raise os_error(err, what, p, key, hint) from None
    except ValueError as err:  # a path the OS cannot take (embedded NUL)
        raise ConfigError(
            _where(key, f'{what}: {_show(str(path))} is not a valid path ({err})')
        ) from None
    except MemoryError:
        raise RunError(_where(key, f'cannot read {what} {p}: out of memory')) from None


def decode(data: bytes, path: str | Path, kind: str, key: str = '') -> str:
    """``data`` as UTF-8 text (a leading byte-order mark dropped); otherwise a
    ConfigError saying where the first bad byte is."""
    if data.startswith(codecs.BOM_UTF8):
        data = data[len(codecs.BOM_UTF8) :]
    try:
        return data.decode('utf-8')
    except UnicodeDecodeError as err:
        line = data.count(b'\n', 0, err.start) + 1
        column = err.start - (data.rfind(b'\n', 0, err.start) + 1) + 1
        raise ConfigError(
            _where(
                key,
                f'{path}: not valid {kind}: not a text (UTF-8) file (byte '
                f'0x{data[err.start]:02x} at line {line}, column {column}; save it as UTF-8)',
            )
        ) from None


def read_text(
    path: str | Path, what: str, kind: str = 'text', key: str = '', hint: str = ''
) -> str:
    """The text of the UTF-8 file ``path`` (a ``what`` written in ``kind``: ``'CSV'``)."""
    return decode(read_bytes(path, what, key, hint), path, kind, key)


def read_toml(path: str | Path, what: str, key: str = '', hint: str = '') -> dict[str, Any]:
    """The TOML file ``path`` (a ``what``) as a dictionary; one line naming the file and
    the place (TOML's own line and column) if it is not valid."""
    text = read_text(path, what, 'TOML', key, hint)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise ConfigError(_where(key, f'{path}: not valid TOML: {err}')) from None
    except RecursionError:
        raise ConfigError(_where(key, f'{path}: not valid TOML: nested too deeply')) from None


# ---------------------------------------------------------------------------- values
def text_value(text: str, flag: str) -> str:
    """A command-line text: not empty, not whitespace only, no NUL byte; stripped."""
    if not isinstance(text, str) or not text.strip():
        raise ConfigError(f'{flag}: empty value')
    if '\x00' in text:
        raise ConfigError(f'{flag}: {_show(text)} contains a NUL byte')
    return text.strip()


def path_value(text: str, flag: str) -> str:
    """A path given on the command line: not empty, not whitespace only, no NUL byte; as
    typed (a name may end in a space)."""
    text_value(text, flag)
    return text


def _integer_text(text: str) -> int | None:
    t = text.strip().replace('_', '')
    if not re.fullmatch(r'[+-]?\d+', t):
        return None
    return int(t)


def integer(text: str, flag: str, lo: int = 0, hi: int = MAX_INT, what: str = '') -> int:
    """A whole number in [lo, hi] (``what`` says what it counts, for the message)."""
    t = text_value(text, flag)
    n = _integer_text(t)
    meaning = f' ({what})' if what else ''
    if n is None:
        span = f'{lo} to {hi}' if hi < MAX_INT else f'>= {lo}'
        raise ConfigError(f'{flag}: expected a whole number {span}{meaning}, got {_show(text)}')
    if n < lo:
        least = f'need at least {lo}' if lo > 1 else f'must be >= {lo}'
        raise ConfigError(f'{flag}: {least}{meaning}, got {n}')
    if n > hi:
        raise ConfigError(f'{flag}: must be at most {hi}{meaning}, got {n}')
    return n


def number(
    text: str,
    flag: str,
    lo: float = -math.inf,
    hi: float = math.inf,
    *,
    positive: bool = False,
    unit: str = '',
    what: str = '',
) -> float:
    """A finite number in [lo, hi] (``positive``: > 0); ``what`` it is, for the message."""
    t = text_value(text, flag)
    subject = f'{flag}: {what} ' if what else f'{flag}: '
    try:
        x = float(t)
    except ValueError:
        raise ConfigError(f'{subject}expected a number, got {_show(text)}') from None
    u = f' {unit}' if unit else ''
    if not math.isfinite(x):
        raise ConfigError(f'{subject}must be a finite number{u}, got {_show(text)}')
    if positive and not x > 0.0:
        raise ConfigError(f'{subject}must be finite and > 0{u}, got {x:g}')
    if not lo <= x <= hi:
        raise ConfigError(f'{subject}must be in [{lo:g}, {hi:g}]{u}, got {x:g}')
    return x


def items(text: str, flag: str, what: str, sep: str = ',') -> list[str]:
    """A ``sep``-separated list of ``what``: at least one entry, none of them empty (a
    doubled or trailing separator is a typo, not an empty entry to skip)."""
    t = text_value(text, flag)
    parts = [p.strip() for p in t.split(sep)]
    if any(not p for p in parts):
        raise ConfigError(
            f'{flag}: an empty entry in {_show(text)} (expected {what}, separated by {sep!r})'
        )
    return parts


def scheduler_address(text: str, flag: str = '--scheduler') -> str:
    """A Dask scheduler address ``SCHEME://HOST[:PORT]`` with a scheme Dask knows."""
    t = text_value(text, flag)
    m = re.fullmatch(r'([A-Za-z][A-Za-z0-9+.-]*)://(\S+)', t)
    if m is None:
        raise ConfigError(f'{flag}: expected an address like tcp://HOST:PORT, got {_show(text)}')
    scheme = m.group(1).lower()
    if scheme not in SCHEDULER_SCHEMES:
        raise ConfigError(
            f'{flag}: {scheme!r} is not a scheme of a Dask scheduler '
            f'({", ".join(SCHEDULER_SCHEMES)}), got {_show(text)}'
        )
    return t
