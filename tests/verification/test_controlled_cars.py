"""Controlled half and full cars (``docs/codesign.md``) against passive ones, by time
marching of both fidelities: a semi-active damper held at ``c0`` at every corner, and an
active force fed back from the compression rate alone (``u = g_rt v_A``), are each a
passive damper ``c0`` (``g_rt``) in parallel with the passive one, so the car moves as
the passive car with ``c_S + c0``. A corner's actuator acting on another corner, with the
wrong sign or along another line than the damper's would break the equality. (In the
mixed model the feedback law measures the wheel's travel rate, not the spring-damper's:
there it is a damper only up to the linkage's motion ratio, so the active case is the
low fidelity's; the semi-active damper acts on the element's own rate in both.)"""

from __future__ import annotations

import json
from typing import Any

import numpy as np
import pytest

from suspopt.records.control import ControlHistory
from suspopt.spec import config_from_dict
from suspopt.spec.vehicles import BMW_E90
from suspopt.verification.timemarching import simulate

HORIZON = 0.4
EXTRA = 700.0  # [N s/m]


def car(model: str, control: dict[str, Any] | None) -> Any:
    if model == 'full_car':
        data: dict[str, Any] = json.loads(json.dumps(BMW_E90))
    else:
        data = {'vehicle': {'model': 'half_car'}}
    data['maneuver'] = {'speed': 10.0, 'horizon': HORIZON}
    data['road'] = {'profile': 'bump', 'start': 1.0, 'length': 2.0, 'height': 0.04}
    data.pop('objective', None)
    if control is not None:
        data['control'] = control
    return config_from_dict(data)


def passive_design(cfg: Any) -> dict[str, float]:
    return {k: v + EXTRA if k.startswith('c_S') else v for k, v in cfg.design.initial().items()}


CASES = [
    ('half_car', 'low', 'semi_active'),
    ('half_car', 'low', 'active'),
    ('full_car', 'low', 'semi_active'),
    ('full_car', 'low', 'active'),
    pytest.param('full_car', 'mixed', 'semi_active', marks=pytest.mark.slow),
]


@pytest.mark.parametrize('model, fidelity, kind', CASES)
def test_a_constant_damping_is_a_passive_damper(model, fidelity, kind):
    if kind == 'semi_active':
        cfg = car(model, {'kind': 'semi_active', 'c_min': 100.0, 'c_max': 3000.0})
        labels = cfg.controlled()
        held = ControlHistory.constant(
            name='c_A', units='N*s/m', corners=labels, scenario='', horizon=HORIZON, value=EXTRA
        )
        design, controls = cfg.design.initial(), [held]
    else:
        cfg = car(model, {'kind': 'active', 'law': 'feedback'})
        design = {
            k: (EXTRA if k.startswith('g_rt') else 0.0) if k.startswith('g_') else v
            for k, v in cfg.design.initial().items()
        }
        controls = []
    passive = car(model, None)
    t = np.linspace(0.0, HORIZON, 81)
    kw: dict[str, Any] = dict(t_eval=t, rtol=1e-7, atol=1e-10)
    mine = simulate(cfg, fidelity, design, controls=controls, **kw)
    theirs = simulate(passive, fidelity, passive_design(passive), **kw)
    assert np.abs(theirs['z_C']).max() > 1e-3  # the bump moves the car
    for name in ('z_C', 'v_C', 'z_W', 'F_T'):
        want = theirs[name]
        np.testing.assert_allclose(mine[name], want, atol=1e-5 * np.abs(want).max(), err_msg=name)
