"""Quarter car on an ISO 8608 road: the Lyapunov and spectral-integral variances against
closed forms, and the intensity convention against the ISO 8608 displacement PSD."""

from __future__ import annotations

import numpy as np
import pytest
from spectral_vehicles import KT, MS, MU, quarter_car

from suspopt.errors import ConfigError
from suspopt.road import ISO8608Road
from suspopt.spectral import RandomRoad, StationaryModel
from suspopt.spectral.integral import spectral_variances


def closed_forms(
    k: float, c: float, q: float, ms: float = MS, mu: float = MU, kt: float = KT
) -> np.ndarray:
    """Variances of sprung acceleration, suspension travel and dynamic tyre load of the
    quarter car (sprung ``ms``, unsprung ``mu``, spring ``k``, damper ``c``, tyre ``kt``;
    default: the hand-written car's) for a white road velocity of intensity q
    (E[u(t)u(t+τ)] = q δ(τ)).

    Derived by the table of integrals (Newland, *An Introduction to Random Vibrations,
    Spectral and Wavelet Analysis*, 3rd ed., Appendix 1, n = 4) from the transfer
    functions of the road velocity, with Δ(s) = m_s m_u s⁴ + c(m_s+m_u) s³ +
    (k(m_s+m_u) + k_t m_s) s² + c k_t s + k k_t: acceleration s k_t(cs + k)/Δ, travel
    -k_t m_s s/Δ, tyre load k_t (m_s m_u s³ + c(m_s+m_u) s² + k(m_s+m_u) s)/Δ
    (docs/spectral.md shows the steps). The same three expressions are the closed forms
    of Gobbi & Mastinu, J. Sound Vib. 245(3), 2001."""
    m = ms + mu
    acc = q / 2.0 * (kt * c / ms**2 + k**2 * m / (c * ms**2))
    travel = q / 2.0 * m / c
    tyre = (
        q
        / 2.0
        * (
            kt * c * m**2 / ms**2
            + k**2 * m**3 / (c * ms**2)
            - 2.0 * k * kt * mu * m / (c * ms)
            + kt**2 * mu / c
        )
    )
    return np.array([acc, travel, tyre])


def newland_i4(a: list[float], b: list[float]) -> float:
    """∫ |B(jω)/A(jω)|² dω over the real line for A of degree 4, B of degree 3
    (Newland, Appendix 1)."""
    a0, a1, a2, a3, a4 = a
    b0, b1, b2, b3 = b
    num = (
        b0**2 / a0 * (-a1 * a4 + a2 * a3)
        + (b1**2 - 2 * b0 * b2) * a3
        + (b2**2 - 2 * b1 * b3) * a1
        + b3**2 / a4 * (-a0 * a3 + a1 * a2)
    )
    return np.pi * num / (a1 * a2 * a3 - a0 * a3**2 - a1**2 * a4)


DESIGNS = [(20000.0, 1500.0), (12000.0, 600.0), (45000.0, 4000.0)]


@pytest.mark.parametrize('k, c', DESIGNS)
def test_closed_forms_match_the_table_of_integrals(k, c):
    """The closed forms are the table's integrals (guards the transcription)."""
    q = 1.7
    m = MS + MU
    a = [k * KT, c * KT, k * m + KT * MS, c * m, MS * MU]
    S = q / (2.0 * np.pi)  # two-sided PSD in rad/s of the road velocity
    table = [
        S * newland_i4(a, [0.0, KT * k, KT * c, 0.0]),
        S * newland_i4(a, [0.0, -KT * MS, 0.0, 0.0]),
        S * newland_i4(a, [0.0, KT * k * m, KT * c * m, KT * MS * MU]),
    ]
    np.testing.assert_allclose(closed_forms(k, c, q), table, rtol=1e-12)


@pytest.mark.parametrize('k, c', DESIGNS)
@pytest.mark.parametrize('road_class, speed', [('C', 20.0), ('A', 8.0), ('E', 33.0)])
def test_lyapunov_matches_closed_forms(k, c, road_class, speed):
    road = RandomRoad(road_class, speed)
    var = StationaryModel(quarter_car(), road).variances(np.array([k, c]))
    np.testing.assert_allclose(var, closed_forms(k, c, road.velocity_intensity()), rtol=1e-8)


@pytest.mark.parametrize('k, c', DESIGNS)
def test_spectral_integral_matches_closed_forms(k, c):
    road = RandomRoad('C', 20.0)
    var = spectral_variances(quarter_car(), road, np.array([k, c]), rtol=1e-11)
    np.testing.assert_allclose(var, closed_forms(k, c, road.velocity_intensity()), rtol=1e-8)


def test_intensity_is_half_the_one_sided_velocity_psd():
    """W = 4π² G_d(n0) n0² v one-sided; the Lyapunov intensity is W/2."""
    road = RandomRoad('D', 25.0)
    gd0 = 1024e-6  # the class D geometric mean of ISO 8608 (Table: 512-2048 × 10⁻⁶ m³)
    assert road.velocity_psd_one_sided() == pytest.approx(4 * np.pi**2 * gd0 * 0.01 * 25.0)
    assert road.velocity_intensity() == pytest.approx(0.5 * road.velocity_psd_one_sided())


@pytest.mark.parametrize('band', [(0.05, 0.2), (0.011, 1.0)])
def test_height_psd_carries_the_iso_8608_band_power(band):
    """The height PSD in rad/s integrated over a band of spatial frequencies (both signs
    of ω) is the band's variance in ISO 8608, ∫ G_d(n) dn = G_d(n0) n0² (1/n1 - 1/n2);
    and the same as the power of suspopt.road's synthesized ISO road in that band."""
    from scipy.integrate import quad

    v = 17.0
    road = RandomRoad('C', v)
    n1, n2 = band
    iso = 256e-6 * 0.1**2 * (1.0 / n1 - 1.0 / n2)
    ours = 2.0 * quad(road.height_psd, 2 * np.pi * v * n1, 2 * np.pi * v * n2, epsrel=1e-12)[0]
    assert ours == pytest.approx(iso, rel=1e-10)
    length = 4000.0
    _, amp, _ = ISO8608Road(road_class='C', n_min=n1, n_max=n2, length=length).lines()
    assert np.sum(amp**2 / 2.0) == pytest.approx(iso, rel=1e-9)


def test_quarter_car_is_within_the_finite_variance_conditions():
    """Sprung displacement follows the road (static gain 1): infinite, named; the three
    outputs of the closed forms are finite."""
    from spectral_vehicles import affine_system

    base = quarter_car()
    C0 = np.vstack([base.C0, [1.0, 0.0, 0.0, 0.0]])
    sys2 = affine_system(
        {'A': base.A0, 'B': base.B0, 'C': C0, 'D': np.vstack([base.D0, [0.0]])},
        {
            name: {
                'A': base.dA[i],
                'C': np.vstack([base.dC[i], np.zeros(4)]),
            }
            for i, name in enumerate(base.design)
        },
        outputs=(*base.outputs, 'z_s'),
    )
    model = StationaryModel(sys2, RandomRoad('C', 20.0))
    p = np.array([20000.0, 1500.0])
    problems = model.infinite_outputs(p)
    assert len(problems) == 1 and problems[0].startswith('outputs.z_s:')
    with pytest.raises(ConfigError, match='outputs.z_s'):
        model.variances(p)
    var = spectral_variances(sys2, RandomRoad('C', 20.0), p)
    assert np.all(np.isfinite(var[:3])) and var[3] == np.inf
