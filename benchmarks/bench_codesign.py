"""Control co-design (docs/codesign.md): the published benchmark reproduced, timed against
its CasADi peer, and the passive / semi-active / active comparison of the half and full
car in both fidelities, with figures of the control histories.

Sections (``--sections``, default all):

* ``grids`` — the simple-suspension benchmark (``examples/codesign_benchmark.toml``),
  co-design and passive, on a sequence of Radau grids against the converged reference
  (``results/codesign_reference.json``), each optimum verified by time marching;
* ``peer`` — the benchmark's co-design on the study file's grid, suspopt (set-up, coloring
  from the cache, solve; and once with an empty cache) and the hand-written CasADi peer
  (``codesign_peer.py``: build, solve) side by side, alternating, ``--repeat`` times;
* ``feedback`` — the benchmark's passive optimum, open-loop bound and state-feedback
  co-design (``run_codesign``): how much of the bound a realizable law recovers;
* ``fullcar`` — a semi-active full car in the mixed model: the passive optimization and
  the semi-active ones (feedback, open loop) timed side by side;
* ``compare`` — the half car and the full car, low and mixed fidelity: passive,
  semi-active and active, open loop and feedback; figures of the control histories
  (``docs/figures/codesign_<car>_<fidelity>.png``).

Writes ``results/codesign.json`` (``write_result``; ``--name``: another name, for a run
of some sections only). ``--quick``: fewer grids, one
repeat, the low fidelity only in ``compare``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import codesign_peer as peer  # noqa: E402
from _common import RESULTS_DIR, fresh_cache, write_result  # noqa: E402

from suspopt.records.codesign import FEEDBACK, OPEN_LOOP, PASSIVE  # noqa: E402
from suspopt.spec import config_from_dict, load_config  # noqa: E402
from suspopt.spec.vehicles import BMW_E90  # noqa: E402
from suspopt.studies.codesign import passive_scales, run_codesign, variant  # noqa: E402
from suspopt.studies.run import initial_guess, optimize  # noqa: E402
from suspopt.transcription.problem import VehicleProblem  # noqa: E402
from suspopt.verification.scales import resolve_scales  # noqa: E402
from suspopt.verification.timemarching import simulate  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
STUDY = ROOT / 'examples' / 'codesign_benchmark.toml'
FIGURES = ROOT / 'docs' / 'figures'
REFERENCE = json.loads((RESULTS_DIR / 'codesign_reference.json').read_text())
GRIDS = (150, 300, 600, 1000)  # segments of order 3 over the 3 s (20, 10, 5, 3 ms)
QUICK_GRIDS = (150, 300)


def log(msg: str) -> None:
    print(msg, flush=True)


def benchmark(segments: int | None = None, passive: bool = False):
    """The study file's benchmark (on ``segments`` of order 3), or its passive car."""
    cfg = load_config(STUDY)
    if segments is not None:
        cfg = dataclasses.replace(
            cfg, transcription=dataclasses.replace(cfg.transcription, segments=segments)
        )
    return variant(cfg, PASSIVE) if passive else cfg


def _scales(cfg) -> Any:
    return ({t: 1.0 for t in cfg.terms()},)


