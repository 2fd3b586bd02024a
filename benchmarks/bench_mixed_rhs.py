"""Benchmark: the mixed-fidelity time marching with the reduced multibody modules.

    python benchmarks/bench_mixed_rhs.py [--models half chassis full] [--states 200]
        [--repeat 3] [--agreement-rtol 1e-10] [--no-compiled]

Models: ``half``, the paper's half car (``StudyConfig()``, ground mount); ``chassis``, the
same with ``multibody.mount = "chassis"``; ``full``, the default full car (``suspopt init
--model full_car``: ``full_car_defaults()``); ``full_chassis`` on request. For each, the
time marching's right-hand side (``suspopt.verification.timemarching.VehicleRHS``,
unchanged) is built with the full modules (``SuspensionModule``, the augmented solve of
eq. 11 at every call) and with the reduced ones (``suspopt.multibody.reduced``, passed as
its ``modules``): NumPy, and compiled by Numba if it is installed.

* right-hand side: process time per call [µs] at ``--states`` consecutive states of the
  low-fidelity trajectory, median of ``--repeat`` sweeps, and the part spent inside the
  multibody modules;
* time marching (``simulate``) at the verification tolerances (rtol 1e-6, atol 1e-9):
  wall time and right-hand-side calls; the compiled modules' first call (Numba's cache
  load or compilation) is made before and reported apart;
* agreement: the objective terms J of the full and the reduced time marching at
  ``--agreement-rtol`` (atol 1e-3 of it), where the integration error is well below 1e-8:
  their largest relative difference must be at most 1e-8 (the script fails otherwise).
  At looser tolerances the two differ by the integrator's own error (two right-hand
  sides equal to rounding make the adaptive steps part, and the J differ at that
  error's level); the difference at the verification tolerance is shown too;
* one-time costs: building each mechanism's table (once per process: later modules of the
  same linkage take it); importing Numba and the compiled kernels' first call.

Timings on a shared machine: compare within one run.
"""

from __future__ import annotations

import argparse
import dataclasses
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import git_revision, machine, write_result  # noqa: E402

from suspopt.multibody.reduced import (  # noqa: E402
    ReducedSuspensionModule,
    clear_tables,
    reduced_modules,
)
from suspopt.spec.load import full_car_defaults  # noqa: E402
from suspopt.spec.schema import StudyConfig  # noqa: E402
from suspopt.transcription.problem import multibody_modules  # noqa: E402
from suspopt.verification.timemarching import VehicleRHS, simulate  # noqa: E402

MODELS = ('half', 'chassis', 'full', 'full_chassis')
VERIFY = (1e-6, 1e-9)
AGREEMENT = 1e-8


def config(model: str):
    cfg = full_car_defaults() if model.startswith('full') else StudyConfig()
    if model.endswith('chassis'):
        cfg = cfg.replace(multibody=dataclasses.replace(cfg.multibody, mount='chassis'))
    return cfg


def variants(compiled: bool) -> list[str]:
    return ['full', 'reduced'] + (['compiled'] if compiled else [])


def modules(cfg, variant: str) -> dict:
    mods = multibody_modules(cfg)
    if variant == 'full':
        return mods
    return reduced_modules(mods, compiled=variant == 'compiled')


def warm_up(mods: dict, cfg) -> float:
    """One query of every module (the compiled kernels' first call): its wall time [s]."""
    t0 = time.perf_counter()
    z = np.zeros(2)
    for mod in mods.values():
        if cfg.multibody.mount == 'chassis':
            kin = mod.kinematics(z, z, pose=(z, z, z, z))
            mod.mount_response(kin, z + 3e4, z + 3e3, z, rotation=True)
        else:
            kin = mod.kinematics(z, z)
            mod.dynamics(kin.state, z, z, z + 3e4, z + 3e3, z)
    return time.perf_counter() - t0


def trajectory_states(cfg, n: int) -> tuple[np.ndarray, np.ndarray, object]:
    """Times and states (n_states, n) along the low-fidelity trajectory at the initial
    design, in the time marching's state layout."""
    sc = cfg.scenarios()[0]
    t = np.linspace(0.0, sc.horizon, n)
    tr = simulate(cfg, 'low', t_eval=t, rtol=1e-6, atol=1e-9)
    rhs = VehicleRHS(cfg, 'low', dict(cfg.design.initial()), sc)
    rows = [tr.values[name] for name in rhs.state_names()]
    rows += list(tr.values['z_W'].T) + list(tr.values['v_W'].T)
    rows += [np.zeros(n)] * rhs.nt
    return t, np.array(rows), sc


