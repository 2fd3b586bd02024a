"""Exceptions with the exit codes the command line maps them to.

The command line's exit codes:

* 0 — success (every result verified by time marching, or verification skipped on request);
* 1 — ``ModelError``: a model evaluation failed (NaN/inf, singular or non-converged
  multibody configuration), or IPOPT did not converge (the result says so);
* 2 — ``ConfigError``: bad input (study file, mechanism or road data, arguments, a damaged
  results directory or one in use by another run), detected before any work starts, one
  line per problem naming the key or the file (:mod:`suspopt.inputs` reads every input);
* 3 — ``NotVerified``: a result whose collocation and time marching disagree beyond the
  verification tolerance (the results are written, marked ``verified: false``);
* 4 — ``RunError``: the environment failed (an unwritable or full output directory, a case
  recorder that cannot be written, an input the machine cannot read);
* 130 — interrupted (Ctrl-C or SIGTERM); what finished is kept.
"""

from __future__ import annotations


class SuspoptError(Exception):
    """Base class; ``exit_code`` is what the command line returns."""

    exit_code = 1


class ConfigError(SuspoptError, ValueError):
    """Invalid study description, mechanism file or road data. One problem per line."""

    exit_code = 2

    def __init__(self, problems: str | list[str]):
        self.problems = [problems] if isinstance(problems, str) else list(problems)
        super().__init__('\n'.join(self.problems))


class ModelError(SuspoptError, RuntimeError):
    """A model evaluation could not be completed (non-finite values, singular mechanism)."""


class MultibodyError(ModelError):
    """The multibody solver failed: singular constraint Jacobian, Newton not converged, NaN."""


class NotVerified(SuspoptError):
    """A result's collocation and time marching disagree beyond the tolerance."""

    exit_code = 3


class RunError(SuspoptError, OSError):
    """The environment failed: an output file could not be written (disk full, read-only)."""

    exit_code = 4