# ------------------------------------------------------------------------------ grids
def section_grids(grids: tuple[int, ...]) -> tuple[str, dict]:
    rows, data = [], {}
    for problem in ('codesign', 'passive'):
        ref = REFERENCE[problem]
        for seg in grids:
            cfg = benchmark(seg, passive=problem == 'passive')
            t0 = time.perf_counter()
            rec = optimize(cfg, 'low', scales=_scales(cfg))
            wall = time.perf_counter() - t0
            assert rec.objective is not None, rec.status
            c = rec.verification.comparison
            march = c.objective if c is not None else float('nan')
            row = {
                'problem': problem,
                'grid': f'{1e3 * 3.0 / seg:g} ms × 3 ({seg} segments)',
                'b': rec.design['c_S1'],
                'k': rec.design['k_S1'],
                'J': rec.objective,
                'dJ_ref': (rec.objective - ref['J']) / ref['J'] if rec.success else None,
                'dk_ref': rec.design['k_S1'] / ref['k'] - 1.0,
                'db_ref': rec.design['c_S1'] / ref['b'] - 1.0,
                'J_march': march,
                'dJ_march': (rec.objective - march) / march if rec.success else None,
                'march_vs_ref': (march - ref['J']) / ref['J'],
                'iterations': rec.iterations,
                'verified': rec.verified,
                'solve_s': rec.times.solve_s if rec.times else None,
                'wall_s': wall,
            }
            rows.append(row)
            log(f'grids: {problem} {row["grid"]}: J {rec.objective} ({row["dJ_ref"]:+.1e})')
    data['rows'] = rows
    md = [
        'Grid convergence of the benchmark (`examples/codesign_benchmark.toml`, Radau order 3), '
        'each optimum verified by time marching (DOP853, rtol 1e-6); reference: the converged '
        'CasADi solution (`results/codesign_reference.json`, 1 ms × 3, J converged to '
        f'{REFERENCE["codesign"]["J_converged_to"]:.0e}): co-design b* = '
        f'{REFERENCE["codesign"]["b"]:.6g}, k* = {REFERENCE["codesign"]["k"]:.7g}, '
        f'J* = {REFERENCE["codesign"]["J"]:.9f}; passive b* = {REFERENCE["passive"]["b"]:.6g}, '
        f'k* = {REFERENCE["passive"]["k"]:.7g}, J* = {REFERENCE["passive"]["J"]:.9f}.',
        '',
        '| problem | grid | b* [N s/m] | k* [N/m] | J* | (J* − J_ref)/J_ref | k*/k_ref − 1 '
        '| b*/b_ref − 1 | J by time marching | (J* − J_march)/J_march | iterations | '
        'solve [s] |',
        '|---|---|---|---|---|---|---|---|---|---|---|---|',
    ]
    for r in rows:
        md.append(
            f'| {r["problem"]} | {r["grid"]} | {r["b"]:.6g} | {r["k"]:.7g} | {r["J"]:.7f} | '
            f'{r["dJ_ref"]:+.1e} | {r["dk_ref"]:+.1e} | {r["db_ref"]:+.1e} | '
            f'{r["J_march"]:.7f} | {r["dJ_march"]:+.1e} | {r["iterations"]} | '
            f'{r["solve_s"]:.2f} |'
        )
    return '\n'.join(md), data


# ------------------------------------------------------------------------------ peer
def _suspopt_once(cold: bool) -> dict[str, float]:
    cfg = benchmark()
    scales = _scales(cfg)
    ctx = fresh_cache() if cold else _nothing()
    with ctx:
        t0 = time.perf_counter()
        vp = VehicleProblem(cfg, 'low', scales)
        t1 = time.perf_counter()
        vp.set_design(cfg.design.initial())
        vp.set_initial_guess(initial_guess(cfg, 'low', cfg.design.initial()))
        rec = vp.solve()
        t2 = time.perf_counter()
        vp.cleanup()
    return {
        'setup': t1 - t0,
        'coloring': rec.times.coloring_s if rec.times else 0.0,
        'solve': t2 - t1 - (rec.times.coloring_s if rec.times else 0.0),
        'total': t2 - t0,
        'iterations': float(rec.iterations or 0),
        'J': rec.objective or float('nan'),
        'k': rec.design['k_S1'],
        'b': rec.design['c_S1'],
    }


class _nothing:
    def __enter__(self) -> None:
        return None

    def __exit__(self, *exc: object) -> None:
        return None


def _peer_once(segments: int) -> dict[str, float]:
    car, spline = peer.QuarterCar(), peer.road_spline()
    grid = peer.radau_grid(segments, 3, car.horizon)
    sol = peer.solve(grid, car, peer.road_rate(spline, car.speed), True, tol=1e-8)
    return {
        'build': sol.build_s,
        'solve': sol.solve_s,
        'total': sol.build_s + sol.solve_s,
        'iterations': float(sol.iterations),
        'J': sol.J,
        'k': sol.k,
        'b': sol.b,
    }


