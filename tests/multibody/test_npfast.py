"""The quarantine of NumPy's private linear-algebra names (:mod:`suspopt.multibody.npfast`):
the direct gufunc calls give what ``np.linalg.solve`` and ``.inv`` give, bit for bit, and
raise as they do on a singular system; a NumPy version outside the checked range gets the
public functions."""

from __future__ import annotations

import numpy as np
import pytest

from suspopt.multibody import npfast


def systems(seed: int = 0):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(7, 5, 5)) + 5.0 * np.eye(5)
    return A, rng.normal(size=(7, 5, 2))


def test_the_installed_numpy_gets_the_direct_gufuncs():
    lo, hi = (np.lib.NumpyVersion(v) for v in npfast.CHECKED)
    installed = np.lib.NumpyVersion(np.__version__)
    assert npfast.PRIVATE == (installed >= npfast.CHECKED[0] and installed < npfast.CHECKED[1])
    assert lo < hi


@pytest.mark.parametrize('version', [np.__version__, '1.26.4', '3.0.0'])
def test_both_routes_equal_the_public_functions(version):
    solve, inv, private = npfast.select(version)
    if version != np.__version__:
        assert not private and solve is np.linalg.solve and inv is np.linalg.inv
    A, b = systems()
    assert np.array_equal(solve(A, b), np.linalg.solve(A, b))
    assert np.array_equal(inv(A), np.linalg.inv(A))
    fast_solve, fast_inv, _ = npfast.select(np.__version__)
    assert np.array_equal(solve(A, b), fast_solve(A, b))
    assert np.array_equal(inv(A), fast_inv(A))


@pytest.mark.parametrize('version', [np.__version__, '1.26.4'])
def test_a_singular_system_raises_linalgerror(version):
    solve, inv, _ = npfast.select(version)
    A, b = systems(1)
    A[3] = 0.0
    with pytest.raises(np.linalg.LinAlgError):
        solve(A, b)
    with pytest.raises(np.linalg.LinAlgError):
        inv(A)
    # the error state is the call's own: NumPy's global one is unchanged afterwards
    assert np.geterr()['invalid'] == 'warn'
