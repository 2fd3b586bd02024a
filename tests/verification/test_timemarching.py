"""The time-marching reference checked against physics derived independently in the test."""

from __future__ import annotations

import numpy as np
import pytest
from half_car_by_hand import half_car_matrices, states_by_hand  # tests/ is on the path

from suspopt.road import wheel_road_inputs
from suspopt.spec.load import config_from_dict
from suspopt.spec.schema import StudyConfig
from suspopt.verification.timemarching import reference_scales, simulate

DESIGN = {'k_S1': 42000.0, 'k_S2': 21000.0, 'c_S1': 2800.0, 'c_S2': 2000.0}


def test_half_car_matches_hand_written_state_space():
    """The model's equations (suspopt.models.equations) reproduce M q'' + C q' + K q = F."""
    cfg = StudyConfig()
    A, _ = half_car_matrices(cfg, DESIGN)
    # the hand-written state space marched by SciPy's lsim (exact for a piecewise-linear
    # road, Richardson-extrapolated): every 0.01 s
    t_eval, ref = states_by_hand(cfg, DESIGN, every=100, step=1e-4)
    tr = simulate(cfg, 'low', DESIGN, t_eval=t_eval)
    signals = (tr['z_C'], tr['theta_C'], tr['z_W'][:, 0], tr['z_W'][:, 1])
    for k, (name, sig) in enumerate(zip(('z_C', 'theta_C', 'z_W1', 'z_W2'), signals)):
        scale = np.max(np.abs(ref[:, k]))
        np.testing.assert_allclose(sig, ref[:, k], atol=1e-6 * scale, err_msg=name)
    np.testing.assert_allclose(
        tr['zdd_C'], (ref @ A.T)[:, 4], atol=1e-5 * np.max(np.abs(tr['zdd_C']))
    )


def test_energy_balance_of_half_car():
    """d/dt (kinetic + spring energy) = -damper dissipation + power of the road on the tyres,
    integrated over the drive: checks every sign of eqs. 5-10."""
    cfg = StudyConfig()
    v = cfg.vehicle
    t = np.linspace(0.0, 5.0, 20001)
    tr = simulate(cfg, 'low', DESIGN, t_eval=t)
    a1, a2 = v.front.axle_position, v.rear.axle_position
    zW, vW = tr['z_W'].T, tr['v_W'].T
    kin = 0.5 * (
        v.chassis_mass * tr['v_C'] ** 2
        + v.chassis_pitch_inertia * tr['omega_C'] ** 2
        + v.front.wheel_mass * vW[0] ** 2
        + v.rear.wheel_mass * vW[1] ** 2
    )
    defl = [zW[0] + a1 * tr['theta_C'] - tr['z_C'], zW[1] + a2 * tr['theta_C'] - tr['z_C']]
    rate = [vW[0] + a1 * tr['omega_C'] - tr['v_C'], vW[1] + a2 * tr['omega_C'] - tr['v_C']]
    k = [DESIGN['k_S1'], DESIGN['k_S2']]
    c = [DESIGN['c_S1'], DESIGN['c_S2']]
    kT = [v.front.tyre_stiffness, v.rear.tyre_stiffness]
    tyre = [tr['delta'][:, 0] - zW[0], tr['delta'][:, 1] - zW[1]]
    _, ddelta = wheel_road_inputs(cfg.road_profile(), t, 10.0, (0.0, v.wheelbase))
    pot = sum(0.5 * k[i] * defl[i] ** 2 + 0.5 * kT[i] * tyre[i] ** 2 for i in range(2))
    energy = kin + pot
    dissipation = sum(c[i] * rate[i] ** 2 for i in range(2))
    road_power = sum(kT[i] * tyre[i] * ddelta[i] for i in range(2))
    from scipy.integrate import cumulative_trapezoid

    balance = energy - cumulative_trapezoid(road_power - dissipation, t, initial=0.0)
    assert np.max(np.abs(balance)) < 1e-5 * np.max(energy)


def test_reference_scales_make_f_one():
    cfg = StudyConfig()
    (s,) = reference_scales(cfg)
    tr = simulate(cfg, 'low')
    np.testing.assert_allclose(tr.J, [s[t] for t in cfg.terms()], rtol=1e-7)
    assert all(v > 0 for v in s.values())


@pytest.mark.parametrize('fidelity', ['low', 'mixed'])
def test_verification_tolerances_give_the_integrals_far_inside_the_check(fidelity):
    """Where the verification integrates by DOP853 (the mixed model, a nonlinear
    low-fidelity one) it does so at VERIFY_RTOL: its J_k agree with a tight integration
    (rtol 1e-10) to 1e-5, hundreds of times inside VERIFY_TOLERANCE — and the looser 1e-3
    of the initial guess would not (so the comparison can fail)."""
    from suspopt.verification.verify import VERIFY_ATOL, VERIFY_RTOL, VERIFY_TOLERANCE

    cfg = config_from_dict({'maneuver': {'horizon': 5.0 if fidelity == 'low' else 2.5}})
    design, end = cfg.design.initial(), np.array([0.0, cfg.maneuver.horizon])

    def march(rtol: float, atol: float) -> np.ndarray:
        return simulate(cfg, fidelity, design, rtol=rtol, atol=atol, t_eval=end, method='DOP853').J

    tight = march(1e-10, 1e-13)
    check = march(VERIFY_RTOL, VERIFY_ATOL)
    assert np.max(np.abs(check / tight - 1.0)) < 1e-5 < VERIFY_TOLERANCE / 100
    rough = march(1e-3, 1e-6)
    assert np.max(np.abs(rough / tight - 1.0)) > 1e-5
