"""Benchmark peer: suspopt's low-fidelity problem written by hand in CasADi.

This is what an engineer would write *instead of* using suspopt: a direct collocation
of the half car (paper eqs. 5-10, docs/model.md) with the weighted objective of paper eq. 4
(docs/model.md), solved by IPOPT through ``casadi.nlpsol``. Nothing of suspopt's model,
transcription or driver is used; only the road profile is taken from suspopt
(``suspopt.road.wheel_road_inputs``), because the road is data, not model, and the
``reference`` objective scales (``suspopt.verification.timemarching.reference_scales``) are
an input.

Model (docs/model.md, paper eqs. 5-10), states x = [z_C, v_C, θ_C, ω_C, z_W1, v_W1, z_W2, v_W2]::

    M  z̈_C  =  F_S1 + F_S2                                   (5)
    I  θ̈_C  = -a1 F_S1 - a2 F_S2                             (6)
    m_i z̈_Wi = -F_Si + F_Ti                 i = 1, 2          (7), (8)
    F_Si = k_Si (z_Wi + a_i θ_C - z_C) + c_Si (ż_Wi + a_i θ̇_C - ż_C)      (9)
    F_Ti = k_Ti (δ_i - z_Wi)                                             (10)

from the zero state at t = 0 over T = 5 s, with δ_1(t) = r(v t), δ_2(t) = r(v t - L).

Objective (paper eq. 4, docs/model.md)::

    f = Σ_k w_k J_k / s_k,  w_k = 0.25,
    J_1 = ∫ z̈_C² dt,  J_2 = ∫ θ̈_C² dt,  J_3 = ∫ z_W1² dt,  J_4 = ∫ z_W2² dt.

Design x = [k_S1, k_S2, c_S1, c_S2], k in [1e4, 5e4] N/m, c in [1e3, 5e3] N s/m, started
at the mid points and scaled to [0, 1] in the NLP (x = lower + (upper - lower) x̂).

Transcription: the grid of Dymos ``Radau(num_segments=S, order=n, compressed=True)``
(default S = 64, n = 5). Each of the S uniform segments of length h = T/S carries
n + 1 state nodes at segment time τ ∈ [-1, 1]: the n Legendre-Gauss-Radau points
(roots of P_{n-1}(τ) + P_n(τ), which include τ = -1, the segment's left end) and τ = +1,
the right end. The state is the degree-n Lagrange polynomial through those n + 1 nodes;
"compressed" means a segment's right end node *is* the next segment's left end node
(continuity), so the phase has N = S n + 1 state nodes, of which the first S n (the LGR
points of all segments) are the collocation nodes and the last one is t = T. The
defects, as in dymos' ``StateInterpComp`` + ``CollocationComp``, are

    D X_seg - (h/2) f(X_col)  = 0     (D: n x (n+1) Lagrange differentiation matrix)

The objective integrals are accumulated with the LGR quadrature weights w_j at the
collocation nodes, J_k = Σ_seg (h/2) Σ_j w_j g_k(x_j). On this grid that is *exactly*
what dymos' integrated states (rate = integrand, read at t = T) give: the collocation
makes the derivative of the degree-n state polynomial the degree-(n-1) interpolant of
g at the n LGR points, and the n-point LGR rule integrates that exactly. The option
``integrals='states'`` builds the integrated-state version instead (J_k/s_k as four more
states) to show the equivalence.

NLP: variables = the scaled design x̂ (4) and the states at nodes 1..N-1 (node 0 is the
fixed zero state), constraints = the 8 S n defects, built with CasADi MX around one SX
function of the right-hand side mapped over the S n collocation nodes. IPOPT runs with
its defaults (tol 1e-8), an exact Hessian by CasADi's AD (``--hessian limited-memory``
for IPOPT's L-BFGS, as suspopt's driver), design start at the mid points, states start
at zero (the collocation equations are linear in the states, so no simulation is needed
for the guess).

Timing: ``build_time_s`` runs from the first step of building the NLP (grid, road at the
nodes, symbolic expressions) to the created ``nlpsol`` and start vector; module imports
(casadi, and suspopt, which pulls in OpenMDAO) and the reference scales are outside it.
``solve_time_s`` is the wall time of the solver call, ``solve_cpu_s`` its CPU time
(``time.process_time``).

Verification (64 x 5, reference scales): with the design pinned at the mid points f =
1.000151 (suspopt's time marching gives 1 exactly); the optimum is k_S1 = 37509.6,
k_S2 = 28117.5, c_S1 = 1494.49, c_S2 = 1237.04, f = 0.860710 with either Hessian and with
either form of the integrals. ``--check-grid`` compares the grid with dymos' GridData.

Run ``python benchmarks/casadi_peer.py --repeat 3`` (``--help`` for the options).
"""

