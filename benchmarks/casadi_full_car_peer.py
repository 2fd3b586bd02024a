"""Benchmark peer: suspopt's default full car at low fidelity, written by hand in CasADi.

    python benchmarks/casadi_full_car_peer.py [--repeat 2] [--no-half-car]
                                              [--peer-only] [--segments N]

The full-car counterpart of ``casadi_peer.py`` (the half car): a direct collocation of the
default full car (``suspopt.spec.load.full_car_defaults()``, docs/model.md "Vehicle
models") with the weighted objective of paper eq. 4, solved by IPOPT through
``casadi.nlpsol``. Nothing of suspopt's model, transcription or driver is used. From
suspopt only data: the study description (masses, inertias, axle positions, tracks, tyre
rates, design bounds and initial values, weights, speed, horizon, grid), the two road
tracks (``suspopt.road.road_tracks``, an ISO 8608 class C road and its coherent right
track) and the ``reference`` objective scales (``suspopt.verification.scales``), which
are an input of the problem. The Radau grid (Legendre-Gauss-Radau points, the
differentiation matrix, the quadrature) is ``casadi_peer.radau_grid``, checked there
against dymos' ``GridData``.

Model (docs/model.md; z up, pitch θ nose down, roll φ left side up, ``a`` forward of and
``y`` left of the CG), corners c = 1L, 1R, 2L, 2R at (a_c, y_c) = (a_1, ±t_1/2),
(a_2, ±t_2/2); states heave z_C, pitch θ_C, roll φ_C, the four wheels z_Wc and their rates::

    z_Mc = z_C - a_c θ_C + y_c φ_C                   (the chassis above corner c)
    s_c  = z_Wc - z_Mc                               (suspension deflection)
    F_Sc = k_S,axle s_c + c_S,axle ṡ_c               (eq. 9)
    F_R,1L = -F_R,1R = k_R1 (s_1L - s_1R) / t_1²     (anti-roll bars, likewise rear)
    F_c  = F_Sc + F_R,c                              (on the chassis)
    M z̈_C = Σ F_c,  I_y θ̈_C = -Σ a_c F_c,  I_x φ̈_C = Σ y_c F_c          (5, 6, roll)
    m_c z̈_Wc = k_T,c (δ_c - z_Wc) - F_c                                 (7, 8, 10)

from the zero state at t = 0 over the horizon; δ_c(t) = r_track(c)(v t - offset_c), the
rear wheels ``offset`` = a_1 - a_2 behind the front ones on the same track.

Objective (paper eq. 4 over the full car's terms, docs/metrics.md)::

    f = Σ_k w_k J_k / s_k,  J_k = ∫ g_k dt,  g = (z̈_C², θ̈_C², φ̈_C², z_W1L², ..., z_W2R²)

with the study's weights (1/6 for each chassis term, 1/8 for each wheel; the study's
tyre-load and travel terms have weight 0) and its reference scales s_k.

Transcription and solve as in ``casadi_peer.py``: the compressed Radau grid of dymos
(S segments × order n, Radau IIA collocation), defects ``D X_seg - (h/2) f(X_col)``, the
integrals by the LGR quadrature at the collocation nodes, design scaled to [0, 1] by its
bounds and started at the study's initial design, states started at zero; IPOPT with its
defaults (tol 1e-8) and CasADi's exact Hessian, or IPOPT's L-BFGS.

The comparison (one process, side by side, ``--repeat`` interleaved rounds): the peer
with either Hessian, and suspopt's
``VehicleProblem`` solve of the same study with each of its Hessian options
(``_common.timed_optimize``: IPOPT's solve from the same start, coloring excluded, cached after
its first run). Reported: f, IPOPT iterations, solve wall and CPU
time (``time.process_time``: the machine is shared), per-iteration CPU time, and
suspopt / peer-exact ratios. The half car (``casadi_peer.py`` against the paper's study)
is measured the same way unless ``--no-half-car``.
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
import casadi_peer  # noqa: E402
from _common import git_revision, machine, timed_optimize, write_result  # noqa: E402
from casadi_peer import radau_grid  # noqa: E402

# from suspopt only data (the study description, the road tracks and the reference scales)
from suspopt.road import road_tracks, wheel_road_inputs  # noqa: E402
from suspopt.spec.load import config_from_dict, full_car_defaults  # noqa: E402
from suspopt.spec.resolve import auto_segments  # noqa: E402
from suspopt.spec.schema import StudyConfig  # noqa: E402
from suspopt.verification.scales import resolve_scales  # noqa: E402

CORNERS = ('1L', '1R', '2L', '2R')
#: the aim on the default full car: suspopt's solve CPU time at most this times the
#: exact-Hessian peer's (docs/performance.md)
AIM = 1.2
DESIGN_NAMES = ('k_S1', 'k_S2', 'c_S1', 'c_S2', 'k_R1', 'k_R2')
N_STATES = 14  # z_C, v_C, θ_C, ω_C, φ_C, p_C, z_W (4), v_W (4)


@dataclasses.dataclass(frozen=True)
class FullCarData:
    """The numbers of the NLP, read off a suspopt study description (data only)."""

    mass: float
    pitch_inertia: float
    roll_inertia: float
    a: np.ndarray  # per corner, forward of the CG [m]
    y: np.ndarray  # per corner, left of the CG [m]
    tracks: tuple[float, float]  # front, rear [m]
    wheel_mass: np.ndarray  # per corner [kg]
    tyre_stiffness: np.ndarray  # per corner [N/m]
    speed: float
    horizon: float
    segments: int
    order: int
    initial: np.ndarray  # design, DESIGN_NAMES order
    lower: np.ndarray
    upper: np.ndarray
    terms: tuple[str, ...]  # weighted terms: heave, pitch, roll, wheel_<c>
    weights: np.ndarray
    scales: np.ndarray
    road: dict[str, Any]


def full_car_study(segments: int | None = None) -> StudyConfig:
    """The default full car with its automatic grid resolved (or ``segments``)."""
    full = full_car_defaults()
    seg = segments or auto_segments(full, full.scenarios()[0], full.transcription.order)
    return config_from_dict({**full.to_dict(), 'transcription': {'segments': seg}})


def read_data(cfg: StudyConfig, scales: dict[str, float]) -> FullCarData:
    """The full car's numbers from ``cfg`` and its reference ``scales`` (term -> s_k)."""
    v, sc = cfg.vehicle, cfg.scenarios()[0]
    t1, t2 = v.front.track, v.rear.track
    a1, a2 = v.front.axle_position, v.rear.axle_position
    d = cfg.design
    terms = ('heave', 'pitch', 'roll') + tuple(f'wheel_{c}' for c in CORNERS)
    w = cfg.objective.weights
    unused = [t for t, wt in w.items() if wt > 0.0 and t not in terms]
    if unused:
        raise ValueError(f'the peer models the terms {terms}; the study also weights {unused}')
    return FullCarData(
        mass=v.chassis_mass,
        pitch_inertia=v.chassis_pitch_inertia,
        roll_inertia=v.chassis_roll_inertia,
        a=np.array([a1, a1, a2, a2]),
        y=np.array([t1 / 2, -t1 / 2, t2 / 2, -t2 / 2]),
        tracks=(t1, t2),
        wheel_mass=np.array([v.front.wheel_mass] * 2 + [v.rear.wheel_mass] * 2),
        tyre_stiffness=np.array([v.front.tyre_stiffness] * 2 + [v.rear.tyre_stiffness] * 2),
        speed=sc.speed,
        horizon=sc.horizon,
        segments=sc.segments,
        order=sc.order,
        initial=np.array([d[n].initial for n in DESIGN_NAMES]),
        lower=np.array([d[n].lower for n in DESIGN_NAMES]),
        upper=np.array([d[n].upper for n in DESIGN_NAMES]),
        terms=terms,
        weights=np.array([w.get(t, 0.0) for t in terms]),
        scales=np.array([scales[t] for t in terms]),
        road=dict(sc.road),
    )


