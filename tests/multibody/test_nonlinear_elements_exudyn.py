"""A nonlinear spring-damper in a linkage, suspopt against Exudyn (J. Gerstmayr et al.).

The MacPherson strut of ``data/macpherson.toml`` (as in ``tests/test_multibody_exudyn.py``,
whose Exudyn model and typed-in numbers this file reuses) with its strut spring-damper
made nonlinear: a progressive spring ``k₁ x + k₃ x³``, an asymmetric digressive damper
given as a table of forces at velocities, a bump stop and a rebound stop (``x`` the
strut's compression from the reference length, positive in bump; the curves' convention
of :mod:`suspopt.curves`). In suspopt these are the strut element's subtables
``spring_curve``, ``damper_curve``, ``bump_stop``, ``rebound_stop``; in Exudyn, the
``springForceUserFunction`` of ``ObjectConnectorSpringDamper`` (the tension from the
elongation ``ΔL`` and its rate, ``f = -F(-ΔL, -ΔL̇)``) written here from the same numbers
with NumPy polynomials and SciPy's ``PchipInterpolator``, no suspopt code. A tyre force
pushes the wheel up through the bump stop, then pulls it down onto the rebound stop.
Compared are the upright's trajectory (x, z, rotation) and the strut's tension, to
1e-6 of their amplitudes. Exudyn's trapezoidal rule is second order: at steps of 1e-4 s
and 5e-5 s its errors are about 1.5e-6 and 4e-7 of the amplitudes, so the reference is
the Richardson extrapolation of the two, ``(4 x_{h/2} - x_h) / 3``, whose error is two
orders smaller; suspopt integrates with DOP853 at ``rtol = 1e-9``.

Exudyn API read from its documentation (``ObjectConnectorSpringDamper``:
``springForceUserFunction(mbs, t, itemNumber, deltaL, deltaL_t, stiffness, damping,
force)`` returns the scalar spring force, tension positive).
"""

from __future__ import annotations

import math

import exudyn as exu
import numpy as np
import pytest
from exudyn.itemInterface import (
    LoadForceVector,
    MarkerBodyPosition,
    MarkerBodyRigid,
    NodeRigidBody2D,
    ObjectGround,
    PrismaticJoint2D,
    RevoluteJoint2D,
    RigidBody2D,
    SensorNode,
    SensorObject,
    SpringDamper,
)
from mechanisms import raw
from scipy.interpolate import PchipInterpolator

from suspopt.multibody.mechanism import mechanism_from_dict
from suspopt.multibody.simulate import simulate_mechanism
from suspopt.multibody.solver import PlanarMultibodySolver

H, OUT_DT, T_END = 1e-4, 0.01, 0.45
#: Exudyn's outputs extrapolated to zero step (Richardson, second order)
EXTRAPOLATED = ('W', 'W_phi', 'spring', 'length')
#: the MacPherson's bodies and points (data/macpherson.toml, typed in)
BODIES = {
    'W': (99.574463, 5.961650, (0.522914, 0.0)),
    'L': (3.425244, 0.020170, (0.301113, -0.098425)),
    'R': (17.000293, 0.000602, (0.370328, 0.23368)),
}
PIVOT, BALL, TOP = (0.159096, -0.115752), (0.452878, -0.10414), (0.330958, 0.46863)
SEAT, PATCH = (0.409698, -0.00127), (0.54, -0.3186)

#: the strut's curves (strut compression x [m], its rate v [m/s], bump positive)
K1, K3 = 30000.0, 3.0e7
VELOCITIES = [-2.0, -1.0, -0.4, -0.15, -0.05, 0.0, 0.05, 0.15, 0.4, 1.0, 2.0]
FORCES = [-3900.0, -2600.0, -1500.0, -820.0, -380.0, 0.0, 150.0, 330.0, 600.0, 1050.0, 1600.0]
BUMP_GAP, BUMP_K = 0.02, (2.0e6, 5.0e7)  # k_2, k_3
REBOUND_GAP, REBOUND_K = 0.01, (3.0e6,)
CURVES = {
    'spring_curve': {'coefficients': [K1, 0.0, K3]},
    'damper_curve': {'velocities': VELOCITIES, 'forces': FORCES},
    'bump_stop': {'gap': BUMP_GAP, 'coefficients': list(BUMP_K)},
    'rebound_stop': {'gap': REBOUND_GAP, 'coefficients': list(REBOUND_K)},
}