class Timed:
    """A module whose queries add their process time to ``cpu_s`` (the modules' own
    ``time_s`` is wall time, which other jobs on a shared machine inflate)."""

    QUERIES = ('kinematics', 'dynamics', 'mount_response', 'constraint_residual')

    def __init__(self, module):
        self.module = module
        self.cpu_s = 0.0

    def __getattr__(self, name):
        attr = getattr(self.module, name)
        if name not in self.QUERIES:
            return attr

        def timed(*args, **kw):
            c0 = time.process_time()
            try:
                return attr(*args, **kw)
            finally:
                self.cpu_s += time.process_time() - c0

        return timed


def rhs_cost(cfg, variant: str, t, Y, sc, repeat: int) -> dict:
    """Process time per right-hand side [µs] along the states, and the modules' part
    (least over ``repeat`` sweeps)."""
    mods = {n: Timed(m) for n, m in modules(cfg, variant).items()}
    warm_up(mods, cfg)
    rhs = VehicleRHS(cfg, 'mixed', dict(cfg.design.initial()), sc, mods)
    per_call, share = [], []
    for _ in range(repeat):
        m0 = sum(m.cpu_s for m in mods.values())
        c0 = time.process_time()
        for i in range(t.size):
            rhs(t[i], Y[:, i])
        elapsed = time.process_time() - c0
        per_call.append(elapsed / t.size * 1e6)
        share.append((sum(m.cpu_s for m in mods.values()) - m0) / t.size * 1e6)
    return {'rhs_us': min(per_call), 'modules_us': min(share)}


def march(cfg, variant: str, rtol: float, atol: float) -> dict:
    mods = modules(cfg, variant)
    first = warm_up(mods, cfg)
    T = cfg.scenarios()[0].horizon
    t0, c0 = time.perf_counter(), time.process_time()
    tr = simulate(cfg, 'mixed', t_eval=np.array([0.0, T]), rtol=rtol, atol=atol, modules=mods)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return {
        'wall_s': wall,
        'cpu_s': cpu,
        'rhs_calls': tr.info['rhs_evaluations'],
        'J': [float(x) for x in tr.J],
        'first_call_s': first,
        'fallbacks': sum(getattr(m, 'fallbacks', 0) for m in mods.values()),
        'max_constraint_residual_m': tr.info['max_constraint_residual_m'],
    }


def table_builds(cfg) -> dict[str, float]:
    out = {}
    clear_tables()
    for name, mod in multibody_modules(cfg).items():
        t0 = time.perf_counter()
        red = ReducedSuspensionModule(mod)
        out[name] = {'build_s': time.perf_counter() - t0, 'degree': red.table.degree}
    return out


NUMBA_STARTUP = """
import time
import numpy as np
from suspopt.multibody.reduced import ReducedSuspensionModule
from suspopt.multibody.suspension import SuspensionModule
t0 = time.perf_counter()
import numba
t1 = time.perf_counter()
z = np.zeros(2)
g = ReducedSuspensionModule(SuspensionModule('double_wishbone'), compiled=True)
c = ReducedSuspensionModule(SuspensionModule('double_wishbone', mount='chassis'), compiled=True)
t2 = time.perf_counter()
g.dynamics(g.kinematics(z, z).state, z, z, z + 3e4, z + 3e3, z)
c.mount_response(c.kinematics(z, z, pose=(z, z, z, z)), z + 3e4, z + 3e3, z)
print(t1 - t0, time.perf_counter() - t2)
"""


def numba_startup_s() -> tuple[float, float] | None:
    """Wall times in a fresh interpreter of ``import numba`` and of the compiled modules'
    first queries (both mounts: Numba's cache load, or compilation when there is no
    cache); None without Numba."""
    res = subprocess.run([sys.executable, '-c', NUMBA_STARTUP], capture_output=True, text=True)
    if res.returncode != 0:
        return None
    imp, first = (float(x) for x in res.stdout.split())
    return imp, first