def road_inputs(data: FullCarData, t: np.ndarray) -> np.ndarray:
    """δ_c(t) (4, len(t)): the left track under the left wheels, the right track under the
    right ones, the rear wheels a wheelbase behind (docs/roads.md)."""
    left, right = road_tracks(data.road, 2, 0.5 * sum(data.tracks))
    wheelbase = float(data.a[0] - data.a[2])
    hl, _ = wheel_road_inputs(left, t, data.speed, (0.0, wheelbase), rates=False)
    hr, _ = wheel_road_inputs(right, t, data.speed, (0.0, wheelbase), rates=False)
    return np.vstack([hl[0], hr[0], hl[1], hr[1]])


# ------------------------------------------------------------------------------- model
def full_car_function(data: FullCarData) -> ca.Function:
    """(x[14], p[6] physical design, δ[4]) -> (ẋ[14], g[7]): the full car's equations and
    the integrands of its weighted terms."""
    x = ca.SX.sym('x', N_STATES)
    p = ca.SX.sym('p', 6)
    delta = ca.SX.sym('delta', 4)
    z_c, v_c, th, om, ph, pr = (x[i] for i in range(6))
    z_w = [x[6 + i] for i in range(4)]
    v_w = [x[10 + i] for i in range(4)]
    k_s = (p[0], p[0], p[1], p[1])
    c_s = (p[2], p[2], p[3], p[3])
    a, y = data.a, data.y
    z_m = [z_c - a[i] * th + y[i] * ph for i in range(4)]
    v_m = [v_c - a[i] * om + y[i] * pr for i in range(4)]
    s = [z_w[i] - z_m[i] for i in range(4)]
    f_s = [k_s[i] * s[i] + c_s[i] * (v_w[i] - v_m[i]) for i in range(4)]  # eq. 9
    bar = [p[4 + ax] * (s[2 * ax] - s[2 * ax + 1]) / data.tracks[ax] ** 2 for ax in (0, 1)]
    f = [f_s[0] + bar[0], f_s[1] - bar[0], f_s[2] + bar[1], f_s[3] - bar[1]]
    zdd = sum(f) / data.mass  # eq. 5
    thdd = -sum(a[i] * f[i] for i in range(4)) / data.pitch_inertia  # eq. 6
    phdd = sum(y[i] * f[i] for i in range(4)) / data.roll_inertia  # roll
    f_t = [data.tyre_stiffness[i] * (delta[i] - z_w[i]) for i in range(4)]  # eq. 10
    wdd = [(f_t[i] - f[i]) / data.wheel_mass[i] for i in range(4)]  # eqs. 7, 8
    xdot = ca.vertcat(v_c, zdd, om, thdd, pr, phdd, *v_w, *wdd)
    g = ca.vertcat(zdd**2, thdd**2, phdd**2, *[zw**2 for zw in z_w])
    return ca.Function('full_car', [x, p, delta], [xdot, g], ['x', 'p', 'delta'], ['xdot', 'g'])