from __future__ import annotations

import argparse
import statistics
import time
from typing import Any

import casadi as ca
import numpy as np

from suspopt.road import wheel_road_inputs

# from suspopt only data: the road profile and the reference scales. Imported here, outside
# every timer (suspopt.road imports OpenMDAO).
from suspopt.spec.schema import StudyConfig
from suspopt.verification.timemarching import reference_scales

# ---------------------------------------------------------------- problem data (docs/model.md)
A1, A2 = 1.271, -1.713  # axle positions a_i [m] (+ ahead of the CG)
M_C, I_C = 1414.0, 2782.0  # chassis mass [kg] and pitch inertia [kg m^2]
M_W = (120.0, 120.0)  # wheel masses m_i [kg]
K_T = (200000.0, 200000.0)  # tyre stiffnesses k_Ti [N/m]
HORIZON = 5.0  # T [s]
SPEED = 10.0  # v [m/s]
WHEELBASE = A1 - A2  # L [m]
DESIGN_NAMES = ('k_S1', 'k_S2', 'c_S1', 'c_S2')
LOWER = np.array([1e4, 1e4, 1e3, 1e3])
UPPER = np.array([5e4, 5e4, 5e3, 5e3])
WEIGHTS = np.array([0.25, 0.25, 0.25, 0.25])
PAPER_SCALES = (0.1, 0.01, 1.0, 1.0)
N_STATES = 8


# ------------------------------------------------------------------------------- grid
def lgr_points(n: int) -> tuple[np.ndarray, np.ndarray]:
    """The n Legendre-Gauss-Radau points on [-1, 1) (τ = -1 included) and their weights.

    Points: roots of P_{n-1} + P_n. Weights: w_j = (1 - τ_j) / (n P_{n-1}(τ_j))², which
    gives 2/n² at τ = -1.
    """
    c = np.zeros(n + 1)
    c[n - 1] = c[n] = 1.0
    tau = np.sort(np.real(np.polynomial.legendre.legroots(c)))
    tau[0] = -1.0  # exact, not a root-finder value
    p_nm1 = np.polynomial.legendre.legval(tau, np.eye(n)[n - 1])
    w = (1.0 - tau) / (n * p_nm1) ** 2
    return tau, w


def differentiation_matrix(nodes: np.ndarray) -> np.ndarray:
    """D[i, j] = l_j'(τ_i) for the Lagrange basis l_j through ``nodes`` (barycentric form)."""
    diff = nodes[:, None] - nodes[None, :]
    np.fill_diagonal(diff, 1.0)
    bw = 1.0 / np.prod(diff, axis=1)  # barycentric weights
    D = (bw[None, :] / bw[:, None]) / diff
    np.fill_diagonal(D, 0.0)
    np.fill_diagonal(D, -D.sum(axis=1))
    return D


def radau_grid(segments: int, order: int, horizon: float = HORIZON) -> dict:
    """The compressed Radau grid of dymos: node times, collocation-node quadrature weights
    (in time, i.e. (h/2) w_j) and the per-segment differentiation matrix (n x (n+1))."""
    tau_col, w_col = lgr_points(order)
    tau = np.append(tau_col, 1.0)  # n LGR points + right end
    D = differentiation_matrix(tau)[:order, :]  # rows: the collocation nodes
    h = horizon / segments
    starts = h * np.arange(segments)
    t_col = (starts[:, None] + 0.5 * h * (tau_col[None, :] + 1.0)).ravel()
    return {
        't': np.append(t_col, horizon),  # N = S n + 1 state nodes
        't_col': t_col,  # the first S n of them
        'quad': np.tile(0.5 * h * w_col, segments),  # ∫ g dt ≈ quad · g(t_col)
        'D': D,
        'h': h,
        'tau': tau,
    }