def section_peer(repeat: int) -> tuple[str, dict]:
    segments = benchmark().scenarios()[0].segments
    cold = _suspopt_once(cold=True)
    mine, theirs = [], []
    for i in range(repeat):  # alternating, so both see the same machine load
        theirs.append(_peer_once(segments))
        mine.append(_suspopt_once(cold=False))
        a, b = mine[-1]['total'], theirs[-1]['total']
        log(f'peer: repeat {i + 1}: suspopt {a:.2f} s, peer {b:.2f} s')
    med = {k: statistics.median(r[k] for r in mine) for k in mine[0]}
    pmed = {k: statistics.median(r[k] for r in theirs) for k in theirs[0]}
    ratio = med['total'] / pmed['total']
    ref = REFERENCE['codesign']
    # the time marching's agreement on this grid (the grids section measures it too)
    rec = optimize(benchmark(), 'low', scales=_scales(benchmark()))
    c = rec.verification.comparison
    agreement = (
        abs(rec.objective - c.objective) / c.objective
        if c is not None and rec.objective is not None
        else float('nan')
    )
    md = [
        f"The benchmark's co-design on the study file's grid ({segments} segments × 3, "
        f'10 ms), solved from the same start (b = 1e3, k = 1e4, zero states and control) to '
        f'IPOPT tol 1e-8 by suspopt (exact Hessian; set-up, coloring from the cache, solve) '
        f'and by the CasADi peer (`codesign_peer.py`, exact Hessian by AD; build, solve), '
        f'alternating, {repeat} repeats, medians; shared 2-core machine: compare within this '
        'table only.',
        '',
        '| | set-up / build [s] | coloring [s] | solve [s] | total [s] | iterations | J* | '
        '(J* − J_ref)/J_ref |',
        '|---|---|---|---|---|---|---|---|',
        f'| suspopt | {med["setup"]:.2f} | {med["coloring"]:.2f} | {med["solve"]:.2f} | '
        f'{med["total"]:.2f} | {med["iterations"]:.0f} | {med["J"]:.7f} | '
        f'{(med["J"] - ref["J"]) / ref["J"]:+.1e} |',
        f'| suspopt, empty coloring cache | {cold["setup"]:.2f} | {cold["coloring"]:.2f} | '
        f'{cold["solve"]:.2f} | {cold["total"]:.2f} | {cold["iterations"]:.0f} | '
        f'{cold["J"]:.7f} | {(cold["J"] - ref["J"]) / ref["J"]:+.1e} |',
        f'| CasADi peer | {pmed["build"]:.2f} | — | {pmed["solve"]:.2f} | {pmed["total"]:.2f} | '
        f'{pmed["iterations"]:.0f} | {pmed["J"]:.7f} | {(pmed["J"] - ref["J"]) / ref["J"]:+.1e} |',
        '',
        f'suspopt / peer: {ratio:.2f} (target: at most 1.5). Target "under 10 s on a grid '
        f'that agrees with time marching to 0.1 %": {med["total"]:.2f} s, the collocation\'s '
        f'J within {agreement:.1e} of the time-marched one.',
    ]
    data = {
        'suspopt': mine,
        'suspopt_cold': cold,
        'peer': theirs,
        'ratio': ratio,
        'marching_agreement': agreement,
    }
    return '\n'.join(md), data


# ------------------------------------------------------------------------------ feedback
def _study_rows(study) -> list[dict[str, Any]]:
    rows = []
    for law, rec in study.entries.items():
        c = rec.verification.comparison
        rows.append(
            {
                'law': law,
                'f': rec.objective,
                'f_march': c.objective if c else None,
                'verified': rec.verified,
                'max_rel_diff': c.max_rel_diff if c else None,
                'design': rec.design,
                'iterations': rec.iterations,
                'wall_s': rec.wall_time_s,
                'status': rec.status,
            }
        )
    return rows