@dataclasses.dataclass(frozen=True)
class PeerResult:
    """One solve of the peer."""

    hessian: str
    objective: float
    design: dict[str, float]
    terms: dict[str, float]  # J_k / s_k
    success: bool
    status: str
    iterations: int
    n_variables: int
    n_constraints: int
    build_s: float
    solve_s: float
    solve_cpu_s: float
    eval_cpu_s: float  # in IPOPT's calls of f, g, ∇f and the Jacobian (CasADi's t_proc)
    hess_cpu_s: float  # in its calls of the Hessian of the Lagrangian


def solve_peer(
    data: FullCarData, hessian: str = 'exact', *, fixed_design: bool = False, expand: bool = False
) -> PeerResult:
    """Build and solve the full car's NLP with IPOPT (``hessian``: 'exact', CasADi's AD,
    or 'limited-memory'); ``fixed_design`` pins the design at the initial one (the
    collocation equations alone: f there is about 1 with reference scales); ``expand``:
    CasADi's ``expand`` option (the MX graph turned into one SX expression graph before
    the solve, which CasADi's documentation recommends for speed). The built solver is
    kept and reused by later calls with the same data and options (its build time is the
    first call's)."""
    if hessian not in ('exact', 'limited-memory'):
        raise ValueError(f"hessian must be 'exact' or 'limited-memory', got {hessian!r}")
    key = (id(data), hessian, expand)
    if key not in _BUILT:
        _BUILT[key] = (data, *build_peer(data, hessian, expand))
    _, solver, terms_fn, n_constraints, build = _BUILT[key]
    lower, span = data.lower, data.upper - data.lower
    n_w = solver.size1_in(0)
    x0_hat = (data.initial - lower) / span
    lbw, ubw = -np.inf * np.ones(n_w), np.inf * np.ones(n_w)
    lbw[:6], ubw[:6] = (x0_hat, x0_hat) if fixed_design else (0.0, 1.0)
    w0 = np.zeros(n_w)
    w0[:6] = x0_hat

    t0, c0 = time.perf_counter(), time.process_time()
    sol = solver(x0=w0, lbx=lbw, ubx=ubw, lbg=0.0, ubg=0.0)
    solve, cpu = time.perf_counter() - t0, time.process_time() - c0
    st = solver.stats()
    w_opt = np.asarray(sol['x']).ravel()
    return PeerResult(
        hessian=hessian,
        objective=float(sol['f']),
        design=dict(zip(DESIGN_NAMES, map(float, lower + span * w_opt[:6]))),
        terms=dict(zip(data.terms, map(float, np.asarray(terms_fn(w_opt)).ravel()))),
        success=bool(st['success']),
        status=str(st['return_status']),
        iterations=int(st['iter_count']),
        n_variables=int(n_w),
        n_constraints=n_constraints,
        build_s=build,
        solve_s=solve,
        solve_cpu_s=cpu,
        eval_cpu_s=float(
            sum(st.get(f't_proc_nlp_{k}', 0.0) for k in ('f', 'g', 'grad_f', 'jac_g'))
        ),
        hess_cpu_s=float(st.get('t_proc_nlp_hess_l', 0.0)),
    )


