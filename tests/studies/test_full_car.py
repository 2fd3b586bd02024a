"""The full car (issue 13): four corners, roll, anti-roll bars; the half car is its
two-corner reduction."""

from __future__ import annotations

import numpy as np
import pytest

from suspopt.spec.load import config_from_dict, full_car_defaults
from suspopt.studies.run import evaluate
from suspopt.verification.scales import resolve_scales
from suspopt.verification.timemarching import simulate

HALF_DESIGN = {'k_S1': 42000.0, 'k_S2': 21000.0, 'c_S1': 2800.0, 'c_S2': 2000.0}


def reduced_full_car(cfg):
    """The full car that must reproduce the half car: same chassis, identical tracks, every
    corner's mass, spring, damper and tyre rate half of the half car's axle values."""
    v = cfg.vehicle

    def axle(ax):
        return {
            'axle_position': ax.axle_position,
            'wheel_mass': ax.wheel_mass / 2,
            'tyre_stiffness': ax.tyre_stiffness / 2,
            'track': 1.5,
            'anti_roll_bar': False,
        }

    return config_from_dict(
        {
            'vehicle': {
                'model': 'full_car',
                'chassis_mass': v.chassis_mass,
                'chassis_pitch_inertia': v.chassis_pitch_inertia,
                'chassis_roll_inertia': 500.0,
                'front': axle(v.front),
                'rear': axle(v.rear),
            },
            'maneuver': {'speed': cfg.maneuver.speed, 'horizon': cfg.maneuver.horizon},
            'road': cfg.road,
            'transcription': {'segments': cfg.transcription.segments},
            'constraints': {  # the default full car's engineering constraints, off
                name: {'enabled': False} for name in ('travel', 'tyre_contact', 'roll_gradient')
            },
            'objective': {  # the paper's (the default full car's is comfort and road holding)
                'weights': {'heave': 1 / 6, 'pitch': 1 / 6, 'roll': 1 / 6, 'wheel': 0.5},
                'normalization': 'custom',
                'scales': dict.fromkeys(
                    ('heave', 'pitch', 'roll', 'wheel_1L', 'wheel_1R', 'wheel_2L', 'wheel_2R'), 1.0
                ),
            },
            'design': {
                'per_corner': False,
                **{
                    n: {'initial': x / 2, 'lower': 1.0, 'upper': 1e6}
                    for n, x in HALF_DESIGN.items()
                },
            },
        }
    )


def _compare(half_J: dict, full_J: dict, tol: float) -> None:
    diffs = {t: abs(full_J[t] / half_J[t] - 1.0) for t in ('heave', 'pitch')}
    for axle in ('1', '2'):
        for side in 'LR':
            diffs[f'wheel_{axle}{side}'] = abs(
                full_J[f'wheel_{axle}{side}'] / half_J[f'wheel_{axle}'] - 1.0
            )
    print(
        f'\nfull car against half car: largest relative difference {max(diffs.values()):.1e} '
        f'({max(diffs, key=diffs.get)}); J_roll / J_pitch = {full_J["roll"] / full_J["pitch"]:.1e}'
    )
    for t, d in diffs.items():
        assert d < tol, t
    assert full_J['roll'] < 1e-20 * full_J['pitch']


def test_full_car_reduces_to_the_half_car_by_time_marching(cfg):
    """Independent of the grid: the same terms to 1e-8, zero roll (time marching at
    rtol 1e-10)."""
    full = reduced_full_car(cfg)
    half = simulate(cfg, 'low', HALF_DESIGN, rtol=1e-11, atol=1e-14, t_eval=np.array([0.0, 5.0]))
    fullt = simulate(
        full,
        'low',
        {n: x / 2 for n, x in HALF_DESIGN.items()},
        rtol=1e-11,
        atol=1e-14,
        t_eval=np.array([0.0, 5.0]),
    )
    _compare(dict(zip(cfg.terms(), half.J)), dict(zip(full.terms(), fullt.J)), 1e-8)


@pytest.mark.slow
def test_full_car_reduces_to_the_half_car_by_collocation(cfg, scales):
    """The same on one grid: the collocation solutions agree to 1e-8 (IPOPT at tol 1e-12)."""
    tight = dict(
        optimizer={'tol': 1e-12, 'options': {'constr_viol_tol': 1e-14}},
        transcription={'segments': 50},
    )  # 2 nodes per period of the stiffest hop
    half_cfg = config_from_dict({**cfg.to_dict(), **tight})
    full = reduced_full_car(half_cfg)
    full = config_from_dict({**full.to_dict(), **tight})
    a = evaluate(half_cfg, 'low', HALF_DESIGN, scales=resolve_scales(half_cfg), verify=False)
    b = evaluate(
        full,
        'low',
        {n: x / 2 for n, x in HALF_DESIGN.items()},
        scales=resolve_scales(full),
        verify=False,
    )
    _compare(a.terms, b.terms, 1e-8)


