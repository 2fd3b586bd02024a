"""The vehicle-facing interface of a suspension mechanism (SPEC §3, paper eqs. 11-13).

One :class:`SuspensionModule` per axle wraps a :class:`PlanarMultibodySolver` and maps the
vehicle's quantities onto the mechanism's roles (``[suspension]`` table of the mechanism
file): wheel travel ``z_W`` drives the independent coordinate; ``q^z_U`` and ``q^z_W``
are the vertical displacements of the spring and wheel markers; ``F_S`` and ``F_T`` are
the magnitudes of the suspension and tyre loads. Both the black-box OpenMDAO components
and the time-marching integrator call these two methods, so both integrate one model.
"""
from __future__ import annotations

import time
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from suspopt.multibody.mechanism import Mechanism, load_mechanism
from suspopt.multibody.solver import MultibodyState, PlanarMultibodySolver


@dataclass
class ModuleKinematics:
    """Vertical displacement/velocity of the spring point (q^z_U) and the wheel (q^z_W)."""

    q_U: np.ndarray
    qd_U: np.ndarray
    q_W: np.ndarray
    qd_W: np.ndarray
    state: MultibodyState


class SuspensionModule:
    """One axle's multibody suspension, queried as a black box.

    It remembers its last few analyses: a query at exactly the inputs of one of them
    returns that analysis instead of repeating it. Under finite differences this is most
    queries: perturbing the wheel-travel rate or a force leaves the positions unchanged,
    and the dynamics query repeats the kinematics query's state. A position analysis
    (Newton on ``C(q) = 0``) starts from the reference pose unless the caller gives a
    guess, so every answer is a function of the query alone, bit for bit, whatever was
    asked before (a warm start from the last pose would save ~0.1 s per mixed solve but
    make results depend on the history, e.g. on whether the coloring was cached).
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
        self.spring = s.marker_names.index(roles['spring_marker'])
        self.wheel = s.marker_names.index(roles['wheel_marker'])
        self.suspension_load = s.load_names.index(roles['suspension_load'])
        self.tyre_load = s.load_names.index(roles['tyre_load'])
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
                kin = ModuleKinematics(q_U=pos[:, self.spring, 1], qd_U=vel[:, self.spring, 1],
                                       q_W=pos[:, self.wheel, 1], qd_W=vel[:, self.wheel, 1],
                                       state=MultibodyState(q=q, qd=qd, Cq=Cq))
                self._remember(self._states, key, kin, self.memory)
        finally:
            self.time_s += time.perf_counter() - t0
        # a fresh state object: dynamics() attaches accelerations and multipliers to it
        st = kin.state
        return ModuleKinematics(q_U=kin.q_U, qd_U=kin.qd_U, q_W=kin.q_W, qd_W=kin.qd_W,
                                state=MultibodyState(q=st.q, qd=st.qd, Cq=st.Cq))

    def dynamics(self, state: MultibodyState, F_S: np.ndarray,
                 F_T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Augmented-form dynamics (eq. 11) under ``-F_S`` on the spring point and ``+F_T``
        on the contact patch: wheel-travel acceleration (N,) and joint reactions (N, nj, 2)."""
        t0 = time.perf_counter()
        s = self.solver
        loads = np.zeros((state.q.shape[0], len(s.load_names)))
        loads[:, self.suspension_load] = F_S  # its direction points down: force = -F_S up
        loads[:, self.tyre_load] = F_T
        try:
            state.qdd, state.lam = s.solve_augmented(state.q, state.qd,
                                                     s.generalized_forces(state.q, loads),
                                                     Cq=state.Cq)
        finally:
            self.time_s += time.perf_counter() - t0
        return state.qdd[:, s.ind[0]], s.joint_reactions(state.lam)

    def constraint_residual(self, state: MultibodyState) -> float:
        """Largest position-constraint violation ``max |C(q)|`` over the states [m]."""
        return float(np.max(np.abs(self.solver.constraints(state.q)), initial=0.0))
