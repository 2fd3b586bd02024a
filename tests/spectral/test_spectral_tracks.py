"""Two wheel tracks (identical, independent, isotropic) on a hand-written full car, and
the conditions for a finite variance."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import k1
from spectral_vehicles import FULL_CAR_DESIGN, full_car

from suspopt.errors import ConfigError
from suspopt.spectral import RandomRoad, StationaryModel
from suspopt.spectral.accuracy import rms_error
from suspopt.spectral.integral import spectral_variances
from suspopt.spectral.shaping import (
    ISOTROPIC_POLES,
    ISOTROPIC_ZEROS,
    fit_isotropic_difference,
    isotropic_coherence_approximation,
    isotropic_filters,
)

SEPARATION = 1.5


def _response(A, B, C, D, s):
    """C (sI - A)⁻¹ B + D at each s: (len(s), rows, cols)."""
    n = A.shape[0]
    return np.array([C @ np.linalg.solve(si * np.eye(n) - A, B) + D for si in s])


def test_coherence_filters_keep_each_track_exact():
    """u = (u_L, u_R) from (w₊, w₋): both auto-spectra exactly 1 (× q), the
    cross-spectrum the rational coherence γ̂; the relative height d has the transfer
    (u_R - u_L)/s."""
    v = 20.0
    f = isotropic_filters(v, SEPARATION)
    w = np.geomspace(1e-2, 1e3, 300)
    H = _response(f.A, f.B, f.C_u, f.D_u, 1j * w)  # (ω, 2 tracks, 2 noises)
    S = np.einsum('wkn,wln->wkl', H, H.conj())
    np.testing.assert_allclose(S[:, 0, 0].real, 1.0, rtol=1e-10)
    np.testing.assert_allclose(S[:, 1, 1].real, 1.0, rtol=1e-10)
    gamma = isotropic_coherence_approximation(w * SEPARATION / v)
    np.testing.assert_allclose(S[:, 0, 1].real, gamma, atol=1e-10)
    np.testing.assert_allclose(S[:, 0, 1].imag, 0.0, atol=1e-10)
    d = _response(f.A, f.B, f.C_d[None, :], np.zeros((1, 2)), 1j * w)[:, 0]
    np.testing.assert_allclose(d, (H[:, 1] - H[:, 0]) / (1j * w[:, None]), rtol=1e-8, atol=1e-14)
    assert np.all(np.linalg.eigvals(f.A).real < 0.0)


def test_rational_coherence_accuracy():
    """Against Kamash & Robson's x K₁(x) on x = ωB/v ∈ [10⁻³, 10³]: the coherence within
    0.0025, the difference channel (1 - γ)/2 within 0.6 % (relative)."""
    x = np.geomspace(1e-3, 1e3, 4000)
    gamma = x * k1(x)
    approx = isotropic_coherence_approximation(x)
    assert np.max(np.abs(approx - gamma)) < 0.0025
    assert np.max(np.abs((1.0 - approx) / (1.0 - gamma) - 1.0)) < 0.006


def test_stored_coherence_fit_is_a_least_squares_optimum():
    z, p = fit_isotropic_difference(ISOTROPIC_ZEROS, ISOTROPIC_POLES)
    np.testing.assert_allclose(z, ISOTROPIC_ZEROS, rtol=1e-5)
    np.testing.assert_allclose(p, ISOTROPIC_POLES, rtol=1e-5)


@pytest.mark.parametrize('tracks', ['identical', 'independent', 'isotropic'])
def test_full_car_lyapunov_matches_the_spectral_integral(tracks):
    """Delays by Padé (order 12), coherence rational: within 1e-5 of the spectral
    integral with the same coherence; the isotropic coherence approximation itself moves
    no RMS by more than 1e-3."""
    system, p = full_car(), FULL_CAR_DESIGN
    road = RandomRoad('C', 20.0, tracks=tracks, separation=SEPARATION)
    model = StationaryModel(system, road, 12)
    rms = model.rms(p)
    floor = np.sqrt(model.variance_rounding(p))
    ref = np.sqrt(np.maximum(spectral_variances(system, road, p, coherence='rational'), 0.0))
    assert rms_error(rms, ref, floor) < 1e-5
    if tracks == 'isotropic':
        exact = np.sqrt(spectral_variances(system, road, p, coherence='exact'))
        assert rms_error(rms, exact, floor) < 1e-3


def test_identical_tracks_do_not_roll_a_symmetric_car():
    system, p = full_car(), FULL_CAR_DESIGN
    road = RandomRoad('C', 20.0, tracks='identical')
    rms = StationaryModel(system, road, 12).rms(p)
    assert rms[system.output_index('roll_acc')] == 0.0
    iso = StationaryModel(system, RandomRoad('C', 20.0, 'isotropic', SEPARATION), 12).rms(p)
    assert iso[system.output_index('roll_acc')] > 0.1


@pytest.mark.parametrize(
    'tracks, infinite',
    [
        ('identical', {'wheel_0'}),
        ('isotropic', {'wheel_0'}),
        ('independent', {'wheel_0', 'roll'}),
    ],
)
def test_finite_variance_condition(tracks, infinite):
    """The roll angle follows the difference of the tracks' heights: finite where the
    tracks agree at low frequency (identical, isotropic), infinite on independent tracks;
    a wheel's height follows the road: infinite always. The spectral integral, which does
    not use the condition, agrees."""
    system = full_car(extra_outputs=('roll', 'wheel_0'))
    p = FULL_CAR_DESIGN
    road = RandomRoad('C', 20.0, tracks=tracks, separation=SEPARATION)
    model = StationaryModel(system, road, 8)
    flagged = {line.split(':')[0].removeprefix('outputs.') for line in model.infinite_outputs(p)}
    assert flagged == infinite
    with pytest.raises(ConfigError, match='outputs.wheel_0'):
        model.variances(p)
    var = spectral_variances(system, road, p, rtol=1e-6)
    assert {n for n, v in zip(system.outputs, var) if not np.isfinite(v)} == infinite