def test_anti_roll_bar_and_roll_energy_balance():
    """The full car's energy balance over a drive on independent tracks with both bars:
    kinetic + spring + bar + tyre energy = road work - damper dissipation; every sign of
    the heave, pitch, roll, wheel and anti-roll equations enters."""
    cfg = full_car_defaults()
    cfg = config_from_dict(
        {
            **cfg.to_dict(),
            'maneuver': {'speed': 20.0, 'horizon': 1.0},
            'road': {'profile': 'iso8608', 'seed': 4, 'coherence': 'independent'},
        }
    )
    design = cfg.design.initial()
    t = np.linspace(0.0, 1.0, 20001)
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
    kin = 0.5 * (
        v.chassis_mass * tr['v_C'] ** 2
        + v.chassis_pitch_inertia * tr['omega_C'] ** 2
        + v.chassis_roll_inertia * tr['p_C'] ** 2
        + np.sum(m * tr['v_W'] ** 2, axis=1)
    )
    bars = [(0, 1, design['k_R1'], v.front.track), (2, 3, design['k_R2'], v.rear.track)]
    pot = np.sum(0.5 * k * s**2 + 0.5 * kT * (tr['delta'] - tr['z_W']) ** 2, axis=1) + sum(
        0.5 * kr * ((s[:, i] - s[:, j]) / tr_) ** 2 for i, j, kr, tr_ in bars
    )
    from suspopt.road import road_tracks

    tracks = road_tracks(cfg.road, 2, lay.track_separation())
    ddelta = np.stack(
        [
            20.0 * tracks[c.track].dr_ds(20.0 * t - off)
            for c, off in zip(lay.corners, lay.offsets())
        ],
        axis=1,
    )
    road_power = np.sum(kT * (tr['delta'] - tr['z_W']) * ddelta, axis=1)
    dissipation = np.sum(c_ * sd**2, axis=1)
    from scipy.integrate import cumulative_trapezoid

    balance = kin + pot - cumulative_trapezoid(road_power - dissipation, t, initial=0.0)
    assert np.max(np.abs(balance)) < 1e-4 * np.max(kin + pot)
    assert np.max(np.abs(tr['phidd_C'])) > 0.1  # the tracks differ: it rolls


def test_iso8608_tracks_follow_the_isotropic_coherence():
    """The right track of an ISO 8608 road: the same PSD as the left one, and the measured
    left/right coherence (Welch, magnitude squared) equals the model's γ(n)² = (x K₁(x))²
    in every band (the estimate's bias over ~40 averages is ~0.03). Mixing the lines by γ²
    or √γ instead would miss by ≥ 0.2 in the middle bands."""
    from scipy.signal import coherence, welch

    from suspopt.road import make_road, track_coherence

    road = make_road({'profile': 'iso8608', 'road_class': 'C', 'seed': 5})
    B = 1.5
    s = np.arange(5.0, 2000.0, 0.05)
    left, right = road.r(s), road.track(1, B).r(s)
    f, msc = coherence(left, right, fs=20.0, nperseg=2048)
    for lo, hi in [(0.02, 0.05), (0.05, 0.1), (0.1, 0.2), (0.2, 0.4), (0.4, 0.9)]:
        band = (f >= lo) & (f < hi)
        model = np.mean(track_coherence('isotropic', f[band], B) ** 2)
        assert abs(np.mean(msc[band]) - model) < 0.08, (lo, hi, np.mean(msc[band]), model)
    _, pl = welch(left, fs=20.0, nperseg=2048)
    _, pr = welch(right, fs=20.0, nperseg=2048)
    band = (f > 0.02) & (f < 0.9)
    assert abs(np.mean(pr[band]) / np.mean(pl[band]) - 1.0) < 0.1
    same = make_road({'profile': 'iso8608', 'road_class': 'C', 'seed': 5, 'coherence': 'identical'})
    np.testing.assert_array_equal(same.track(1, B).r(s), left)


def _full(**over):
    base = full_car_defaults().to_dict()
    for key, value in over.items():
        base[key] = {**base.get(key, {}), **value} if key != 'road' else value
    return base