def tyre_force(t: float) -> float:
    """Up through the bump stop, then down onto the rebound stop."""
    if t < 0.1:
        return 2200.0 * math.sin(math.pi * t / 0.1) ** 2
    if 0.22 < t < 0.32:
        return -2200.0 * math.sin(math.pi * (t - 0.22) / 0.1) ** 2
    return 0.0


_damper = PchipInterpolator(VELOCITIES, FORCES)


def strut_force(x: float, v: float) -> float:
    """The strut's force in compression (bump positive), written independently of suspopt."""
    spring = K1 * x + K3 * x**3
    d = max(x - BUMP_GAP, 0.0)
    bump = BUMP_K[0] * d**2 + BUMP_K[1] * d**3
    r = max(-x - REBOUND_GAP, 0.0)
    rebound = -REBOUND_K[0] * r**2
    return spring + float(_damper(v)) + bump + rebound


def run_exudyn(step: float) -> dict:
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddObject(ObjectGround())
    nodes, objs, cg = {}, {'ground': ground}, {ground: (0.0, 0.0)}
    for name, (m, J, pos) in BODIES.items():
        nodes[name] = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[pos[0], pos[1], 0.0]))
        objs[name] = mbs.AddObject(RigidBody2D(nodeNumber=nodes[name], mass=m, inertia=J))
        cg[objs[name]] = pos

    def marker(name, p, rigid=False):
        b = objs[name]
        c = cg[b]
        kind = MarkerBodyRigid if rigid else MarkerBodyPosition
        return mbs.AddMarker(kind(bodyNumber=b, localPosition=[p[0] - c[0], p[1] - c[1], 0.0]))

    for a, b, p in (('L', 'ground', PIVOT), ('L', 'W', BALL), ('R', 'ground', TOP)):
        mbs.AddObject(RevoluteJoint2D(markerNumbers=[marker(a, p), marker(b, p)]))
    axis = np.subtract(TOP, SEAT)
    length = float(np.hypot(*axis))
    axis = axis / length
    mbs.AddObject(
        PrismaticJoint2D(
            markerNumbers=[marker('R', SEAT, True), marker('W', SEAT, True)],
            axisMarker0=[axis[0], axis[1], 0.0],
            normalMarker1=[-axis[1], axis[0], 0.0],
            constrainRotation=True,
        )
    )

    def user_force(mbs, t, itemNumber, deltaL, deltaL_t, stiffness, damping, force):
        return -strut_force(-deltaL, -deltaL_t)  # tension

    spring = mbs.AddObject(
        SpringDamper(
            markerNumbers=[marker('ground', TOP), marker('W', SEAT)],
            referenceLength=length,
            springForceUserFunction=user_force,
        )
    )
    mbs.AddLoad(
        LoadForceVector(
            markerNumber=marker('W', PATCH),
            loadVector=[0, 1, 0],
            loadVectorUserFunction=lambda mbs, t, lv: [0.0, tyre_force(t), 0.0],
        )
    )
    out = exu.OutputVariableType
    sensors = {
        'W': mbs.AddSensor(
            SensorNode(
                nodeNumber=nodes['W'], storeInternal=True, outputVariableType=out.Displacement
            )
        ),
        'W_phi': mbs.AddSensor(
            SensorNode(nodeNumber=nodes['W'], storeInternal=True, outputVariableType=out.Rotation)
        ),
        'spring': mbs.AddSensor(
            SensorObject(objectNumber=spring, storeInternal=True, outputVariableType=out.ForceLocal)
        ),
        'length': mbs.AddSensor(
            SensorObject(objectNumber=spring, storeInternal=True, outputVariableType=out.Distance)
        ),
    }
    mbs.Assemble()
    ss = exu.SimulationSettings()
    ss.timeIntegration.numberOfSteps = int(round(T_END / step))
    ss.timeIntegration.endTime = T_END
    ss.timeIntegration.verboseMode = 0
    ss.timeIntegration.generalizedAlpha.useIndex2Constraints = True
    ss.timeIntegration.generalizedAlpha.useNewmark = True
    ss.solution.file.write = False
    ss.solution.sensors.writePeriod = OUT_DT
    mbs.SolveDynamic(ss)
    data = {k: mbs.GetSensorStoredData(s) for k, s in sensors.items()}
    data['reference_length'] = length
    return data


