"""A semi-active damper only dissipates (``docs/codesign.md``): its force is ``c v`` with
``c`` in ``[c_min, c_max]``, ``c_min >= 0``, so the power it takes from the suspension,
``F v``, is never negative, whatever its command. Checked on the vehicle, by time
marching of both fidelities under a command that leaves the range, from the marched
force and compression rate (not the model's own power signal); and in the NLP, where the
open-loop damping is a Dymos control bounded by ``[c_min, c_max]``."""

from __future__ import annotations

import numpy as np
import pytest

from suspopt.errors import ConfigError
from suspopt.models.assembly import controls
from suspopt.records.control import ControlHistory
from suspopt.spec import config_from_dict
from suspopt.transcription.vehicle import vehicle_spec
from suspopt.verification.timemarching import simulate

C_MIN, C_MAX = 300.0, 4000.0
HORIZON = 0.3
SEGMENTS = 6


def semi_active(c_min: float = C_MIN, c_max: float = C_MAX):
    return config_from_dict(
        {
            'vehicle': {'model': 'quarter_car'},
            'maneuver': {'speed': 10.0, 'horizon': HORIZON},
            'road': {'profile': 'bump', 'start': 0.5, 'length': 2.0, 'height': 0.05},
            'transcription': {'segments': SEGMENTS, 'order': 3},
            'control': {'kind': 'semi_active', 'c_min': c_min, 'c_max': c_max},
        }
    )


def wild_command(segments: int = SEGMENTS) -> ControlHistory:
    """A damping command at the LGR points of every segment, most of it beyond the
    damper's range on either side (negative: a push the damper cannot give)."""
    rng = np.random.default_rng(7)
    tau = np.array([-1.0, -0.2898979485566355, 0.6898979485566358])
    return ControlHistory.radau(
        name='c_A',
        units='N*s/m',
        corners=('1',),
        scenario='main',
        segment_ends=np.linspace(0.0, HORIZON, segments + 1),
        tau=tau,
        values=rng.uniform(-3000.0, 9000.0, size=(segments * tau.size, 1)),
    )


@pytest.mark.parametrize('fidelity', ['low', 'mixed'])
def test_a_semi_active_damper_only_dissipates(fidelity):
    cfg = semi_active()
    t = np.linspace(0.0, HORIZON, 301)
    # loose tolerances: the bound holds at every instant of any trajectory, accurate or not
    tr = simulate(cfg, fidelity, controls=(wild_command(),), t_eval=t, rtol=1e-4, atol=1e-7)
    F, v = tr['u_F'][:, 0], tr['v_A'][:, 0]
    assert np.abs(v).max() > 0.05  # the bump moves the damper
    power = F * v
    assert np.all(power >= 0.0), power.min()
    # the bounded-coefficient form: c_min v² <= F v <= c_max v² at every instant
    scale = 1e-9 * C_MAX * v.max() ** 2
    assert np.all(power >= C_MIN * v * v - scale)
    assert np.all(power <= C_MAX * v * v + scale)
    # and it is the force that acts on the chassis
    np.testing.assert_array_equal(tr['F_A'][:, 0], F)


def test_the_open_loop_damping_is_bounded_in_the_nlp():
    cfg = semi_active()
    (ctrl,) = controls(vehicle_spec(cfg, cfg.scenarios()[0], 'low'))
    assert (ctrl.name, ctrl.lower, ctrl.upper) == ('c_A', C_MIN, C_MAX)


def test_a_negative_damping_is_refused():
    with pytest.raises(ConfigError) as err:
        semi_active(c_min=-100.0)
    assert any(p.startswith('control.c_min:') for p in err.value.problems), err.value.problems