#: built solvers by (id(data), hessian, expand), with their data (kept alive: the id)
_BUILT: dict[tuple[int, str, bool], tuple[Any, ...]] = {}


def build_peer(
    data: FullCarData, hessian: str, expand: bool
) -> tuple[ca.Function, ca.Function, int, float]:
    """The NLP as a CasADi ``nlpsol`` (variables: the scaled design, then the states at
    nodes 1..N-1; node 0 is the zero initial state), the function of the normalized
    terms J_k / s_k, the number of defects and the build time [s]."""
    t_build = time.perf_counter()
    S, n = data.segments, data.order
    grid = radau_grid(S, n, data.horizon)
    n_col = S * n
    n_nodes = n_col + 1
    delta = road_inputs(data, grid['t_col'])

    r = (np.arange(S)[:, None, None] * n + np.arange(n)[None, :, None]) + 0 * np.arange(n + 1)
    c = (np.arange(S)[:, None, None] * n + np.arange(n + 1)[None, None, :]) + 0 * r
    vals = np.broadcast_to(grid['D'][None], (S, n, n + 1))
    D_glob = ca.DM.triplet(
        r.ravel().tolist(), c.ravel().tolist(), ca.DM(vals.ravel()), n_col, n_nodes
    )

    xhat = ca.MX.sym('xhat', 6)
    X_free = ca.MX.sym('X', N_STATES, n_nodes - 1)
    X = ca.horzcat(ca.MX.zeros(N_STATES, 1), X_free)
    lower, span = data.lower, data.upper - data.lower
    design = lower + span * xhat
    ode = full_car_function(data).map(n_col)
    F, G = ode(X[:, :n_col], ca.repmat(design, 1, n_col), ca.DM(delta))
    defects = ca.mtimes(X, D_glob.T) - 0.5 * grid['h'] * F
    J = ca.mtimes(G, ca.DM(grid['quad']))  # the integrals J_k
    f = ca.dot(ca.DM(data.weights / data.scales), J)

    w = ca.vertcat(xhat, ca.vec(X_free))
    opts: dict[str, Any] = {
        'ipopt.print_level': 0,
        'print_time': False,
        'ipopt.sb': 'yes',
        'ipopt.hessian_approximation': hessian,
        'expand': expand,
    }
    nlp: dict[str, Any] = {'x': w, 'f': f, 'g': ca.vec(defects)}
    solver = ca.nlpsol('solver', 'ipopt', nlp, opts)
    terms_fn = ca.Function('terms', [w], [J / ca.DM(data.scales)])
    return solver, terms_fn, int(defects.numel()), time.perf_counter() - t_build


