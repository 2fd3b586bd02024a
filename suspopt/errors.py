"""Exceptions with the exit codes the command line maps them to.

``ConfigError`` (exit 2): bad input, detected before any work starts.
``ModelError`` (exit 1): a model evaluation failed (NaN/inf, singular or non-converged
multibody configuration).
``OptimizationFailed`` (exit 1): IPOPT did not converge; carries the partial result.
"""
from __future__ import annotations

from typing import Any


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


class OptimizationFailed(SuspoptError, RuntimeError):
    """IPOPT stopped without converging; ``result`` holds what was computed."""

    def __init__(self, message: str, result: Any = None):
        super().__init__(message)
        self.result = result
