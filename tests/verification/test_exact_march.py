"""The exact time marching of the linear (low-fidelity) models: its numerics against closed
forms and quadrature, the vehicles against a tight DOP853 integration, the fallback to
DOP853 when the model is not linear, and the reference scales' cache."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad, quad_vec, solve_ivp
from scipy.interpolate import CubicHermiteSpline
from scipy.linalg import expm
from scipy.signal import lsim

import suspopt.verification.timemarching as tm
from suspopt.errors import ModelError
from suspopt.models.forces import SuspensionForceComp
from suspopt.road import wheel_road_inputs
from suspopt.spec.load import config_from_dict, full_car_defaults
from suspopt.spec.schema import StudyConfig
from suspopt.transcription import coloring_cache
from suspopt.verification import linear_march as lm
from suspopt.verification import road_sampling
from suspopt.verification.timemarching import reference_scales, simulate


# ------------------------------------------------------------------------- the numerics
def test_march_and_integrals_exact_for_a_cubic_input():
    """x' = -a x + u, y = x + d u with a cubic u: the state (closed form) and ∫ y² dt
    (adaptive quadrature of the closed form) on an irregular grid, to rounding."""
    a, d = 3.0, 0.5
    c = np.array([0.2, -1.0, 2.5, -0.8])  # u = c0 + c1 t + c2 t² + c3 t³
    p3 = c[3] / a
    p2 = (c[2] - 3 * p3) / a
    p1 = (c[1] - 2 * p2) / a
    p0 = (c[0] - p1) / a  # the polynomial particular solution; x(0) = 0

    def u(t):
        return c[0] + t * (c[1] + t * (c[2] + t * c[3]))

    def x(t):
        return p0 + t * (p1 + t * (p2 + t * p3)) - p0 * np.exp(-a * t)

    t = np.cumsum(np.r_[0.0, np.random.default_rng(1).uniform(0.05, 0.4, 12)])
    du = c[1] + t * (2 * c[2] + t * 3 * c[3])
    chain = lm.hermite_chain(t, u(t)[:, None], du[:-1, None], du[1:, None])
    marched = lm.march(np.array([[-a]]), np.array([[1.0]]), t, chain)
    np.testing.assert_allclose(marched.x[:, 0], x(t), rtol=1e-13, atol=1e-15)
    G = np.zeros((1, marched.F.shape[0]))
    G[0, 0], G[0, 1] = 1.0, d
    exact = quad(lambda s: (x(s) + d * u(s)) ** 2, 0.0, t[-1], epsabs=0, epsrel=1e-13)[0]
    np.testing.assert_allclose(marched.integrals(G), [exact], rtol=1e-12)
    inner = np.sort(np.random.default_rng(2).uniform(0.0, t[-1], 50))
    np.testing.assert_allclose(marched.states_at(inner)[:, 0], x(inner), rtol=1e-12, atol=1e-15)


def test_march_equals_lsim_for_a_piecewise_linear_input():
    """A stable MIMO system driven by a piecewise-linear input (Hermite slopes = each
    piece's own): the states equal SciPy's lsim (exact for such an input)."""
    rng = np.random.default_rng(3)
    n, m = 5, 2
    A = rng.standard_normal((n, n)) - 3.0 * np.eye(n)
    B = rng.standard_normal((n, m))
    t = np.linspace(0.0, 2.0, 201)
    u = rng.standard_normal((t.size, m))
    slope = np.diff(u, axis=0) / np.diff(t)[:, None]
    marched = lm.march(A, B, t, lm.hermite_chain(t, u, slope, slope))
    _, _, ref = lsim((A, B, np.eye(n), np.zeros((n, m))), u, t, interp=True)
    np.testing.assert_allclose(marched.x, ref, atol=1e-12 * np.max(np.abs(ref)))


def test_march_and_integrals_match_dop853_for_a_cubic_hermite_input():
    """A stable MIMO system, ``y = C x + D u``, driven by a C¹ piecewise-cubic input (SciPy's
    ``CubicHermiteSpline``, random slopes) on a grid of two interleaved step lengths: the
    states at the grid points and ``∫ y_i² dt`` equal DOP853 at rtol 1e-12 (restarted at
    every knot, where the input's second derivative jumps); shares no code with the
    march."""
    rng = np.random.default_rng(7)
    n, m, p = 6, 2, 3
    A = rng.standard_normal((n, n)) - 4.0 * np.eye(n)
    B, C, D = (rng.standard_normal(s) for s in ((n, m), (p, n), (p, m)))
    steps = 135
    t = np.r_[0.0, np.cumsum(np.where(rng.random(steps) < 0.5, 0.02, 0.037))]
    u, du = rng.standard_normal((t.size, m)), 5.0 * rng.standard_normal((t.size, m))
    road = CubicHermiteSpline(t, u, du, axis=0)

    def rates(s: float, z: np.ndarray) -> np.ndarray:
        x, us = z[:n], road(s)
        return np.concatenate([A @ x + B @ us, (C @ x + D @ us) ** 2])

    z = np.zeros(n + p)
    ref = [z[:n]]
    for a, b in zip(t[:-1], t[1:]):
        z = solve_ivp(rates, (a, b), z, method='DOP853', rtol=1e-12, atol=1e-14).y[:, -1]
        ref.append(z[:n])
    marched = lm.Propagator(A, B, t).march(lm.hermite_chain(t, u, du[:-1], du[1:]))
    np.testing.assert_allclose(marched.x, ref, rtol=0, atol=1e-11 * np.max(np.abs(ref)))
    G = np.zeros((p, marched.F.shape[0]))
    G[:, :n], G[:, n : n + m] = C, D
    np.testing.assert_allclose(marched.integrals(G), z[n:], rtol=1e-11)


def test_gramian_matches_quadrature():
    rng = np.random.default_rng(4)
    F = rng.standard_normal((6, 6)) * 20.0 - 5.0 * np.eye(6)
    W = rng.standard_normal((6, 3))
    S, h = W @ W.T, 0.3
    ref = quad_vec(lambda s: expm(F * s) @ S @ expm(F * s).T, 0.0, h, epsabs=0, epsrel=1e-13)[0]
    np.testing.assert_allclose(lm.gramian(F, S, h), ref, rtol=1e-10, atol=1e-12 * np.abs(ref).max())


# ------------------------------------------------------------------------- the vehicles
def _compare(cfg: StudyConfig, rtol_J: float, rtol_signals: float, horizon_points: int = 101):
    """The exact marching against DOP853 at rtol 1e-10: every J_k, and the recorded
    signals at the sample times (each relative to its largest magnitude; one that is
    zero, as the roll on a road equal under both tracks, to rounding)."""
    T = cfg.scenarios()[0].horizon
    t = np.linspace(0.0, T, horizon_points)
    exact = simulate(cfg, 'low', t_eval=t)
    ref = simulate(cfg, 'low', t_eval=t, method='DOP853', rtol=1e-10, atol=1e-13)
    assert exact.info['integrator'].startswith('exact')
    assert ref.info['integrator'].startswith('DOP853')
    np.testing.assert_allclose(exact.J, ref.J, rtol=rtol_J)
    assert set(exact.values) == set(ref.values)
    np.testing.assert_array_equal(exact.t, ref.t)
    for name, value in ref.values.items():
        scale = float(np.max(np.abs(value)))
        diff = float(np.max(np.abs(np.asarray(exact[name]) - value)))
        assert diff <= (rtol_signals * scale if scale > 0.0 else 1e-10), (name, diff, scale)
    return exact


def test_half_car_two_bumps_exact():
    """The paper's half car on its two bumps (cubic road between samples, refined to
    ROAD_TOLERANCE): J_k to 1e-9, the signals to 1e-9 of their ranges."""
    _compare(config_from_dict({'maneuver': {'horizon': 1.6}}), rtol_J=1e-9, rtol_signals=1e-9)


def test_quarter_car_step_exact():
    cfg = config_from_dict(
        {
            'vehicle': {'model': 'quarter_car'},
            'road': {'profile': 'step'},
            'maneuver': {'horizon': 1.5},
        }
    )
    _compare(cfg, rtol_J=1e-9, rtol_signals=1e-9)


def test_full_car_bars_seat_two_bumps_exact():
    """The full car with both anti-roll bars and an ISO 2631-1 seat filter (its states
    integrated with the vehicle's), on the paper's two bumps."""
    base = full_car_defaults().to_dict()
    cfg = config_from_dict(
        {
            **base,
            'road': {'profile': 'two_bumps'},
            'maneuver': {'speed': 10.0, 'horizon': 1.6},
            'comfort': {'seats': [{'name': 'driver', 'x': 0.4, 'y': 0.35}]},
        }
    )
    assert all(ax.anti_roll_bar for ax in cfg.vehicle.axles)
    tr = _compare(cfg, rtol_J=1e-9, rtol_signals=1e-9)
    assert 'a_w' in tr.values and 'F_R' in tr.values


def test_iso_road_exact_full_car_with_seat():
    """An ISO 8608 road is a cubic spline: sampled at its knots under every wheel it is
    marched exactly; DOP853 (which steps across the knots) agrees to its own accuracy."""
    base = full_car_defaults().to_dict()
    cfg = config_from_dict(
        {
            **base,
            'maneuver': {'speed': 20.0, 'horizon': 0.5},
            'comfort': {'seats': [{'name': 'driver', 'x': 0.4, 'y': 0.35}]},
        }
    )
    _compare(cfg, rtol_J=2e-8, rtol_signals=1e-7)


def test_sample_grid_resolves_the_road():
    """The grid holds the ISO road's knots under both axles and every bump's breakpoints,
    and between samples the cubic interpolant is within ROAD_TOLERANCE of the road
    (checked here at 15 points a step, not the three the grid is refined by; long steps
    allowed, so that the refinement places the samples)."""
    iso = config_from_dict(
        {'maneuver': {'speed': 20.0, 'horizon': 1.0}, 'road': {'profile': 'iso8608'}}
    )
    for cfg in (StudyConfig(), iso):
        sc = cfg.scenarios()[0]
        spec = tm.vehicle_spec(cfg, sc, 'low')
        t, (u, p, q) = road_sampling.sample_grid(spec, sc.horizon, 0.02)
        assert np.all(np.diff(t) <= 0.02 * (1 + 1e-9))
        for road, _, off in road_sampling.corner_roads(spec):
            knots = road.knots()
            assert (knots is not None) == (cfg is iso)
            marks = list(road.breakpoints()) + list(knots if knots is not None else [])
            for s in marks:
                when = (s + off) / sc.speed
                if 0.0 < when < sc.horizon:
                    assert np.min(np.abs(t - when)) < 1e-9 * sc.horizon
        chain = lm.hermite_chain(t, u, p, q)
        frac = np.linspace(0.0, 1.0, 17)[1:-1]
        k = np.repeat(np.arange(t.size - 1), frac.size)
        tau = np.tile(frac, t.size - 1) * np.diff(t)[k]
        cubic = lm.input_at(chain[k], tau)
        for road, corners, off in road_sampling.corner_roads(spec):
            true = wheel_road_inputs(road, t[k] + tau, sc.speed, (off,), rates=False)[0][0]
            err = np.max(np.abs(cubic[:, corners[0]] - true))
            assert err <= 1.2 * road_sampling.ROAD_TOLERANCE * np.max(np.abs(u)), err


def test_dense_path_signals_match_dop853():
    """``dense``: travel and tyre-load ratio along the whole drive, both methods; their
    extremes agree."""
    cfg = config_from_dict({'maneuver': {'horizon': 1.6}})
    names = ('travel', 'tyre_load_ratio')
    end = np.array([0.0, 1.6])
    a = simulate(cfg, 'low', t_eval=end, dense=names).info['dense']
    b = simulate(cfg, 'low', t_eval=end, dense=names, method='DOP853', rtol=1e-9, atol=1e-12).info[
        'dense'
    ]
    assert a.t[0] == 0.0 and a.t[-1] == 1.6 and np.all(np.diff(a.t) > 0)
    for name in names:
        assert a[name].shape == (a.t.size, 2) and b[name].shape == (b.t.size, 2)
        for ext in (np.max, np.min):
            np.testing.assert_allclose(ext(a[name], axis=0), ext(b[name], axis=0), rtol=2e-3)


# ----------------------------------------------------------- nonlinear models, fallbacks
def _nonlinear_spring(monkeypatch, force):
    """The low-fidelity suspension force plus ``force(travel)``."""
    original = SuspensionForceComp.evaluate

    def evaluate(self, inputs):
        out = original(self, inputs)
        x = np.asarray(inputs['z_W']) - np.asarray(inputs['z_M'])
        return {'F_S': out['F_S'] + force(x)}

    monkeypatch.setattr(SuspensionForceComp, 'evaluate', evaluate)


def test_nonlinear_curve_marched_by_relaxation(monkeypatch):
    """A progressive spring makes the low-fidelity model nonlinear: not exact, but the
    relaxation converges and agrees with a tight DOP853 integration."""
    cfg = config_from_dict({'maneuver': {'horizon': 1.6}})
    _nonlinear_spring(monkeypatch, lambda x: 4e6 * x**3)
    end = np.array([0.0, 1.6])
    tr = simulate(cfg, 'low', t_eval=end, rtol=1e-8)
    assert tr.info['integrator'].startswith('waveform relaxation')
    assert 'not linear' in tr.info['fallbacks']['exact']
    with pytest.raises(ModelError, match='exact time marching impossible'):
        simulate(cfg, 'low', t_eval=end, method='exact')
    ref = simulate(cfg, 'low', t_eval=end, method='DOP853', rtol=1e-10, atol=1e-13)
    np.testing.assert_allclose(tr.J, ref.J, rtol=1e-7)


def test_strong_nonlinearity_falls_back_to_dop853(monkeypatch):
    """A stop 150 times stiffer than the spring beyond 5 mm of travel: the relaxation
    does not contract, DOP853 integrates."""
    cfg = config_from_dict({'maneuver': {'horizon': 0.8}})
    _nonlinear_spring(monkeypatch, lambda x: 5e6 * np.sign(x) * np.maximum(np.abs(x) - 0.005, 0.0))
    end = np.array([0.0, 0.8])
    tr = simulate(cfg, 'low', t_eval=end)
    assert tr.info['integrator'].startswith('DOP853')
    assert set(tr.info['fallbacks']) == {'exact', 'relaxation'}
    with pytest.raises(ModelError, match='relaxation failed'):
        simulate(cfg, 'low', t_eval=end, method='relaxation')


def test_time_varying_input_is_not_marched_exactly(monkeypatch):
    """A force that varies with time (a control input) is caught by the probes."""
    original = SuspensionForceComp.evaluate

    def evaluate(self, inputs):
        out = original(self, inputs)
        gain = 1.0 + 0.2 * np.sin(7.0 * np.asarray(inputs['time']))
        return {'F_S': out['F_S'] * np.reshape(gain, (-1, 1))}

    monkeypatch.setattr(SuspensionForceComp, 'evaluate', evaluate)
    cfg = config_from_dict({'maneuver': {'horizon': 0.8}})
    asm = tm.vehicle_assembly(cfg, cfg.scenarios()[0], 'low')
    design = cfg.design.initial()
    with pytest.raises(tm.NonlinearModelError, match='not linear time-invariant'):
        tm.check_linear(asm, design, tm.linearize(asm, design), horizon=0.8)
    tr = simulate(cfg, 'low', t_eval=np.array([0.0, 0.8]))
    assert not tr.info['integrator'].startswith('exact')


def test_nonlinearity_met_along_the_trajectory_only_is_found(monkeypatch):
    """A stop the probes miss (engaged between 10 and 11 mm of travel only) is found by
    the check of every marched state against the linearization."""
    cfg = config_from_dict({'maneuver': {'horizon': 0.8}})
    _nonlinear_spring(
        monkeypatch, lambda x: np.where((np.abs(x) > 0.010) & (np.abs(x) < 0.011), 4e7 * x**3, 0.0)
    )
    tr = simulate(cfg, 'low', t_eval=np.array([0.0, 0.8]))
    assert 'along the trajectory' in tr.info['fallbacks']['exact']


def test_mixed_model_by_relaxation_matches_dop853():
    """The mixed-fidelity half car on the paper's bumps: the relaxation (its default for
    a nonlinear model) agrees with DOP853 at rtol 1e-10 about as well as ``rtol`` asks,
    the path signals' extremes too; the constraint residual of the linkages is tracked."""
    cfg = config_from_dict({'maneuver': {'horizon': 1.6}})
    t = np.linspace(0.0, 1.6, 41)
    dense = ('travel',)
    tr = simulate(cfg, 'mixed', t_eval=t, rtol=1e-8, dense=dense)
    ref = simulate(cfg, 'mixed', t_eval=t, method='DOP853', rtol=1e-10, atol=1e-13, dense=dense)
    for ext in (np.max, np.min):
        np.testing.assert_allclose(
            ext(tr.info['dense']['travel'], axis=0),
            ext(ref.info['dense']['travel'], axis=0),
            rtol=2e-3,
        )
    assert tr.info['integrator'].startswith('waveform relaxation')
    np.testing.assert_allclose(tr.J, ref.J, rtol=2e-8)
    for name in ('z_C', 'theta_C', 'zdd_C', 'F_S', 'q_W'):
        scale = np.max(np.abs(ref[name]))
        assert np.max(np.abs(tr[name] - ref[name])) <= 1e-7 * scale, name
    assert tr.info['max_constraint_residual_m'] < 1e-10
    from suspopt.verification.verify import VERIFY_RTOL, VERIFY_TOLERANCE

    check = simulate(cfg, 'mixed', t_eval=t, rtol=VERIFY_RTOL)  # what the verification runs
    assert np.max(np.abs(check.J / ref.J - 1.0)) < 2e-6 < VERIFY_TOLERANCE / 1000


def test_relaxation_jacobians_and_slopes():
    """The finite-difference Jacobians of a linear model equal its matrices (the rate
    that is a state exactly); the local slopes are exact for quartics and one-sided at a
    break."""
    from suspopt.verification import relaxation

    rng = np.random.default_rng(5)
    A = rng.standard_normal((4, 4))
    A[0] = [0.0, 1.0, 0.0, 0.0]
    B = rng.standard_normal((4, 2))
    Aj, Bj = relaxation.jacobians(
        lambda t, X, U: A @ X + B @ U, np.array([0.02, 0.2, 0.05, 1.0]), 2, 0.05
    )
    assert np.array_equal(Aj[0], A[0])
    np.testing.assert_allclose(Aj, A, rtol=1e-8, atol=1e-9)
    np.testing.assert_allclose(Bj, B, rtol=1e-8, atol=1e-9)
    t = np.sort(np.r_[0.0, rng.uniform(0.0, 1.0, 30), 1.0])
    cut = t[12]
    quartic = np.polynomial.Polynomial([0.3, -1.0, 2.0, 0.5, -1.5])
    right = np.polynomial.Polynomial([0.1, 4.0, -3.0])
    values = np.where(t <= cut, quartic(t), quartic(cut) + right(t - cut) - right(0.0))[:, None]
    start, end = relaxation.LocalSlopes(t, np.array([cut]))(values)
    d_left, d_right = quartic.deriv(), right.deriv()
    exact_start = np.where(t[:-1] < cut, d_left(t[:-1]), d_right(t[:-1] - cut))
    exact_end = np.where(t[1:] <= cut, d_left(t[1:]), d_right(t[1:] - cut))
    np.testing.assert_allclose(start[:, 0], exact_start, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(end[:, 0], exact_end, rtol=1e-9, atol=1e-9)


# ------------------------------------------------------------------------- scales' cache
def test_reference_scales_cached_and_invalidated(monkeypatch, tmp_path):
    monkeypatch.setenv('SUSPOPT_CACHE_DIR', str(tmp_path))
    calls = []
    real = tm.simulate

    def counting(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(tm, 'simulate', counting)
    base = StudyConfig()
    first = reference_scales(base)
    assert len(calls) == 1
    assert reference_scales(StudyConfig()) == first and len(calls) == 1  # reused
    assert reference_scales(base, cache=False) == first and len(calls) == 2
    np.testing.assert_allclose(
        [first[0][t] for t in base.terms()],
        simulate(base, 'low', t_eval=np.array([0.0, 5.0])).J,
        rtol=1e-15,
    )
    d = base.to_dict()
    changed = [
        {**d, 'vehicle': {**d['vehicle'], 'chassis_mass': d['vehicle']['chassis_mass'] + 1e-6}},
        {**d, 'road': {**d['road'], 'height': 0.051}},
        {**d, 'maneuver': {**d['maneuver'], 'horizon': 4.0}},
        {**d, 'maneuver': {**d['maneuver'], 'speed': 11.0}},
        {
            **d,
            'design': {
                **d['design'],
                'k_S1': {**d['design']['k_S1'], 'initial': d['design']['k_S1']['initial'] + 1.0},
            },
        },
        {**d, 'comfort': {'seats': [{'name': 'driver'}]}},
    ]
    for k, variant in enumerate(changed):
        reference_scales(config_from_dict(variant))
        assert len(calls) == 3 + k, variant
    monkeypatch.setattr(coloring_cache, 'source_digest', lambda entries=(): 'changed')
    reference_scales(base)
    assert len(calls) == 3 + len(changed)


def test_reference_scales_cache_follows_a_road_file(monkeypatch, tmp_path):
    """A measured road's file contents are part of the key (same path, new data)."""
    monkeypatch.setenv('SUSPOPT_CACHE_DIR', str(tmp_path / 'cache'))
    s = np.arange(0.0, 80.0, 0.05)
    path = tmp_path / 'road.csv'

    def write(height: float) -> None:
        h = height * np.exp(-(((s - 10.0) / 0.8) ** 2))
        path.write_text('distance,height\n' + '\n'.join(f'{a},{b}' for a, b in zip(s, h)))

    write(0.03)
    cfg = config_from_dict(
        {'road': {'profile': 'csv', 'file': str(path)}, 'maneuver': {'horizon': 2.0}}
    )
    a = reference_scales(cfg)
    assert reference_scales(cfg) == a
    write(0.04)
    b = reference_scales(config_from_dict(cfg.to_dict()))
    assert b[0]['heave'] == pytest.approx(a[0]['heave'] * (4 / 3) ** 2, rel=1e-9)