def check_grid_against_dymos(segments: int, order: int) -> float:
    """Largest difference between this grid and dymos' ``GridData`` for Radau (nodes in
    phase τ, segment τ, the collocation subset and the differentiation matrix)."""
    from dymos.transcriptions.grid_data import GridData

    gd = GridData(
        num_segments=segments, transcription='radau-ps', transcription_order=order, compressed=True
    )
    g = radau_grid(segments, order)
    n = order
    # dymos lists n + 1 nodes per segment (the shared ends appear twice in its node list)
    ptau = gd.node_ptau.reshape(segments, n + 1)
    t_dymos = (ptau + 1.0) * HORIZON / 2.0
    err = [
        np.abs(t_dymos[:, :n].ravel() - g['t_col']).max(),
        np.abs(t_dymos[:, n] - (g['h'] * np.arange(1, segments + 1))).max(),
        np.abs(gd.node_stau[: n + 1] - g['tau']).max(),
        np.abs(
            gd.node_weight.reshape(segments, n + 1)[:, :n].ravel() * 0.5 * g['h'] - g['quad']
        ).max(),
    ]
    col = gd.subset_node_indices['col'].reshape(segments, n)
    assert np.array_equal(col, np.arange(segments)[:, None] * (n + 1) + np.arange(n)), (
        'dymos collocation nodes are not the first n nodes of each segment'
    )
    # dymos' state-to-collocation differentiation matrix (block diagonal, on segment τ)
    _, Ad = gd.phase_lagrange_matrices('state_disc', 'col')
    D_dymos = np.asarray(Ad)[:n, : n + 1]  # first segment's block
    err.append(np.abs(D_dymos - g['D']).max())
    return float(max(err))


# ------------------------------------------------------------------------------- model
def half_car_function():
    """CasADi function (x[8], p[4] physical design, δ[2]) -> (ẋ[8], g[4]) of eqs. 5-10,
    with g the four objective integrands of eq. 4."""
    x = ca.SX.sym('x', N_STATES)
    p = ca.SX.sym('p', 4)
    delta = ca.SX.sym('delta', 2)
    z_c, v_c, th, om, z_w1, v_w1, z_w2, v_w2 = ca.vertsplit(x)
    k_s, c_s = (p[0], p[1]), (p[2], p[3])
    z_w, v_w, a = (z_w1, z_w2), (v_w1, v_w2), (A1, A2)
    f_s = [
        k_s[i] * (z_w[i] + a[i] * th - z_c) + c_s[i] * (v_w[i] + a[i] * om - v_c) for i in range(2)
    ]  # eq. 9
    f_t = [K_T[i] * (delta[i] - z_w[i]) for i in range(2)]  # eq. 10
    zdd_c = (f_s[0] + f_s[1]) / M_C  # eq. 5
    thdd_c = (-A1 * f_s[0] - A2 * f_s[1]) / I_C  # eq. 6
    zdd_w = [(-f_s[i] + f_t[i]) / M_W[i] for i in range(2)]  # eqs. 7, 8
    xdot = ca.vertcat(v_c, zdd_c, om, thdd_c, v_w1, zdd_w[0], v_w2, zdd_w[1])
    g = ca.vertcat(zdd_c**2, thdd_c**2, z_w1**2, z_w2**2)  # eq. 4
    return ca.Function('half_car', [x, p, delta], [xdot, g], ['x', 'p', 'delta'], ['xdot', 'g'])


def road_inputs(t: np.ndarray) -> np.ndarray:
    """δ_1(t), δ_2(t) of the default study road (docs/roads.md), from suspopt (data only)."""
    road = StudyConfig().road_profile()
    heights, _ = wheel_road_inputs(road, t, SPEED, (0.0, WHEELBASE))
    return heights


def resolve_scales(scales) -> tuple[float, ...]:
    """``None``/'reference' -> suspopt's time-marching J_k at the initial design;
    'paper' -> (0.1, 0.01, 1, 1); a 4-sequence is used as is."""
    if scales is None or (isinstance(scales, str) and scales == 'reference'):
        scales = reference_scales(StudyConfig())
    if isinstance(scales, str):
        if scales != 'paper':
            raise ValueError(f"scales must be 'reference', 'paper' or 4 numbers, got {scales!r}")
        return PAPER_SCALES
    if isinstance(scales, tuple) and scales and isinstance(scales[0], dict):
        # suspopt's per-term table: the four weighted terms of eq. 4
        scales = [scales[0][t] for t in ('heave', 'pitch', 'wheel_1', 'wheel_2')]
    scales = tuple(float(s) for s in scales)
    if len(scales) != 4 or not all(s > 0 for s in scales):
        raise ValueError(f'need 4 positive scales, got {scales}')
    return scales