# ------------------------------------------------------------------------------- compare
@dataclasses.dataclass(frozen=True)
class Run:
    """One timed solve of either tool, as the tables show it."""

    car: str
    solver: str  # 'CasADi peer' or 'suspopt'
    hessian: str
    f: float
    iterations: int
    success: bool
    setup_s: float  # the peer's NLP build; suspopt's problem setup + starting trajectory
    solve_s: float
    solve_cpu_s: float
    eval_cpu_s: float  # CPU time in IPOPT's calls of f, g, ∇f and the Jacobian
    hess_cpu_s: float  # in its calls of the Hessian
    design: dict[str, float]
    round: int = 0


def peer_run(car: str, who: str, solve: Any, hessian: str) -> Run:
    r = solve(hessian)
    if isinstance(r, PeerResult):
        return Run(
            car,
            who,
            hessian,
            r.objective,
            r.iterations,
            r.success,
            r.build_s,
            r.solve_s,
            r.solve_cpu_s,
            r.eval_cpu_s,
            r.hess_cpu_s,
            r.design,
        )
    return Run(  # casadi_peer.solve_peer's dict (the half car)
        car,
        'CasADi peer',
        hessian,
        r['objective'],
        r['iterations'],
        r['success'],
        r['build_time_s'],
        r['solve_time_s'],
        r['solve_cpu_s'],
        r['eval_cpu_s'],
        r['hess_cpu_s'],
        r['design'],
    )


@contextmanager
def callback_clock() -> Iterator[dict[str, float]]:
    """CPU time spent in the IPOPT callbacks of suspopt's driver while inside: ``eval``
    (objective, constraints, gradient, Jacobian) and ``hess`` (the Hessian), by wrapping
    the driver's methods (a few hundred calls per solve: the clock costs nothing)."""
    from suspopt.driver.ipopt import IpoptDriver

    spent = {'eval': 0.0, 'hess': 0.0}
    names = {'objective': 'eval', 'constraints': 'eval', 'gradient': 'eval'}
    names |= {'jacobian': 'eval', 'hessian': 'hess'}
    saved = {n: getattr(IpoptDriver, n) for n in names}

    def clocked(fn: Any, kind: str) -> Any:
        def call(*args: Any, **kwargs: Any) -> Any:
            c0 = time.process_time()
            try:
                return fn(*args, **kwargs)
            finally:
                spent[kind] += time.process_time() - c0

        return call

    for n, kind in names.items():
        setattr(IpoptDriver, n, clocked(saved[n], kind))
    try:
        yield spent
    finally:
        for n, fn in saved.items():
            setattr(IpoptDriver, n, fn)


def suspopt_run(car: str, cfg: StudyConfig, scales: Any, hessian: str) -> Run:
    with callback_clock() as spent:
        r = timed_optimize(cfg, 'low', scales, cfg.design.initial(), hessian=hessian)
    r.pop('problem').cleanup()
    return Run(
        car,
        'suspopt',
        hessian,
        r['f'],
        r['iterations'],
        r['success'],
        r['setup'] + r['guess'],
        r['solve'],
        r['solve_cpu'],
        spent['eval'],
        spent['hess'],
        r['design'],
    )


