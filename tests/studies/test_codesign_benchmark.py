"""The control co-design benchmark (``examples/codesign_benchmark.toml``; Herber &
Sundarrajan, after Allison, Guo & Han 2014) against its converged reference
(``benchmarks/results/codesign_reference.json``, a CasADi peer).

The fast tests run the reference's own control (its values at the LGR points of every
1 ms segment) and plant through suspopt's model by time marching over the first 0.2 s,
against the exact discretization of ``tests/benchmarks_data/test_codesign_reference.py``
(shares no code with suspopt) and the reference's states every 10 ms: the road (its
start on the road), the actuator's sign and line, the objective's mapping onto
suspopt's metrics and the control's polynomial between the points. The slow tests
optimize the whole benchmark, co-design and passive, and compare b*, k*, J*."""

from __future__ import annotations

import dataclasses
import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from suspopt.records.control import ControlHistory
from suspopt.spec import load_config
from suspopt.spec.schema import ControlConfig
from suspopt.verification.timemarching import simulate

ROOT = Path(__file__).resolve().parents[2]
STUDY = ROOT / 'examples' / 'codesign_benchmark.toml'
REFERENCE = ROOT / 'benchmarks' / 'results' / 'codesign_reference.json'
SHORT = 0.2  # [s]: 200 of the reference's segments


def _exact_objective():
    """``exact_objective`` of the reference's own check (an independent computation)."""
    path = ROOT / 'tests' / 'benchmarks_data' / 'test_codesign_reference.py'
    spec = importlib.util.spec_from_file_location('codesign_reference_check', path)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod.exact_objective


@pytest.fixture(scope='module')
def ref() -> dict:
    return json.loads(REFERENCE.read_text())


@pytest.fixture(scope='module')
def study():
    return load_config(STUDY)


def _short(study):
    return dataclasses.replace(
        study,
        maneuver=dataclasses.replace(study.maneuver, horizon=SHORT),
        transcription=dataclasses.replace(study.transcription, segments=30),
    )


def _reference_control(ref: dict, segments: int, horizon: float) -> ControlHistory:
    c = ref['codesign']['control_lgr']
    n = len(c['tau'])
    u = np.asarray(c['u'])[: segments * n]
    return ControlHistory.radau(
        name='u_A',
        units='N',
        corners=('1',),
        scenario='main',
        segment_ends=np.linspace(0.0, horizon, segments + 1),
        tau=np.asarray(c['tau']),
        values=u[:, None],
    )


def _objective(study, J: np.ndarray) -> float:
    w = study.objective.weights
    return float(sum(w[t] * j for t, j in zip(study.terms(), J)))


def test_the_study_file_is_the_benchmark(study, ref):
    p = ref['problem']
    v = study.vehicle
    assert (v.chassis_mass, v.front.wheel_mass, v.front.tyre_stiffness) == (
        p['m_s'],
        p['m_u'],
        p['k_t'],
    )
    assert study.design.bounds() == {'k_S1': tuple(p['k_bounds']), 'c_S1': tuple(p['b_bounds'])}
    w = study.objective.weights
    assert w['tyre_load_1'] * p['k_t'] ** 2 == pytest.approx(p['w1'], rel=1e-15)
    assert (w['heave'], w['control_1']) == (p['w2'], p['w3'])
    assert study.constraints.travel.bump == study.constraints.travel.rebound == p['r_max']
    assert study.control.kind == 'active' and study.road['relative_to_start'] is True


@pytest.mark.parametrize('problem', ['codesign', 'passive'])
def test_reference_design_and_control_through_the_model(study, ref, problem):
    """J over the first 0.2 s of the reference's plant (and control) by suspopt's time
    marching equals the exact discretization to 1e-7; the states every 10 ms equal the
    reference's."""
    r, p = ref[problem], dict(ref['problem'], horizon=SHORT)
    segments = round(SHORT / ref['grid']['segment_length_s'])
    config = _short(study)
    controls = ()
    if problem == 'passive':
        config = dataclasses.replace(config, control=ControlConfig())
    else:
        controls = (_reference_control(ref, segments, SHORT),)
    t = np.asarray(r['samples_10ms']['t'])
    t = t[t <= SHORT + 1e-12]
    tr = simulate(
        config,
        'low',
        {'k_S1': r['k'], 'c_S1': r['b']},
        controls=controls,
        t_eval=t,
        rtol=1e-9,
        atol=1e-13,
    )
    data = np.loadtxt(ROOT / 'examples' / 'data' / 'iri_737b.csv', delimiter=',', skiprows=1)
    road = CubicSpline(data[:, 0], data[:, 1], bc_type='not-a-knot')
    u = None if problem == 'passive' else np.asarray(r['control_lgr']['u'])[: 3 * segments]
    tau = np.asarray(r['control_lgr']['tau']) if u is not None else np.zeros(3)
    exact = _exact_objective()(p, road, r['b'], r['k'], u, tau)
    assert _objective(config, tr.J) == pytest.approx(exact, rel=1e-7)
    # the original's states: tyre deflection, wheel velocity, rattlespace, body velocity
    s = r['samples_10ms']
    n = t.size
    mine = {
        'z_u - z_0': tr['z_W'][:, 0] - tr['delta'][:, 0],
        'dz_u/dt': tr['v_W'][:, 0],
        'z_s - z_u': tr['z_C'] - tr['z_W'][:, 0],
        'dz_s/dt': tr['v_C'],
    }
    for name, val in mine.items():
        want = np.asarray(s[name])[:n]
        np.testing.assert_allclose(val, want, atol=1e-6 * np.abs(want).max(), err_msg=name)


@pytest.mark.slow
@pytest.mark.parametrize('problem', ['codesign', 'passive'])
def test_the_benchmark_optimum(study, ref, problem):
    """The study file's optimum (10 ms segments of order 3), verified by time marching:
    J* and k* within 1e-4 of the converged reference, b* within 1 % (J is flat in b)."""
    from suspopt.studies.run import optimize
    from suspopt.verification.scales import resolve_scales

    config = study
    if problem == 'passive':
        weights = {t: w for t, w in study.objective.weights.items() if t != 'control_1'}
        config = dataclasses.replace(
            study,
            control=ControlConfig(),
            objective=dataclasses.replace(study.objective, weights=weights),
        )
    rec = optimize(config, 'low', scales=resolve_scales(config))
    r = ref[problem]
    assert rec.success and rec.verified
    assert rec.objective == pytest.approx(r['J'], rel=1e-4)
    assert rec.design['k_S1'] == pytest.approx(r['k'], rel=1e-4)
    assert rec.design['c_S1'] == pytest.approx(r['b'], rel=1e-2)
    assert rec.verification.comparison.objective == pytest.approx(r['J'], rel=1e-4)
    assert bool(rec.controls) == (problem == 'codesign')
