"""Independent cross-check of the suspension linkages against Exudyn (J. Gerstmayr et al.).

Three linkages. The MacPherson strut (``macpherson``, at the end of this file): Exudyn's
``ObjectJointPrismatic2D`` (strut), ``ObjectConnectorSpringDamper`` (spring and damper
along it) and three ``ObjectJointRevolute2D``, its numbers typed in here; compared are
the upright's trajectory (x, z, rotation), the spring tension and all joint reactions.

Two double wishbones: the double wishbone of docs/model.md (a parallelogram: the upright translates)
and the short-long-arm variation shipped as ``sla_double_wishbone`` (the upright
rotates: camber gain). Each is built in Exudyn from its numbers typed into this file (not
from suspopt's data structures): three planar rigid bodies (``NodeRigidBody2D`` +
``ObjectRigidBody2D``, node = centre of mass) W, U, L; the frame F is the ground
(``ObjectGround``); four ``ObjectJointRevolute2D`` at ``MarkerBodyPosition`` points; no
gravity. Both codes are driven by the same prescribed vertical tyre force at the contact
point (0.54, -0.38) on W, a smooth pulse F_T(t) = 300 N sin²(π t / 0.1 s) for t < 0.1 s,
and by a linear spring k = 30 kN/m on the vertical displacement of the spring point (the
centre of gravity of U, resp. L; in Exudyn an ``ObjectConnectorCoordinateSpringDamper``
on that node's y coordinate, in suspopt the 'suspension' load carrying F_S = k z), so the
wheel oscillates at about 1.3 Hz with about 20 mm amplitude.

Exudyn integrates with its implicit trapezoidal rule (generalized-alpha in Newmark mode
with index-2 constraints, step 1e-4 s; the index-3 default with spectral radius 1 gives
undamped oscillations of the Lagrange multipliers, so its joint forces are noisy),
suspopt with DOP853 on the partitioned coordinates. The wheel's vertical trajectories are
compared over 1.5 s (required: 0.5 % of the amplitude; measured ~5e-7), and so are the
upright's rotation, the joint reaction forces (suspopt's ``joint_reactions`` from λ vs
Exudyn's joint ``Force`` output; same convention: force on the joint's first body).

Exudyn API read from its documentation (docs/RST/items/ObjectRigidBody2D.rst,
ObjectJointRevolute2D.rst, LoadForceVector.rst, ObjectConnectorCoordinateSpringDamper.rst
and Examples/doublePendulum2D.py of github.com/jgerstmayr/EXUDYN).
"""

from __future__ import annotations

import math

# a test dependency ([test] extra): a missing exudyn is a broken install, not a skip
import exudyn as exu  # noqa: E402
import numpy as np
import pytest
from exudyn.itemInterface import (
    CoordinateSpringDamper,
    LoadForceVector,  # noqa: E402
    MarkerBodyPosition,
    MarkerBodyRigid,
    MarkerNodeCoordinate,
    NodePointGround,
    NodeRigidBody2D,
    ObjectGround,
    PrismaticJoint2D,
    RevoluteJoint2D,
    RigidBody2D,
    SensorNode,
    SensorObject,
    SpringDamper,
)
from mechanisms import with_suspension_load  # noqa: E402 (tests/ is on the path)

from suspopt.multibody.mechanism import load_mechanism  # noqa: E402
from suspopt.multibody.simulate import simulate_mechanism  # noqa: E402
from suspopt.multibody.solver import PlanarMultibodySolver  # noqa: E402

K_SPRING = 3.0e4
F_PEAK, T_PULSE = 300.0, 0.1
T_END, H = 1.5, 1e-4
OUT_DT = 0.01