def half_car_solver(scales: tuple[float, ...]) -> Any:
    """``casadi_peer.solve_peer`` on the paper's study grid."""
    segments = StudyConfig().transcription.segments

    def solve(hessian: str) -> dict[str, Any]:
        return casadi_peer.solve_peer(segments, 5, scales, hessian)

    return solve


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--repeat', type=int, default=2, help='rounds')
    ap.add_argument('--segments', type=int, default=None, help="default: the study's auto grid")
    ap.add_argument('--no-half-car', action='store_true')
    ap.add_argument('--peer-only', action='store_true', help='the peer alone, not written')
    args = ap.parse_args(argv)

    full = full_car_study(args.segments)
    full_scales = resolve_scales(full)
    data = read_data(full, full_scales[0])
    cases: list[tuple[str, dict[str, Any], StudyConfig, Any]] = [
        (
            'full car',
            {
                'CasADi peer': lambda h: solve_peer(data, h),
                'CasADi peer (SX)': lambda h: solve_peer(data, h, expand=True),
            },
            full,
            full_scales,
        )
    ]
    if not args.no_half_car:
        paper = StudyConfig()
        paper_scales = resolve_scales(paper)
        cases.append(
            (
                'half car (paper)',
                {'CasADi peer': half_car_solver(casadi_peer.resolve_scales(paper_scales))},
                paper,
                paper_scales,
            )
        )
    fixed = solve_peer(data, 'exact', fixed_design=True)
    print(
        f'peer at the initial design (collocation alone): f = {fixed.objective:.6f}; '
        f'{fixed.n_variables} variables, {fixed.n_constraints} constraints',
        flush=True,
    )

    solvers = [('CasADi peer', h) for h in ('exact', 'limited-memory')]
    solvers += [('CasADi peer (SX)', 'exact')]
    if not args.peer_only:
        solvers += [('suspopt', h) for h in ('limited-memory', 'exact')]
    runs: list[Run] = []
    for rnd in range(args.repeat):
        for car, peers, cfg, scales in cases:
            for who, h in solvers:
                if who == 'suspopt':
                    run = suspopt_run(car, cfg, scales, h)
                elif who in peers:
                    run = peer_run(car, who, peers[who], h)
                else:
                    continue
                print(
                    f'round {rnd} {car:<17} {who:<17} {h:<15} f={run.f:.10g} '
                    f'it={run.iterations:<4} solve {run.solve_s:6.2f} s, '
                    f'CPU {run.solve_cpu_s:6.2f} s',
                    flush=True,
                )
                runs.append(dataclasses.replace(run, round=rnd))
    md = tables(runs, cases, solvers, data, fixed, args.repeat)
    print(md)
    if not args.peer_only:
        path = write_result(
            'casadi_full_car_peer',
            'suspopt against hand-written CasADi collocations (full car and half car)',
            md,
            {
                'runs': [dataclasses.asdict(r) for r in runs],
                'full_car': {
                    'segments': data.segments,
                    'order': data.order,
                    'n_variables': fixed.n_variables,
                    'n_constraints': fixed.n_constraints,
                    'f_at_initial_design': fixed.objective,
                },
            },
        )
        print(f'\nwritten to {path}')


def round_ratios(runs: list[Run], refs: list[Run]) -> list[float]:
    """Solve CPU time of each of ``runs`` over that of ``refs`` in the same round."""
    by_round = {r.round: r.solve_cpu_s for r in refs}
    return [r.solve_cpu_s / by_round[r.round] for r in runs if r.round in by_round]


def ratio_cell(runs: list[Run], refs: list[Run]) -> str:
    """The median of the per-round ratios in bold, their range in brackets."""
    x = round_ratios(runs, refs)
    return f'**{statistics.median(x):.2f}** ({min(x):.2f}–{max(x):.2f})'


