"""Nonlinear hardware in studies (docs/nonlinear_hardware.md): collocation against time
marching through a bump stop's contact in both fidelities, the NLP's total derivatives
w.r.t. curve parameters, the black box's cost per Jacobian with curve settings, and the
coloring cache's key."""

from __future__ import annotations

import dataclasses
from contextlib import contextmanager

import numpy as np
import pytest

from suspopt.multibody.components import SuspensionDynamicsComp
from suspopt.spec.load import config_from_dict
from suspopt.studies.run import evaluate
from suspopt.transcription.coloring_cache import coloring_key
from suspopt.transcription.problem import VehicleProblem
from suspopt.verification.timemarching import simulate

DIGRESSIVE = {
    'c_bump_low': 1500.0,
    'v_bump_knee': 0.1,
    'c_bump_high': 700.0,
    'c_rebound_low': 3000.0,
    'v_rebound_knee': 0.1,
    'c_rebound_high': 1400.0,
}
GAP = 0.02


def quarter_car(segments: int = 24, stop: bool = True, **design) -> dict:
    """The default quarter car over an 8 cm bump at 10 m/s, through its first rebound: the
    bump stop engages (the test checks by how much). Every metric weighted (travel and
    tyre load too)."""
    front: dict = {'damper_curve': DIGRESSIVE}
    if stop:
        front['bump_stop'] = {'gap': GAP, 'coefficients': [5.0e6]}
    return {
        'vehicle': {'model': 'quarter_car', 'front': front},
        'maneuver': {'speed': 10.0, 'horizon': 0.8},
        'road': {'profile': 'bump', 'height': 0.08, 'length': 2.0, 'start': 2.0},
        'transcription': {'segments': segments},
        'objective': {
            'normalization': 'custom',
            'weights': {'heave': 1.0, 'wheel': 1.0, 'tyre_load': 1.0, 'travel': 1.0},
            'scales': {'heave': 1.0, 'wheel_1': 1e-4, 'tyre_load_1': 1e6, 'travel_1': 1e-4},
        },
        'design': design or {'c_bump_low_1': {}, 'c_rebound_low_1': {}, 'bump_gap_1': {}},
    }


#: the stop's gap in each fidelity: at the wheel (low), along the paper's double
#: wishbone's spring (mixed; its motion ratio is 0.45)
GAPS = {'low': 0.02, 'mixed': 0.008}


@pytest.mark.parametrize('fidelity', ['low', pytest.param('mixed', marks=pytest.mark.slow)])
def test_collocation_matches_time_marching_through_bump_stop_contact(fidelity):
    """Collocation (24 segments over 0.8 s) and time marching agree on every weighted
    term within the verification's tolerance, on a road where the bump stop engages: the
    compression at the collocation nodes passes the gap by a margin (low: the travel;
    mixed: the spring element's compression along its axis, relative to the chassis)."""
    d = quarter_car()
    d['vehicle']['front']['bump_stop']['gap'] = GAPS[fidelity]
    cfg = config_from_dict(d)
    scales = ({t: cfg.objective.scales.get(t, 1.0) for t in cfg.terms()},)
    with VehicleProblem(cfg, fidelity, scales) as vp:
        rec = evaluate(cfg, fidelity, scales=scales, problem=vp)
        ts = vp.timeseries().values
        if fidelity == 'low':
            compression = np.ravel(ts['travel'])
        else:
            mod = next(iter(vp.modules.values()))
            kin = mod.kinematics(np.ravel(ts['z_W']), np.ravel(ts['v_W']))
            spring = mod.solver.spring(mod.spring_name, kin.state.q, kin.state.qd)
            e_z = mod.axis_vertical(kin.state)
            compression = -np.ravel(spring.deflection) - e_z * np.ravel(ts['z_M'])
    assert rec.success and rec.verification.state.value == 'verified', rec.verification
    assert rec.verification.comparison.max_rel_diff < 5e-3
    assert compression.max() > GAPS[fidelity] + 0.015, compression.max()


