"""The command line's exit codes: one table from the error classes of
:mod:`suspopt.errors` (and the environment's) to the codes (``docs/commands.md``, "Exit
codes").

* 0 — success (every result verified by time marching, or verification skipped on request);
* 1 — ``ModelError``: a model evaluation failed (NaN/inf, singular or non-converged
  multibody configuration), or IPOPT did not converge (the results say so); also a bug
  of suspopt (an unexpected error, said so);
* 2 — ``ConfigError``: bad input (study file, mechanism or road data, arguments, a damaged
  results directory), detected before any work starts;
* 3 — ``NotVerified``: a result whose collocation and time marching disagree beyond the
  verification tolerance (the results are written, marked not verified);
* 4 — ``RunError``: the environment failed (an unwritable or full output directory, a
  case recorder that cannot be written, out of memory);
* 130 — interrupted (Ctrl-C or SIGTERM); what finished is kept.
"""

from __future__ import annotations

import sqlite3

from suspopt.errors import ConfigError, ModelError, NotVerified, RunError, SuspoptError

OK = 0
FAILED = 1
BAD_INPUT = 2
NOT_VERIFIED = 3
ENVIRONMENT = 4
INTERRUPTED = 130

#: error class → exit code; the first class an error is an instance of decides
EXIT_CODES: tuple[tuple[type[BaseException], int], ...] = (
    (ConfigError, BAD_INPUT),
    (NotVerified, NOT_VERIFIED),
    (RunError, ENVIRONMENT),
    (ModelError, FAILED),
    (SuspoptError, FAILED),
    (KeyboardInterrupt, INTERRUPTED),
    (MemoryError, ENVIRONMENT),
    (OSError, ENVIRONMENT),
    # SQLite's own errors come only from writing a case recorder (reading one is a
    # ConfigError naming it): a full disk, a read-only or locked file
    (sqlite3.OperationalError, ENVIRONMENT),
)


def exit_code(err: BaseException) -> int:
    """The exit code of an error (:data:`EXIT_CODES`; anything else is a bug: 1)."""
    for cls, code in EXIT_CODES:
        if isinstance(err, cls):
            return code
    return FAILED