def _study_table(rows: list[dict[str, Any]], title: str) -> list[str]:
    md = [
        title,
        '',
        '| design | f (collocation) | f (time marching) | verified (largest rel. diff.) | '
        'design variables | iterations | wall [s] |',
        '|---|---|---|---|---|---|---|',
    ]
    for r in rows:
        dv = ', '.join(f'{k} = {v:.4g}' for k, v in r['design'].items())
        f = f'{r["f"]:.6f}' if r['f'] is not None else r['status']
        fm = f'{r["f_march"]:.6f}' if r['f_march'] is not None else '—'
        ver = f'{r["verified"]} ({r["max_rel_diff"]:.1e})' if r['max_rel_diff'] else '—'
        md.append(
            f'| {r["law"]} | {f} | {fm} | {ver} | {dv} | {r["iterations"]} | {r["wall_s"]:.1f} |'
        )
    return md


def section_feedback() -> tuple[str, dict]:
    cfg = benchmark()
    study = run_codesign(cfg, 'low', scales=_scales(cfg), log=log)
    rows = _study_rows(study)
    rec = study.recovered()
    md = _study_table(
        rows,
        'The benchmark three ways (`run_codesign`, one objective): the passive optimum, the '
        'open-loop co-design (the bound of any controller with full preview of the road) and '
        'the co-design of the state-feedback law on measurable signals '
        '(`u = −g_sky v_M + g_gnd v_W + g_tr s + g_rt ṡ`, docs/codesign.md §3).',
    )
    md += [
        '',
        f"The feedback law realizes {100 * rec:.1f} % of the open-loop bound's gain over the "
        'passive optimum, (f_passive − f_feedback) / (f_passive − f_open_loop), by time '
        'marching.'
        if rec is not None
        else 'Not all three converged.',
    ]
    return '\n'.join(md), {'rows': rows, 'recovered': rec, 'study': study.to_json()}


# ------------------------------------------------------------------------------ cars
def half_car(kind: str, law: str = OPEN_LOOP) -> Any:
    """The paper's half car on its two bumps (3 s at 10 m/s), the dampers' lower bound
    at 100 N s/m (so that a controlled car can be as soft as it likes), with a controlled
    suspension at both corners: semi-active in [0, 4000] N s/m, or active (effort weight
    0.5 by the reference normalization)."""
    data: dict[str, Any] = {
        'maneuver': {'speed': 10.0, 'horizon': 3.0},
        'design': {
            'c_S1': {'initial': 2000.0, 'lower': 100.0, 'upper': 5000.0},
            'c_S2': {'initial': 2000.0, 'lower': 100.0, 'upper': 5000.0},
        },
        'transcription': {'segments': 240, 'order': 3},
    }
    return _controlled(data, kind, law)


def full_car(kind: str, law: str = OPEN_LOOP) -> Any:
    """The default full car (BMW E90) on its ISO 8608 class C road, 3 s at 10 m/s, the
    dampers' lower bound at 100 N s/m, controlled at all four corners."""
    data = json.loads(json.dumps(BMW_E90))
    data['maneuver'] = {'speed': 10.0, 'horizon': 3.0}
    for n in ('c_S1', 'c_S2'):
        data['design'][n] = {**data['design'].get(n, {}), 'lower': 100.0}
    data['transcription'] = {'segments': 240, 'order': 3}
    return _controlled(data, kind, law)


def _controlled(data: dict[str, Any], kind: str, law: str) -> Any:
    data['control'] = {'kind': kind, 'law': law}
    if kind == 'semi_active':
        data['control'].update(c_min=0.0, c_max=4000.0)
    # the passive car's weights and the effort's group weight (per-corner control_<c>
    # keys would override the group)
    weights = {
        k: v
        for k, v in config_from_dict(data).objective.weights.items()
        if not k.startswith('control_')
    }
    data['objective'] = {'weights': {**weights, 'control': 0.5 if kind == 'active' else 0.0}}
    return config_from_dict(data)


