"""The spectral method against suspopt's time marching on its own ISO 8608 roads: the
figure and table of ``docs/spectral.md`` (section 10).

    python benchmarks/spectral_time_domain.py [--cases quarter half full] [--seeds 3]
        [--horizon 200] [--speed 20]

For each car (the default quarter car, the paper's half car, the default full car; each
with a seat's Wk filter, the objective on comfort and tyre load) at its initial design on
a class C road: the stationary RMS of every metric by the spectral method (Lyapunov,
white road velocity: what ``--method spectral`` reports), by the spectral integral over
the band ``[n_min, n_max]`` where suspopt's generator (``road.profile = "iso8608"``)
puts the road's power (exact delay and coherence), and by time marching
(``suspopt.verification.timemarching.simulate``, DOP853 at rtol 1e-3) over ``horizon``
seconds on the roads of ``seeds`` seeds, the first 2 s and the rear wheel's delay left
out. The scatter of each run's mean square: batch means (10 batches); across runs: the
seeds' standard deviation. Writes ``benchmarks/results/spectral_time_domain.json`` and
``docs/figures/spectral_time_domain.png`` (``--replot``: the figure again from that
file).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / 'tests' / 'studies'))

from _common import RESULTS_DIR, write_result  # noqa: E402
from stationary_sampling import mean_squares  # noqa: E402

from suspopt.spec.load import config_from_dict  # noqa: E402
from suspopt.spec.resolve import MIN_NODES_PER_PERIOD, wheel_hop_frequency  # noqa: E402
from suspopt.spectral import StationaryModel, choose_pade_order  # noqa: E402
from suspopt.spectral.integral import spectral_variances  # noqa: E402
from suspopt.spectral.vehicle import road_band  # noqa: E402
from suspopt.studies.spectral import spectral_cases  # noqa: E402
from suspopt.verification.timemarching import simulate  # noqa: E402

FIGURE = HERE.parent / 'docs' / 'figures' / 'spectral_time_domain.png'
#: the transient left out at the start of every run [s] (and the rear wheel's delay)
SKIP = 2.0
CARS = {
    'quarter': ('quarter_car', {'name': 'driver'}, 'quarter car'),
    'half': ('half_car', {'name': 'driver', 'x': 0.3}, "the paper's half car"),
    'full': ('full_car', {'name': 'driver', 'x': 0.3, 'y': 0.35}, 'full car (BMW E90)'),
}


def config(car: str, seed: int, speed: float, horizon: float):
    model, seat, _ = CARS[car]
    data = {
        'vehicle': {'model': model},
        'comfort': {'seats': [seat]},
        'maneuver': {'speed': speed, 'horizon': horizon},
        'road': {'profile': 'iso8608', 'road_class': 'C', 'seed': seed, 'length': speed * horizon},
        'objective': {'weights': {'comfort': 0.5, 'tyre_load': 0.5}},
    }
    # the study file's grid (unused by the time marching) at the coarsest it accepts: an
    # "auto" grid of a long horizon is beyond the collocation's size limit
    f_hop = wheel_hop_frequency(config_from_dict({**data, 'maneuver': {'horizon': 1.0}}))
    segments = math.ceil(horizon * f_hop * MIN_NODES_PER_PERIOD / 5) + 1
    return config_from_dict({**data, 'transcription': {'segments': segments, 'order': 5}})


def run_case(car: str, seeds: int, speed: float, horizon: float, rtol: float) -> dict:
    cfg = config(car, 0, speed, horizon)
    (case,) = spectral_cases(cfg)
    terms = case.system.outputs
    p = case.system.design_vector(cfg.design.initial())
    order = choose_pade_order(case.system, case.road, p).order
    white = StationaryModel(case.system, case.road, order).variances(p)
    band = spectral_variances(case.system, case.road, p, band=road_band(cfg.road, speed), rtol=1e-8)
    t0 = SKIP + max(cfg.layout().offsets()) / speed
    seats = tuple(s.name for s in cfg.comfort.seats)
    runs = []
    for seed in range(seeds):
        c = config(car, seed, speed, horizon)
        t = time.perf_counter()
        tr = simulate(c, 'low', rtol=rtol, atol=rtol * 1e-3, t_eval=np.arange(0, horizon, 0.01))
        ms, se = mean_squares(tr, terms, c.layout().labels, seats, t0)
        runs.append({'seed': seed, 'ms': ms, 'se': se, 'time_s': time.perf_counter() - t})
        print(f'{car} seed {seed}: {runs[-1]["time_s"]:.0f} s', flush=True)
    return {
        'label': CARS[car][2],
        'terms': list(terms),
        'pade_order': order,
        'white': dict(zip(terms, white.tolist())),
        'band': dict(zip(terms, band.tolist())),
        'band_rad_s': list(road_band(cfg.road, speed)),
        'runs': runs,
    }


def summary(res: dict) -> dict[str, dict[str, float]]:
    """Per term: RMS ratios time marching / band-limited spectral (mean and seeds'
    standard deviation), the runs' batch-means standard error of that ratio (mean), and
    the white-velocity RMS over the band-limited one."""
    out = {}
    for t in res['terms']:
        band = res['band'][t]
        ratio = np.array([np.sqrt(r['ms'][t] / band) for r in res['runs']])
        # standard error of an RMS from that of its mean square: se_ms / (2 ms)
        se = np.array(
            [r['se'][t] / (2.0 * r['ms'][t]) * np.sqrt(r['ms'][t] / band) for r in res['runs']]
        )
        out[t] = {
            'rms_white': float(np.sqrt(res['white'][t])),
            'rms_band': float(np.sqrt(band)),
            'rms_time': float(np.mean([np.sqrt(r['ms'][t]) for r in res['runs']])),
            'ratio': float(ratio.mean()),
            'seed_std': float(ratio.std(ddof=1)) if ratio.size > 1 else float('nan'),
            'batch_se': float(se.mean()),
            'white_over_band': float(np.sqrt(res['white'][t] / band)),
        }
    return out


def figure(results: dict[str, dict], path: Path) -> None:
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    n = len(results)
    fig, axes = plt.subplots(1, n, figsize=(4.2 * n, 4.2), constrained_layout=True, squeeze=False)
    for ax, res in zip(axes[0], results.values()):
        terms = res['terms']
        x = np.arange(len(terms))
        s = summary(res)
        for i, run in enumerate(res['runs']):
            r = [np.sqrt(run['ms'][t] / res['band'][t]) for t in terms]
            e = [2.0 * run['se'][t] / (2.0 * run['ms'][t]) * r[j] for j, t in enumerate(terms)]
            ax.errorbar(
                x + 0.08 * (i - 1),
                r,
                yerr=e,
                fmt='o',
                ms=4,
                capsize=2,
                color='tab:blue',
                label='time marching / band-limited (±2 batch s.e.)' if i == 0 else None,
            )
        ax.plot(
            x,
            [s[t]['white_over_band'] for t in terms],
            'x',
            color='tab:red',
            ms=8,
            label='white velocity (--method spectral) / band-limited',
        )
        ax.axhline(1.0, color='k', lw=0.8)
        lo, hi = ax.get_ylim()
        top = max(s[t]['white_over_band'] for t in terms)
        ax.set_ylim(min(lo, 0.98), max(hi, top + 0.1 * (top - min(lo, 0.98))))
        ax.set_xticks(x, terms, rotation=45, ha='right', fontsize=8)
        ax.set_title(res['label'], fontsize=10)
        ax.set_ylabel('RMS ratio')
        ax.grid(alpha=0.3)
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc='outside lower center', ncol=2, fontsize=8)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def markdown(results: dict[str, dict], args: argparse.Namespace) -> str:
    lines = [
        f'Class C road at {args.speed:g} m/s, initial designs, {args.seeds} seeds × '
        f'{args.horizon:g} s of time marching (DOP853, rtol {args.rtol:g}), the first '
        f"{SKIP:g} s (and the rear wheel's delay) left out. RMS [units of the metric]: "
        '*white* the spectral method (Lyapunov, white road velocity), *band* the spectral '
        "integral over the generator's band [n_min, n_max], *time* the runs' mean. Ratio: "
        'time / band (mean over the seeds ± their standard deviation); s.e.: the mean '
        "batch-means standard error of one run's ratio (10 batches).",
        '',
    ]
    for res in results.values():
        s = summary(res)
        lo, hi = res['band_rad_s']
        lines += [
            f'**{res["label"]}** (band {lo / (2 * np.pi):.3g}–{hi / (2 * np.pi):.3g} Hz, '
            f'Padé order {res["pade_order"]}):',
            '',
            '| metric | white | band | time | time/band | s.e. | white/band |',
            '|---|---|---|---|---|---|---|',
        ]
        for t, v in s.items():
            lines.append(
                f'| {t} | {v["rms_white"]:.4g} | {v["rms_band"]:.4g} | {v["rms_time"]:.4g} | '
                f'{v["ratio"]:.4f} ± {v["seed_std"]:.4f} | {v["batch_se"]:.4f} | '
                f'{v["white_over_band"]:.4f} |'
            )
        lines.append('')
    lines.append(f'Figure: `docs/figures/{FIGURE.name}`.')
    return '\n'.join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--cases', nargs='+', default=list(CARS), choices=list(CARS))
    ap.add_argument('--seeds', type=int, default=3)
    ap.add_argument('--horizon', type=float, default=200.0)
    ap.add_argument('--speed', type=float, default=20.0)
    ap.add_argument('--rtol', type=float, default=1e-3)
    ap.add_argument(
        '--replot', action='store_true', help='redraw the figure from the results file only'
    )
    args = ap.parse_args()
    if args.replot:
        data = json.loads((RESULTS_DIR / 'spectral_time_domain.json').read_text())['data']
        figure(data, FIGURE)
        print(f'written {FIGURE}')
        return
    results = {
        car: run_case(car, args.seeds, args.speed, args.horizon, args.rtol) for car in args.cases
    }
    figure(results, FIGURE)
    md = markdown(results, args)
    path = write_result(
        'spectral_time_domain', 'The spectral method against time marching', md, results
    )
    print(md)
    print(f'written to {path} and {FIGURE}')


if __name__ == '__main__':
    main()
