"""The spectral method on a study (suspopt.studies.spectral, ``evaluate``/``optimize
--method spectral``): the normalization, what is refused, the constraints as RMS limits,
and the stationary optimum against the quarter car's closed form and against SciPy."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.optimize import minimize

from suspopt.cli.main import main
from suspopt.errors import ConfigError
from suspopt.models.metrics import static_loads
from suspopt.output.rundir import read_record
from suspopt.records.spectral import SpectralRecord
from suspopt.spec.load import config_from_dict
from suspopt.spectral import StationaryModel
from suspopt.studies.spectral import (
    evaluate_spectral,
    optimize_spectral_study,
    spectral_cases,
)

ISO = {'profile': 'iso8608', 'road_class': 'C'}
SEAT = {'seats': [{'name': 'driver'}]}
WEIGHTS = {'comfort': 0.5, 'tyre_load': 0.5}


def study(model: str, **more):
    data = {
        'vehicle': {'model': model},
        'road': ISO,
        'maneuver': {'speed': 20.0},
        'comfort': SEAT,
        'objective': {'weights': WEIGHTS},
    }
    data.update(more)
    return config_from_dict(data)


# ---------------------------------------------------------------------------- evaluate
@pytest.mark.parametrize('model', ['quarter_car', 'half_car', 'full_car'])
def test_reference_normalization_makes_f_one_at_the_initial_design(model):
    cfg = study(model)
    rec = evaluate_spectral(cfg)
    assert rec.success and rec.mode == 'evaluate' and rec.objective == pytest.approx(1.0, 1e-12)
    (sc,) = rec.scenarios
    (case,) = spectral_cases(cfg)
    var = StationaryModel(case.system, case.road, sc.pade_order).variances(
        case.system.design_vector(cfg.design.initial())
    )
    assert sc.scales == pytest.approx(dict(zip(case.system.outputs, var)), rel=1e-12)
    assert sc.rms == pytest.approx(dict(zip(case.system.outputs, np.sqrt(var))), rel=1e-12)
    # another design: f = Σ w_k Var_k / Var_k(initial)
    other = {n: 1.2 * v for n, v in cfg.design.initial().items()}
    rec2 = evaluate_spectral(cfg, other)
    f = sum(w * rec2.rms[t] ** 2 / sc.scales[t] for t, w in cfg.objective.weights.items() if w)
    assert rec2.objective == pytest.approx(f, rel=1e-12) and rec2.objective != 1.0


def test_custom_scales_are_the_expected_time_domain_objective_over_the_horizon():
    """``custom`` scales S_k of J_k over the horizon T: f = Σ w_k T Var_k / S_k."""
    scales = {'heave': 3.0, 'tyre_load_1': 2.0e7}
    cfg = study(
        'quarter_car',
        objective={
            'weights': {'heave': 0.7, 'tyre_load': 0.3},
            'normalization': 'custom',
            'scales': scales,
        },
        maneuver={'speed': 20.0, 'horizon': 8.0},
    )
    rec = evaluate_spectral(cfg)
    want = 8.0 * (0.7 * rec.rms['heave'] ** 2 / 3.0 + 0.3 * rec.rms['tyre_load_1'] ** 2 / 2.0e7)
    assert rec.objective == pytest.approx(want, rel=1e-12)


def test_scenarios_combine_as_in_the_time_domain():
    base = {
        'vehicle': {'model': 'half_car'},
        'road': ISO,
        'comfort': SEAT,
        'objective': {'weights': WEIGHTS},
    }
    scen = [
        {'name': 'city', 'speed': 10.0, 'weight': 1.0},
        {'name': 'highway', 'speed': 30.0, 'weight': 3.0, 'road': ISO | {'road_class': 'B'}},
    ]
    rec = evaluate_spectral(
        config_from_dict(base | {'scenario': scen}),
        {'k_S1': 25000.0, 'k_S2': 35000.0, 'c_S1': 2500.0, 'c_S2': 3500.0},
    )
    city, highway = rec.scenarios
    assert (city.road.speed, highway.road.speed, highway.road.road_class) == (10.0, 30.0, 'B')
    assert rec.objective == pytest.approx(city.objective + 3.0 * highway.objective, rel=1e-12)
    unweighted = [{k: v for k, v in sc.items() if k != 'weight'} for sc in scen]
    worst = config_from_dict(
        base | {'scenario': unweighted, 'objective': base['objective'] | {'aggregate': 'max'}}
    )
    assert evaluate_spectral(worst, rec.design).objective == pytest.approx(
        max(city.objective, highway.objective), rel=1e-12
    )


# ---------------------------------------------------------------------------- refused
def test_a_weighted_wheel_displacement_is_refused_in_one_line():
    cfg = config_from_dict(  # the paper's weights
        {
            'vehicle': {'model': 'full_car'},
            'objective': {'weights': {'heave': 1 / 6, 'pitch': 1 / 6, 'roll': 1 / 6, 'wheel': 0.5}},
        }
    )
    with pytest.raises(ConfigError) as err:
        evaluate_spectral(cfg)
    (line,) = err.value.problems
    assert line.startswith('objective.weights.wheel_1L (and wheel_1R, wheel_2L, wheel_2R): ')
    assert 'no stationary variance' in line and 'tyre_load_1L' in line and 'travel_1L' in line


def test_a_road_that_is_not_iso_8608_is_refused_naming_its_key():
    with pytest.raises(ConfigError) as err:
        evaluate_spectral(study('half_car', road={'profile': 'two_bumps'}))
    assert err.value.problems[0].startswith('road.profile: the spectral method needs')
    two = [{'name': 'a', 'speed': 10.0}, {'name': 'b', 'speed': 20.0, 'road': {'profile': 'step'}}]
    cfg = study('half_car', scenario=two)
    with pytest.raises(ConfigError) as err:
        evaluate_spectral(cfg)
    assert err.value.problems[0].startswith('scenario[1].road.profile: ')
    with pytest.raises(ConfigError, match=r'^scenario: the spectral optimization takes one road'):
        optimize_spectral_study(study('half_car', scenario=[two[0], two[1] | {'road': ISO}]))


def test_independent_tracks_drop_the_travel_of_a_warped_car_and_refuse_its_weight():
    """The default full car's front and rear tracks differ: on independent tracks its
    travel and tyre loads have no stationary variance (docs/spectral.md, section 3)."""
    road = ISO | {'coherence': 'independent'}
    rec = evaluate_spectral(study('full_car', road=road, objective={'weights': {'comfort': 1.0}}))
    (sc,) = rec.scenarios
    assert set(sc.not_stationary) == {
        f'{k}_{c}' for k in ('tyre_load', 'travel') for c in ('1L', '1R', '2L', '2R')
    }
    assert set(sc.rms) == {'heave', 'pitch', 'roll', 'comfort_driver'}
    with pytest.raises(ConfigError, match=r'^road.coherence: on independent tracks'):
        evaluate_spectral(study('full_car', road=road))


# ---------------------------------------------------------------------------- optimize
def _closed_form_quarter_car(cfg, q: float, rms_travel: float | None) -> tuple[float, float]:
    """Minimum sprung-acceleration variance with RMS travel <= ℓ (docs/spectral.md,
    section 7): k at its lower bound, c = max(c*, q (m_s+m_u)/(2ℓ²)), c* = k √((m_s+m_u)/k_t),
    clipped to c's bounds."""
    v = cfg.vehicle
    m, kt = v.chassis_mass + v.front.wheel_mass, v.front.tyre_stiffness
    k = cfg.design['k_S1'].lower
    c = k * np.sqrt(m / kt)
    if rms_travel is not None:
        c = max(c, q * m / (2.0 * rms_travel**2))
    return k, float(np.clip(c, cfg.design['c_S1'].lower, cfg.design['c_S1'].upper))