def nonlinear_macpherson():
    data = raw('macpherson')
    for force in data['forces']:
        if force['name'] == 'strut_spring':
            del force['stiffness'], force['damping']
            force.update(CURVES)
    return mechanism_from_dict(data, source='macpherson (nonlinear strut)', suspension=True)


@pytest.fixture(scope='module')
def both():
    coarse, fine = run_exudyn(H), run_exudyn(H / 2)
    ex = {k: (4.0 * fine[k] - coarse[k]) / 3.0 for k in EXTRAPOLATED}
    t = fine['W'][:, 0]
    s = PlanarMultibodySolver(nonlinear_macpherson())
    tr = simulate_mechanism(
        s,
        (0.0, T_END),
        [s.q0[1]],
        [0.0],
        t_eval=t,
        max_step=0.01,
        loads=lambda t, q, qd: np.array([tyre_force(t)]),
        rtol=1e-9,
        atol=1e-11,
    )
    return ex, tr, s


def test_nonlinear_strut_matches_exudyn(both):
    ex, tr, s = both
    np.testing.assert_allclose(tr.t, ex['W'][:, 0], atol=1e-9)
    sp = s.spring('strut_spring', tr.q, tr.qd)
    x = -sp.deflection  # strut compression
    # the motion reached every part of the curves: both stops, both damper sides
    assert x.max() > BUMP_GAP + 0.003 and x.min() < -REBOUND_GAP - 0.003
    assert -sp.rate.max() < -0.1 < 0.1 < -sp.rate.min()
    assert np.max(np.abs(sp.rate)) < VELOCITIES[-1]  # inside the table (SciPy extrapolates)
    np.testing.assert_allclose(ex['length'][:, 1], sp.length, atol=1e-5)
    z, phi = tr.q[:, 1], tr.q[:, 2]
    amp, phi_amp = np.max(np.abs(z)), np.max(np.abs(phi))
    f_amp = np.max(np.abs(sp.force))
    err = {
        'z': np.max(np.abs(z - ex['W'][:, 2])) / amp,
        'x': np.max(np.abs(tr.q[:, 0] - BODIES['W'][2][0] - ex['W'][:, 1])) / amp,
        'phi': np.max(np.abs(phi - ex['W_phi'][:, -1])) / phi_amp,
        'strut tension': np.max(np.abs(sp.force - ex['spring'][:, 1])) / f_amp,
    }
    print(
        f'\nnonlinear MacPherson: wheel z amplitude {amp * 1e3:.2f} mm, strut compression '
        f'{x.min() * 1e3:.1f} .. {x.max() * 1e3:.1f} mm, tension amplitude {f_amp:.0f} N; '
        'max differences (of each amplitude): ' + ', '.join(f'{k} {v:.1e}' for k, v in err.items())
    )
    for k, v in err.items():
        assert v < 1e-6, (k, v)


def test_tension_is_the_independent_force_law(both):
    """suspopt's strut tension at the simulated states is ``-F(-ΔL, -ΔL̇)`` of the
    independent force law above (the curves and their sign convention)."""
    _, tr, s = both
    sp = s.spring('strut_spring', tr.q, tr.qd)
    ref = [-strut_force(-dl, -r) for dl, r in zip(sp.deflection, sp.rate)]
    np.testing.assert_allclose(sp.force, ref, rtol=1e-12, atol=1e-9)
