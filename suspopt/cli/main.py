"""The ``suspopt`` command line: parse, run the command, map what went wrong to its exit
code (:mod:`suspopt.cli.exits`) with one line per problem on stderr.

    suspopt study     [--out DIR] [--config FILE] ...      the paper's two-step study
    suspopt optimize  --fidelity low|mixed [--start DESIGN] [--out DIR] ...
    suspopt evaluate  --fidelity low|mixed [--design DESIGN] [--method ...]
    suspopt pareto    [--fidelity low|mixed] [--points N] [--out DIR] ...   comfort vs road holding
    suspopt compare   [--mechanisms A,B,C] [--out DIR] ...  suspension topologies side by side
    suspopt coupling  [--out DIR] ...                       the coupling assumption, 4 x 3
    suspopt init [--model half_car|full_car] FILE         write a default car as a study file
    suspopt report DIR                                    re-render table and figures of a run
    suspopt kinematics MECHANISM | --study FILE [--axle A]  a linkage's K&C curves
    suspopt robust --config FILE [--fidelity ...]         robust design over the scenarios
    suspopt codesign --config FILE [--fidelity ...]       hardware and controller together
    suspopt sweep FILE --out DIR [--workers N | --scheduler ADDR]   many runs on Dask

A DESIGN is the design variables' values in order (``30000,30000,3000,3000`` for the half
car's k_S1, k_S2, c_S1, c_S2) or by name (``k_S1=30000,c_S2=2500``; the others keep their
configured values).
"""

from __future__ import annotations

import os
import sqlite3
import sys

from suspopt import interrupts
from suspopt.cli.exits import INTERRUPTED, exit_code
from suspopt.cli.inputs import check_arguments
from suspopt.cli.parser import build_parser
from suspopt.errors import ConfigError, SuspoptError


def main(argv: list[str] | None = None) -> int:
    """Run the command line with ``argv`` (default: ``sys.argv``); its exit code."""
    _printable_output()
    try:
        args = check_arguments(build_parser().parse_args(argv))
    except ConfigError as err:  # the command line itself: before anything else
        for line in error_lines(err):
            print(f'suspopt: error: {line}', file=sys.stderr)
        return exit_code(err)
    if getattr(args, 'command', None) == 'optimize' and not args.out:
        args.out = f'results/optimize-{args.fidelity}'
    from suspopt.quiet import quiet_libraries

    quiet_libraries()  # OpenMDAO's and Dymos' warnings about their internals
    try:
        with interrupts.handling():  # SIGINT and SIGTERM alike (suspopt.interrupts)
            return int(args.func(args))
    except KeyboardInterrupt:
        print('suspopt: interrupted; results written so far are kept', file=sys.stderr)
        return INTERRUPTED
    except Exception as err:
        expected = (SuspoptError, MemoryError, OSError, sqlite3.OperationalError)
        if not isinstance(err, expected) and os.environ.get('SUSPOPT_DEBUG'):
            raise
        for line in error_lines(err):
            print(f'suspopt: error: {line}', file=sys.stderr)
        return exit_code(err)


def error_lines(err: BaseException) -> list[str]:
    """What the user is told of an error: bad input one line per problem, the environment
    its cause, a bug that it is one."""
    if isinstance(err, ConfigError):
        return list(err.problems)
    if isinstance(err, SuspoptError):
        return [str(err)]
    if isinstance(err, MemoryError):
        return ['out of memory (a smaller grid or horizon, or fewer scenarios)']
    if isinstance(err, OSError):  # the environment, not suspopt
        return [f'{err.strerror or err}: {err.filename or ""}'.rstrip(': ')]
    if isinstance(err, sqlite3.OperationalError):
        return [f'cannot write a case recorder (*.sql in the output directory): {err}']
    return [
        f'unexpected {type(err).__name__}: {err} (this is a bug in suspopt; '
        'SUSPOPT_DEBUG=1 shows the traceback)'
    ]


def _printable_output() -> None:
    """Paths given as bytes that are not UTF-8 (Python keeps them as surrogate escapes)
    are printed escaped, never an encoding error at the end of a run."""
    for stream in (sys.stdout, sys.stderr):
        reconfigure = getattr(stream, 'reconfigure', None)
        if reconfigure is not None:
            try:
                reconfigure(errors='backslashreplace')
            except (ValueError, OSError):  # pragma: no cover - a closed or odd stream
                pass


if __name__ == '__main__':
    sys.exit(main())
