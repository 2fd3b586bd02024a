"""The full car (issue 13): four corners, roll, anti-roll bars; the half car is its
two-corner reduction."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from suspopt.config import config_from_dict, full_car_defaults
from suspopt.study import evaluate, resolve_scales
from suspopt.timemarching import simulate

HALF_DESIGN = {'k_S1': 42000.0, 'k_S2': 21000.0, 'c_S1': 2800.0, 'c_S2': 2000.0}


def reduced_full_car(cfg):
    """The full car that must reproduce the half car: same chassis, identical tracks, every
    corner's mass, spring, damper and tyre rate half of the half car's axle values."""
    v = cfg.vehicle
    axle = lambda ax: {'axle_position': ax.axle_position, 'wheel_mass': ax.wheel_mass / 2,
                       'tyre_stiffness': ax.tyre_stiffness / 2, 'track': 1.5,
                       'anti_roll_bar': False}  # noqa: E731
    return config_from_dict({
        'vehicle': {'model': 'full_car', 'chassis_mass': v.chassis_mass,
                    'chassis_pitch_inertia': v.chassis_pitch_inertia,
                    'chassis_roll_inertia': 500.0, 'front': axle(v.front),
                    'rear': axle(v.rear)},
        'maneuver': {'speed': cfg.maneuver.speed, 'horizon': cfg.maneuver.horizon},
        'road': cfg.road, 'transcription': {'segments': cfg.transcription.segments},
        'objective': {'normalization': 'custom',
                      'scales': dict.fromkeys(('heave', 'pitch', 'roll', 'wheel_1L',
                                               'wheel_1R', 'wheel_2L', 'wheel_2R'), 1.0)},
        'design': {'per_corner': False, **{n: {'initial': x / 2, 'lower': 1.0,
                                               'upper': 1e6} for n, x in HALF_DESIGN.items()}},
    })


def _compare(half_J: dict, full_J: dict, tol: float) -> None:
    for t in ('heave', 'pitch'):
        assert abs(full_J[t] / half_J[t] - 1.0) < tol, t
    for axle in ('1', '2'):
        for side in 'LR':
            assert abs(full_J[f'wheel_{axle}{side}'] / half_J[f'wheel_{axle}'] - 1.0) < tol
    assert full_J['roll'] < 1e-20 * full_J['pitch']


def test_full_car_reduces_to_the_half_car_by_time_marching(cfg):
    """Independent of the grid: the same terms to 1e-8, zero roll (time marching at
    rtol 1e-10)."""
    full = reduced_full_car(cfg)
    half = simulate(cfg, 'low', HALF_DESIGN, rtol=1e-11, atol=1e-14,
                    t_eval=np.array([0.0, 5.0]))
    fullt = simulate(full, 'low', {n: x / 2 for n, x in HALF_DESIGN.items()}, rtol=1e-11,
                     atol=1e-14, t_eval=np.array([0.0, 5.0]))
    _compare(dict(zip(cfg.terms(), half.J)), dict(zip(full.terms(), fullt.J)), 1e-8)


@pytest.mark.slow
def test_full_car_reduces_to_the_half_car_by_collocation(cfg, scales):
    """The same on one grid: the collocation solutions agree to 1e-8 (IPOPT at tol 1e-12)."""
    tight = dict(optimizer={'tol': 1e-12, 'options': {'constr_viol_tol': 1e-14}},
                 transcription={'segments': 50})  # 2 nodes per period of the stiffest hop
    half_cfg = config_from_dict({**cfg.to_dict(), **tight})
    full = reduced_full_car(half_cfg)
    full = config_from_dict({**full.to_dict(), **tight})
    a = evaluate(half_cfg, 'low', HALF_DESIGN, scales=resolve_scales(half_cfg), verify=False)
    b = evaluate(full, 'low', {n: x / 2 for n, x in HALF_DESIGN.items()},
                 scales=resolve_scales(full), verify=False)
    _compare(a['terms'], b['terms'], 1e-8)


def test_anti_roll_bar_and_roll_energy_balance():
    """The full car's energy balance over a drive on independent tracks with both bars:
    kinetic + spring + bar + tyre energy = road work - damper dissipation; every sign of
    the heave, pitch, roll, wheel and anti-roll equations enters."""
    cfg = full_car_defaults()
    cfg = config_from_dict({**cfg.to_dict(), 'maneuver': {'speed': 20.0, 'horizon': 2.0},
                            'road': {'profile': 'iso8608', 'seed': 4,
                                     'coherence': 'independent'}})
    design = cfg.design.initial()
    t = np.linspace(0.0, 2.0, 40001)
    tr = simulate(cfg, 'low', design, t_eval=t, rtol=1e-10, atol=1e-13)
    v, lay = cfg.vehicle, cfg.layout()
    m = np.array([v.axles[c.axle].wheel_mass for c in lay.corners])
    kT = np.array([v.axles[c.axle].tyre_stiffness for c in lay.corners])
    k = np.array([design[f'k_S{c.axle + 1}'] for c in lay.corners])
    c_ = np.array([design[f'c_S{c.axle + 1}'] for c in lay.corners])
    a, y = lay.a, lay.y
    zM = tr['z_C'][:, None] - a * tr['theta_C'][:, None] + y * tr['phi_C'][:, None]
    vM = tr['v_C'][:, None] - a * tr['omega_C'][:, None] + y * tr['p_C'][:, None]
    s, sd = tr['z_W'] - zM, tr['v_W'] - vM
    kin = 0.5 * (v.chassis_mass * tr['v_C']**2 + v.chassis_pitch_inertia * tr['omega_C']**2
                 + v.chassis_roll_inertia * tr['p_C']**2 + np.sum(m * tr['v_W']**2, axis=1))
    bars = [(0, 1, design['k_R1'], v.front.track), (2, 3, design['k_R2'], v.rear.track)]
    pot = np.sum(0.5 * k * s**2 + 0.5 * kT * (tr['delta'] - tr['z_W'])**2, axis=1) + sum(
        0.5 * kr * ((s[:, i] - s[:, j]) / tr_) ** 2 for i, j, kr, tr_ in bars)
    from suspopt.road import road_tracks
    tracks = road_tracks(cfg.road, 2, lay.track_separation())
    ddelta = np.stack([20.0 * tracks[c.track].dr_ds(20.0 * t - off)
                       for c, off in zip(lay.corners, lay.offsets())], axis=1)
    road_power = np.sum(kT * (tr['delta'] - tr['z_W']) * ddelta, axis=1)
    dissipation = np.sum(c_ * sd**2, axis=1)
    from scipy.integrate import cumulative_trapezoid
    balance = kin + pot - cumulative_trapezoid(road_power - dissipation, t, initial=0.0)
    assert np.max(np.abs(balance)) < 1e-4 * np.max(kin + pot)
    assert np.max(np.abs(tr['phidd_C'])) > 0.1  # the tracks differ: it rolls