@pytest.mark.parametrize('travel', [None, 0.015])
def test_the_quarter_car_optimum_is_the_closed_form(travel):
    design = {
        'k_S1': {'initial': 20000.0, 'lower': 5000.0, 'upper': 60000.0},
        'c_S1': {'initial': 1500.0, 'lower': 100.0, 'upper': 6000.0},
    }
    more = (
        {} if travel is None else {'constraints': {'travel': {'bump': 3 * travel, 'rebound': 0.1}}}
    )
    cfg = study('quarter_car', design=design, objective={'weights': {'heave': 1.0}}, **more)
    rec = optimize_spectral_study(cfg)
    (case,) = spectral_cases(cfg)
    k, c = _closed_form_quarter_car(cfg, case.road.velocity_intensity(), travel)
    assert rec.success and rec.mode == 'optimize'
    assert rec.design == pytest.approx({'k_S1': k, 'c_S1': c}, rel=1e-6)
    if travel is not None:
        (lim,) = rec.limits
        assert (lim.term, lim.key, lim.rms_limit) == (
            'travel_1',
            'constraints.travel.bump',
            pytest.approx(travel, rel=1e-15),
        )
        assert lim.active and lim.multiplier > 0.0


def test_constraints_become_rms_limits():
    cfg = study(
        'half_car',
        constraints={
            'travel': {'bump': 0.09, 'rebound': 0.12},
            'tyre_contact': {'margin': 0.25},
            'ride_frequency': {'heave': [0.8, 1.6]},
        },
    )
    rec = optimize_spectral_study(cfg, sigmas=2.5)
    v = cfg.vehicle
    static = static_loads(
        cfg.layout(), v.chassis_mass, np.array([v.front.wheel_mass, v.rear.wheel_mass])
    )
    lims = {lim.term: lim for lim in rec.limits}
    assert set(lims) == {'travel_1', 'travel_2', 'tyre_load_1', 'tyre_load_2'}
    assert lims['travel_2'].rms_limit == pytest.approx(0.09 / 2.5, rel=1e-15)
    assert lims['tyre_load_2'].rms_limit == pytest.approx(0.75 * static[1] / 2.5, rel=1e-15)
    assert lims['tyre_load_1'].key == 'constraints.tyre_contact.margin'
    assert rec.success
    for lim in rec.limits:
        assert lim.rms == rec.rms[lim.term] <= lim.rms_limit * (1 + 1e-7)
    (warning,) = rec.warnings
    assert warning.startswith('constraints.ride_frequency: not applied by the spectral method')


