"""The ``suspopt`` command line.

    suspopt study     [--out DIR] [--config FILE] ...      the paper's two-step study
    suspopt optimize  --fidelity low|mixed [--start DESIGN] [--out DIR] ...
    suspopt evaluate  --fidelity low|mixed [--design DESIGN] [--method ...]
    suspopt pareto    [--fidelity low|mixed] [--points N] [--out DIR] ...   comfort vs road holding
    suspopt compare   [--mechanisms A,B,C] [--out DIR] ...  suspension topologies side by side
    suspopt init [--model half_car|full_car] FILE         write a default car as a study file
    suspopt report DIR                                    re-render table and figures of a run
    suspopt kinematics MECHANISM [--out DIR]              a linkage's kinematic curves
    suspopt robust --config FILE [--fidelity ...]         robust design over the scenarios
    suspopt sweep FILE --out DIR [--workers N | --scheduler ADDR]   many runs on Dask

A DESIGN is the design variables' values in order (``30000,30000,3000,3000`` for the half
car's k_S1, k_S2, c_S1, c_S2) or by name (``k_S1=30000,c_S2=2500``; the others keep their
configured values).

Exit codes: 0 success (every result verified by time marching); 1 a model or optimization
failure (results so far are kept); 2 bad input (one line per problem, naming the key);
3 a result not verified (collocation and time marching disagree; the results are written,
marked so); 4 the environment failed (unwritable or full output directory); 130
interrupted (Ctrl-C or SIGTERM: stops at the next safe point, keeps what finished).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import signal
import sys
from pathlib import Path
from typing import Any

from suspopt.errors import ConfigError, NotVerified, SuspoptError
from suspopt.spec.load import config_from_dict, load_config
from suspopt.spec.schema import StudyConfig

EPILOG = (
    'Exit codes: 0 ok (verified), 1 model/optimization failure, 2 bad input, '
    '3 not verified by time marching, 4 output not writable, 130 interrupted.'
)


def parse_design(text: str, flag: str, config: StudyConfig) -> dict[str, float]:
    """A design from ``--start``/``--design``: values in the design order, or name=value
    pairs (the rest from the configuration); checked finite, positive and in the bounds."""
    names = config.design_names()
    parts = [p.strip() for p in text.split(',') if p.strip()]
    design = config.design.initial()
    if parts and all('=' in p for p in parts):
        for p in parts:
            name, _, val = p.partition('=')
            name = name.strip()
            if name not in names:
                raise ConfigError(
                    f'{flag}: unknown design variable {name!r} (this car: {", ".join(names)})'
                )
            try:
                design[name] = float(val)
            except ValueError:
                raise ConfigError(f'{flag}: {name} = {val!r} is not a number') from None
    else:
        try:
            values = [float(p) for p in parts]
        except ValueError:
            values = []
        if len(values) != len(names):
            raise ConfigError(
                f'{flag}: expected {len(names)} numbers ({",".join(names)}) or '
                f'name=value pairs, got {text!r}'
            )
        design.update(zip(names, values))
    bad = [f'{n} = {v:g}' for n, v in design.items() if not math.isfinite(v) or v < 0.0]
    if bad:
        raise ConfigError(f'{flag}: design values must be finite and >= 0, got {", ".join(bad)}')
    out = [
        f'{n} = {v:g} is outside [{lo:g}, {hi:g}]'
        for n, v in design.items()
        for lo, hi in [config.design.bounds()[n]]
        if not lo <= v <= hi
    ]
    if out:
        raise ConfigError(f'{flag}: {"; ".join(out)}')
    return design


def _config(args: argparse.Namespace) -> StudyConfig:
    """The study description: the file (or SPEC defaults), then command-line overrides."""
    cfg = load_config(args.config) if args.config else StudyConfig()
    data = cfg.to_dict()
    if getattr(args, 'normalization', None):
        data['objective']['normalization'] = args.normalization
        if args.normalization != 'custom':
            data['objective']['scales'] = {}
    if getattr(args, 'segments', None) is not None:
        try:
            data['transcription']['segments'] = (
                args.segments if args.segments == 'auto' else int(args.segments)
            )
        except ValueError:
            raise ConfigError(
                f'--segments: must be an integer or "auto", got {args.segments!r}'
            ) from None
    if getattr(args, 'order', None) is not None:
        data['transcription']['order'] = args.order
    if getattr(args, 'max_iter', None) is not None:
        data['optimizer']['max_iter'] = args.max_iter
    if getattr(args, 'mount', None):
        data['multibody']['mount'] = args.mount
    return config_from_dict(data)


def _start(args: argparse.Namespace, config: StudyConfig) -> dict[str, float] | None:
    """``--start``: where IPOPT starts, inside the bounds. Only the free variables move:
    a variable with ``optimize = false`` keeps its configured value (it is not optimized).
    It is not the study's initial design, which also defines the ``reference``
    normalization (SPEC §5): an optimization from another start minimizes the same f."""
    if not args.start:
        return None
    start = parse_design(args.start, '--start', config)
    held = [
        n
        for n in config.design_names()
        if not config.design[n].optimize and start[n] != config.design[n].initial
    ]
    if held:
        raise ConfigError(
            f'--start: {", ".join(held)} has optimize = false in the study file '
            'and is held at its initial value; change it there, not in --start'
        )
    return start


def _printer(quiet: bool, names: tuple[str, ...]):
    if quiet:
        return None, (lambda msg: None)
    state = {'header': False}

    def progress(info) -> None:
        if not state['header']:
            print(
                f'{"iter":>5} {"objective":>12} {"constr.viol":>11} {"elapsed":>8}  '
                + '  '.join(f'{n:>8}' for n in names),
                file=sys.stderr,
            )
            state['header'] = True
        d = {k.rsplit(':', 1)[-1]: v for k, v in info.design.items()}
        vals = '  '.join(f'{d[n]:8.1f}' for n in names if n in d)
        print(
            f'{info.iteration:5d} {info.objective:12.6f} {info.constraint_violation:11.2e} '
            f'{info.elapsed_s:7.1f}s  {vals}',
            file=sys.stderr,
            flush=True,
        )

    def log(msg: str) -> None:
        state['header'] = False
        print(f'[suspopt] {msg}', file=sys.stderr, flush=True)

    return progress, log


def _verdict(res: dict[str, Any]) -> str:
    v = res.get('verified')
    if not res['success']:
        return 'NOT converged'
    if v is None:
        return 'converged, NOT checked by time marching (--no-verify)'
    return (
        'converged and verified by time marching'
        if v
        else 'converged but NOT VERIFIED (collocation and time marching disagree)'
    )


def _summary(res: dict[str, Any]) -> str:
    d, s = res['design'], res['scales']
    lines = [
        f'{res["fidelity"]}-fidelity {res["mode"]} ({res["method"]}): '
        f'{_verdict(res)} — {res["status"]}'
    ]
    if res['success']:
        J = res['terms']
        lines += [
            '  design   ' + ', '.join(f'{n} = {v:.1f}' for n, v in d.items()),
            f'  objective f = {res["objective"]:.6f}   '
            + '  '.join(f'J_{k} = {v:.5g}' for k, v in J.items()),
        ]
    else:  # what IPOPT stopped at is not a result: never printed as one
        stop, J = res.get('objective_at_stop'), res.get('terms_at_stop') or {}
        lines += [
            '  design at the stop (not a result)   '
            + ', '.join(f'{n} = {v:.1f}' for n, v in d.items()),
            '  objective f: none (not converged'
            + (f'; {stop:.6g} at the stop' if stop is not None else '')
            + ')'
            + (
                '   at the stop: ' + '  '.join(f'J_{k} = {v:.5g}' for k, v in J.items())
                if J
                else ''
            ),
        ]
    lines.append(
        f'  scales ({res["normalization"]}) ' + '  '.join(f'{k} = {v:.5g}' for k, v in s.items())
    )
    v = res.get('verification') or {}
    if 'max_rel_diff' in v:
        lines.append(
            f'  time marching f = {v["objective"]:.6f}, largest relative difference '
            f'{v["max_rel_diff"]:.2g} (tolerance {v["tolerance"]:g}, '
            f'{v["time_s"]:.2f} s)'
        )
    lines.append(f'  iterations {res["iterations"]}, wall time {res["wall_time_s"]:.2f} s')
    return '\n'.join(lines)


def _check_result(res: dict[str, Any]) -> int:
    """The exit code of one result (and its one-line message on stderr)."""
    if not res['success']:
        _fail_message(res)
        return 1
    if res.get('verified') is False:
        v = res['verification']
        print(
            f'suspopt: error: result NOT verified: collocation and time marching differ by '
            f'{100 * v["max_rel_diff"]:.3g} % on some objective term (tolerance '
            f'{100 * v["tolerance"]:g} %); the grid is too coarse for this car and road: '
            'more --segments, or segments = "auto"',
            file=sys.stderr,
        )
        return NotVerified.exit_code
    return 0


def _fail_message(res: dict[str, Any]) -> None:
    last = res.get('last_iterate') or {}
    best = res.get('best_feasible_iterate')
    msg = (
        f'suspopt: error: IPOPT did not converge ({res["status"]}) after '
        f'{res["iterations"]} iterations: last objective '
        f'{last.get("objective", float("nan")):.6g}, constraint violation '
        f'{last.get("constraint_violation", float("nan")):.2e}'
    )
    if best:
        msg += (
            f'; best feasible iterate {best["iteration"]} f = {best["objective"]:.6g} at '
            + ', '.join(f'{k} = {v:.1f}' for k, v in best['design'].items())
        )
    print(msg, file=sys.stderr)


def cmd_optimize(args: argparse.Namespace) -> int:
    config = _config(args)
    from suspopt.output.rundir import RunDirectory
    from suspopt.studies.run import optimize

    start = _start(args, config)
    with RunDirectory(args.out, args.overwrite) as out:
        progress, log = _printer(args.quiet, config.design_names())
        log(f'optimizing the {args.fidelity}-fidelity model; results in {out.path}')
        res = optimize(
            config,
            args.fidelity,
            start=start,
            out_dir=out,
            progress=progress,
            verify=not args.no_verify,
        )
    print(_summary(res))
    return _check_result(res)


def cmd_evaluate(args: argparse.Namespace) -> int:
    config = _config(args)
    from suspopt.studies.run import evaluate

    design = parse_design(args.design, '--design', config) if args.design else None
    res = evaluate(config, args.fidelity, design, method=args.method, verify=not args.no_verify)
    res.pop('history', None)
    print(json.dumps(res, indent=2, default=float))
    return _check_result(res) if args.method == 'collocation' else 0


def _jobs(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        n = -1
    if n < 0:
        raise argparse.ArgumentTypeError(f'must be a whole number >= 0, got {text!r}')
    return n


def cmd_study(args: argparse.Namespace) -> int:
    config = _config(args)
    from suspopt.output.rundir import RunDirectory
    from suspopt.studies.run import StepFailed
    from suspopt.studies.twostep import run_study

    with RunDirectory(args.out, args.overwrite) as out:
        progress, log = _printer(args.quiet, config.design_names())
        log(f'two-step study; results in {out.path}')
        try:
            study = run_study(
                config,
                out,
                progress=progress,
                log=log,
                verify=not args.no_verify,
                verify_jobs=args.verify_jobs,
            )
        except StepFailed as err:
            print(f'suspopt: error: {err}; partial results in {out.path}', file=sys.stderr)
            return 1
    print((out.path / 'table.md').read_text())
    print(f'results: {out.path}/study.json, table.md, figures/ ({study["wall_time_s"]:.1f} s)')
    if study.get('verified') is False:
        print(f'suspopt: error: {study["warnings"][-1]}', file=sys.stderr)
        return NotVerified.exit_code
    return 0


def cmd_coupling(args: argparse.Namespace) -> int:
    config = _config(args)
    from suspopt.output.rundir import RunDirectory
    from suspopt.studies.coupling import run_coupling
    from suspopt.studies.run import StepFailed

    with RunDirectory(args.out, args.overwrite) as out:
        progress, log = _printer(args.quiet, config.design_names())
        log(
            'the coupling assumption: two-step studies with the frame on the ground and on '
            f'the chassis, 4 designs x 3 models; results in {out.path}'
        )
        try:
            res = run_coupling(config, out, progress=progress, log=log, verify=not args.no_verify)
        except StepFailed as err:
            print(f'suspopt: error: {err}; partial results in {out.path}', file=sys.stderr)
            return 1
    print((out.path / 'table.md').read_text())
    print(
        f'results: {out.path}/coupling.json, table.md, figures/coupling.png '
        f'({res["wall_time_s"]:.1f} s)'
    )
    if res.get('verified') is False:
        print(f'suspopt: error: {res["warnings"][-1]}', file=sys.stderr)
        return NotVerified.exit_code
    return 0


def cmd_pareto(args: argparse.Namespace) -> int:
    if args.points < 2:
        raise ConfigError(f'--points: need at least 2, got {args.points}')
    config = _config(args)
    from suspopt.output.rundir import RunDirectory
    from suspopt.studies.pareto import run_pareto

    with RunDirectory(args.out, args.overwrite) as out:
        progress, log = _printer(args.quiet, config.design_names())
        log(
            f'Pareto front of the {args.fidelity}-fidelity model, {args.points} points; '
            f'results in {out.path}'
        )
        front = run_pareto(
            config,
            out,
            fidelity=args.fidelity,
            points=args.points,
            progress=progress,
            log=log,
            verify=not args.no_verify,
        )
    print((out.path / 'table.md').read_text())
    print(
        f'results: {out.path}/pareto.json, table.md, figures/pareto.png '
        f'({front["wall_time_s"]:.1f} s)'
    )
    failed = [p for p in front['points'] if not p['success']]
    if failed:
        where = ', '.join(f'{p["alpha"]:.3f} ({p["status"]})' for p in failed)
        print(
            f'suspopt: error: IPOPT did not converge at comfort share(s) {where}; the '
            'other points are kept',
            file=sys.stderr,
        )
        return 1
    unverified = [p for p in front['points'] if p.get('verified') is False]
    if unverified:
        print(
            'suspopt: error: NOT verified by time marching at comfort share(s) '
            + ', '.join(f'{p["alpha"]:.3f}' for p in unverified),
            file=sys.stderr,
        )
        return NotVerified.exit_code
    return 0


def cmd_compare(args: argparse.Namespace) -> int:
    """The topology study (suspopt.compare): every topology's mixed-fidelity optimum, the
    cross table of every optimum in every model, kinematic curves."""
    config = _config(args)
    from suspopt.output.rundir import RunDirectory
    from suspopt.studies.compare import exit_code, parse_topologies, run_compare, topology_config
    from suspopt.studies.run import StepFailed

    for front, rear in parse_topologies(args.mechanisms):  # bad input before any work
        topology_config(config, front, rear)
    with RunDirectory(args.out, args.overwrite) as out:
        progress, log = _printer(args.quiet, config.design_names())
        log(f'topology study of {args.mechanisms}; results in {out.path}')
        try:
            data = run_compare(
                config, out, args.mechanisms, progress=progress, log=log, verify=not args.no_verify
            )
        except StepFailed as err:
            print(
                f'suspopt: error: {err}; no topology can start from it; partial results '
                f'in {out.path}',
                file=sys.stderr,
            )
            return 1
    print((out.path / 'table.md').read_text())
    print(f'results: {out.path}/compare.json, table.md, figures/ ({data["wall_time_s"]:.1f} s)')
    code = exit_code(data)
    if code == 1:
        for f in data['failures']:
            where = f['model'] + (f' at {f["design"]}' if f.get('design') else '')
            print(
                f'suspopt: error: {f["what"]} failed in {where}: {f["status"]} '
                f'{f.get("message", "")}'.rstrip()
                + '; the other results are kept',
                file=sys.stderr,
            )
    elif code == NotVerified.exit_code:
        print(f'suspopt: error: {data["warnings"][-1]}', file=sys.stderr)
    return code


def cmd_robust(args: argparse.Namespace) -> int:
    config = _config(args)
    import suspopt.output.report as report
    from suspopt.output.rundir import RunDirectory
    from suspopt.studies.robust import run_robust

    with RunDirectory(args.out, args.overwrite) as out:
        progress, log = _printer(args.quiet, config.design_names())
        log(f'robust design of the {args.fidelity}-fidelity model; results in {out.path}')
        data = run_robust(
            config,
            out,
            fidelity=args.fidelity,
            progress=progress,
            log=log,
            verify=not args.no_verify,
        )
        log('writing table and figure')
        report.render(out.path)
    print((out.path / 'table.md').read_text())
    print(
        f'results: {out.path}/robust.json, table.md, figures/robustness.png '
        f'({data["wall_time_s"]:.1f} s)'
    )
    failed = [k for k, r in data['optima'].items() if not r['success']]
    if failed:
        print(
            f'suspopt: error: IPOPT did not converge for {", ".join(failed)}; the others are kept',
            file=sys.stderr,
        )
        return 1
    if data.get('verified') is False:
        print(
            'suspopt: error: some optimum is NOT verified by time marching (see table.md)',
            file=sys.stderr,
        )
        return NotVerified.exit_code
    return 0


def cmd_sweep(args: argparse.Namespace) -> int:
    """Many optimizations or studies in parallel on Dask (see suspopt.sweep)."""
    from suspopt.sweep.runner import run_sweep

    log = (lambda msg: None) if args.quiet else None
    outcome = run_sweep(
        args.file,
        args.out,
        workers=args.workers,
        scheduler=args.scheduler,
        retry_failed=args.retry_failed,
        log=log,
        worker_start=args.worker_start,
    )
    return outcome.exit_code


def cmd_init(args: argparse.Namespace) -> int:
    from suspopt.spec.template import default_config_toml

    path = Path(args.file)
    if path.exists() and not args.overwrite:
        raise ConfigError(f'{path} exists; pass --overwrite to replace it')
    if not path.parent.is_dir():
        raise ConfigError(f'{path}: directory {path.parent} does not exist')
    try:
        path.write_text(default_config_toml(args.model))
    except OSError as err:
        raise ConfigError(f'cannot write {path}: {err.strerror}') from None
    what = "the paper's case" if args.model == 'half_car' else 'the default full car'
    print(f'wrote {path} ({what}; edit it and pass --config {path})')
    return 0


def cmd_report(args: argparse.Namespace) -> int:
    from suspopt.output.report import render

    written = render(args.dir)
    print((Path(args.dir) / 'table.md').read_text())
    print('wrote ' + ', '.join(str(p) for p in written))
    return 0


def cmd_kinematics(args: argparse.Namespace) -> int:
    """Kinematic curves of a suspension mechanism: table on stdout, figure and table in --out."""
    from suspopt.multibody.kinematics import curves_table, kinematic_curves, plot_curves
    from suspopt.multibody.mechanism import mechanism_path

    travel = None
    if args.travel is not None:
        try:
            travel = tuple(float(x) for x in args.travel.split(','))
        except ValueError:
            travel = ()
        if (
            len(travel) != 2
            or not all(math.isfinite(x) for x in travel)
            or not travel[0] < travel[1]
        ):
            raise ConfigError(f'--travel: expected MIN,MAX [m] with MIN < MAX, got {args.travel!r}')
    if args.k is not None and not (math.isfinite(args.k) and args.k > 0.0):
        raise ConfigError(f'--k: the spring rate must be finite and > 0 N/m, got {args.k:g}')
    if args.points < 2:
        raise ConfigError(f'--points: need at least 2, got {args.points}')
    curves = kinematic_curves(args.mechanism, travel, args.k, args.points)
    table = curves_table(curves)
    print(table)
    out = Path(args.out)
    try:
        out.mkdir(parents=True, exist_ok=True)
        stem = f'kinematics_{mechanism_path(args.mechanism).stem}'
        (out / f'{stem}.md').write_text(table)
        figure = plot_curves(curves, out / f'{stem}.png')
    except OSError as err:
        raise ConfigError(f'--out: cannot write to {out}: {err.strerror}') from None
    print(f'wrote {figure} and {out / f"{stem}.md"}')
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='suspopt',
        epilog=EPILOG,
        description='Mixed-fidelity suspension design optimization (half or full car + '
        'multibody suspension linkages; Dymos Radau collocation; IPOPT).',
    )
    sub = parser.add_subparsers(dest='command', required=True)

    def common(
        p: argparse.ArgumentParser, grid: bool = True, verify: bool = True, mount: bool = True
    ) -> None:
        p.add_argument('--config', metavar='FILE', help='study file (TOML); see `suspopt init`')
        if mount:
            p.add_argument(
                '--mount',
                choices=('ground', 'chassis'),
                help="multibody modules' frame on the ground (the paper) or on the "
                'chassis; default: from the config (multibody.mount)',
            )
        p.add_argument(
            '--normalization',
            choices=('reference', 'paper'),
            help='objective normalization (SPEC §5); default: from the config',
        )
        if grid:
            p.add_argument('--segments', metavar='N', help='collocation segments, or "auto"')
            p.add_argument('--order', type=int, metavar='P', help='Radau order per segment')
        if verify:
            p.add_argument(
                '--no-verify',
                action='store_true',
                help='skip the time-marching verification (the results say so)',
            )

    def run_opts(p: argparse.ArgumentParser, out: str | None) -> None:
        p.add_argument(
            '--out',
            default=out,
            metavar='DIR',
            help='output directory' + (' (default: %(default)s)' if out else ''),
        )
        p.add_argument(
            '--overwrite',
            action='store_true',
            help='reuse a non-empty --out (its earlier results are removed first)',
        )
        p.add_argument('--max-iter', type=int, dest='max_iter', help='IPOPT iteration limit')
        p.add_argument('--quiet', action='store_true', help='no progress lines')

    p = sub.add_parser('study', help="run the paper's two-step study", epilog=EPILOG)
    common(p)
    run_opts(p, 'results/study')
    p.add_argument(
        '--verify-jobs',
        type=_jobs,
        dest='verify_jobs',
        metavar='N',
        help='time-marching verifications run at once in background processes, '
        'beside the optimizations (default: the cores less one; 0: each in '
        'this process after its solve)',
    )
    p.set_defaults(func=cmd_study)

    p = sub.add_parser(
        'coupling',
        help='how much the coupling of the multibody modules '
        '(frame on the ground, as the paper, or on the '
        'chassis) moves the optimum: 4 designs x 3 models',
        epilog=EPILOG,
    )
    common(p, mount=False)
    run_opts(p, 'results/coupling')
    p.set_defaults(func=cmd_coupling)

    p = sub.add_parser('optimize', help='optimize one model', epilog=EPILOG)
    p.add_argument('--fidelity', choices=('low', 'mixed'), required=True)
    common(p)
    p.add_argument('--start', metavar='DESIGN', help='starting design (default: config)')
    run_opts(p, None)
    p.set_defaults(func=cmd_optimize)

    p = sub.add_parser('evaluate', help='evaluate one design without optimizing', epilog=EPILOG)
    p.add_argument('--fidelity', choices=('low', 'mixed'), required=True)
    common(p)
    p.add_argument('--design', metavar='DESIGN', help='design (default: config initial)')
    p.add_argument('--method', choices=('collocation', 'time-marching'), default='collocation')
    p.set_defaults(func=cmd_evaluate)

    p = sub.add_parser(
        'pareto',
        help='ride comfort against road holding: the Pareto front by weighted sums',
        epilog=EPILOG,
    )
    p.add_argument('--fidelity', choices=('low', 'mixed'), default='low')
    common(p)
    p.add_argument(
        '--points',
        type=int,
        default=9,
        metavar='N',
        help='comfort shares 0 ... 1 (default: %(default)s)',
    )
    run_opts(p, 'results/pareto')
    p.set_defaults(func=cmd_pareto)

    p = sub.add_parser(
        'compare',
        help="suspension topologies side by side: each one's "
        'mixed-fidelity optimum, every optimum in every model',
        epilog=EPILOG,
    )
    p.add_argument(
        '--mechanisms',
        default='double_wishbone,sla_double_wishbone,macpherson',
        metavar='A,B,...',
        help='topologies: built-in names or mechanism TOML paths (relative to '
        'the working directory), each on both axles, or FRONT+REAR (default: '
        '%(default)s)',
    )
    common(p)
    run_opts(p, 'results/compare')
    p.set_defaults(func=cmd_compare)

    p = sub.add_parser(
        'robust',
        help="robust design over the study file's scenarios: the "
        "robust optimum against each scenario's own",
        epilog=EPILOG,
    )
    p.add_argument('--fidelity', choices=('low', 'mixed'), default='low')
    common(p)
    run_opts(p, 'results/robust')
    p.set_defaults(func=cmd_robust)

    p = sub.add_parser(
        'sweep',
        help='many optimizations or studies in parallel on Dask '
        '(a sweep file: axes or a task list)',
        epilog=EPILOG,
    )
    p.add_argument('file', help='sweep file (TOML); see examples/sweep.toml')
    p.add_argument(
        '--out',
        required=True,
        metavar='DIR',
        help='output directory; rerunning with it resumes the sweep',
    )
    p.add_argument(
        '--workers', type=int, metavar='N', help='local worker processes (default: one per core)'
    )
    p.add_argument(
        '--scheduler',
        metavar='tcp://HOST:PORT',
        help='run on an existing Dask cluster instead of a local one',
    )
    p.add_argument(
        '--worker-start',
        choices=('auto', 'fork', 'spawn'),
        default='auto',
        dest='worker_start',
        help='how local workers start: forked from this process (auto on Linux; '
        'suspopt already imported) or spawned (import it each)',
    )
    p.add_argument(
        '--retry-failed',
        action='store_true',
        dest='retry_failed',
        help='when resuming, rerun the tasks that failed',
    )
    p.add_argument('--quiet', action='store_true', help='no progress lines')
    p.set_defaults(func=cmd_sweep)

    p = sub.add_parser(
        'kinematics',
        help='kinematic curves of a suspension mechanism: motion '
        'ratio, wheel rate, camber, track change',
        epilog=EPILOG,
    )
    p.add_argument(
        'mechanism',
        help='built-in name (double_wishbone, sla_double_wishbone, '
        'macpherson) or path of a mechanism TOML',
    )
    p.add_argument(
        '--travel',
        metavar='MIN,MAX',
        help='wheel travel range [m], e.g. --travel=-0.08,0.1 (with "=": it starts '
        "with a minus) (default: the mechanism's)",
    )
    p.add_argument(
        '--k',
        type=float,
        metavar='N/m',
        help="spring rate for the wheel rate (default: the file's, or 30000)",
    )
    p.add_argument(
        '--points',
        type=int,
        default=21,
        metavar='N',
        help='travels in the range (default: %(default)s)',
    )
    p.add_argument(
        '--out',
        default='results/kinematics',
        metavar='DIR',
        help='directory of the figure and table (default: %(default)s)',
    )
    p.set_defaults(func=cmd_kinematics)

    p = sub.add_parser('init', help='write a default car as a commented study file')
    p.add_argument('file')
    p.add_argument(
        '--model',
        choices=('half_car', 'full_car'),
        default='half_car',
        help="the paper's half car (default) or the default full car",
    )
    p.add_argument('--overwrite', action='store_true')
    p.set_defaults(func=cmd_init)

    p = sub.add_parser(
        'report', help='re-render the table and figures of a run from its results directory'
    )
    p.add_argument('dir')
    p.set_defaults(func=cmd_report)
    return parser


def _sigterm_as_interrupt(signum, frame) -> None:
    raise KeyboardInterrupt


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if getattr(args, 'command', None) == 'optimize' and not args.out:
        args.out = f'results/optimize-{args.fidelity}'
    _quiet_libraries()
    try:
        previous = signal.signal(signal.SIGTERM, _sigterm_as_interrupt)
    except ValueError:  # not in the main thread
        previous = None
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
    except MemoryError:
        print(
            'suspopt: error: out of memory (a smaller grid or horizon, or fewer scenarios)',
            file=sys.stderr,
        )
        return 4
    except OSError as err:  # the environment, not suspopt
        print(
            f'suspopt: error: {err.strerror or err}: {err.filename or ""}'.rstrip(': '),
            file=sys.stderr,
        )
        return 4
    except Exception as err:  # a bug: one line for the user, the traceback on request
        if os.environ.get('SUSPOPT_DEBUG'):
            raise
        print(
            f'suspopt: error: unexpected {type(err).__name__}: {err} (this is a bug in '
            'suspopt; SUSPOPT_DEBUG=1 shows the traceback)',
            file=sys.stderr,
        )
        return 1
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


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
