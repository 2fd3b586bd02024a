"""Independent cross-check of the double wishbone against Exudyn (J. Gerstmayr et al.).

The same mechanism is built in Exudyn from the numbers of SPEC §3 (not from suspopt's
data structures): three planar rigid bodies (``NodeRigidBody2D`` + ``ObjectRigidBody2D``,
node = centre of mass) W, U, L; the frame F is the ground (``ObjectGround``); four
``ObjectJointRevolute2D`` at ``MarkerBodyPosition`` points; no gravity. Both codes are
driven by the same prescribed vertical tyre force at the contact point (0.54, -0.38) on
W, a smooth pulse F_T(t) = 300 N sin²(π t / 0.1 s) for t < 0.1 s, and by a linear spring
k = 30 kN/m on the vertical displacement of the spring point of U (= U's centre of
gravity; in Exudyn an ``ObjectConnectorCoordinateSpringDamper`` on U's y coordinate, in
suspopt the 'suspension' load carrying F_S = k z_U), so the wheel oscillates at about
1.3 Hz with 20 mm amplitude.

Exudyn integrates with its implicit trapezoidal rule (generalized-alpha in Newmark mode
with index-2 constraints, step 1e-4 s; the index-3 default with spectral radius 1 gives
undamped oscillations of the Lagrange multipliers, so its joint forces are noisy),
suspopt with DOP853 on the partitioned coordinates. The wheel's vertical trajectories are
compared over 1.5 s (required: 0.5 % of the amplitude; measured ~5e-7), and so are the
joint reaction forces (suspopt's ``joint_reactions`` from λ vs Exudyn's joint ``Force``
output; same convention: force on the joint's first body).

Exudyn API read from its documentation (docs/RST/items/ObjectRigidBody2D.rst,
ObjectJointRevolute2D.rst, LoadForceVector.rst, ObjectConnectorCoordinateSpringDamper.rst
and Examples/doublePendulum2D.py of github.com/jgerstmayr/EXUDYN).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

# a test dependency ([test] extra): a missing exudyn is a broken install, not a skip
import exudyn as exu  # noqa: E402
from exudyn.itemInterface import (CoordinateSpringDamper, LoadForceVector,  # noqa: E402
                                  MarkerBodyPosition, MarkerNodeCoordinate, NodePointGround,
                                  NodeRigidBody2D, ObjectGround, RevoluteJoint2D,
                                  RigidBody2D, SensorNode, SensorObject)

from suspopt.multibody.mechanism import load_mechanism  # noqa: E402
from suspopt.multibody.simulate import simulate_mechanism  # noqa: E402
from suspopt.multibody.solver import PlanarMultibodySolver  # noqa: E402

K_SPRING = 3.0e4
F_PEAK, T_PULSE = 300.0, 0.1
T_END, H = 1.5, 1e-4
OUT_DT = 0.01


def tyre_force(t: float) -> float:
    return F_PEAK * math.sin(math.pi * t / T_PULSE) ** 2 if t < T_PULSE else 0.0


def run_exudyn():
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddObject(ObjectGround())
    cg = {ground: (0.0, 0.0)}

    def body(m, J, pos):
        n = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[pos[0], pos[1], 0.0]))
        try:
            item = RigidBody2D(nodeNumber=n, mass=m, inertia=J)
        except TypeError:          # exudyn < 1.12.258 names them physicsMass/-Inertia
            item = RigidBody2D(nodeNumber=n, physicsMass=m, physicsInertia=J)
        b = mbs.AddObject(item)
        cg[b] = pos
        return n, b

    nW, bW = body(80.0, 7.5, (0.54, 0.0))
    nU, bU = body(20.0, 0.15, (0.27, 0.2))
    _, bL = body(20.0, 0.15, (0.27, -0.2))

    def marker(b, p):
        c = cg[b]
        return mbs.AddMarker(MarkerBodyPosition(bodyNumber=b,
                                                localPosition=[p[0] - c[0], p[1] - c[1], 0.0]))

    joints = [mbs.AddObject(RevoluteJoint2D(markerNumbers=[marker(b1, p), marker(b2, p)]))
              for b1, b2, p in [(bW, bU, (0.45, 0.2)), (bW, bL, (0.45, -0.2)),
                                (bU, ground, (0.12, 0.2)), (bL, ground, (0.12, -0.2))]]
    nG = mbs.AddNode(NodePointGround(referenceCoordinates=[0.0, 0.0, 0.0]))
    mbs.AddObject(CoordinateSpringDamper(
        markerNumbers=[mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nG, coordinate=1)),
                       mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nU, coordinate=1))],
        stiffness=K_SPRING, damping=0.0))
    mbs.AddLoad(LoadForceVector(markerNumber=marker(bW, (0.54, -0.38)), loadVector=[0, 1, 0],
                                loadVectorUserFunction=lambda mbs, t, lv: [0.0, tyre_force(t),
                                                                           0.0]))
    sensors = {
        'W': mbs.AddSensor(SensorNode(nodeNumber=nW, storeInternal=True,
                                      outputVariableType=exu.OutputVariableType.Displacement)),
        'U': mbs.AddSensor(SensorNode(nodeNumber=nU, storeInternal=True,
                                      outputVariableType=exu.OutputVariableType.Displacement)),
    }
    for k, j in enumerate(joints):
        sensors[k] = mbs.AddSensor(SensorObject(objectNumber=j, storeInternal=True,
                                                outputVariableType=exu.OutputVariableType.Force))
    mbs.Assemble()
    ss = exu.SimulationSettings()
    ss.timeIntegration.numberOfSteps = int(round(T_END / H))
    ss.timeIntegration.endTime = T_END
    ss.timeIntegration.verboseMode = 0
    ss.timeIntegration.generalizedAlpha.useIndex2Constraints = True
    ss.timeIntegration.generalizedAlpha.useNewmark = True
    if hasattr(ss, 'solution'):                     # exudyn >= 1.12
        ss.solution.file.write = False
        ss.solution.sensors.writePeriod = OUT_DT
    else:
        ss.solutionSettings.writeSolutionToFile = False
        ss.solutionSettings.sensorsWritePeriod = OUT_DT
    mbs.SolveDynamic(ss)
    return {k: mbs.GetSensorStoredData(s) for k, s in sensors.items()}


@pytest.fixture(scope='module')
def both():
    ex = run_exudyn()
    t = ex['W'][:, 0]
    s = PlanarMultibodySolver(load_mechanism('double_wishbone', suspension=True))

    def loads(t, q, qd):   # [suspension F_S (acts down on U), tyre F_T (acts up on W)]
        return np.array([K_SPRING * (q[4] - 0.2), tyre_force(t)])

    tr = simulate_mechanism(s, (0.0, T_END), [0.0], [0.0], loads=loads, t_eval=t,
                            max_step=0.01)   # do not step over the 0.1 s pulse
    return ex, tr, s


def test_wheel_trajectory_matches_exudyn(both):
    ex, tr, _ = both
    assert ex['W'].shape[0] == round(T_END / OUT_DT) + 1
    np.testing.assert_allclose(tr.t, ex['W'][:, 0], atol=1e-9)
    z_sus, z_exu = tr.q[:, 1], ex['W'][:, 2]
    amp = np.max(np.abs(z_sus))
    assert 0.015 < amp < 0.025                                 # it oscillated
    rel = np.max(np.abs(z_sus - z_exu)) / amp
    print(f'\nwheel z: amplitude {amp * 1e3:.2f} mm, max difference {rel:.2e} of it')
    assert rel < 5e-3
    # and the rest of the motion: wheel lateral shift, spring point travel
    np.testing.assert_allclose(tr.q[:, 0] - 0.54, ex['W'][:, 1], atol=5e-3 * amp)
    np.testing.assert_allclose(tr.q[:, 4] - 0.2, ex['U'][:, 2], atol=5e-3 * amp)


def test_joint_reactions_match_exudyn(both):
    ex, tr, s = both
    R = s.joint_reactions(tr.lam)                       # (N, 4, 2), on each first body
    scale = np.max(np.abs(R))
    assert scale > 50.0
    worst = 0.0
    for k in range(4):
        d = np.max(np.abs(R[:, k, :] - ex[k][:, 1:3]))
        worst = max(worst, d)
    print(f'\njoint reactions: max {scale:.1f} N, max difference {worst / scale:.2e} of it')
    assert worst < 5e-3 * scale
