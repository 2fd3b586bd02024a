"""Ctrl-C and SIGTERM: one protocol for every command (``docs/commands.md``,
"Interrupting a run").

* The first SIGINT or SIGTERM stops the run: at once where nothing is at stake (a
  ``KeyboardInterrupt``), or, inside a :func:`hold` — an IPOPT solve and the writing of
  its result — at the end of that: IPOPT stops at its next callback, a converged result
  is written first, then the run stops (exit 130).
* A second signal ends the process at once, even while the main thread is inside C
  code that never returns to Python (a long sparse factorization, where the
  interpreter's handlers cannot run): once the first has been handled, SIGINT and
  SIGTERM have the operating system's default action (the shell reports 130 or 143);
  before that, a watchdog process that the interpreter's C-level handler tells of every
  signal (:func:`signal.set_wakeup_fd`) kills it at the second (the shell reports 137).
  Every file written so far is whole (they are written atomically).

:func:`handling` installs the handlers (the command line for a whole command; a hold
installs them itself where they are not); :func:`requested` tells whether a signal came;
:func:`checkpoint` stops a held run where nothing is at stake yet (the preparation of a
solve: its sparsity and coloring).
Signal handlers can only be installed in the main thread: elsewhere (a Dask worker's
thread) these are no-ops and Python's defaults apply.
"""

from __future__ import annotations

import os
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
    #: the watchdog's pid, the wakeup pipe's write end, the previous wakeup fd
    watchdog: tuple[int, int, int] | None = None


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


def _watch(r: int) -> None:
    """The watchdog (a forked child): count the SIGINT and SIGTERM the parent's
    interpreter received (their numbers, written to the wakeup pipe by its C-level
    handler); kill the parent at the second; leave when the parent closes the pipe."""
    try:
        for sig in SIGNALS:  # a Ctrl-C reaches the whole process group
            signal.signal(sig, signal.SIG_IGN)
        signal.set_wakeup_fd(-1)
        parent, seen = os.getppid(), 0
        while True:
            data = os.read(r, 64)
            if not data:
                break
            seen += sum(1 for b in data if b in SIGNALS)
            if seen >= 2:
                os.kill(parent, signal.SIGKILL)
                break
    finally:
        os._exit(0)


def _start_watchdog() -> tuple[int, int, int] | None:
    """The watchdog of :func:`_watch` and the wakeup pipe: (pid, write end, previous
    wakeup fd); None where it cannot run (no fork)."""
    if not hasattr(os, 'fork'):  # pragma: no cover - not on Linux/macOS
        return None
    r, w = os.pipe()
    os.set_blocking(w, False)
    previous = signal.set_wakeup_fd(w, warn_on_full_buffer=False)
    pid = os.fork()
    if pid == 0:
        os.close(w)
        _watch(r)
    os.close(r)
    return pid, w, previous


def _stop_watchdog(watchdog: tuple[int, int, int] | None) -> None:
    if watchdog is None:
        return
    pid, w, previous = watchdog
    signal.set_wakeup_fd(previous)
    os.close(w)  # the watchdog reads end-of-file and leaves
    try:
        os.waitpid(pid, 0)
    except ChildProcessError:  # pragma: no cover - reaped elsewhere
        pass


def _forget_in_child() -> None:
    """A process forked from one handling signals (a background verification, a local
    Dask worker) neither writes to the watchdog's pipe nor owns it."""
    if _state.watchdog is not None:
        try:
            signal.set_wakeup_fd(-1)
        except ValueError:  # pragma: no cover - not the main thread
            pass
        try:
            os.close(_state.watchdog[1])
        except OSError:
            pass
        _state.watchdog = None


os.register_at_fork(after_in_child=_forget_in_child)


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
        _state.watchdog = _start_watchdog()
    _state.depth += 1
    try:
        yield
    finally:
        _state.depth -= 1
        if _state.depth == 0:
            _stop_watchdog(_state.watchdog)
            _state.watchdog = None
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


def stage(name: str, **info: Any) -> None:
    """A named point of a run (``'ipopt:iteration'``, ``'write:result.json'``,
    ``'solve:returned'``): the observers in :data:`OBSERVERS` are called with its name
    and ``info``, in order (tests hook faults to stages deterministically; nothing else
    uses it)."""
    for observer in list(OBSERVERS):
        observer(name, **info)


#: callables told of every :func:`stage`
OBSERVERS: list[Any] = []
