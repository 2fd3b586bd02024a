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
    """One axle's multibody suspension, queried as a black box."""

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

    def kinematics(self, z_W: np.ndarray, v_W: np.ndarray,
                   guess: np.ndarray | None = None) -> ModuleKinematics:
        """Position and velocity analysis at N wheel-travel states (arrays of shape (N,))."""
        t0 = time.perf_counter()
        s = self.solver
        try:
            st = s.consistent_state(np.asarray(z_W, dtype=float)[:, None] + self.ind0,
                                    np.asarray(v_W, dtype=float)[:, None], guess)
            pos = s.marker_positions(st.q) - self.marker_ref
            vel = s.marker_velocities(st.q, st.qd)
        finally:
            self.time_s += time.perf_counter() - t0
        return ModuleKinematics(q_U=pos[:, self.spring, 1], qd_U=vel[:, self.spring, 1],
                                q_W=pos[:, self.wheel, 1], qd_W=vel[:, self.wheel, 1], state=st)

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
