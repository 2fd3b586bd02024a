"""suspopt's own low-fidelity vehicles as stationary systems (suspopt.spectral.vehicle):
the quarter car against the closed forms, the Lyapunov route against the spectral
integral on the half and full car with their Wk filters, the wheel displacement's
infinite variance, the road and its band."""

from __future__ import annotations

import numpy as np
import pytest
from test_spectral_closed_form import closed_forms

from suspopt.errors import ConfigError
from suspopt.models.linear import affine_linearize
from suspopt.spec.load import config_from_dict
from suspopt.spectral import (
    AffineLinearSystem,
    RandomRoad,
    StationaryModel,
    choose_pade_order,
)
from suspopt.spectral.integral import spectral_variances
from suspopt.spectral.vehicle import random_road, road_band, vehicle_system
from suspopt.transcription.vehicle import vehicle_assembly

SEAT = {'comfort': {'seats': [{'name': 'driver'}]}}


def study(model: str, **more) -> object:
    return config_from_dict({'vehicle': {'model': model}, **SEAT, **more})


def system_of(cfg) -> AffineLinearSystem:
    return vehicle_system(vehicle_assembly(cfg, cfg.scenarios()[0], 'low'))


@pytest.mark.parametrize(
    'ms, mu, kt, k, c',
    [
        (325.0, 65.0, 232500.0, 20000.0, 1500.0),
        (300.0, 40.0, 200000.0, 12000.0, 600.0),
        (450.0, 55.0, 300000.0, 45000.0, 4000.0),
    ],
)
@pytest.mark.parametrize('road_class, speed', [('C', 20.0), ('A', 8.0), ('E', 33.0)])
def test_quarter_car_matches_the_closed_forms(ms, mu, kt, k, c, road_class, speed):
    """Sprung acceleration, suspension travel and dynamic tyre load of suspopt's quarter
    car (vehicle.model = "quarter_car": its assembly's equations) on a white road velocity,
    against the closed forms of docs/spectral.md (section 7)."""
    cfg = config_from_dict(
        {
            'vehicle': {
                'model': 'quarter_car',
                'chassis_mass': ms,
                'front': {'wheel_mass': mu, 'tyre_stiffness': kt},
            },
            'maneuver': {'speed': speed},
            'road': {'profile': 'iso8608', 'road_class': road_class},
        }
    )
    system = system_of(cfg)
    road = random_road(cfg.road, speed, cfg.layout())
    var = StationaryModel(system, road).variances(system.design_vector({'k_S1': k, 'c_S1': c}))
    got = dict(zip(system.outputs, var))
    want = closed_forms(k, c, road.velocity_intensity(), ms=ms, mu=mu, kt=kt)
    np.testing.assert_allclose(
        [got['heave'], got['travel_1'], got['tyre_load_1']], want, rtol=1e-8, atol=0.0
    )


@pytest.mark.parametrize('model', ['quarter_car', 'half_car', 'full_car'])
def test_the_outputs_are_the_terms_of_finite_variance(model):
    cfg = study(model)
    system = system_of(cfg)
    assert system.outputs == tuple(t for t in cfg.terms() if not t.startswith('wheel_'))
    assert system.design == cfg.design_names()
    assert [c.offset for c in system.corners] == list(cfg.layout().offsets())
    assert [c.track for c in system.corners] == [c.track for c in cfg.layout().corners]


@pytest.mark.parametrize('model', ['quarter_car', 'half_car', 'full_car'])
def test_the_wheel_displacement_has_infinite_variance(model):
    """What the refusal of a weighted wheel_<c> rests on: the Lyapunov route's condition
    and the spectral integral both find the wheel displacement's variance infinite, and
    only it among the assembly's signals."""
    cfg = study(model)
    asm = vehicle_assembly(cfg, cfg.scenarios()[0], 'low')
    lin = affine_linearize(asm, ('z_W', 'travel', 'F_T'))
    system = AffineLinearSystem(
        lin.base.A,
        lin.base.B,
        lin.base.C,
        lin.base.D,
        lin.dA,
        lin.dB,
        lin.dC,
        lin.dD,
        design=lin.design,
        outputs=lin.base.outputs,
        corners=system_of(cfg).corners,
    )
    road = random_road({'profile': 'iso8608'}, 20.0, cfg.layout())
    p = system.design_vector(cfg.design.initial())
    infinite = StationaryModel(system, road, 4).infinite_outputs(p)
    wheels = [n for n in system.outputs if n.startswith('z_W')]
    assert [line.split(':')[0] for line in infinite] == [f'outputs.{n}' for n in wheels]
    var = spectral_variances(system, road, p, coherence='rational', rtol=1e-6)
    assert np.all(np.isinf(var[: len(wheels)])) and np.all(np.isfinite(var[len(wheels) :]))


