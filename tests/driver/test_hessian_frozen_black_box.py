"""The exact Hessian of a controlled car's mixed-fidelity model leaves out the multibody
black boxes' own curvature (``hessian_frozen``, ``docs/codesign.md``): their partials
are finite differences, whose differences are noise. The analytic components' curvature
(the squared metrics, the actuator's products) stays; the open-loop co-design then
converges in about as many iterations as the low-fidelity one."""

from __future__ import annotations

import numpy as np
import pytest

from suspopt.multibody.components import NodewiseBlackBox
from suspopt.spec import config_from_dict
from suspopt.transcription.problem import VehicleProblem


def _problem(control: bool, segments: int = 8) -> VehicleProblem:
    effort = {'control_1': 0.2} if control else {}
    data = {
        'vehicle': {'model': 'quarter_car'},
        'maneuver': {'speed': 10.0, 'horizon': 1.0},
        'road': {'profile': 'bump', 'start': 2.0, 'length': 2.0, 'height': 0.04},
        'transcription': {'segments': segments, 'order': 3},
        'objective': {
            'weights': {'heave': 0.5, 'tyre_load_1': 0.5, **effort},
            'normalization': 'custom',
            'scales': {'heave': 1.0, 'tyre_load_1': 1e6, 'control_1': 1e5},
        },
    }
    if control:
        data['control'] = {'kind': 'active'}
    else:
        del data['objective']['scales']['control_1']
    cfg = config_from_dict(data)
    scales = ({t: cfg.objective.scales.get(t, 1.0) for t in cfg.terms()},)
    return VehicleProblem(cfg, 'mixed', scales, use_cache=False, hessian='exact')


def _black_boxes(vp: VehicleProblem) -> set[str]:
    return {
        c.pathname
        for c in vp.problem.model.system_iter(recurse=True)
        if isinstance(c, NodewiseBlackBox)
    }


@pytest.mark.parametrize('control', [False, True])
def test_a_controlled_cars_hessian_leaves_the_black_boxes_out(control):
    with _problem(control) as vp:
        vp.problem.run_model()
        drv = vp.driver
        drv.prepare()
        hs = drv.hessian_structure()
        flow = drv._flow()
        owners = {flow.deps[o][k].component for o, k in hs.varying}
        boxes = _black_boxes(vp)
        assert boxes
        # a passive car keeps them (as before); a controlled car's Hessian has none
        assert bool(owners & boxes) is (not control)
        assert owners - boxes  # the analytic components' curvature stays
        H = drv.hessian(drv.scaled_design(), np.ones(drv.layout().m), 1.0)
        assert np.all(np.isfinite(H))


def test_the_mixed_open_loop_converges_with_it():
    with _problem(True, segments=30) as vp:
        vp.set_design(vp.config.design.initial())
        rec = vp.solve()
    assert rec.success and 5 < rec.iterations < 40, (rec.status, rec.iterations)