def test_the_half_car_optimum_agrees_with_scipy():
    """IPOPT's stationary optimum (adjoint gradients, exact Hessian) against SciPy's SLSQP
    on the same objective and RMS limits, with its own finite-difference gradients."""
    design = {
        'k_S1': {'initial': 30000.0, 'lower': 10000.0, 'upper': 50000.0},
        'k_S2': {'initial': 30000.0, 'lower': 10000.0, 'upper': 50000.0},
        'c_S1': {'initial': 3000.0, 'lower': 500.0, 'upper': 5000.0},
        'c_S2': {'initial': 3000.0, 'lower': 500.0, 'upper': 5000.0},
    }
    cfg = study('half_car', design=design, constraints={'travel': {'bump': 0.035, 'rebound': 0.05}})
    rec = optimize_spectral_study(cfg)
    assert rec.success
    (case,) = spectral_cases(cfg)
    (sc,) = rec.scenarios
    model = StationaryModel(case.system, case.road, sc.pade_order)
    outs = case.system.outputs
    w = np.array([rec.weights.get(t, 0.0) / sc.scales[t] for t in outs])
    rows = [outs.index(lim.term) for lim in rec.limits]
    limits = np.array([lim.rms_limit for lim in rec.limits])
    p0 = case.system.design_vector(cfg.design.initial())
    lo, hi = (np.array([b[i] for b in cfg.design.bounds().values()]) for i in (0, 1))

    def var(x):
        return model.variances(x * p0)

    res = minimize(
        lambda x: w @ var(x),
        np.ones(4),
        method='SLSQP',
        bounds=list(zip(lo / p0, hi / p0)),
        constraints=[{'type': 'ineq', 'fun': lambda x: 1.0 - var(x)[rows] / limits**2}],
        options={'ftol': 1e-12, 'maxiter': 500},
    )
    assert res.success, res.message
    assert rec.objective == pytest.approx(res.fun, rel=1e-6)
    np.testing.assert_allclose(case.system.design_vector(rec.design), res.x * p0, rtol=1e-3)
    assert any(lim.active for lim in rec.limits)  # the travel limit shapes the optimum


def test_a_held_variable_keeps_its_value():
    design = {
        'k_S1': {'initial': 20000.0, 'lower': 5000.0, 'upper': 60000.0, 'optimize': False},
        'c_S1': {'initial': 1500.0, 'lower': 300.0, 'upper': 6000.0},
    }
    rec = optimize_spectral_study(study('quarter_car', design=design))
    assert rec.success and rec.design['k_S1'] == 20000.0 and rec.design['c_S1'] != 1500.0


# ---------------------------------------------------------------------------- command line
QUARTER_TOML = """
[vehicle]
model = "quarter_car"
[road]
profile = "iso8608"
road_class = "D"
[maneuver]
speed = 15.0
[objective.weights]
heave = 0.5
tyre_load = 0.5
[constraints.travel]
bump = 0.06
rebound = 0.08
"""


def test_the_commands(tmp_path, capsys):
    toml = tmp_path / 'q.toml'
    toml.write_text(QUARTER_TOML)
    out = tmp_path / 'run'
    argv = ['optimize', '--fidelity', 'low', '--method', 'spectral', '--config', str(toml)]
    assert main([*argv, '--out', str(out), '--quiet']) == 0
    printed = capsys.readouterr().out
    assert '**Stationary (spectral) optimize**' in printed and 'ISO 8608 class D' in printed
    assert {p.name for p in out.iterdir()} >= {'manifest.json', 'spectral.json', 'table.md'}
    rec = read_record(out, SpectralRecord)
    assert rec.success and rec.config is not None and rec.limits[0].term == 'travel_1'
    table = (out / 'table.md').read_text()
    (out / 'table.md').unlink()
    assert main(['report', str(out)]) == 0 and (out / 'table.md').read_text() == table
    capsys.readouterr()

    (hint,) = [line for line in printed.splitlines() if '--start' in line]
    design = hint.split('--start ')[1]  # the time-domain steps' start, as printed
    ev = ['evaluate', '--fidelity', 'low', '--method', 'spectral', '--config', str(toml)]
    assert main([*ev, '--design', design]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data['kind'] == 'spectral' and data['mode'] == 'evaluate'
    assert data['objective'] == pytest.approx(rec.objective, rel=1e-5)
    assert data['rms'] == pytest.approx(rec.rms, rel=1e-5)

    assert main([*ev, '--fidelity', 'mixed']) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith('suspopt: error: --fidelity: the spectral method takes the low')
    assert main(['evaluate', '--fidelity', 'low', '--method', 'spectral']) == 2  # two bumps
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith('suspopt: error: road.profile: the spectral method needs')