def tables(
    runs: list[Run],
    cases: list[tuple[str, dict[str, Any], StudyConfig, Any]],
    solvers: list[tuple[str, str]],
    data: FullCarData,
    fixed: PeerResult,
    repeat: int,
) -> str:
    med = statistics.median
    md = [
        f'Low fidelity, from the initial design, states from zero — {machine()}, suspopt '
        f'{git_revision()}. Default full car: {data.segments} × {data.order} Radau, '
        f'{fixed.n_variables} NLP variables, {fixed.n_constraints} defects (the peer); the '
        "paper's half car on its 80 × 5 grid. Medians of "
        f'{repeat} interleaved rounds (the coloring, cached after its first run, is not in '
        "suspopt's solve time); the ratios are the median (and range) of each round's "
        'ratio to the peer solved in that round.',
        '',
        '| car | solver | Hessian | f | IPOPT iterations | setup [s] | solve [s] | '
        'solve CPU [s] | CPU per iteration [ms] | CPU / peer exact | CPU / peer (SX) exact |',
        '|---|---|---|---|---|---|---|---|---|---|---|',
    ]
    for car, *_ in cases:
        sel = {
            (w, h): [r for r in runs if (r.car, r.solver, r.hessian) == (car, w, h)]
            for w, h in solvers
        }
        ref = sel['CasADi peer', 'exact']
        sx = sel.get(('CasADi peer (SX)', 'exact'))
        f_ref = sel['CasADi peer', 'exact'][-1].f
        for (w, h), rs in sel.items():
            if not rs:
                continue
            last = rs[-1]
            cpu = med(r.solve_cpu_s for r in rs)
            flag = '' if last.success else ' (not converged)'
            md.append(
                f'| {car} | {w} | {h} | {last.f:.10g} (Δ {abs(last.f - f_ref) / abs(f_ref):.1e}) '
                f'| {last.iterations}{flag} | {med(r.setup_s for r in rs):.2f} '
                f'| {med(r.solve_s for r in rs):.2f} | {cpu:.2f} '
                f'| {1e3 * cpu / max(last.iterations, 1):.0f} | {ratio_cell(rs, ref)} '
                + (f'| {ratio_cell(rs, sx)} |' if sx else '| — |')
            )
    md += [
        '',
        "Where each solve's CPU time goes (medians): in IPOPT's calls of the model (f, "
        'constraints, their gradient and Jacobian), of the Hessian of the Lagrangian, and '
        "in IPOPT itself (the rest: the KKT factorizations by MUMPS, L-BFGS' updates, "
        "the driver's own bookkeeping outside the callbacks, "
        "line search), per iteration. The peer's from CasADi's own `t_proc_*` statistics, "
        "suspopt's by a CPU clock around its driver's callbacks.",
        '',
        '| car | solver | Hessian | iterations | model calls [ms/it] | Hessian [ms/it] | '
        'IPOPT itself [ms/it] | all [ms/it] |',
        '|---|---|---|---|---|---|---|---|',
    ]
    summary = []
    for car, *_ in cases:
        best: dict[str, tuple[float, list[Run], float]] = {}
        for w, h in solvers:
            rs = [r for r in runs if (r.car, r.solver, r.hessian) == (car, w, h)]
            if not rs:
                continue
            it = max(rs[-1].iterations, 1)
            cpu, ev, he = (
                med(getattr(r, k) for r in rs) for k in ('solve_cpu_s', 'eval_cpu_s', 'hess_cpu_s')
            )
            md.append(
                f'| {car} | {w} | {h} | {rs[-1].iterations} | {1e3 * ev / it:.0f} '
                f'| {1e3 * he / it:.0f} | {1e3 * (cpu - ev - he) / it:.0f} | {1e3 * cpu / it:.0f} |'
            )
            if w == 'suspopt' and ('suspopt' not in best or cpu < best['suspopt'][0]):
                best['suspopt'] = (cpu, rs, cpu / it)
            if h == 'exact' and w.startswith('CasADi'):
                best[w] = (cpu, rs, cpu / it)
        _, s_rs, s_it = best['suspopt']
        s_run = s_rs[-1]
        for w in ('CasADi peer', 'CasADi peer (SX)'):
            if w not in best:
                continue
            _, p_rs, p_it = best[w]
            p_run = p_rs[-1]
            ratio = med(round_ratios(s_rs, p_rs))
            summary.append(
                f"{car}: suspopt's fastest option ({s_run.hessian}) takes {ratio:.2f}× the "
                f'CPU time of the {w} with the exact Hessian (median of the rounds): '
                f'{s_run.iterations} iterations '
                f'against {p_run.iterations} ({s_run.iterations / max(p_run.iterations, 1):.2f}×) '
                f'at {1e3 * s_it:.0f} against {1e3 * p_it:.0f} ms per iteration '
                f'({s_it / p_it:.2f}×)'
                + (
                    f'; {"within" if ratio <= AIM else "above"} the aim of {AIM}×.'
                    if car == 'full car'
                    else '.'
                )
            )
    md += ['', *summary]
    md += [
        '',
        'Δ: |f − f(peer, exact)| / f(peer, exact). Solve: IPOPT alone (suspopt: the '
        "driver's solve without the coloring; the peer: `nlpsol`'s call). Setup: building the NLP "
        '(suspopt: the OpenMDAO/Dymos problem and the starting trajectory). CPU time is '
        "the process's (`time.process_time`); the machine is shared, so wall times are "
        'noisy and CPU time is the fairer measure. The peer (SX): the same NLP with '
        "CasADi's `expand` option (its MX graph turned into one SX graph before the "
        'solve).',
    ]
    return '\n'.join(md)


if __name__ == '__main__':
    main()
