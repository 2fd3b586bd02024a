"""Reference outputs of the shipped linkages, recorded before the element-library refactor.

``compute(name)`` runs the public solver API (position, velocity and acceleration
analysis, joint reactions, a Baumgarte-stabilized solve off the constraint manifold, the
suspension module's two queries and ``simulate_mechanism`` with both methods) at fixed
inputs; ``python tests/data/multibody_reference.py`` writes the results to
``tests/data/multibody_reference_<name>.json``. ``tests/multibody/test_multibody_regression.py``
recomputes them with the current code and requires agreement to 1e-10 (outputs the
current code has in addition, such as new markers, are not compared).

The recorded files come from commit c12b754 (main before the refactor); regenerate them
only for an intended change of results, and say so in the commit.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np

from suspopt.multibody.mechanism import load_mechanism  # noqa: F401
from suspopt.multibody.simulate import simulate_mechanism
from suspopt.multibody.solver import PlanarMultibodySolver
from suspopt.multibody.suspension import SuspensionModule

sys.path.insert(0, str(Path(__file__).parent.parent))
from mechanisms import SPRING_POINT, with_suspension_load  # noqa: E402

LINKAGES = ('double_wishbone', 'sla_double_wishbone')
HERE = Path(__file__).parent
K_SPRING = 3.0e4


def inputs() -> dict[str, np.ndarray]:
    """Wheel travels, rates and the two load magnitudes (F_S, F_T) of the 11 states."""
    z = np.linspace(-0.08, 0.08, 11)
    v = 0.6 * np.sin(np.arange(11) * 1.3)
    loads = np.stack(
        [2500.0 * np.cos(np.arange(11) * 0.7), 3000.0 * np.sin(np.arange(11) * 0.9 + 0.2)], -1
    )
    return {'z': z, 'v': v, 'loads': loads}


def compute(name: str) -> dict[str, list]:
    mech = with_suspension_load(name)
    s = PlanarMultibodySolver(mech)
    x = inputs()
    st = s.dynamics(x['z'][:, None] + s.q0[s.ind[0]], x['v'][:, None], x['loads'])
    out = {
        'q': st.q,
        'qd': st.qd,
        'qdd': st.qdd,
        'lam': st.lam,
        'reactions': s.joint_reactions(st.lam),
        'Cq': s.constraint_jacobian(st.q),
        'gamma': s.gamma(st.q, st.qd),
        'Q': s.generalized_forces(st.q, x['loads']),
    }
    pos, vel = s.marker_positions(st.q), s.marker_velocities(st.q, st.qd)
    for i, mk in enumerate(s.marker_names):  # by name: a file may gain markers
        out[f'marker {mk}'], out[f'marker velocity {mk}'] = pos[:, i], vel[:, i]
    # off the constraint manifold: constraints and the Baumgarte-stabilized solve
    rng = np.random.default_rng(5)
    q_off = st.q + 1e-4 * rng.standard_normal(st.q.shape)
    qd_off = st.qd + 1e-2 * rng.standard_normal(st.qd.shape)
    out['C_off'] = s.constraints(q_off)
    out['qdd_baumgarte'], out['lam_baumgarte'] = s.solve_augmented(
        q_off, qd_off, s.generalized_forces(q_off, x['loads']), baumgarte=(10.0, 10.0)
    )
    out['qdd_dense'], out['lam_dense'] = s.solve_augmented(
        q_off, qd_off, s.generalized_forces(q_off, x['loads']), method='dense'
    )
    # the vehicle interface: the spring element inside the mechanism, driven so that its
    # force equals the recorded load (k = 30 kN/m, no damping, the chassis mount placed at
    # z_M = q^z_U - F_S / k), gives the recorded accelerations and reactions
    spring = s.marker_names.index(SPRING_POINT[name])
    mod = SuspensionModule(name)
    kin = mod.kinematics(x['z'], x['v'])
    q_U = s.marker_positions(kin.state.q)[:, spring, 1] - s.marker_reference()[spring, 1]
    qd_U = s.marker_velocities(kin.state.q, kin.state.qd)[:, spring, 1]
    out.update(q_U=q_U, qd_U=qd_U, q_W=kin.q_W, qd_W=kin.qd_W)
    k, F_S = np.full(q_U.size, 3.0e4), x['loads'][:, 0]
    out['zdd_W'], out['module_F_S'], out['module_reactions'] = mod.dynamics(
        kin.state, q_U - F_S / k, np.zeros_like(q_U), k, np.zeros_like(k), x['loads'][:, 1]
    )
    # time simulation: a linear spring on the spring point's vertical displacement and a
    # tyre pulse (as in tests/validation/test_multibody_exudyn.py), both constraint methods
    z_U0 = s.marker_reference()[spring, 1]

    def loads(t, q, qd):
        z_U = s.marker_positions(q[None])[0, spring, 1] - z_U0
        pulse = 300.0 * math.sin(math.pi * t / 0.1) ** 2 if t < 0.1 else 0.0
        return np.array([K_SPRING * z_U, pulse])

    t = np.linspace(0.0, 0.3, 31)
    for method in ('partitioned', 'baumgarte'):
        tr = simulate_mechanism(
            s,
            (0.0, 0.3),
            [s.q0[s.ind[0]]],
            [0.0],
            loads=loads,
            method=method,
            t_eval=t,
            max_step=0.01,
        )
        out[f'sim_{method}_q'], out[f'sim_{method}_qd'] = tr.q, tr.qd
        out[f'sim_{method}_qdd'], out[f'sim_{method}_lam'] = tr.qdd, tr.lam
    return {k: np.asarray(v).tolist() for k, v in out.items()}


def path(name: str) -> Path:
    return HERE / f'multibody_reference_{name}.json'


def main() -> int:
    for name in LINKAGES:
        data = {'inputs': {k: v.tolist() for k, v in inputs().items()}, 'outputs': compute(name)}
        path(name).write_text(json.dumps(data))
        print(f'wrote {path(name)}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