def rel_diff(a, b) -> float:
    a, b = np.asarray(a), np.asarray(b)
    return float(np.max(np.abs(a / b - 1.0)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--models', nargs='+', choices=MODELS, default=['half', 'chassis', 'full'])
    ap.add_argument('--states', type=int, default=200)
    ap.add_argument('--repeat', type=int, default=3)
    ap.add_argument('--agreement-rtol', type=float, default=1e-10)
    ap.add_argument('--no-compiled', action='store_true', help='leave the Numba kernels out')
    args = ap.parse_args()
    try:
        import numba  # noqa: F401

        compiled = not args.no_compiled
    except ImportError:
        compiled = False
    names = variants(compiled)
    print(f'# mixed time marching, reduced multibody model — {machine()}, suspopt {git_revision()}')
    startup = numba_startup_s() if compiled else None
    data: dict = {'numba_startup_s': startup, 'models': {}}
    rtol_a = args.agreement_rtol
    atol_a = 1e-3 * rtol_a
    failures = []
    md = []
    for model in args.models:
        cfg = config(model)
        t, Y, sc = trajectory_states(cfg, args.states)
        rec: dict = {'tables': table_builds(cfg), 'rhs': {}, 'verify': {}, 'agreement': {}}
        for v in names:
            rec['rhs'][v] = rhs_cost(cfg, v, t, Y, sc, args.repeat)
            print(model, v, rec['rhs'][v], flush=True)
        for v in names:
            rec['verify'][v] = march(cfg, v, *VERIFY)
            print(model, v, 'rtol 1e-6', rec['verify'][v], flush=True)
        for v in ('full', 'reduced'):
            rec['agreement'][v] = march(cfg, v, rtol_a, atol_a)
            print(model, v, f'rtol {rtol_a:g}', rec['agreement'][v], flush=True)
        diff = rel_diff(rec['agreement']['reduced']['J'], rec['agreement']['full']['J'])
        diff_verify = {
            v: rel_diff(rec['verify'][v]['J'], rec['verify']['full']['J']) for v in names[1:]
        }
        rec['agreement_rel_diff'] = diff
        rec['verify_rel_diff'] = diff_verify
        if not diff <= AGREEMENT:
            failures.append(f'{model}: J differ by {diff:.2e} at rtol {rtol_a:g}')
        data['models'][model] = rec

        full_v = rec['verify']['full']
        md += [
            f'### {model}: {cfg.vehicle.layout().n} corners, mount {cfg.multibody.mount}',
            '',
            '| modules | RHS [µs CPU] | of which modules [µs CPU] | time marching [s wall] '
            '| [s CPU] | RHS calls | J vs full (rtol 1e-6) |',
            '|---|---|---|---|---|---|---|',
        ]
        for v in names:
            r, m = rec['rhs'][v], rec['verify'][v]
            d = '—' if v == 'full' else f'{diff_verify[v]:.1e}'
            md.append(
                f'| {v} | {r["rhs_us"]:.0f} | {r["modules_us"]:.0f} | {m["wall_s"]:.2f} '
                f'| {m["cpu_s"]:.2f} | {m["rhs_calls"]} | {d} |'
            )
        speed = full_v['cpu_s'] / rec['verify']['reduced']['cpu_s']
        tables = ', '.join(
            f'{n} {x["build_s"]:.2f} s (degree {x["degree"]})' for n, x in rec['tables'].items()
        )
        agree_f, agree_r = rec['agreement']['full'], rec['agreement']['reduced']
        md += [
            '',
            f'Time marching: {speed:.1f}× less CPU time with the reduced modules. Objective '
            f'terms at rtol {rtol_a:g}: largest relative difference {diff:.1e} '
            f'(full {agree_f["cpu_s"]:.1f} s CPU, '
            f'{agree_f["rhs_calls"]} calls; reduced {agree_r["cpu_s"]:.1f} s CPU, '
            f'{agree_r["rhs_calls"]} calls). Tables built in {tables}.',
            '',
        ]
    if startup is not None:
        md.append(
            f'Compiled modules, once per process (fresh interpreter, wall time): importing '
            f'Numba {startup[0]:.2f} s, the first queries (its cache load, or compilation '
            f'when there is none) {startup[1]:.2f} s.'
        )
    markdown = '\n'.join(
        [
            'Right-hand side of the time marching (`VehicleRHS`) with the full multibody '
            'modules (augmented solve at every call) and the reduced ones '
            '(`suspopt.multibody.reduced`: Chebyshev series in the wheel travel; NumPy, and '
            'Numba-compiled); process time per call at states of the low-fidelity '
            'trajectory (least of the sweeps); time marching at the verification tolerance '
            '(rtol 1e-6, atol 1e-9), wall and process time (a shared machine: the CPU '
            'times are the steadier).',
            '',
        ]
        + md
    )
    print(markdown)
    write_result(
        'mixed_rhs', 'Mixed time marching with the reduced multibody model', markdown, data
    )
    if failures:
        raise SystemExit('objective terms disagree: ' + '; '.join(failures))


if __name__ == '__main__':
    main()