def solve_exudyn(mbs, sensors: dict, t_end: float) -> dict:
    """Assemble ``mbs``, integrate it to ``t_end`` (generalized-α with index-2 constraints,
    Newmark, step H) and return every sensor's stored data (every OUT_DT)."""
    mbs.Assemble()
    ss = exu.SimulationSettings()
    ss.timeIntegration.numberOfSteps = int(round(t_end / H))
    ss.timeIntegration.endTime = t_end
    ss.timeIntegration.verboseMode = 0
    ss.timeIntegration.generalizedAlpha.useIndex2Constraints = True
    ss.timeIntegration.generalizedAlpha.useNewmark = True
    if hasattr(ss, 'solution'):  # exudyn >= 1.12
        ss.solution.file.write = False
        ss.solution.sensors.writePeriod = OUT_DT
    else:
        ss.solutionSettings.writeSolutionToFile = False
        ss.solutionSettings.sensorsWritePeriod = OUT_DT
    mbs.SolveDynamic(ss)
    return {k: mbs.GetSensorStoredData(s) for k, s in sensors.items()}


def tyre_force(t: float) -> float:
    return F_PEAK * math.sin(math.pi * t / T_PULSE) ** 2 if t < T_PULSE else 0.0


#: The linkages, typed in from their numbers (docs/model.md for the double wishbone; the SLA
#: variation's file header), not read from suspopt's files: body -> (mass, inertia, CG);
#: joints (body, body or 'ground', point); the body whose CG carries the spring; the
#: index of that body's z in suspopt's coordinates (x, z, φ per body, file order).
LINKAGES = {
    'double_wishbone': {
        'bodies': {
            'W': (80.0, 7.5, (0.54, 0.0)),
            'U': (20.0, 0.15, (0.27, 0.2)),
            'L': (20.0, 0.15, (0.27, -0.2)),
        },
        'joints': [
            ('W', 'U', (0.45, 0.2)),
            ('W', 'L', (0.45, -0.2)),
            ('U', 'ground', (0.12, 0.2)),
            ('L', 'ground', (0.12, -0.2)),
        ],
        'spring': 'U',
        'spring_z': 4,
    },
    'sla_double_wishbone': {
        'bodies': {
            'W': (80.0, 7.5, (0.54, 0.0)),
            'U': (12.0, 0.06, (0.335, 0.19)),
            'L': (28.0, 0.3, (0.275, -0.21)),
        },
        'joints': [
            ('W', 'U', (0.45, 0.2)),
            ('W', 'L', (0.45, -0.2)),
            ('U', 'ground', (0.22, 0.18)),
            ('L', 'ground', (0.10, -0.22)),
        ],
        'spring': 'L',
        'spring_z': 7,
    },
}


def run_exudyn(linkage: dict):
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddObject(ObjectGround())
    cg = {ground: (0.0, 0.0)}

    def body(m, J, pos):
        n = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[pos[0], pos[1], 0.0]))
        try:
            item = RigidBody2D(nodeNumber=n, mass=m, inertia=J)
        except TypeError:  # exudyn < 1.12.258 names them physicsMass/-Inertia
            item = RigidBody2D(nodeNumber=n, physicsMass=m, physicsInertia=J)
        b = mbs.AddObject(item)
        cg[b] = pos
        return n, b

    nodes, objs = {}, {'ground': ground}
    for name, (m, J, pos) in linkage['bodies'].items():
        nodes[name], objs[name] = body(m, J, pos)

    def marker(b, p):
        c = cg[b]
        return mbs.AddMarker(
            MarkerBodyPosition(bodyNumber=b, localPosition=[p[0] - c[0], p[1] - c[1], 0.0])
        )

    joints = [
        mbs.AddObject(RevoluteJoint2D(markerNumbers=[marker(objs[b1], p), marker(objs[b2], p)]))
        for b1, b2, p in linkage['joints']
    ]
    nG = mbs.AddNode(NodePointGround(referenceCoordinates=[0.0, 0.0, 0.0]))
    spring_node = nodes[linkage['spring']]
    mbs.AddObject(
        CoordinateSpringDamper(
            markerNumbers=[
                mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nG, coordinate=1)),
                mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=spring_node, coordinate=1)),
            ],
            stiffness=K_SPRING,
            damping=0.0,
        )
    )
    mbs.AddLoad(
        LoadForceVector(
            markerNumber=marker(objs['W'], (0.54, -0.38)),
            loadVector=[0, 1, 0],
            loadVectorUserFunction=lambda mbs, t, lv: [0.0, tyre_force(t), 0.0],
        )
    )
    sensors = {
        'W': mbs.AddSensor(
            SensorNode(
                nodeNumber=nodes['W'],
                storeInternal=True,
                outputVariableType=exu.OutputVariableType.Displacement,
            )
        ),
        'W_phi': mbs.AddSensor(
            SensorNode(
                nodeNumber=nodes['W'],
                storeInternal=True,
                outputVariableType=exu.OutputVariableType.Rotation,
            )
        ),
        'spring': mbs.AddSensor(
            SensorNode(
                nodeNumber=spring_node,
                storeInternal=True,
                outputVariableType=exu.OutputVariableType.Displacement,
            )
        ),
    }
    for k, j in enumerate(joints):
        sensors[k] = mbs.AddSensor(
            SensorObject(
                objectNumber=j, storeInternal=True, outputVariableType=exu.OutputVariableType.Force
            )
        )
    return solve_exudyn(mbs, sensors, T_END)


