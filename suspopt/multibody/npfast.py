"""Batched solves and inverses of small dense systems, with NumPy's private names kept here.

``np.linalg.solve`` and ``np.linalg.inv`` are thin wrappers around the gufuncs
``numpy.linalg._umath_linalg.solve`` / ``.inv``: they check and convert their arguments
and set the error state that turns a singular matrix into ``LinAlgError``. For batches of
a few 10 × 10 systems that handling costs about as much as the factorizations, so the
multibody solver calls the gufuncs directly, with the same error state made once. Those
are private NumPy names (``numpy.linalg._umath_linalg``, ``numpy.linalg._linalg.
_raise_linalgerror_singular``, ``numpy._core._ufunc_config``): this module is the only
place that uses them, and only on the NumPy versions it was checked with
(:data:`CHECKED`); on any other version, or if a name is missing, :func:`solve` and
:func:`inv` are ``np.linalg.solve`` and ``np.linalg.inv`` themselves (same results, the
public functions being wrappers of the same gufuncs).

:func:`solve` takes ``A`` (N, m, m) and ``b`` (N, m, k) float64 and :func:`inv` ``A``
(N, m, m) float64; both raise ``np.linalg.LinAlgError`` on a singular system.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

#: NumPy versions ``[first, end)`` whose private linear-algebra names this module uses
CHECKED = ('2.0.0', '3.0.0')

Solve = Callable[[np.ndarray, np.ndarray], np.ndarray]
Inverse = Callable[[np.ndarray], np.ndarray]


def public() -> tuple[Solve, Inverse]:
    """The public functions: ``np.linalg.solve`` and ``np.linalg.inv``."""
    return np.linalg.solve, np.linalg.inv


def select(version: str) -> tuple[Solve, Inverse, bool]:
    """``(solve, inv, private)`` for NumPy ``version``: the gufuncs called directly on a
    checked version (``private`` True), the public functions otherwise."""
    v = np.lib.NumpyVersion(version)
    if not (v >= CHECKED[0] and v < CHECKED[1]):
        return (*public(), False)
    try:
        return (*_gufuncs(), True)
    except (ImportError, AttributeError, TypeError):
        return (*public(), False)


def _gufuncs() -> tuple[Solve, Inverse]:
    """The gufuncs behind ``np.linalg.solve`` and ``.inv`` with ``np.linalg``'s error state
    (singular: ``LinAlgError``; overflow, division and underflow ignored) set per call."""
    # private names (no stubs): this module is their quarantine
    from numpy._core._ufunc_config import (  # type: ignore[attr-defined]
        _extobj_contextvar,
        _make_extobj,
    )
    from numpy.linalg import _umath_linalg
    from numpy.linalg._linalg import _raise_linalgerror_singular  # type: ignore[attr-defined]

    gufunc_solve: Any = _umath_linalg.solve
    gufunc_inv: Any = _umath_linalg.inv
    errors = _make_extobj(
        call=_raise_linalgerror_singular,
        invalid='call',
        over='ignore',
        divide='ignore',
        under='ignore',
    )

    def solve(A: np.ndarray, b: np.ndarray) -> np.ndarray:
        token = _extobj_contextvar.set(errors)
        try:
            return gufunc_solve(A, b, signature='dd->d')
        finally:
            _extobj_contextvar.reset(token)

    def inv(A: np.ndarray) -> np.ndarray:
        token = _extobj_contextvar.set(errors)
        try:
            return gufunc_inv(A, signature='d->d')
        finally:
            _extobj_contextvar.reset(token)

    return solve, inv


solve, inv, PRIVATE = select(np.__version__)

__all__ = ['CHECKED', 'PRIVATE', 'inv', 'public', 'select', 'solve']
