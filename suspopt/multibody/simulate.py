"""Forward time simulation of a mechanism on its own (no optimizer, no vehicle).

Two ways of keeping the constraints satisfied, selectable by ``method``:

``'partitioned'`` (default) — coordinate partitioning (Wehage & Haug 1982): only the
    independent coordinates and rates are integrated; at every evaluation the dependent
    positions are solved by Newton's method (``C(q) = 0``, warm-started from the previous
    solution) and the velocities from ``C_q q̇ = 0``, then the augmented system (eq. 11)
    gives the accelerations. Position and velocity constraints hold to the Newton
    tolerance at all times. This is what the vehicle model uses.

``'baumgarte'`` — all body coordinates and velocities are integrated with the augmented
    system whose acceleration constraint is stabilized,
    ``C_q q̈ = γ - 2α Ċ - β² C`` (Baumgarte 1972); drift is damped, not removed.

Both integrate with SciPy's DOP853 (adaptive 8th-order Runge-Kutta).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from suspopt.errors import MultibodyError
from suspopt.multibody.solver import Motion, Params, PlanarMultibodySolver

#: load magnitudes (n_loads,) as a function of time and the state (q, q̇) of one instant
LoadFunction = Callable[[float, np.ndarray, np.ndarray], np.ndarray]
#: additional generalized forces (n,) as a function of time and the state of one instant
ForceFunction = Callable[[float, np.ndarray, np.ndarray], np.ndarray]
#: prescribed motion (values of one state) as a function of time
MotionFunction = Callable[[float], Motion]


@dataclass
class MechanismTrajectory:
    """Body coordinates, velocities, accelerations and multipliers at the output times."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    lam: np.ndarray
    info: dict[str, Any] = field(default_factory=dict)


def simulate_mechanism(
    solver: PlanarMultibodySolver,
    t_span: tuple[float, float],
    q_ind0: np.ndarray,
    qd_ind0: np.ndarray,
    *,
    loads: LoadFunction | None = None,
    forces: ForceFunction | None = None,
    params: Params | None = None,
    motion: MotionFunction | None = None,
    method: str = 'partitioned',
    t_eval: np.ndarray | None = None,
    rtol: float = 1e-10,
    atol: float = 1e-12,
    baumgarte: tuple[float, float] = (10.0, 10.0),
    max_step: float = np.inf,
    q_guess: np.ndarray | None = None,
    max_evaluations: int = 200_000,
) -> MechanismTrajectory:
    """Simulate a mechanism from consistent initial conditions built from the independent
    coordinates ``q_ind0`` and rates ``qd_ind0`` (absolute values, shape (dof,)), under
    its force elements (with ``params``, see :class:`PlanarMultibodySolver`), the load
    magnitudes ``loads(t, q, q̇)``, extra generalized forces ``forces(t, q, q̇)`` and the
    prescribed motion ``motion(t)``.

    ``q_guess`` (all coordinates, shape (n,)) starts the initial position analysis instead
    of the reference pose: it selects the assembly branch when the start is far from it.
    A run that needs more than ``max_evaluations`` right-hand sides (the step size
    collapses, typically at a singular configuration where C_q loses rank) stops with a
    :class:`MultibodyError` instead of grinding on.
    """
    q_ind0 = np.atleast_1d(np.asarray(q_ind0, dtype=float))
    qd_ind0 = np.atleast_1d(np.asarray(qd_ind0, dtype=float))
    guess0 = None if q_guess is None else np.asarray(q_guess, dtype=float).reshape(1, -1)
    motion_at = (lambda t: None) if motion is None else motion
    st0 = solver.consistent_state(q_ind0[None], qd_ind0[None], guess0, motion_at(t_span[0]))
    ind, dof, n = solver.ind, solver.dof, solver.n
    t_eval = np.linspace(*t_span, 201) if t_eval is None else np.asarray(t_eval, dtype=float)

    def accelerations(t: float, q: np.ndarray, qd: np.ndarray, stab):
        load = None if loads is None else np.asarray(loads(t, q[0], qd[0]), dtype=float)[None]
        Q = solver.generalized_forces(q, load, qd, params)
        if forces is not None:
            Q = Q + np.asarray(forces(t, q[0], qd[0]), dtype=float)[None]
        return solver.solve_augmented(q, qd, Q, baumgarte=stab, motion=motion_at(t))

    if method == 'partitioned':
        guess = [st0.q]

        def full_state(t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            q = solver.positions(y[None, :dof], guess[0], motion_at(t))
            guess[0] = q
            return q, solver.velocities(q, y[None, dof:], motion=motion_at(t))

        def rhs(t: float, y: np.ndarray) -> np.ndarray:
            q, qd = full_state(t, y)
            qdd, _ = accelerations(t, q, qd, None)
            return np.concatenate([y[dof:], qdd[0, ind]])

        y0 = np.concatenate([q_ind0, qd_ind0])
    elif method == 'baumgarte':

        def full_state(t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            return y[None, :n], y[None, n:]

        def rhs(t: float, y: np.ndarray) -> np.ndarray:
            qdd, _ = accelerations(t, y[None, :n], y[None, n:], baumgarte)
            return np.concatenate([y[n:], qdd[0]])

        y0 = np.concatenate([st0.q[0], st0.qd[0]])
    else:
        raise ValueError(f"method must be 'partitioned' or 'baumgarte', got {method!r}")

    count = [0]

    def guarded(t: float, y: np.ndarray) -> np.ndarray:
        count[0] += 1
        if count[0] > max_evaluations:
            raise MultibodyError(
                f'{solver.mechanism.name}: simulation stalled at t = {t:.6g} after '
                f'{max_evaluations} evaluations (step size collapsed; near a singular '
                'configuration?)'
            )
        return rhs(t, y)

    sol = solve_ivp(
        guarded, t_span, y0, method='DOP853', t_eval=t_eval, rtol=rtol, atol=atol, max_step=max_step
    )
    if sol.status != 0:
        raise MultibodyError(
            f'{solver.mechanism.name}: simulation failed at t = {sol.t[-1]:.4g}: {sol.message}'
        )
    qs: list[np.ndarray] = []
    qds: list[np.ndarray] = []
    qdds: list[np.ndarray] = []
    lams: list[np.ndarray] = []
    for k, t in enumerate(sol.t):
        if method == 'partitioned':
            guess = [qs[-1] if qs else st0.q]
        q, qd = full_state(t, sol.y[:, k])
        qdd, lam = accelerations(t, q, qd, None if method == 'partitioned' else baumgarte)
        qs.append(q)
        qds.append(qd)
        qdds.append(qdd)
        lams.append(lam)
    q = np.concatenate(qs)
    return MechanismTrajectory(
        t=sol.t,
        q=q,
        qd=np.concatenate(qds),
        qdd=np.concatenate(qdds),
        lam=np.concatenate(lams),
        info={
            'method': method,
            'rhs_evaluations': int(sol.nfev),
            'max_constraint_residual': float(
                np.max(
                    np.abs(
                        solver.constraints(q)
                        if motion is None
                        else np.concatenate(
                            [
                                solver.constraints(q[k : k + 1], motion(t))
                                for k, t in enumerate(sol.t)
                            ]
                        )
                    )
                )
            ),
        },
    )