def test_two_csv_tracks_with_the_same_profile_do_not_roll(tmp_path):
    """A two-track road of two identical CSV files gives the same drive as the profile
    under both tracks: no roll, equal left and right wheel terms (time marching)."""
    s = np.linspace(0.0, 120.0, 1201)
    h = 0.03 * np.sin(2.0 * np.pi * s / 7.0) * (s > 5.0)
    for side in ('left', 'right'):
        np.savetxt(tmp_path / f'{side}.csv', np.column_stack([s, h]), delimiter=',')
    two = config_from_dict(
        _full(
            road={
                'profile': 'two_tracks',
                'left': {'profile': 'csv', 'file': str(tmp_path / 'left.csv')},
                'right': {'profile': 'csv', 'file': str(tmp_path / 'right.csv')},
            },
            maneuver={'speed': 15.0, 'horizon': 3.0},
        )
    )
    one = config_from_dict(
        _full(
            road={'profile': 'csv', 'file': str(tmp_path / 'left.csv')},
            maneuver={'speed': 15.0, 'horizon': 3.0},
        )
    )
    d = two.design.initial()
    a = dict(zip(two.terms(), simulate(two, 'low', d, t_eval=np.array([0.0, 3.0])).J))
    b = dict(zip(one.terms(), simulate(one, 'low', d, t_eval=np.array([0.0, 3.0])).J))
    assert a['roll'] < 1e-12 * a['pitch']
    for term in a:
        assert a[term] == pytest.approx(b[term], rel=1e-9, abs=1e-30), term
    assert a['wheel_1L'] == pytest.approx(a['wheel_1R'], rel=1e-9)


@pytest.mark.parametrize(
    'over,key,words',
    [
        ({'vehicle': {'front': {'track': 0.0}}}, 'vehicle.front.track', 'must be > 0'),
        ({'vehicle': {'rear': {'track': -1.5}}}, 'vehicle.rear.track', 'must be > 0'),
        ({'vehicle': {'chassis_roll_inertia': 0.0}}, 'vehicle.chassis_roll_inertia', 'must be > 0'),
    ],
    ids=['front track 0', 'rear track < 0', 'roll inertia 0'],
)
def test_bad_full_car_input_exits_2_naming_the_key(tmp_path, capsys, over, key, words):
    _bad(tmp_path, capsys, _merge_deep(full_car_defaults().to_dict(), over), key, words)


def test_anti_roll_bar_or_two_tracks_on_a_half_car_exit_2(tmp_path, capsys):
    from suspopt.spec.schema import StudyConfig

    half = StudyConfig().to_dict()
    _bad(
        tmp_path,
        capsys,
        _merge_deep(half, {'vehicle': {'front': {'anti_roll_bar': True}}}),
        'vehicle.front.anti_roll_bar',
        'half car',
    )
    _bad(
        tmp_path,
        capsys,
        _merge_deep(
            half,
            {
                'road': {
                    'profile': 'two_tracks',
                    'left': {'profile': 'bump'},
                    'right': {'profile': 'bump'},
                }
            },
        ),
        'road.profile',
        'two wheel tracks',
    )


def test_two_track_files_of_different_lengths_exit_2(tmp_path, capsys):
    for side, end in (('left', 120.0), ('right', 110.0)):
        s = np.linspace(0.0, end, 200)
        np.savetxt(tmp_path / f'{side}.csv', np.column_stack([s, 0.0 * s]), delimiter=',')
    cfg = full_car_defaults().to_dict()
    cfg['road'] = {
        'profile': 'two_tracks',
        'left': {'profile': 'csv', 'file': str(tmp_path / 'left.csv')},
        'right': {'profile': 'csv', 'file': str(tmp_path / 'right.csv')},
    }
    _bad(tmp_path, capsys, cfg, 'road.right.file', 'different lengths')


def _merge_deep(base: dict, over: dict) -> dict:
    out = dict(base)
    for k, v in over.items():
        out[k] = (
            _merge_deep(out.get(k, {}), v)
            if isinstance(v, dict) and isinstance(out.get(k), dict)
            else v
        )
    return out


def _bad(tmp_path, capsys, data: dict, key: str, words: str) -> None:
    """The study file ``data`` is refused by the CLI with exit 2, one line naming ``key``."""
    from suspopt.cli.main import main
    from suspopt.spec.template import toml_value

    path = tmp_path / 'bad.toml'
    path.write_text(''.join(f'{k} = {toml_value(v)}\n' for k, v in data.items()))
    assert main(['evaluate', '--fidelity', 'low', '--config', str(path)]) == 2
    err = capsys.readouterr().err
    lines = [ln for ln in err.strip().splitlines() if key in ln]
    assert lines and any(words in ln for ln in lines), err
    assert 'Traceback' not in err