@pytest.mark.parametrize(
    'model, road',
    [
        ('half_car', {'profile': 'iso8608', 'road_class': 'C'}),
        ('full_car', {'profile': 'iso8608', 'road_class': 'C', 'coherence': 'isotropic'}),
        ('full_car', {'profile': 'iso8608', 'road_class': 'D', 'coherence': 'identical'}),
    ],
)
def test_lyapunov_matches_the_spectral_integral_on_suspopts_cars(model, road):
    """Every stationary RMS of the half and full car with a seat's Wk filter by the
    Lyapunov route (Padé delay, rational coherence) against the spectral integral with
    the delay and the coherence exact."""
    cfg = study(model, road=road, maneuver={'speed': 15.0})
    system = system_of(cfg)
    rr = random_road(cfg.road, 15.0, cfg.layout())
    p = system.design_vector(cfg.design.initial())
    order = choose_pade_order(system, rr, p, rtol=1e-5).order
    model_ = StationaryModel(system, rr, order)
    rms = model_.rms(p)
    ref = np.sqrt(spectral_variances(system, rr, p, rtol=1e-8))
    floor = np.sqrt(model_.variance_rounding(p))
    err = np.abs(rms - ref) / np.maximum(ref, floor)
    assert err.max() < 1e-3, dict(zip(system.outputs, err))


def test_the_road_of_a_study():
    half = study('half_car', road={'profile': 'iso8608', 'road_class': 'd'})
    assert random_road(half.road, 12.0, half.layout()) == RandomRoad('D', 12.0, 'identical', 0.0)
    full = study('full_car')
    lay = full.layout()
    rr = random_road(full.road, 20.0, lay)
    assert (rr.tracks, rr.separation) == ('isotropic', lay.track_separation())
    assert rr.road_class == 'C' and rr.speed == 20.0
    with pytest.raises(ConfigError) as err:
        random_road({'profile': 'two_bumps'}, 10.0, lay, 'scenario[1].road')
    (line,) = err.value.problems
    assert (
        line.startswith('scenario[1].road.profile: the spectral method needs') and 'iso8608' in line
    )
    lo, hi = road_band({'profile': 'iso8608', 'n_min': 0.02, 'n_max': 0.5}, 10.0)
    assert (lo, hi) == pytest.approx((2 * np.pi * 0.2, 2 * np.pi * 5.0), rel=1e-15)


def test_the_band_limited_integral_carries_the_iso_8608_band_variance():
    """``spectral_variances(..., band=)``: the road height itself (D = 1, infinite over
    every frequency) between n1 and n2 has ISO 8608's band variance G_d(n0) n0² (1/n1 -
    1/n2), the power suspopt's generator puts there; bands add up."""
    system = AffineLinearSystem(
        np.array([[-1.0]]),
        np.zeros((1, 1)),
        np.zeros((1, 1)),
        np.ones((1, 1)),
        np.zeros((0, 1, 1)),
        np.zeros((0, 1, 1)),
        np.zeros((0, 1, 1)),
        np.zeros((0, 1, 1)),
        design=(),
        outputs=('height',),
    )
    road = RandomRoad('C', 17.0)
    n1, n2, n3 = 0.011, 0.2, 1.0
    w = 2 * np.pi * road.speed

    def band(a, b):
        return spectral_variances(system, road, np.zeros(0), band=(w * a, w * b), rtol=1e-10)[0]

    g0 = road.displacement_psd_n0
    assert band(n1, n3) == pytest.approx(g0 * 0.01 * (1 / n1 - 1 / n3), rel=1e-9)
    assert band(n1, n2) + band(n2, n3) == pytest.approx(band(n1, n3), rel=1e-9)
    with pytest.raises(ConfigError, match='band: need 0 < lower < upper'):
        spectral_variances(system, road, np.zeros(0), band=(2.0, 1.0))
