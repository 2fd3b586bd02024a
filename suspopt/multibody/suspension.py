"""The vehicle-facing interface of a suspension mechanism (SPEC §3, paper eqs. 11-13).

One :class:`SuspensionModule` per mechanism wraps a :class:`PlanarMultibodySolver` and
maps the vehicle's quantities onto the mechanism's roles (its ``[suspension]`` table):
wheel travel ``z_W`` drives the independent coordinate; ``q^z_W`` is the vertical
displacement of the wheel marker; ``F_T`` is the magnitude of the tyre load; and the
suspension spring-damper is a force element of the mechanism between its chassis-side
mount and the linkage, whose rate ``k_S`` and damping ``c_S`` are inputs of the module.

The chassis couples to the spring along the spring's own line of action (eq. 12
generalized): with ``e`` the unit vector from the spring's linkage end to its chassis end,
the chassis mount's vertical motion ``z_M`` (``v_M``) shortens the spring by ``e_z z_M``, so
the spring's tension is ``f = k (ℓ - ℓ0 + e_z z_M) + c (ℓ̇ + e_z v_M)``, ``ℓ`` its length in
the linkage, and the chassis receives its vertical component ``F_S = -f e_z`` (up). For a
vertical spring (the double wishbones) this is exactly eq. 12,
``F_S = k (q^z_U - z_M) + c (q̇^z_U - v_M)``. The frame stays fixed to the ground (the
paper's coupling, SPEC §3).

Both the black-box OpenMDAO components and the time-marching integrator call these two
methods, so both integrate one model.
"""
from __future__ import annotations

import time
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from suspopt.errors import ConfigError
from suspopt.multibody.mechanism import Mechanism, load_mechanism
from suspopt.multibody.solver import MultibodyState, PlanarMultibodySolver


@dataclass
class ModuleKinematics:
    """Vertical displacement/velocity of the wheel marker (q^z_W) and the linkage state."""

    q_W: np.ndarray
    qd_W: np.ndarray
    state: MultibodyState