def section_fullcar() -> tuple[str, dict]:
    out: dict[str, Any] = {}
    cases = [
        ('passive', variant(full_car('semi_active', FEEDBACK), PASSIVE)),
        ('semi-active feedback', full_car('semi_active', FEEDBACK)),
        ('semi-active open loop', full_car('semi_active', OPEN_LOOP)),
    ]
    scales = resolve_scales(full_car('semi_active'))
    for label, cfg in cases:
        sc = passive_scales(full_car('semi_active'), scales) if label == 'passive' else scales
        t0 = time.perf_counter()
        vp = VehicleProblem(cfg, 'mixed', sc)
        t1 = time.perf_counter()
        vp.set_design(cfg.design.initial())
        vp.set_initial_guess(initial_guess(cfg, 'mixed', cfg.design.initial()))
        rec = vp.solve()
        t2 = time.perf_counter()
        vp.cleanup()
        out[label] = {
            'setup': t1 - t0,
            'total': t2 - t0,
            'iterations': rec.iterations,
            'f': rec.objective,
            'status': rec.status,
            'hessian': vp.hessian,
        }
        log(f'fullcar: {label}: {t2 - t0:.1f} s, {rec.iterations} iterations, f {rec.objective}')
    base = out['passive']['total']
    md = [
        'A semi-active full car in the mixed model (BMW E90, MacPherson front and double '
        'wishbone rear linkages, ISO 8608 class C, 3 s at 10 m/s, 240 segments × 3; damping '
        'c(t) ∈ [0, 4000] N s/m at every corner in parallel with the passive damper): '
        'the whole optimization (set-up, guess, coloring, IPOPT) of each, side by side. '
        'Target: the semi-active optimize at most 2× the passive one.',
        '',
        '| | Hessian | total [s] | × passive | iterations | f | status |',
        '|---|---|---|---|---|---|---|',
    ]
    for label, r in out.items():
        f = '—' if r['f'] is None else f'{r["f"]:.5f}'
        md.append(
            f'| {label} | {r["hessian"]} | {r["total"]:.1f} | {r["total"] / base:.2f} | '
            f'{r["iterations"]} | {f} | {r["status"]} |'
        )
    return '\n'.join(md), out


def _histories(cfg_of: dict[str, Any], fidelity: str) -> dict[str, Any]:
    """Each controlled optimum's actuator force u_F(t) and the chassis' heave acceleration,
    by time marching (the open-loop control as the collocation represents it)."""
    out = {}
    for label, (cfg, rec) in cfg_of.items():
        if not rec.success:
            continue
        tr = simulate(cfg, fidelity, rec.design, controls=rec.controls, rtol=1e-6, atol=1e-9)
        out[label] = {
            't': tr.t,
            'heave': tr['zdd_C'],
            'u_F': tr.values.get('u_F'),
            'corners': cfg.controlled(),
        }
    return out


def _figure(name: str, title: str, hist: dict[str, Any]) -> str:
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    controlled = [k for k, v in hist.items() if v['u_F'] is not None]
    corners = hist[controlled[0]]['corners'] if controlled else ()
    fig, axes = plt.subplots(
        len(corners) + 1, 1, figsize=(9, 2.2 * (len(corners) + 1)), sharex=True
    )
    for label, h in hist.items():
        axes[0].plot(h['t'], h['heave'], label=label, lw=1.0)
        if h['u_F'] is not None:
            for i in range(len(corners)):
                axes[i + 1].plot(h['t'], h['u_F'][:, i], label=label, lw=1.0)
    axes[0].set_ylabel('heave acc. [m/s²]')
    axes[0].legend(fontsize=7, ncol=3)
    for i, c in enumerate(corners):
        axes[i + 1].set_ylabel(f'force {c} [N]')
    axes[-1].set_xlabel('t [s]')
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    FIGURES.mkdir(exist_ok=True)
    path = FIGURES / f'{name}.png'
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return str(path.relative_to(ROOT))