# ------------------------------------------------------------------------------- solve
def solve_peer(
    segments: int = 64,
    order: int = 5,
    scales=None,
    hessian: str = 'exact',
    *,
    start: dict | None = None,
    fixed_design: bool = False,
    integrals: str = 'quadrature',
) -> dict:
    """Build and solve the low-fidelity NLP; return the optimum and timings.

    scales : None (= 'reference', by suspopt's time marching), 'paper' or 4 numbers.
             Computed before the timer starts: they are an input of the problem.
    hessian : 'exact' (CasADi's AD Hessian) or 'limited-memory' (IPOPT L-BFGS, as suspopt).
    start : initial design {k_S1: ..} (default: the mid points of the bounds).
    fixed_design : pin the design at ``start`` (evaluation by collocation).
    integrals : 'quadrature' (LGR weights) or 'states' (integrated states J_k/s_k).
    """
    if hessian not in ('exact', 'limited-memory'):
        raise ValueError(f"hessian must be 'exact' or 'limited-memory', got {hessian!r}")
    if integrals not in ('quadrature', 'states'):
        raise ValueError(f"integrals must be 'quadrature' or 'states', got {integrals!r}")
    s = np.asarray(resolve_scales(scales), dtype=float)

    t_build = time.perf_counter()
    grid = radau_grid(segments, order)
    n, n_col = order, segments * order
    n_nodes = n_col + 1
    delta = road_inputs(grid['t_col'])  # 2 x n_col, road at col nodes

    # global differentiation matrix: defect block of segment j uses nodes j n .. j n + n
    rows, cols, vals = [], [], []
    for j in range(segments):
        for r in range(n):
            for c in range(n + 1):
                rows.append(j * n + r)
                cols.append(j * n + c)
                vals.append(grid['D'][r, c])
    D_glob = ca.DM.triplet(rows, cols, ca.DM(vals), n_col, n_nodes)

    # decision variables: scaled design, then the states at nodes 1..N-1 (node 0 is the
    # fixed zero initial state)
    n_aug = N_STATES + (4 if integrals == 'states' else 0)
    xhat = ca.MX.sym('xhat', 4)
    X_free = ca.MX.sym('X', n_aug, n_nodes - 1)
    X = ca.horzcat(ca.MX.zeros(n_aug, 1), X_free)
    design = LOWER + (UPPER - LOWER) * xhat  # physical design [N/m, N s/m]

    ode = half_car_function().map(n_col)  # vectorized over the col nodes
    F, G = ode(X[:N_STATES, :n_col], ca.repmat(design, 1, n_col), ca.DM(delta))
    rhs = F if integrals == 'quadrature' else ca.vertcat(F, G / ca.DM(s))
    defects = ca.mtimes(X, D_glob.T) - 0.5 * grid['h'] * rhs

    if integrals == 'quadrature':
        J = ca.mtimes(G, ca.DM(grid['quad']))  # 4 x 1, the integrals J_k
    else:
        J = X[N_STATES:, -1] * ca.DM(s)  # read J_k/s_k at t = T
    f = ca.dot(ca.DM(WEIGHTS / s), J)

    w = ca.vertcat(xhat, ca.vec(X_free))
    nlp = {'x': w, 'f': f, 'g': ca.vec(defects)}
    opts: dict[str, Any] = {
        'ipopt.print_level': 0,
        'print_time': False,
        'ipopt.sb': 'yes',
        'ipopt.hessian_approximation': hessian,
    }
    solver = ca.nlpsol('solver', 'ipopt', nlp, opts)
    terms_fn = ca.Function('terms', [w], [J])
    n_w = w.numel()
    x0 = (LOWER + UPPER) / 2 if start is None else np.array([start[k] for k in DESIGN_NAMES])
    x0_hat = (x0 - LOWER) / (UPPER - LOWER)
    lbw, ubw = -np.inf * np.ones(n_w), np.inf * np.ones(n_w)
    lbw[:4], ubw[:4] = (x0_hat, x0_hat) if fixed_design else (0.0, 1.0)
    w0 = np.zeros(n_w)  # states: zero initial guess
    w0[:4] = x0_hat
    build_time = time.perf_counter() - t_build

    t_solve, cpu_solve = time.perf_counter(), time.process_time()
    sol = solver(x0=w0, lbx=lbw, ubx=ubw, lbg=0.0, ubg=0.0)
    solve_time, solve_cpu = time.perf_counter() - t_solve, time.process_time() - cpu_solve

    stats = solver.stats()
    t_eval = sum(stats.get(f't_proc_nlp_{k}', 0.0) for k in ('f', 'g', 'grad_f', 'jac_g'))
    w_opt = np.asarray(sol['x']).ravel()
    x_opt = LOWER + (UPPER - LOWER) * w_opt[:4]
    J_opt = np.asarray(terms_fn(w_opt)).ravel()
    return {
        'design': dict(zip(DESIGN_NAMES, map(float, x_opt))),
        'objective': float(sol['f']),
        'terms': dict(zip(('J1', 'J2', 'J3', 'J4'), map(float, J_opt))),  # unnormalized J_k
        'scales': tuple(map(float, s)),
        'success': bool(stats['success']),
        'status': stats['return_status'],
        'iterations': int(stats['iter_count']),
        'n_variables': int(n_w),
        'n_constraints': int(defects.numel()),
        'build_time_s': build_time,
        'solve_time_s': solve_time,
        'solve_cpu_s': solve_cpu,
        'eval_cpu_s': float(t_eval),  # IPOPT's calls of f, g and their derivatives
        'hess_cpu_s': float(stats.get('t_proc_nlp_hess_l', 0.0)),  # of the Hessian
        'total_time_s': build_time + solve_time,
    }