class SuspensionModule:
    """One mechanism's multibody suspension, queried as a black box.

    It remembers its last few analyses: a query at exactly the inputs of one of them
    returns that analysis instead of repeating it. Under finite differences this is most
    queries: perturbing the wheel-travel rate, the chassis motion, a force or a setting
    leaves the positions unchanged, and the dynamics query repeats the kinematics query's
    state. A position analysis (Newton on ``C(q) = 0``) starts from the reference pose
    unless the caller gives a guess, so every answer is a function of the query alone,
    bit for bit, whatever was asked before.
    """

    #: analyses remembered per kind (position; position + velocity)
    memory = 8
    #: a state where the linkage moves this many times faster than at its reference pose
    #: is refused as the edge of its range (a toggle position: the double wishbone's arms
    #: vertical, 99.995 % of the 0.33 m arm length)
    max_sensitivity = 100.0

    def __init__(self, mechanism: Mechanism | str, newton_tol: float = 1e-13):
        if isinstance(mechanism, str):
            mechanism = load_mechanism(mechanism, suspension=True)
        self.mechanism = mechanism
        self.solver = s = PlanarMultibodySolver(mechanism, newton_tol=newton_tol)
        roles = mechanism.roles
        self.spring_name = roles['spring']
        self.wheel = s.marker_names.index(roles['wheel_marker'])
        self.tyre_load = s.load_names.index(roles['tyre_load'])
        ends = s.spring(self.spring_name, s.q0[None]).bodies
        fixed = {mechanism.body_index(b.name) for b in mechanism.bodies if b.fixed}
        chassis = [i for i, b in enumerate(ends)
                   if b == 'ground' or (b != 'ground' and mechanism.body_index(b) in fixed)]
        if len(chassis) != 1:  # the reader refuses such files; a Mechanism built in Python
            raise ConfigError(f'{mechanism.name}: the suspension spring {self.spring_name!r} '
                              f'must connect the chassis side to the linkage (ends {ends})')
        self.chassis_end = chassis[0]
        self.marker_ref = s.marker_reference()
        self.ind0 = s.q0[s.ind[0]]
        self.time_s = 0.0  # wall time spent inside this module (benchmarks)
        self.reused = 0  # queries answered from a remembered analysis
        self._poses: OrderedDict[bytes, tuple[np.ndarray, np.ndarray, np.ndarray]] = \
            OrderedDict()
        self._states: OrderedDict[bytes, ModuleKinematics] = OrderedDict()

    @staticmethod
    def _remember(memory: OrderedDict, key: bytes, value, size: int) -> None:
        memory[key] = value
        while len(memory) > size:
            memory.popitem(last=False)

    def _pose(self, z_W: np.ndarray, guess: np.ndarray | None):
        """Position analysis at wheel travels ``z_W``: (q, C_q, marker positions)."""
        key = z_W.tobytes()
        pose = self._poses.get(key)
        if pose is not None:
            self.reused += 1
            return pose
        s = self.solver
        q = s.positions(z_W[:, None] + self.ind0, guess)
        Cq = s.constraint_jacobian(q)
        pose = (q, Cq, s.marker_positions(q) - self.marker_ref)
        for a in pose:
            a.flags.writeable = False
        self._remember(self._poses, key, pose, self.memory)
        return pose

    def kinematics(self, z_W: np.ndarray, v_W: np.ndarray,
                   guess: np.ndarray | None = None) -> ModuleKinematics:
        """Position and velocity analysis at N wheel-travel states (arrays of shape (N,));
        ``guess``: body coordinates (N, n) to start the position analysis from."""
        t0 = time.perf_counter()
        z_W = np.ascontiguousarray(z_W, dtype=float)
        v_W = np.ascontiguousarray(v_W, dtype=float)
        key = z_W.tobytes() + v_W.tobytes()
        try:
            kin = self._states.get(key)
            if kin is not None:
                self.reused += 1
            else:
                s = self.solver
                q, Cq, pos = self._pose(z_W, guess)
                qd = s.velocities(q, v_W[:, None], Cq, max_sensitivity=self.max_sensitivity)
                qd.flags.writeable = False
                vel = s.marker_velocities(q, qd)
                kin = ModuleKinematics(q_W=pos[:, self.wheel, 1], qd_W=vel[:, self.wheel, 1],
                                       state=MultibodyState(q=q, qd=qd, Cq=Cq))
                self._remember(self._states, key, kin, self.memory)
        finally:
            self.time_s += time.perf_counter() - t0
        # a fresh state object: dynamics() attaches accelerations and multipliers to it
        st = kin.state
        return ModuleKinematics(q_W=kin.q_W, qd_W=kin.qd_W,
                                state=MultibodyState(q=st.q, qd=st.qd, Cq=st.Cq))

    def spring_params(self, state: MultibodyState, z_M, v_M, k_S, c_S) -> dict:
        """The spring's run-time values: rate, damping, and the preload
        ``e_z (k_S z_M + c_S v_M)`` of the chassis mount's motion along its axis."""
        e_z = self.axis_vertical(state)
        return {self.spring_name: {'stiffness': k_S, 'damping': c_S,
                                   'preload': e_z * (k_S * z_M + c_S * v_M)}}

    def axis_vertical(self, state: MultibodyState) -> np.ndarray:
        """``e_z``: vertical component of the unit vector from the spring's linkage end to
        its chassis end, (N,)."""
        sp = self.solver.spring(self.spring_name, state.q)
        return sp.direction[:, 1 - self.chassis_end, 1]

    def dynamics(self, state: MultibodyState, z_M: np.ndarray, v_M: np.ndarray,
                 k_S: np.ndarray, c_S: np.ndarray, F_T: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Augmented-form dynamics (eq. 11) under the suspension spring (rate ``k_S``,
        damping ``c_S``, chassis mount at ``z_M``, ``v_M``) and ``+F_T`` on the contact
        patch: wheel-travel acceleration (N,), the spring's vertical force on the chassis
        ``F_S`` (N,) and the joint reactions (N, nj, 2)."""
        t0 = time.perf_counter()
        s = self.solver
        try:
            loads = np.zeros((state.q.shape[0], len(s.load_names)))
            loads[:, self.tyre_load] = F_T
            params = self.spring_params(state, z_M, v_M, k_S, c_S)
            Q = s.generalized_forces(state.q, loads, state.qd, params)
            state.qdd, state.lam = s.solve_augmented(state.q, state.qd, Q, Cq=state.Cq)
            sp = s.spring(self.spring_name, state.q, state.qd, params)
            F_S = -sp.force * sp.direction[:, 1 - self.chassis_end, 1]
        finally:
            self.time_s += time.perf_counter() - t0
        return state.qdd[:, s.ind[0]], F_S, s.joint_reactions(state.lam, state.q)

    def constraint_residual(self, state: MultibodyState) -> float:
        """Largest position-constraint violation ``max |C(q)|`` over the states [m]."""
        return float(np.max(np.abs(self.solver.constraints(state.q)), initial=0.0))