@pytest.fixture(scope='module', params=list(LINKAGES))
def both(request):
    linkage = LINKAGES[request.param]
    ex = run_exudyn(linkage)
    t = ex['W'][:, 0]
    s = PlanarMultibodySolver(with_suspension_load(request.param))
    iz = linkage['spring_z']
    z0 = s.q0[iz]

    def loads(t, q, qd):  # [suspension F_S (acts down on the arm), tyre F_T (up on W)]
        return np.array([K_SPRING * (q[iz] - z0), tyre_force(t)])

    tr = simulate_mechanism(
        s, (0.0, T_END), [0.0], [0.0], loads=loads, t_eval=t, max_step=0.01
    )  # do not step over the 0.1 s pulse
    return ex, tr, s, linkage


def test_wheel_trajectory_matches_exudyn(both):
    ex, tr, s, linkage = both
    assert ex['W'].shape[0] == round(T_END / OUT_DT) + 1
    np.testing.assert_allclose(tr.t, ex['W'][:, 0], atol=1e-9)
    z_sus, z_exu = tr.q[:, 1], ex['W'][:, 2]
    amp = np.max(np.abs(z_sus))
    assert 0.01 < amp < 0.03  # it oscillated
    rel = np.max(np.abs(z_sus - z_exu)) / amp
    print(
        f'\n{s.mechanism.name}: wheel z amplitude {amp * 1e3:.2f} mm, max difference '
        f'{rel:.2e} of it'
    )
    assert rel < 5e-3
    # and the rest of the motion: wheel lateral shift, its rotation, spring point travel
    iz = linkage['spring_z']
    np.testing.assert_allclose(tr.q[:, 0] - 0.54, ex['W'][:, 1], atol=5e-3 * amp)
    np.testing.assert_allclose(tr.q[:, iz] - s.q0[iz], ex['spring'][:, 2], atol=5e-3 * amp)
    phi_amp = np.max(np.abs(tr.q[:, 2]))
    if linkage['spring'] == 'L':  # the SLA's upright rotates
        assert phi_amp > 1e-4
        phi_exu = ex['W_phi'][:, -1]
        print(
            f'{s.mechanism.name}: upright rotation amplitude {phi_amp:.2e} rad, max '
            f'difference {np.max(np.abs(tr.q[:, 2] - phi_exu)) / phi_amp:.2e} of it'
        )
        np.testing.assert_allclose(tr.q[:, 2], phi_exu, atol=5e-3 * phi_amp)
    else:  # the parallelogram's does not
        assert phi_amp < 1e-12


def test_joint_reactions_match_exudyn(both):
    ex, tr, s, linkage = both
    R = s.joint_reactions(tr.lam)  # (N, 4, 2), on each first body
    scale = np.max(np.abs(R))
    assert scale > 50.0
    worst = 0.0
    for k in range(4):
        d = np.max(np.abs(R[:, k, :] - ex[k][:, 1:3]))
        worst = max(worst, d)
    print(
        f'\n{s.mechanism.name}: joint reactions max {scale:.1f} N, max difference '
        f'{worst / scale:.2e} of it'
    )
    assert worst < 5e-3 * scale