def _reduced_check(cfg, fidelity: str, names: tuple[str, ...]) -> float:
    """check_totals of the NLP's objective and defects w.r.t. design variables ``names``
    at a non-converged point (the low fidelity's time-marched states): the largest
    difference of analytic (MAUD: analytic partials, and the black box's differences) and
    central-difference totals, relative to each block's largest entry."""
    with VehicleProblem(cfg, fidelity, ({t: 1.0 for t in cfg.terms()},)) as vp:
        x0 = cfg.design.initial()
        vp.set_design(x0)
        vp.set_initial_guess(simulate(cfg, 'low', x0, rtol=1e-7, atol=1e-10))
        p = vp.problem
        p.run_model()
        of = ['objective.f'] + [c.name for c in vp.driver.layout().constraints]
        data = p.check_totals(
            of=of,
            wrt=[vp.design_var(n) for n in names],
            method='fd',
            form='central',
            step=1e-4,
            step_calc='rel',
            out_stream=None,
            driver_scaling=False,
        )
    worst = 0.0
    for d in data.values():
        J_fd, J_an = np.asarray(d['J_fd']), np.asarray(d['J_fwd'])
        scale = max(np.max(np.abs(J_fd)), 1e-30)
        worst = max(worst, np.max(np.abs(J_an - J_fd)) / scale)
    return worst


@pytest.mark.parametrize('fidelity', ['low', 'mixed'])
def test_total_derivatives_with_respect_to_curve_parameters(fidelity):
    """The gradient the optimizer gets w.r.t. the damper's slopes and the stop's gap
    (analytic partials of the curves in the low fidelity, the black box's differences of
    its curve settings in the mixed) against central differences of the whole NLP (whose
    own error is first order where the stop's contact, C¹, lies between the points)."""
    cfg = config_from_dict(quarter_car())
    cfg = cfg.replace(transcription=dataclasses.replace(cfg.transcription, segments=10))
    names = ('c_bump_low_1', 'c_rebound_low_1', 'bump_gap_1')
    assert set(names) <= set(cfg.design_names())
    worst = _reduced_check(cfg, fidelity, names)
    assert worst < (1e-5 if fidelity == 'low' else 1e-4), worst


@contextmanager
def counted(cls):
    """Count the black-box queries (``evaluate`` calls) of a component class."""
    count = [0]
    original = cls.evaluate

    def evaluate(self, values):
        count[0] += 1
        return original(self, values)

    cls.evaluate = evaluate
    try:
        yield count
    finally:
        cls.evaluate = original


def test_black_box_jacobian_costs_one_call_per_designed_setting_whatever_the_nodes():
    """The mixed model's dynamic analysis differences its node-wise inputs and only the
    settings that are design variables (``k_S`` and the named curve parameters; not the
    curves' other parameters, nor ``c_S``, which the damper curve replaced): the same
    number of batched calls per Jacobian at 4 and 8 segments."""
    calls = {}
    for segments in (4, 8):
        cfg = config_from_dict(
            {
                'vehicle': {
                    'front': {
                        'damper_curve': DIGRESSIVE,
                        'bump_stop': {'gap': 0.03, 'coefficients': [1e6]},
                    },
                    'rear': {
                        'damper_curve': DIGRESSIVE,
                        'bump_stop': {'gap': 0.03, 'coefficients': [1e6]},
                    },
                },
                'design': {'c_bump_low_1': {}, 'c_rebound_low_2': {}, 'bump_gap_1': {}},
            }
        )
        cfg = cfg.replace(transcription=dataclasses.replace(cfg.transcription, segments=segments))
        with VehicleProblem(cfg, 'mixed', ({t: 1.0 for t in cfg.terms()},)) as vp:
            comp = vp.problem.model.traj.phases.s0.rhs_all.dynamics
            inputs = set(comp._var_rel_names['input'])
            assert {'c_bump_low', 'c_rebound_low', 'bump_gap'} <= inputs
            assert not {'c_bump_high', 'v_bump_knee', 'bump_k2'} & inputs
            vp.problem.run_model()
            with counted(SuspensionDynamicsComp) as count:
                vp.problem.model.run_linearize()
            calls[segments] = count[0]
    node_inputs = len(SuspensionDynamicsComp.NODE_INPUTS)
    assert calls[4] == calls[8] == node_inputs + 1 + 3, calls  # k_S and three curve settings


def test_the_coloring_key_follows_the_curves_forms_not_their_values():
    base = {'vehicle': {'front': {'damper_curve': DIGRESSIVE}}, 'design': {'c_bump_low_1': {}}}
    key = coloring_key(config_from_dict(base), 'low')
    assert key != coloring_key(config_from_dict({}), 'low')
    softer = {**DIGRESSIVE, 'c_bump_high': 500.0}
    same = {'vehicle': {'front': {'damper_curve': softer}}, 'design': {'c_bump_low_1': {}}}
    assert coloring_key(config_from_dict(same), 'low') == key
    stop = {'damper_curve': DIGRESSIVE, 'bump_stop': {'gap': 0.03, 'coefficients': [1e6]}}
    other = {'vehicle': {'front': stop}, 'design': {'c_bump_low_1': {}}}
    assert coloring_key(config_from_dict(other), 'low') != key
