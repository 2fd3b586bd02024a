"""The ``suspopt`` command line.

    suspopt study     [--out DIR] [--config FILE] ...      the paper's two-step study
    suspopt optimize  --fidelity low|mixed [--start K1,K2,C1,C2] [--out DIR] ...
    suspopt evaluate  --fidelity low|mixed --design K1,K2,C1,C2 [--method ...]
    suspopt pareto    [--fidelity low|mixed] [--points N] [--out DIR] ...   comfort vs road holding
    suspopt init FILE                                     write the paper's case as a study file
    suspopt report DIR                                    re-render table and figures of a run

Exit codes: 0 success; 1 a model or optimization failure (results so far are kept);
2 bad input (one line per problem, naming the key); 130 interrupted.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import sys
import time
from pathlib import Path
from typing import Any

from suspopt.config import DESIGN_NAMES, StudyConfig, config_from_dict, load_config
from suspopt.errors import ConfigError, SuspoptError

EPILOG = 'Exit codes: 0 ok, 1 model/optimization failure, 2 bad input, 130 interrupted.'


def _design(text: str, flag: str) -> dict[str, float]:
    parts = text.split(',')
    try:
        values = [float(p) for p in parts]
    except ValueError:
        values = []
    if len(values) != 4:
        raise ConfigError(f'{flag}: expected four numbers K1,K2,C1,C2 '
                          f'(k_S1, k_S2 [N/m], c_S1, c_S2 [N s/m]), got {text!r}')
    bad = [f'{n} = {v:g}' for n, v in zip(DESIGN_NAMES, values)
           if not math.isfinite(v) or v < 0.0 or (n.startswith('k') and v == 0.0)]
    if bad:
        raise ConfigError(f'{flag}: spring rates must be finite and > 0, damping finite and '
                          f'>= 0; got {", ".join(bad)}')
    return dict(zip(DESIGN_NAMES, values))


def _config(args: argparse.Namespace) -> StudyConfig:
    """The study description: the file (or SPEC defaults), then command-line overrides."""
    cfg = load_config(args.config) if args.config else StudyConfig()
    data = cfg.to_dict()
    if getattr(args, 'normalization', None):
        data['objective']['normalization'] = args.normalization
        if args.normalization != 'custom':
            data['objective']['scales'] = []
    if getattr(args, 'segments', None) is not None:
        data['transcription']['segments'] = args.segments
    if getattr(args, 'order', None) is not None:
        data['transcription']['order'] = args.order
    if getattr(args, 'max_iter', None) is not None:
        data['optimizer']['max_iter'] = args.max_iter
    return config_from_dict(data)


def _start(args: argparse.Namespace, config: StudyConfig) -> dict[str, float] | None:
    """``--start``: where IPOPT starts, inside the bounds. It is not the study's initial
    design, which also defines the ``reference`` normalization (SPEC §5): an optimization
    from another start still minimizes the same f."""
    if not args.start:
        return None
    start = _design(args.start, '--start')
    bad = [f'{n} = {v:g} is outside [{lo:g}, {hi:g}]'
           for n, v in start.items() for lo, hi in [config.design.bounds()[n]]
           if not lo <= v <= hi]
    if bad:
        raise ConfigError(f'--start: {"; ".join(bad)}')
    return start


def _printer(quiet: bool):
    if quiet:
        return None, (lambda msg: None)
    state = {'header': False}

    def progress(info) -> None:
        if not state['header']:
            print(f"{'iter':>5} {'objective':>12} {'constr.viol':>11} {'elapsed':>8}  "
                  'k_S1      k_S2      c_S1     c_S2', file=sys.stderr)
            state['header'] = True
        d = info.design
        vals = '  '.join(f'{d[k]:8.1f}' for k in sorted(d, key=lambda n: DESIGN_NAMES.index(
            n.rsplit(':', 1)[-1]))) if d else ''
        print(f'{info.iteration:5d} {info.objective:12.6f} {info.constraint_violation:11.2e} '
              f'{info.elapsed_s:7.1f}s  {vals}', file=sys.stderr, flush=True)
        if info.iteration == 0:
            pass

    def log(msg: str) -> None:
        state['header'] = False
        print(f'[suspopt] {msg}', file=sys.stderr, flush=True)

    return progress, log


def _summary(res: dict[str, Any]) -> str:
    d, J, s = res['design'], res['terms'], res['scales']
    lines = [f"{res['fidelity']}-fidelity {res['mode']} ({res['method']}): "
             f"{'converged' if res['success'] else 'NOT converged'} — {res['status']}",
             f"  design   k_S1 = {d['k_S1']:.1f} N/m, k_S2 = {d['k_S2']:.1f} N/m, "
             f"c_S1 = {d['c_S1']:.1f} N s/m, c_S2 = {d['c_S2']:.1f} N s/m",
             f"  objective f = {res['objective']:.6f}   "
             + '  '.join(f'{k} = {v:.5g}' for k, v in J.items()),
             f"  scales ({res['normalization']}) "
             + '  '.join(f'{k} = {v:.5g}' for k, v in s.items()),
             f"  iterations {res['iterations']}, wall time {res['wall_time_s']:.2f} s"]
    return '\n'.join(lines)


def cmd_optimize(args: argparse.Namespace) -> int:
    from suspopt.study import optimize, prepare_out_dir
    config = _config(args)
    start = _start(args, config)
    out = prepare_out_dir(args.out, args.overwrite)
    progress, log = _printer(args.quiet)
    log(f'optimizing the {args.fidelity}-fidelity model; results in {out}')
    res = optimize(config, args.fidelity, start=start, out_dir=out, progress=progress)
    print(_summary(res))
    if not res['success']:
        _fail_message(res)
        return 1
    return 0


def _fail_message(res: dict[str, Any]) -> None:
    last = res.get('last_iterate') or {}
    best = res.get('best_feasible_iterate')
    msg = (f"suspopt: error: IPOPT did not converge ({res['status']}) after "
           f"{res['iterations']} iterations: last objective {last.get('objective', float('nan')):.6g}, "
           f"constraint violation {last.get('constraint_violation', float('nan')):.2e}")
    if best:
        msg += (f"; best feasible iterate {best['iteration']} f = {best['objective']:.6g} at "
                + ', '.join(f'{k} = {v:.1f}' for k, v in best['design'].items()))
    print(msg, file=sys.stderr)


def cmd_evaluate(args: argparse.Namespace) -> int:
    from suspopt.study import evaluate
    config = _config(args)
    design = _design(args.design, '--design') if args.design else None
    res = evaluate(config, args.fidelity, design, method=args.method)
    res.pop('history', None)
    print(json.dumps(res, indent=2, default=float))
    return 0 if res['success'] else 1


def cmd_study(args: argparse.Namespace) -> int:
    from suspopt.study import StepFailed, prepare_out_dir, run_study
    config = _config(args)
    out = prepare_out_dir(args.out, args.overwrite)
    progress, log = _printer(args.quiet)
    log(f'two-step study; results in {out}')
    try:
        study = run_study(config, out, progress=progress, log=log, verify=not args.no_verify)
    except StepFailed as err:
        print(f'suspopt: error: {err}; partial results in {out}', file=sys.stderr)
        return 1
    print((out / 'table.md').read_text())
    print(f"results: {out}/study.json, {out}/table.md, {out}/figures/ "
          f"({study['wall_time_s']:.1f} s)")
    return 0


def cmd_pareto(args: argparse.Namespace) -> int:
    from suspopt.pareto import run_pareto
    from suspopt.study import prepare_out_dir
    if args.points < 2:
        raise ConfigError(f'--points: need at least 2, got {args.points}')
    config = _config(args)
    out = prepare_out_dir(args.out, args.overwrite)
    progress, log = _printer(args.quiet)
    log(f'Pareto front of the {args.fidelity}-fidelity model, {args.points} points; '
        f'results in {out}')
    front = run_pareto(config, out, fidelity=args.fidelity, points=args.points,
                       progress=progress, log=log)
    print((out / 'table.md').read_text())
    print(f"results: {out}/pareto.json, {out}/table.md, {out}/figures/pareto.png "
          f"({front['wall_time_s']:.1f} s)")
    failed = [p for p in front['points'] if not p['success']]
    if failed:
        where = ', '.join(f"{p['alpha']:.3f} ({p['status']})" for p in failed)
        print(f'suspopt: error: IPOPT did not converge at comfort share(s) {where}; the '
              'other points are kept', file=sys.stderr)
        return 1
    return 0


def cmd_sweep(args: argparse.Namespace) -> int:
    """Many optimizations or studies in parallel on Dask (see suspopt.sweep)."""
    from suspopt.sweep import run_sweep
    log = (lambda msg: None) if args.quiet else None
    outcome = run_sweep(args.file, args.out, workers=args.workers, scheduler=args.scheduler,
                        retry_failed=args.retry_failed, log=log)
    return outcome.exit_code


def cmd_init(args: argparse.Namespace) -> int:
    from suspopt.config import default_config_toml
    path = Path(args.file)
    if path.exists() and not args.overwrite:
        raise ConfigError(f'{path} exists; pass --overwrite to replace it')
    if not path.parent.is_dir():
        raise ConfigError(f'{path}: directory {path.parent} does not exist')
    try:
        path.write_text(default_config_toml())
    except OSError as err:
        raise ConfigError(f'cannot write {path}: {err.strerror}') from None
    print(f'wrote {path} (the paper\'s case; edit it and pass --config {path})')
    return 0


def cmd_report(args: argparse.Namespace) -> int:
    from suspopt.report import render
    written = render(args.dir)
    print((Path(args.dir) / 'table.md').read_text())
    print('wrote ' + ', '.join(str(p) for p in written))
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='suspopt', epilog=EPILOG,
        description='Mixed-fidelity suspension design optimization (half car + multibody '
                    'double wishbone; Dymos Radau collocation; IPOPT).')
    sub = parser.add_subparsers(dest='command', required=True)

    def common(p: argparse.ArgumentParser, grid: bool = True) -> None:
        p.add_argument('--config', metavar='FILE', help='study file (TOML); see `suspopt init`')
        p.add_argument('--normalization', choices=('reference', 'paper'),
                       help='objective normalization (SPEC §5); default: from the config')
        if grid:
            p.add_argument('--segments', type=int, metavar='N', help='collocation segments')
            p.add_argument('--order', type=int, metavar='P', help='Radau order per segment')

    p = sub.add_parser('study', help="run the paper's two-step study", epilog=EPILOG)
    common(p)
    p.add_argument('--out', default='results/study', metavar='DIR',
                   help='output directory (default: %(default)s)')
    p.add_argument('--overwrite', action='store_true', help='reuse a non-empty --out')
    p.add_argument('--max-iter', type=int, dest='max_iter', help='IPOPT iteration limit')
    p.add_argument('--no-verify', action='store_true',
                   help='skip the time-marching verification of every design')
    p.add_argument('--quiet', action='store_true', help='no progress lines')
    p.set_defaults(func=cmd_study)

    p = sub.add_parser('optimize', help='optimize one model', epilog=EPILOG)
    p.add_argument('--fidelity', choices=('low', 'mixed'), required=True)
    common(p)
    p.add_argument('--start', metavar='K1,K2,C1,C2', help='starting design (default: config)')
    p.add_argument('--out', metavar='DIR', help='output directory (default: results/optimize-FIDELITY)')
    p.add_argument('--overwrite', action='store_true', help='reuse a non-empty --out')
    p.add_argument('--max-iter', type=int, dest='max_iter', help='IPOPT iteration limit')
    p.add_argument('--quiet', action='store_true', help='no progress lines')
    p.set_defaults(func=cmd_optimize)

    p = sub.add_parser('evaluate', help='evaluate one design without optimizing', epilog=EPILOG)
    p.add_argument('--fidelity', choices=('low', 'mixed'), required=True)
    common(p)
    p.add_argument('--design', metavar='K1,K2,C1,C2', help='design (default: config initial)')
    p.add_argument('--method', choices=('collocation', 'time-marching'), default='collocation')
    p.set_defaults(func=cmd_evaluate)

    p = sub.add_parser('pareto', help='ride comfort against road holding: the Pareto front '
                                      'by weighted sums', epilog=EPILOG)
    p.add_argument('--fidelity', choices=('low', 'mixed'), default='low')
    common(p)
    p.add_argument('--points', type=int, default=9, metavar='N',
                   help='comfort shares 0 ... 1 (default: %(default)s)')
    p.add_argument('--out', default='results/pareto', metavar='DIR',
                   help='output directory (default: %(default)s)')
    p.add_argument('--overwrite', action='store_true', help='reuse a non-empty --out')
    p.add_argument('--max-iter', type=int, dest='max_iter', help='IPOPT iteration limit')
    p.add_argument('--quiet', action='store_true', help='no progress lines')
    p.set_defaults(func=cmd_pareto)

    p = sub.add_parser('sweep', help='many optimizations or studies in parallel on Dask '
                                     '(a sweep file: axes or a task list)', epilog=EPILOG)
    p.add_argument('file', help='sweep file (TOML); see examples/sweep.toml')
    p.add_argument('--out', required=True, metavar='DIR',
                   help='output directory; rerunning with it resumes the sweep')
    p.add_argument('--workers', type=int, metavar='N',
                   help='local worker processes (default: one per core)')
    p.add_argument('--scheduler', metavar='tcp://HOST:PORT',
                   help='run on an existing Dask cluster instead of a local one')
    p.add_argument('--retry-failed', action='store_true', dest='retry_failed',
                   help='when resuming, rerun the tasks that failed')
    p.add_argument('--quiet', action='store_true', help='no progress lines')
    p.set_defaults(func=cmd_sweep)

    p = sub.add_parser('init', help="write the paper's case as a commented study file")
    p.add_argument('file')
    p.add_argument('--overwrite', action='store_true')
    p.set_defaults(func=cmd_init)

    p = sub.add_parser('report', help="re-render the table and figures of a study or an "
                                      "optimize run from its records")
    p.add_argument('dir')
    p.set_defaults(func=cmd_report)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if getattr(args, 'command', None) == 'optimize' and not args.out:
        args.out = f'results/optimize-{args.fidelity}'
    _quiet_libraries()
    try:
        return args.func(args)
    except ConfigError as err:
        for problem in err.problems:
            print(f'suspopt: error: {problem}', file=sys.stderr)
        return 2
    except SuspoptError as err:
        print(f'suspopt: error: {err}', file=sys.stderr)
        return err.exit_code
    except KeyboardInterrupt:
        print('suspopt: interrupted; results written so far are kept', file=sys.stderr)
        return 130
    except Exception as err:  # a bug: one line for the user, the traceback on request
        if os.environ.get('SUSPOPT_DEBUG'):
            raise
        print(f'suspopt: error: unexpected {type(err).__name__}: {err} (this is a bug in '
              'suspopt; SUSPOPT_DEBUG=1 shows the traceback)', file=sys.stderr)
        return 1


def _quiet_libraries() -> None:
    """OpenMDAO/Dymos warnings about their own internals are noise for a user."""
    import warnings
    warnings.filterwarnings('ignore', module='openmdao')
    warnings.filterwarnings('ignore', module='dymos')
    warnings.filterwarnings('ignore', category=DeprecationWarning)
    try:
        from openmdao.utils.om_warnings import OpenMDAOWarning
        warnings.filterwarnings('ignore', category=OpenMDAOWarning)
    except ImportError:  # pragma: no cover
        pass


if __name__ == '__main__':
    sys.exit(main())
