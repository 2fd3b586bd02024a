"""The command line's arguments: every command, its options and its help
(``docs/commands.md``)."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any, NoReturn

import suspopt.cli.commands as commands
from suspopt.errors import ConfigError

EPILOG = (
    'Exit codes: 0 ok (verified), 1 model/optimization failure, 2 bad input, '
    '3 not verified by time marching, 4 output not writable, 130 interrupted.'
)


class Parser(argparse.ArgumentParser):
    """argparse with suspopt's error lines: a malformed command line is one line naming
    the option (``suspopt: error: --fidelity: ...``, exit 2), raised as a ConfigError
    instead of argparse's usage dump. Every value is read as text here and checked by
    :func:`suspopt.cli.inputs.check_arguments` (the one input layer)."""

    def error(self, message: str) -> NoReturn:
        text = ' '.join(message.split())
        if text.startswith('argument '):
            text = text.removeprefix('argument ')
            flag, _, rest = text.partition(': ')
            text = f'{flag.split("/")[-1]}: {rest}' if rest else text
        raise ConfigError(f'{text} ({self.prog} --help)')


def _common(
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
        help='objective normalization (docs/model.md); default: from the config',
    )
    if grid:
        p.add_argument('--segments', metavar='N', help='collocation segments, or "auto"')
        p.add_argument('--order', metavar='P', help='Radau order per segment')
    if verify:
        p.add_argument(
            '--no-verify',
            action='store_true',
            help='skip the time-marching verification (the results say so)',
        )


def _run_options(p: argparse.ArgumentParser, out: str | None) -> None:
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
    p.add_argument('--max-iter', dest='max_iter', metavar='N', help='IPOPT iteration limit')
    p.add_argument('--quiet', action='store_true', help='no progress lines')


def _study(sub: Any) -> None:
    p = sub.add_parser('study', help="run the paper's two-step study", epilog=EPILOG)
    _common(p)
    _run_options(p, 'results/study')
    p.add_argument(
        '--verify-jobs',
        dest='verify_jobs',
        metavar='N',
        help='time-marching verifications run at once in background processes, '
        'beside the optimizations (default: the cores less one; 0: each in '
        'this process after its solve)',
    )
    p.set_defaults(func=commands.study)


def _coupling(sub: Any) -> None:
    p = sub.add_parser(
        'coupling',
        help='how much the coupling of the multibody modules '
        '(frame on the ground, as the paper, or on the '
        'chassis) moves the optimum: 4 designs x 3 models',
        epilog=EPILOG,
    )
    _common(p, mount=False)
    _run_options(p, 'results/coupling')
    p.set_defaults(func=commands.coupling)


def _optimize(sub: Any) -> None:
    p = sub.add_parser('optimize', help='optimize one model', epilog=EPILOG)
    p.add_argument('--fidelity', choices=('low', 'mixed'), required=True)
    _common(p)
    p.add_argument('--start', metavar='DESIGN', help='starting design (default: config)')
    p.add_argument(
        '--method',
        choices=('collocation', 'spectral'),
        default='collocation',
        help="collocation (default) or spectral: the stationary optimum on the study's "
        'ISO 8608 road (low fidelity; docs/spectral.md)',
    )
    _run_options(p, None)
    p.set_defaults(func=commands.optimize)


def _evaluate(sub: Any) -> None:
    p = sub.add_parser('evaluate', help='evaluate one design without optimizing', epilog=EPILOG)
    p.add_argument('--fidelity', choices=('low', 'mixed'), required=True)
    _common(p)
    p.add_argument('--design', metavar='DESIGN', help='design (default: config initial)')
    p.add_argument(
        '--method',
        choices=('collocation', 'time-marching', 'spectral'),
        default='collocation',
        help='collocation (default), time-marching, or spectral: the stationary RMS on the '
        "study's ISO 8608 road (low fidelity; docs/spectral.md)",
    )
    p.set_defaults(func=commands.evaluate)


def _pareto(sub: Any) -> None:
    p = sub.add_parser(
        'pareto',
        help='ride comfort against road holding: the Pareto front by weighted sums',
        epilog=EPILOG,
    )
    p.add_argument('--fidelity', choices=('low', 'mixed'), default='low')
    _common(p)
    p.add_argument(
        '--points',
        default='9',
        metavar='N',
        help='comfort shares 0 ... 1 (default: %(default)s)',
    )
    _run_options(p, 'results/pareto')
    p.set_defaults(func=commands.pareto)


def _compare(sub: Any) -> None:
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
    _common(p)
    _run_options(p, 'results/compare')
    p.set_defaults(func=commands.compare)


def _optima_study(sub: Any, name: str, summary: str, func: Callable[..., int]) -> None:
    """A study command of several optima in one model (``--fidelity``)."""
    p = sub.add_parser(name, help=summary, epilog=EPILOG)
    p.add_argument('--fidelity', choices=('low', 'mixed'), default='low')
    _common(p)
    _run_options(p, f'results/{name}')
    p.set_defaults(func=func)


def _robust(sub: Any) -> None:
    _optima_study(
        sub,
        'robust',
        "robust design over the study file's scenarios: the robust optimum against each "
        "scenario's own",
        commands.robust,
    )


def _codesign(sub: Any) -> None:
    _optima_study(
        sub,
        'codesign',
        "control co-design of the study file's [control]: the passive optimum, the "
        'open-loop bound and the feedback law, each verified',
        commands.codesign,
    )


def _sweep(sub: Any) -> None:
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
    p.add_argument('--workers', metavar='N', help='local worker processes (default: one per core)')
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
    p.set_defaults(func=commands.sweep)


def _kinematics(sub: Any) -> None:
    p = sub.add_parser(
        'kinematics',
        help='kinematic curves of a suspension mechanism: motion '
        'ratio, wheel rate, camber, track change, roll centre and its migration',
        epilog=EPILOG,
    )
    p.add_argument(
        'mechanism',
        nargs='?',
        help='built-in name (double_wishbone, sla_double_wishbone, '
        "macpherson) or path of a mechanism TOML (default with --study: the axle's)",
    )
    p.add_argument(
        '--study',
        metavar='FILE',
        help="a study file: the axle's mechanism, spring rate k_S and hardware curves "
        '(spring curve, bump and rebound stops: the wheel rate with them; '
        'docs/nonlinear_hardware.md)',
    )
    p.add_argument(
        '--axle',
        choices=('front', 'rear'),
        default='front',
        help='with --study: which axle (default: %(default)s)',
    )
    p.add_argument(
        '--centre-line',
        metavar='X',
        help="lateral position x [m] of the vehicle's centre line in the file's front "
        "view, for the roll centre (default: the file's [suspension] centre_line)",
    )
    p.add_argument(
        '--travel',
        metavar='MIN,MAX',
        help='wheel travel range [m], e.g. --travel=-0.08,0.1 (with "=": it starts '
        "with a minus) (default: the mechanism's)",
    )
    p.add_argument(
        '--k',
        metavar='N/m',
        help="spring rate for the wheel rate (default: the file's, or 30000)",
    )
    p.add_argument(
        '--points',
        default='21',
        metavar='N',
        help='travels in the range (default: %(default)s)',
    )
    p.add_argument(
        '--out',
        default='results/kinematics',
        metavar='DIR',
        help='directory of the figure and table (default: %(default)s)',
    )
    p.set_defaults(func=commands.kinematics)


def _init(sub: Any) -> None:
    p = sub.add_parser('init', help='write a default car as a commented study file')
    p.add_argument('file')
    p.add_argument(
        '--model',
        choices=('half_car', 'full_car'),
        default='half_car',
        help="the paper's half car (default) or the default full car",
    )
    p.add_argument('--overwrite', action='store_true')
    p.set_defaults(func=commands.init)


def _report(sub: Any) -> None:
    p = sub.add_parser(
        'report', help='re-render the table and figures of a run from its results directory'
    )
    p.add_argument('dir')
    p.set_defaults(func=commands.report)


#: every command, in the order of the help
COMMANDS: tuple[Callable[[Any], None], ...] = (
    _study,
    _coupling,
    _optimize,
    _evaluate,
    _pareto,
    _compare,
    _robust,
    _codesign,
    _sweep,
    _kinematics,
    _init,
    _report,
)


def build_parser() -> argparse.ArgumentParser:
    """The parser of every command."""
    parser = Parser(
        prog='suspopt',
        epilog=EPILOG,
        description='Mixed-fidelity suspension design optimization (half or full car + '
        'multibody suspension linkages; Dymos Radau collocation; IPOPT).',
    )
    sub = parser.add_subparsers(dest='command', required=True)
    for add in COMMANDS:
        add(sub)
    return parser
