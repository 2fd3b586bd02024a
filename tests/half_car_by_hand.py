"""The paper's half car (eqs. 5-10) written out by hand as a state space, and its
objective integrals (eq. 4) marched by SciPy alone: a route to the low-fidelity model
that shares no code with suspopt's models or time marching (only the road profile, an
input)."""

from __future__ import annotations

import numpy as np
from scipy.integrate import trapezoid
from scipy.signal import lsim

from suspopt.road import wheel_road_inputs
from suspopt.spec.schema import StudyConfig


def half_car_matrices(cfg: StudyConfig, x: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """State-space form of paper eqs. 5-10 written out by hand: y' = A y + B δ,
    y = (z_C, θ, z_W1, z_W2, v_C, ω, v_W1, v_W2)."""
    v = cfg.vehicle
    M, I = v.chassis_mass, v.chassis_pitch_inertia
    a = np.array([v.front.axle_position, v.rear.axle_position])
    m = np.array([v.front.wheel_mass, v.rear.wheel_mass])
    kT = np.array([v.front.tyre_stiffness, v.rear.tyre_stiffness])
    k = np.array([x['k_S1'], x['k_S2']])
    c = np.array([x['c_S1'], x['c_S2']])
    # suspension deflection of axle i: z_Wi + a_i θ - z_C = D[i] @ (z_C, θ, z_W1, z_W2)
    D = np.array([[-1.0, a[0], 1.0, 0.0], [-1.0, a[1], 0.0, 1.0]])
    # generalized forces on (z_C, θ, z_W1, z_W2) from F_S1, F_S2: -D^T (virtual work)
    Mass = np.diag([M, I, m[0], m[1]])
    K = D.T @ np.diag(k) @ D + np.diag([0.0, 0.0, kT[0], kT[1]])
    C = D.T @ np.diag(c) @ D
    A = np.zeros((8, 8))
    A[:4, 4:] = np.eye(4)
    A[4:, :4] = -np.linalg.solve(Mass, K)
    A[4:, 4:] = -np.linalg.solve(Mass, C)
    B = np.zeros((8, 2))
    B[4:, :] = np.linalg.solve(Mass, np.array([[0, 0], [0, 0], [kT[0], 0], [0, kT[1]]]))
    return A, B


def _march(
    A: np.ndarray, B: np.ndarray, cfg: StudyConfig, step: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Grid times, states (N, 8) and wheel road heights (N, 2) from the zero state: exact
    for a road input linear between the grid times (``lsim``'s first-order hold)."""
    T = cfg.maneuver.horizon
    t = np.linspace(0.0, T, int(round(T / step)) + 1)
    d, _ = wheel_road_inputs(
        cfg.road_profile(), t, cfg.maneuver.speed, (0.0, cfg.vehicle.wheelbase), rates=False
    )
    _, _, y = lsim((A, B, np.eye(8), np.zeros((8, 2))), d.T, t, X0=np.zeros(8), interp=True)
    return t, y, d.T


def states_by_hand(
    cfg: StudyConfig, x: dict[str, float], every: int = 100, *, step: float = 1e-4
) -> tuple[np.ndarray, np.ndarray]:
    """Times (every ``every`` steps of ``step``) and the states there, (N, 8), on grids of
    ``step`` and twice it, Richardson-extrapolated (the hold's error is O(step²))."""
    A, B = half_car_matrices(cfg, x)
    t, fine, _ = _march(A, B, cfg, step)
    _, coarse, _ = _march(A, B, cfg, 2 * step)
    return t[::every], (4.0 * fine[::every] - coarse[:: every // 2]) / 3.0


def _terms_on_grid(A: np.ndarray, B: np.ndarray, cfg: StudyConfig, step: float) -> np.ndarray:
    t, y, d = _march(A, B, cfg, step)
    acc = y @ A[4:6].T + d @ B[4:6].T  # z̈_C, θ̈ at every grid time
    return trapezoid(np.column_stack([acc**2, y[:, 2:4] ** 2]), t, axis=0)


def objective_terms_by_hand(
    cfg: StudyConfig, x: dict[str, float], *, step: float = 1e-3
) -> np.ndarray:
    """(∫ z̈_C², ∫ θ̈², ∫ z_W1², ∫ z_W2²) over the horizon from the zero state (eq. 4's
    terms in the order of ``cfg.terms()``): the hand-written state space marched exactly
    for a piecewise-linear road input on a fixed grid (SciPy's ``lsim``, first-order hold
    through a matrix exponential), the integrals by the trapezoid rule, on grids of
    ``step`` and twice it, Richardson-extrapolated (both errors are O(step²)). Fixed grids
    make the result a smooth function of the design (no adaptive step to change), as
    finite differences need."""
    A, B = half_car_matrices(cfg, x)
    fine, coarse = _terms_on_grid(A, B, cfg, step), _terms_on_grid(A, B, cfg, 2 * step)
    return (4.0 * fine - coarse) / 3.0