# ================================================================== MacPherson strut
#: ``data/macpherson.toml`` typed in from its numbers (the BMW E90 front strut of
#: Chrono::Vehicle in the front view, masses scaled to 120 kg): body -> (mass, inertia,
#: CG); the frame F is the ground.
MP_BODIES = {
    'W': (99.574463, 5.961650, (0.522914, 0.0)),
    'L': (3.425244, 0.020170, (0.301113, -0.098425)),
    'R': (17.000293, 0.000602, (0.370328, 0.23368)),
}
MP_PIVOT, MP_BALL, MP_TOP = (0.159096, -0.115752), (0.452878, -0.10414), (0.330958, 0.46863)
MP_SEAT, MP_PATCH = (0.409698, -0.00127), (0.54, -0.3186)
MP_K, MP_C, MP_PEAK = 3.0e4, 1500.0, 1500.0
MP_T_END = 0.6


def mp_tyre_force(t: float) -> float:
    return MP_PEAK * math.sin(math.pi * t / T_PULSE) ** 2 if t < T_PULSE else 0.0


def run_exudyn_macpherson():
    """Exudyn: W, L, R as ObjectRigidBody2D; ObjectJointRevolute2D L-ground (LCA bushing),
    L-W (ball joint), R-ground (top mount); ObjectJointPrismatic2D R-W along the strut
    (axisMarker0 in R, normalMarker1 in W, constrainRotation); ObjectConnectorSpringDamper
    from the top mount on the ground to the spring seat on W (reference length = the
    reference distance); the tyre pulse on W at the contact patch."""
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddObject(ObjectGround())
    nodes, objs, cg = {}, {'ground': ground}, {ground: (0.0, 0.0)}
    for name, (m, J, pos) in MP_BODIES.items():
        nodes[name] = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[pos[0], pos[1], 0.0]))
        objs[name] = mbs.AddObject(RigidBody2D(nodeNumber=nodes[name], mass=m, inertia=J))
        cg[objs[name]] = pos

    def marker(name, p, rigid=False):
        b = objs[name]
        c = cg[b]
        kind = MarkerBodyRigid if rigid else MarkerBodyPosition
        return mbs.AddMarker(kind(bodyNumber=b, localPosition=[p[0] - c[0], p[1] - c[1], 0.0]))

    revolutes = [
        mbs.AddObject(RevoluteJoint2D(markerNumbers=[marker(a, p), marker(b, p)]))
        for a, b, p in (('L', 'ground', MP_PIVOT), ('L', 'W', MP_BALL), ('R', 'ground', MP_TOP))
    ]
    axis = np.subtract(MP_TOP, MP_SEAT)
    length = float(np.hypot(*axis))
    axis = axis / length
    mbs.AddObject(
        PrismaticJoint2D(
            markerNumbers=[marker('R', MP_SEAT, True), marker('W', MP_SEAT, True)],
            axisMarker0=[axis[0], axis[1], 0.0],
            normalMarker1=[-axis[1], axis[0], 0.0],
            constrainRotation=True,
        )
    )
    spring = mbs.AddObject(
        SpringDamper(
            markerNumbers=[marker('ground', MP_TOP), marker('W', MP_SEAT)],
            referenceLength=length,
            stiffness=MP_K,
            damping=MP_C,
        )
    )
    mbs.AddLoad(
        LoadForceVector(
            markerNumber=marker('W', MP_PATCH),
            loadVector=[0, 1, 0],
            loadVectorUserFunction=lambda mbs, t, lv: [0.0, mp_tyre_force(t), 0.0],
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
        'R_acc': mbs.AddSensor(
            SensorNode(
                nodeNumber=nodes['R'], storeInternal=True, outputVariableType=out.Acceleration
            )
        ),
        'R_alpha': mbs.AddSensor(
            SensorNode(
                nodeNumber=nodes['R'],
                storeInternal=True,
                outputVariableType=out.AngularAcceleration,
            )
        ),
        'R_pos': mbs.AddSensor(
            SensorNode(nodeNumber=nodes['R'], storeInternal=True, outputVariableType=out.Position)
        ),
        'spring': mbs.AddSensor(
            SensorObject(objectNumber=spring, storeInternal=True, outputVariableType=out.ForceLocal)
        ),
    }
    for k, j in enumerate(revolutes):
        sensors[k] = mbs.AddSensor(
            SensorObject(objectNumber=j, storeInternal=True, outputVariableType=out.Force)
        )
    return solve_exudyn(mbs, sensors, MP_T_END)


@pytest.fixture(scope='module')
def macpherson():
    ex = run_exudyn_macpherson()
    t = ex['W'][:, 0]
    s = PlanarMultibodySolver(load_mechanism('macpherson', suspension=True))
    tr = simulate_mechanism(
        s,
        (0.0, MP_T_END),
        [s.q0[1]],
        [0.0],
        t_eval=t,
        max_step=0.01,
        loads=lambda t, q, qd: np.array([mp_tyre_force(t)]),
        params={'strut_spring': {'stiffness': MP_K, 'damping': MP_C}},
    )
    return ex, tr, s


def test_macpherson_trajectory_matches_exudyn(macpherson):
    ex, tr, s = macpherson
    assert s.n == 12 and s.m == 11 and s.dof == 1  # Exudyn: 9 coordinates, 8 equations
    np.testing.assert_allclose(tr.t, ex['W'][:, 0], atol=1e-9)
    z, phi = tr.q[:, 1], tr.q[:, 2]
    amp, phi_amp = np.max(np.abs(z)), np.max(np.abs(phi))
    assert 0.02 < amp < 0.06 and phi_amp > 1e-3  # it moved, and turned
    err = {
        'z': np.max(np.abs(z - ex['W'][:, 2])) / amp,
        'x': np.max(np.abs(tr.q[:, 0] - 0.522914 - ex['W'][:, 1])) / amp,
        'phi': np.max(np.abs(phi - ex['W_phi'][:, -1])) / phi_amp,
    }
    f_sus = s.spring(
        'strut_spring', tr.q, tr.qd, {'strut_spring': {'stiffness': MP_K, 'damping': MP_C}}
    ).force
    err['spring tension'] = np.max(np.abs(f_sus - ex['spring'][:, 1])) / np.max(np.abs(f_sus))
    print(
        f'\nMacPherson: wheel z amplitude {amp * 1e3:.2f} mm, upright rotation amplitude '
        f'{phi_amp:.2e} rad; max differences (of each amplitude): '
        + ', '.join(f'{k} {v:.1e}' for k, v in err.items())
    )
    for k, v in err.items():
        assert v < 1e-5, (k, v)


def test_macpherson_reactions_match_exudyn(macpherson):
    """The three pins: suspopt's ``joint_reactions`` (on each joint's first body) against
    Exudyn's joint forces. The prismatic joint (no force output in Exudyn): its force and
    torque on the rod R from R's Newton–Euler in Exudyn (R's accelerations and the top
    mount's force are the only other terms) against suspopt's ``reactions``."""
    ex, tr, s = macpherson
    R = s.joint_reactions(tr.lam, tr.q)
    scale = np.max(np.abs(R))
    assert scale > 100.0
    err = {
        name: np.max(np.abs(R[:, k] - ex[k][:, 1:3])) / scale
        for k, name in enumerate(['L-F', 'L-W', 'R-F'])
    }
    m_R, I_R, _ = MP_BODIES['R']
    F_top = ex[2][:, 1:3]  # on R (its first body)
    F_prism = m_R * ex['R_acc'][:, 1:3] - F_top
    arm = np.asarray(MP_TOP) - ex['R_pos'][:, 1:3]
    M_prism = I_R * ex['R_alpha'][:, -1] - (arm[:, 0] * F_top[:, 1] - arm[:, 1] * F_top[:, 0])
    sus = s.reactions(tr.q, tr.lam)[:, s.joint_names.index('strut'), 0]
    err['strut force'] = np.max(np.abs(sus[:, :2] - F_prism)) / scale
    err['strut torque'] = np.max(np.abs(sus[:, 2] - M_prism)) / np.max(np.abs(sus[:, 2]))
    print(
        f'\nMacPherson: joint reactions max {scale:.1f} N; max differences (of it; the '
        'strut torque of its own max): ' + ', '.join(f'{k} {v:.1e}' for k, v in err.items())
    )
    for k, v in err.items():
        assert v < 1e-5, (k, v)