# ------------------------------------------------------------------------------- CLI
def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--segments', type=int, default=64)
    ap.add_argument('--order', type=int, default=5)
    ap.add_argument('--normalization', choices=('reference', 'paper'), default='reference')
    ap.add_argument('--hessian', choices=('exact', 'limited-memory'), default='exact')
    ap.add_argument(
        '--integrals',
        choices=('quadrature', 'states'),
        default='quadrature',
        help='objective integrals by LGR quadrature (default) or integrated states',
    )
    ap.add_argument(
        '--fixed-design',
        action='store_true',
        help='pin the design at the initial point (checks f there, ~1 with reference scales)',
    )
    ap.add_argument('--repeat', type=int, default=1)
    ap.add_argument(
        '--check-grid', action='store_true', help="compare the grid with dymos' GridData and exit"
    )
    args = ap.parse_args(argv)

    if args.check_grid:
        err = check_grid_against_dymos(args.segments, args.order)
        print(
            f'grid {args.segments} x {args.order}: largest difference to dymos GridData '
            f'(node times, segment tau, quadrature weights, differentiation) = {err:.2e}'
        )
        return

    scales = resolve_scales(args.normalization)
    runs = [
        solve_peer(
            args.segments,
            args.order,
            scales,
            args.hessian,
            fixed_design=args.fixed_design,
            integrals=args.integrals,
        )
        for _ in range(args.repeat)
    ]
    r = runs[-1]
    print(
        f'CasADi peer: half car, Radau {args.segments} x {args.order} '
        f'({r["n_variables"]} variables, {r["n_constraints"]} constraints), '
        f'hessian={args.hessian}, integrals={args.integrals}, '
        f'normalization={args.normalization}, repeats={args.repeat}'
    )
    print(f'{"time [s]":<10}{"median":>10}{"min":>10}{"max":>10}')
    for key in ('build_time_s', 'solve_time_s', 'total_time_s'):
        vals = [run[key] for run in runs]
        print(f'{key[:-7]:<10}{statistics.median(vals):>10.3f}{min(vals):>10.3f}{max(vals):>10.3f}')
    print(f'status: {r["status"]} (success={r["success"]}), iterations: {r["iterations"]}')
    print('design: ' + ', '.join(f'{k}={v:.6g}' for k, v in r['design'].items()))
    print(
        f'f = {r["objective"]:.6f}   terms J_k/s_k: '
        + ', '.join(f'{k}={v / s:.5f}' for (k, v), s in zip(r['terms'].items(), r['scales']))
    )


if __name__ == '__main__':
    main()
