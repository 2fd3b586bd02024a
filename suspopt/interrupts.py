"""Ctrl-C and SIGTERM: one protocol for every command (``docs/commands.md``,
"Interrupting a run").

* The first SIGINT or SIGTERM stops the run: at once where nothing is at stake (a
  ``KeyboardInterrupt``), or, inside a :func:`hold` — an IPOPT solve and the writing of
  its result — at the end of that: IPOPT stops at its next callback, a converged result
  is written first, then the run stops (exit 130).
* From the first signal on, SIGINT and SIGTERM have the operating system's default
  action: a second one ends the process at once, even while the main thread is inside
  C code that never returns to Python (a long sparse factorization). The shell reports
  130 (SIGINT) or 143 (SIGTERM); every file written so far is whole (they are written
  atomically).

:func:`handling` installs the handlers (the command line for a whole command; a hold
installs them itself where they are not); :func:`requested` tells whether a signal came;
:func:`checkpoint` stops a held run where nothing is at stake yet (the preparation of a
solve: its sparsity and coloring).
Signal handlers can only be installed in the main thread: elsewhere (a Dask worker's
thread) these are no-ops and Python's defaults apply.
"""

from __future__ import annotations

import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from types import FrameType
from typing import Any

#: the signals that interrupt a run
SIGNALS = (signal.SIGINT, signal.SIGTERM)


@dataclass
class _State:
    depth: int = 0
    holds: int = 0
    signum: int | None = None
    previous: dict[int, Any] = field(default_factory=dict)


_state = _State()


def requested() -> bool:
    """Whether a SIGINT or SIGTERM came since :func:`handling` was entered."""
    return _state.signum is not None


def holding() -> bool:
    """Whether a :func:`hold` is active (a first signal is then held, not raised)."""
    return _state.holds > 0


def _on_signal(signum: int, frame: FrameType | None) -> None:
    if _state.signum is not None:  # only if the default could not be restored
        raise KeyboardInterrupt
    _state.signum = signum
    for sig in SIGNALS:  # a second signal ends the process at once (see the module doc)
        try:
            signal.signal(sig, signal.SIG_DFL)
        except (ValueError, OSError):  # pragma: no cover - not the main thread
            pass
    if _state.holds:
        print(
            '\nsuspopt: interrupted: stopping after the current step, keeping what is '
            'done (again to abort at once)',
            file=sys.stderr,
            flush=True,
        )
        return
    raise KeyboardInterrupt


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


@contextmanager
def handling() -> Iterator[None]:
    """SIGINT and SIGTERM handled by this module while inside (nested: the outermost
    installs and, on leaving, restores the previous handlers and forgets the signal)."""
    if not _main_thread():
        yield
        return
    if _state.depth == 0:
        _state.signum = None
        _state.previous = {sig: signal.getsignal(sig) for sig in SIGNALS}
        for sig in SIGNALS:
            signal.signal(sig, _on_signal)
    _state.depth += 1
    try:
        yield
    finally:
        _state.depth -= 1
        if _state.depth == 0:
            for signum, previous in _state.previous.items():
                signal.signal(signum, previous if previous is not None else signal.SIG_DFL)
            _state.previous = {}
            _state.signum = None


@contextmanager
def hold(raise_on_exit: bool = True) -> Iterator[None]:
    """A first signal inside is held (recorded, not raised), so that what is computed in
    here can be kept; code inside checks :func:`requested` where it can stop early. On
    leaving the outermost hold normally, a held signal is raised as ``KeyboardInterrupt``
    (``raise_on_exit=False``: the caller reports it itself)."""
    with handling():
        _state.holds += 1
        try:
            yield
        finally:
            _state.holds -= 1
        if raise_on_exit and _state.holds == 0 and requested():
            raise KeyboardInterrupt


def checkpoint() -> None:
    """A point of a run's preparation (the sparsity and coloring, the first model runs)
    where nothing computed would be lost: a signal held by a surrounding :func:`hold`
    stops the run here, at once, instead of at the end of the hold."""
    if _state.signum is not None:
        raise KeyboardInterrupt


def stage(name: str) -> None:
    """A named point of a run (``'ipopt:iteration'``, ``'write:result.json'``,
    ``'solve:converged'``): the observers in :data:`OBSERVERS` are called with its name,
    in order (tests hook faults to stages deterministically; nothing else uses it)."""
    for observer in list(OBSERVERS):
        observer(name)


#: callables told of every :func:`stage`
OBSERVERS: list[Any] = []