def section_compare(
    fidelities: tuple[str, ...], cars: tuple[str, ...] = ('half', 'full')
) -> tuple[str, dict]:
    md = [
        'Passive, semi-active (c(t) ∈ [0, 4000] N s/m in parallel with the passive damper, '
        'no effort weight) and active (effort weight 0.5 by the reference normalization) '
        'suspensions at every corner, open loop (the bound) and state feedback (realizable), '
        'each verified by time marching; 240 segments × 3 over 3 s at 10 m/s. Half car: the '
        "paper's car on its two bumps; full car: the BMW E90 on ISO 8608 class C.",
    ]
    data: dict[str, Any] = {}
    for car, make in (('half car', half_car), ('full car', full_car)):
        if car.split()[0] not in cars:
            continue
        for fid in fidelities:
            key = f'{car}, {fid}'
            scales = resolve_scales(make('semi_active'))
            semi = run_codesign(make('semi_active'), fid, scales=scales, log=log)
            active = run_codesign(
                make('active'),
                fid,
                laws=(OPEN_LOOP, FEEDBACK),
                passive=semi.entries[PASSIVE],
                scales=resolve_scales(make('active')),
                log=log,
            )
            rows = _study_rows(semi)
            rows += [dict(r, law=f'active {r["law"]}') for r in _study_rows(active)][1:]
            for r in rows[1:3]:
                r['law'] = f'semi-active {r["law"]}'
            md += ['', *_study_table(rows, f'**{key}**')]
            rec_s, rec_a = semi.recovered(), active.recovered()
            md += [
                '',
                'Feedback recovers of the open-loop gain: semi-active '
                + (f'{100 * rec_s:.0f} %' if rec_s is not None else '—')
                + ', active '
                + (f'{100 * rec_a:.0f} %' if rec_a is not None else '—')
                + '.',
            ]
            cfgs = {
                'passive': (variant(make('semi_active'), PASSIVE), semi.entries[PASSIVE]),
                'semi-active open loop': (make('semi_active', OPEN_LOOP), semi.entries[OPEN_LOOP]),
                'semi-active feedback': (make('semi_active', FEEDBACK), semi.entries[FEEDBACK]),
                'active open loop': (make('active', OPEN_LOOP), active.entries[OPEN_LOOP]),
                'active feedback': (make('active', FEEDBACK), active.entries[FEEDBACK]),
            }
            hist = _histories(cfgs, fid)
            fig = _figure(
                f'codesign_{car.replace(" ", "_")}_{fid}',
                f'{key}: heave acceleration and actuator forces, by time marching',
                hist,
            )
            md += ['', f'Figure: `{fig}`.']
            data[key] = {
                'semi_active': semi.to_json(),
                'active': active.to_json(),
                'recovered': {'semi_active': rec_s, 'active': rec_a},
                'figure': fig,
            }
    return '\n'.join(md), data


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument(
        '--sections', default='grids,peer,feedback,fullcar,compare', help='comma-separated'
    )
    ap.add_argument('--repeat', type=int, default=3)
    ap.add_argument('--quick', action='store_true')
    ap.add_argument('--fidelities', default='low,mixed', help='compare: comma-separated')
    ap.add_argument('--cars', default='half,full', help='compare: comma-separated')
    ap.add_argument('--no-write', action='store_true')
    ap.add_argument(
        '--name', default='codesign', help='results/<name>.json (a run of some sections only)'
    )
    args = ap.parse_args(argv)
    sections = args.sections.split(',')
    parts, data = [], {}
    if 'grids' in sections:
        md, data['grids'] = section_grids(QUICK_GRIDS if args.quick else GRIDS)
        parts += ['### The benchmark: grid convergence', '', md]
    if 'peer' in sections:
        md, data['peer'] = section_peer(1 if args.quick else args.repeat)
        parts += ['', '### The benchmark against its CasADi peer', '', md]
    if 'feedback' in sections:
        md, data['feedback'] = section_feedback()
        parts += ['', '### The benchmark: open-loop bound against state feedback', '', md]
    if 'fullcar' in sections:
        md, data['fullcar'] = section_fullcar()
        parts += ['', '### Semi-active full car, mixed model, against the passive one', '', md]
    if 'compare' in sections:
        fids = ('low',) if args.quick else tuple(args.fidelities.split(','))
        md, data['compare'] = section_compare(fids, tuple(args.cars.split(',')))
        parts += ['', '### Passive, semi-active and active, half and full car', '', md]
    text = '\n'.join(parts)
    print(text)
    if not args.no_write:
        path = write_result(args.name, 'Control co-design', text, _plain(data))
        print(f'wrote {path}')


def _plain(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if isinstance(x, np.ndarray):
        return x.tolist()
    return x


if __name__ == '__main__':
    main()
