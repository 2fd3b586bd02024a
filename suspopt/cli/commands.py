"""The commands of the command line (``docs/commands.md``): each one takes the parsed
arguments, runs, prints, and returns its exit code (:mod:`suspopt.cli.exits`).

The heavy modules (OpenMDAO, Dymos, Matplotlib) are imported only once the arguments and
the study file have been checked: bad input is refused at once."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from suspopt.cli.exits import FAILED, NOT_VERIFIED, OK
from suspopt.cli.inputs import Printer, parse_design, start_design, study_config
from suspopt.errors import ConfigError
from suspopt.records.solve import SolveRecord
from suspopt.spec.load import load_config


def _error(msg: str) -> None:
    print(f'suspopt: error: {msg}', file=sys.stderr)


# ---------------------------------------------------------------------------- one result
def _verdict(res: SolveRecord) -> str:
    if not res.success:
        return 'NOT converged'
    if res.verified is None:
        return 'converged, NOT checked by time marching (--no-verify)'
    return (
        'converged and verified by time marching'
        if res.verified
        else 'converged but NOT VERIFIED (collocation and time marching disagree)'
    )


def _terms_text(J: dict[str, float]) -> str:
    return '  '.join(f'J_{k} = {v:.5g}' for k, v in J.items())


def summary(res: SolveRecord) -> str:
    """One result in a few lines (never a failed solve's values as a result): every
    scenario's terms and scales, and how they make f."""
    d = res.design
    several = len(res.scenarios) > 1
    lines = [f'{res.fidelity}-fidelity {res.mode} ({res.method}): {_verdict(res)} — {res.status}']
    if res.success:
        lines += [
            '  design   ' + ', '.join(f'{n} = {v:.1f}' for n, v in d.items()),
            f'  objective f = {res.objective:.6f}'
            + ('' if several else f'   {_terms_text(res.terms or {})}'),
        ]
    else:  # what IPOPT stopped at is not a result: never printed as one
        stop, J = res.objective_at_stop, res.terms_at_stop or {}
        lines += [
            '  design at the stop (not a result)   '
            + ', '.join(f'{n} = {v:.1f}' for n, v in d.items()),
            '  objective f: none (not converged'
            + (f'; {stop:.6g} at the stop' if stop is not None else '')
            + ')'
            + (f'   at the stop: {_terms_text(J)}' if J and not several else ''),
        ]
    if several:  # every scenario: its f_s, terms and scales (f is their aggregate)
        lines.append(f'  {res.formula()}')
        for sc in res.scenarios:
            f_s, reached = sc.reached
            lines.append(
                f'  scenario {sc.name} (w = {sc.weight:g}): f_s = '
                + ('—' if f_s is None else f'{f_s:.6f}')
                + ('' if res.success else ' (at the stop, not a result)')
                + (f'   {_terms_text(reached)}' if reached else '')
            )
            lines.append(
                f'    scales ({res.normalization}) '
                + '  '.join(f'{k} = {v:.5g}' for k, v in sc.scales.items())
            )
    else:
        lines.append(
            f'  scales ({res.normalization}) '
            + '  '.join(f'{k} = {v:.5g}' for k, v in res.scales.items())
        )
    if res.constraints:
        active = [v.name for v in res.constraints if v.active]
        lines.append(
            f'  constraints: {len(res.constraints)}, active: {", ".join(active) or "none"}'
        )
    c = res.verification.comparison
    if c is not None:
        lines.append(
            f'  time marching f = {c.objective:.6f}, largest relative difference '
            f'{c.max_rel_diff:.2g} (tolerance {c.tolerance:g}, {c.time_s:.2f} s)'
        )
    lines.append(f'  iterations {res.iterations}, wall time {res.wall_time_s:.2f} s')
    return '\n'.join(lines)


def check_result(res: SolveRecord) -> int:
    """The exit code of one result (and its one-line message on stderr)."""
    if not res.success:
        _error(_not_converged(res))
        return FAILED
    c = res.verification.comparison
    if res.verified is False and c is not None:
        _error(
            f'result NOT verified: {c.disagreement()}: the grid is too coarse for this car '
            'and road: more --segments, or segments = "auto"'
        )
        return NOT_VERIFIED
    return OK


def _not_converged(res: SolveRecord) -> str:
    last, best = res.last_iterate, res.best_feasible_iterate
    nan = float('nan')
    msg = (
        f'IPOPT did not converge ({res.status}) after {res.iterations} iterations: last '
        f'objective {last.objective if last else nan:.6g}, constraint violation '
        f'{last.constraint_violation if last else nan:.2e}'
    )
    if res.infeasibility is not None:
        msg += f'; infeasible: {res.infeasibility.describe()}'
    if best is not None:
        msg += f'; best feasible iterate {best.iteration} f = {best.objective:.6g} at ' + ', '.join(
            f'{k} = {v:.1f}' for k, v in best.design.items()
        )
    return msg


def _spectral_fidelity(args: argparse.Namespace) -> None:
    if args.fidelity != 'low':
        raise ConfigError(
            f'--fidelity: the spectral method takes the low-fidelity vehicle (linear), got '
            f'{args.fidelity!r}; use --fidelity low'
        )


def optimize_spectral(args: argparse.Namespace) -> int:
    """``optimize --method spectral``: the stationary optimum (docs/spectral.md)."""
    _spectral_fidelity(args)
    config = study_config(args)
    from suspopt.output.rundir import RunDirectory
    from suspopt.output.spectral_report import spectral_markdown
    from suspopt.studies.spectral import optimize_spectral_study

    start = start_design(args, config)
    if args.out is None:
        res = optimize_spectral_study(config, start=start)
    else:
        with RunDirectory(args.out, args.overwrite) as out:
            Printer(args.quiet, config.design_names()).log(
                f'stationary optimum of the low-fidelity model; results in {out.path}'
            )
            res = optimize_spectral_study(config, start=start, out_dir=out)
    print(spectral_markdown(res))
    if args.out is not None:
        print(f'results: {args.out}/spectral.json, table.md ({res.wall_time_s:.2f} s)')
    if res.success:
        found = ','.join(f'{n}={v:.6g}' for n, v in res.design.items())
        print(f'the time-domain steps can start from it: --start {found}')
    for w in res.warnings:
        _error(f'warning: {w}')
    if not res.success:
        _error(f'IPOPT did not converge ({res.status}) after {res.iterations} iterations')
        return FAILED
    return OK


def optimize(args: argparse.Namespace) -> int:
    if args.method == 'spectral':
        return optimize_spectral(args)
    config = study_config(args)
    import suspopt.studies.run as run
    from suspopt.output.rundir import RunDirectory

    start = start_design(args, config)
    with RunDirectory(args.out, args.overwrite) as out:
        printer = Printer(args.quiet, config.design_names())
        printer.log(f'optimizing the {args.fidelity}-fidelity model; results in {out.path}')
        res = run.optimize(
            config,
            args.fidelity,
            start=start,
            out_dir=out,
            progress=printer.progress,
            verify=not args.no_verify,
        )
        printer.log('writing table and figures')
        from suspopt.output.report import render

        render(out.path)  # the table, figures and input copies of every run directory
    print(summary(res))
    print(f'results: {out.path}/result.json, table.md, figures/')
    return check_result(res)


def evaluate(args: argparse.Namespace) -> int:
    config = study_config(args)
    import suspopt.studies.run as run

    design = parse_design(args.design, '--design', config) if args.design else None
    if args.method == 'spectral':
        _spectral_fidelity(args)
        from suspopt.studies.spectral import evaluate_spectral

        spectral = evaluate_spectral(config, design)
        print(json.dumps(spectral.to_json(), indent=2, default=float))
        return OK
    res = run.evaluate(config, args.fidelity, design, method=args.method, verify=not args.no_verify)
    data = res.to_json()
    data.pop('history', None)
    print(json.dumps(data, indent=2, default=float))
    return check_result(res) if args.method == 'collocation' else OK


# ---------------------------------------------------------------------------- studies
def _results(out: Path, files: str, wall_time_s: float | None) -> None:
    """The table on stdout, and where the results are."""
    print((out / 'table.md').read_text())
    print(f'results: {out}/{files} ({wall_time_s or 0.0:.1f} s)')


def study(args: argparse.Namespace) -> int:
    config = study_config(args)
    from suspopt.output.rundir import RunDirectory
    from suspopt.studies.run import StepFailed
    from suspopt.studies.twostep import run_study

    with RunDirectory(args.out, args.overwrite) as out:
        printer = Printer(args.quiet, config.design_names())
        printer.log(f'two-step study; results in {out.path}')
        try:
            rec = run_study(
                config,
                out,
                progress=printer.progress,
                log=printer.log,
                verify=not args.no_verify,
                verify_jobs=args.verify_jobs,
            )
        except StepFailed as err:
            _error(f'{err}; partial results in {out.path}')
            return FAILED
    _results(out.path, 'study.json, table.md, figures/', rec.wall_time_s)
    if rec.verified is False:
        _error(rec.warnings[-1])
        return NOT_VERIFIED
    return OK


def coupling(args: argparse.Namespace) -> int:
    config = study_config(args)
    from suspopt.output.rundir import RunDirectory
    from suspopt.studies.coupling import run_coupling
    from suspopt.studies.run import StepFailed

    with RunDirectory(args.out, args.overwrite) as out:
        printer = Printer(args.quiet, config.design_names())
        printer.log(
            'the coupling assumption: two-step studies with the frame on the ground and on '
            f'the chassis, 4 designs x 3 models; results in {out.path}'
        )
        try:
            rec = run_coupling(
                config, out, progress=printer.progress, log=printer.log, verify=not args.no_verify
            )
        except StepFailed as err:
            _error(f'{err}; partial results in {out.path}')
            return FAILED
    _results(out.path, 'coupling.json, table.md, figures/coupling.png', rec.wall_time_s)
    if rec.verified is False:
        _error(rec.warnings[-1])
        return NOT_VERIFIED
    return OK


def pareto(args: argparse.Namespace) -> int:
    config = study_config(args)
    from suspopt.output.rundir import RunDirectory
    from suspopt.studies.pareto import run_pareto

    with RunDirectory(args.out, args.overwrite) as out:
        printer = Printer(args.quiet, config.design_names())
        printer.log(
            f'Pareto front of the {args.fidelity}-fidelity model, {args.points} points; '
            f'results in {out.path}'
        )
        front = run_pareto(
            config,
            out,
            fidelity=args.fidelity,
            points=args.points,
            progress=printer.progress,
            log=printer.log,
            verify=not args.no_verify,
        )
    _results(out.path, 'pareto.json, table.md, figures/pareto.png', front.wall_time_s)
    failed = [p for p in front.points if not p.success]
    if failed:
        where = ', '.join(f'{p.alpha:.3f} ({p.result.status})' for p in failed)
        _error(f'IPOPT did not converge at comfort share(s) {where}; the other points are kept')
        return FAILED
    unverified = [p for p in front.points if p.result.verified is False]
    if unverified:
        _error(
            'NOT verified by time marching at comfort share(s) '
            + ', '.join(f'{p.alpha:.3f}' for p in unverified)
        )
        return NOT_VERIFIED
    return OK


def compare(args: argparse.Namespace) -> int:
    """The topology study (suspopt.studies.compare): every topology's mixed-fidelity
    optimum, the cross table of every optimum in every model, kinematic curves."""
    config = study_config(args)
    from suspopt.output.rundir import RunDirectory
    from suspopt.studies.compare import exit_code, parse_topologies, run_compare, topology_config
    from suspopt.studies.run import StepFailed

    for front, rear in parse_topologies(args.mechanisms):  # bad input before any work
        topology_config(config, front, rear)
    with RunDirectory(args.out, args.overwrite) as out:
        printer = Printer(args.quiet, config.design_names())
        printer.log(f'topology study of {args.mechanisms}; results in {out.path}')
        try:
            rec = run_compare(
                config,
                out,
                args.mechanisms,
                progress=printer.progress,
                log=printer.log,
                verify=not args.no_verify,
            )
        except StepFailed as err:
            _error(f'{err}; no topology can start from it; partial results in {out.path}')
            return FAILED
    _results(out.path, 'compare.json, table.md, figures/', rec.wall_time_s)
    code = exit_code(rec)
    if code == FAILED:
        for f in rec.failures:
            where = f.model + (f' at {f.design}' if f.design else '')
            _error(
                f'{f.what} failed in {where}: {f.status} {f.message}'.rstrip()
                + '; the other results are kept'
            )
    elif code == NOT_VERIFIED:
        _error(rec.warnings[-1])
    return code


def robust(args: argparse.Namespace) -> int:
    config = study_config(args)
    from suspopt.output.report import render
    from suspopt.output.rundir import RunDirectory
    from suspopt.studies.robust import run_robust

    with RunDirectory(args.out, args.overwrite) as out:
        printer = Printer(args.quiet, config.design_names())
        printer.log(f'robust design of the {args.fidelity}-fidelity model; results in {out.path}')
        rec = run_robust(
            config,
            out,
            fidelity=args.fidelity,
            progress=printer.progress,
            log=printer.log,
            verify=not args.no_verify,
        )
        printer.log('writing table and figure')
        render(out.path)
    _results(out.path, 'robust.json, table.md, figures/robustness.png', rec.wall_time_s)
    return _optima_code(rec.optima, rec.verified)


def codesign(args: argparse.Namespace) -> int:
    """The control co-design study (suspopt.studies.codesign): passive, open-loop and
    feedback optima of the study file's controlled suspension."""
    config = study_config(args)
    from suspopt.output.report import render
    from suspopt.output.rundir import RunDirectory
    from suspopt.studies.codesign import run_codesign, variant

    variant(config, 'passive')  # bad input (no [control]) before any work
    with RunDirectory(args.out, args.overwrite) as out:
        printer = Printer(args.quiet, config.design_names())
        printer.log(
            f'{config.control.kind.replace("_", "-")} co-design of the {args.fidelity}-fidelity '
            f'model; results in {out.path}'
        )
        rec = run_codesign(
            config,
            args.fidelity,
            progress=printer.progress,
            log=printer.log,
            verify=not args.no_verify,
            out_dir=out,
        )
        printer.log('writing table and figure')
        render(out.path)
    _results(out.path, 'codesign.json, table.md, figures/codesign.png', rec.wall_time_s)
    return _optima_code(rec.entries, rec.verified)


def _optima_code(optima: dict[str, SolveRecord], verified: bool | None) -> int:
    """The exit code of a study of several optima (and its one line on stderr): any not
    converged, then any NOT verified."""
    failed = [k for k, r in optima.items() if not r.success]
    if failed:
        _error(f'IPOPT did not converge for {", ".join(failed)}; the others are kept')
        return FAILED
    if verified is False:
        _error('some optimum is NOT verified by time marching (see table.md)')
        return NOT_VERIFIED
    return OK


def sweep(args: argparse.Namespace) -> int:
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


# ---------------------------------------------------------------------------- files
def init(args: argparse.Namespace) -> int:
    from suspopt.output.rundir import write_text
    from suspopt.spec.template import default_config_toml

    path = Path(args.file)
    if path.is_dir():
        raise ConfigError(f'FILE: {path} is a directory')
    if path.exists() and not args.overwrite:
        raise ConfigError(f'{path} exists; pass --overwrite to replace it')
    if not path.parent.is_dir():
        raise ConfigError(f'{path}: directory {path.parent} does not exist')
    write_text(path, default_config_toml(args.model))  # unwritable, full: RunError (exit 4)
    what = "the paper's case" if args.model == 'half_car' else 'the default full car'
    print(f'wrote {path} ({what}; edit it and pass --config {path})')
    return OK


def report(args: argparse.Namespace) -> int:
    """Re-render a results directory of any kind (a sweep's by
    :func:`suspopt.sweep.summary.render`), holding its lock: never while a run writes
    into it."""
    from suspopt.output.report import render
    from suspopt.output.rundir import RunDirectory, read_json

    d = Path(args.dir)
    if not d.is_dir():
        raise ConfigError(f'DIR: {d}: not a directory')
    with RunDirectory(d, fresh=False, flag='DIR'):
        manifest = d / 'manifest.json'
        kind = read_json(manifest).get('kind') if manifest.exists() else None
        if kind == 'sweep':
            written = _render_sweep(d)
        else:
            written = render(d)
    table = d / 'table.md'
    if table.exists():
        print(table.read_text())
    print('wrote ' + ', '.join(str(p) for p in written))
    return OK


def _render_sweep(directory: Path) -> list[Path]:
    """A sweep directory's table and figures (:mod:`suspopt.sweep.summary`)."""
    from suspopt.sweep.summary import render as render_sweep

    return list(render_sweep(directory))


def _study_axle(args: argparse.Namespace) -> tuple[str, object, float | None]:
    """With ``--study``: the axle's mechanism (``args.mechanism`` if given), that mechanism
    with the study's hardware curves on its spring (or its name, linear), and the
    axle's spring rate (the design's initial ``k_S``; None for a spring table)."""
    from suspopt.models.design import design_id
    from suspopt.spec.hardware import study_units

    cfg = load_config(args.study)
    if args.axle == 'rear' and cfg.vehicle.model == 'quarter_car':
        raise ConfigError('--axle: a quarter car has one corner (front)')
    a = ('front', 'rear').index(args.axle)
    name = args.mechanism or cfg.vehicle.axles[a].mechanism
    rate = next(
        (
            x
            for n, x in cfg.design.initial().items()
            if design_id(n).kind.symbol == 'k_S' and design_id(n).axle == a
        ),
        None,
    )
    unit = study_units(cfg)[a]
    if unit is None:
        return name, name, rate
    from suspopt.multibody.mechanism import load_mechanism
    from suspopt.transcription.vehicle import with_hardware

    return name, with_hardware(load_mechanism(name, suspension=True), unit), rate


def kinematics(args: argparse.Namespace) -> int:
    """Kinematic curves of a suspension mechanism: table on stdout, figure and table in --out."""
    from suspopt.multibody.kinematics import curves_table, kinematic_curves, plot_curves
    from suspopt.multibody.mechanism import mechanism_path
    from suspopt.output.rundir import RunDirectory, write_text

    name, mechanism, k = args.mechanism, args.mechanism, args.k
    if args.study:
        name, mechanism, rate = _study_axle(args)
        k = rate if k is None else k
    elif name is None:
        raise ConfigError('kinematics: give a MECHANISM, or --study FILE [--axle front|rear]')
    curves = kinematic_curves(mechanism, args.travel, k, args.points, args.centre_line)
    table = curves_table(curves)
    print(table)
    # the lock of every command on a directory; its other files stay (one per mechanism)
    with RunDirectory(args.out, fresh=False) as out:
        stem = f'kinematics_{mechanism_path(name).stem}'
        if args.study:
            stem += f'_{Path(args.study).stem}_{args.axle}'
        write_text(out / f'{stem}.md', table)
        figure = plot_curves(curves, out / f'{stem}.png')
    print(f'wrote {figure} and {out / f"{stem}.md"}')
    return OK
