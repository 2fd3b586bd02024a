"""What the command line's arguments say: every value checked by the one input layer
(:mod:`suspopt.inputs`, :func:`check_arguments`), the study description with its
overrides, a design given on the command line, and the progress lines."""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from suspopt.errors import ConfigError
from suspopt.inputs import (
    MAX_INT,
    integer,
    items,
    number,
    path_value,
    scheduler_address,
    text_value,
)
from suspopt.spec.load import config_from_dict, load_config
from suspopt.spec.schema import StudyConfig

if TYPE_CHECKING:  # the driver imports OpenMDAO and IPOPT: not before the input is checked
    from suspopt.driver import IterationInfo


#: Radau points per segment the command line accepts (the study file's own check follows)
MAX_ORDER = 50
#: Pareto points (each an optimization) and kinematic travels the command line accepts
MAX_PARETO_POINTS, MAX_TRAVELS = 1000, 100_000
#: local worker processes and background verification processes
MAX_PROCESSES = 1024
#: wheel travel [m] a kinematic range may span, each way (a suspension travel)
MAX_TRAVEL = 1.0


def _count(lo: int, hi: int, what: str) -> Callable[[str, str], int]:
    return lambda text, flag: integer(text, flag, lo, hi, what)


def _segments(text: str, flag: str) -> str | int:
    t = text_value(text, flag)
    return 'auto' if t == 'auto' else integer(t, flag, 1, MAX_INT, 'segments, or "auto"')


def _travel(text: str, flag: str) -> tuple[float, float]:
    parts = items(text, flag, 'MIN,MAX [m]')
    if len(parts) != 2:
        raise ConfigError(f'{flag}: expected MIN,MAX [m] with MIN < MAX, got {text!r}')
    lo, hi = (number(p, flag, -MAX_TRAVEL, MAX_TRAVEL, unit='m') for p in parts)
    if not lo < hi:
        raise ConfigError(f'{flag}: expected MIN,MAX [m] with MIN < MAX, got {text!r}')
    return lo, hi


def _mechanisms(text: str, flag: str) -> list[str]:
    out = items(text, flag, 'a comma-separated list of mechanisms, FRONT+REAR for one per axle')
    for entry in out:
        items(entry, flag, 'FRONT+REAR', sep='+')
    return out


def _spring_rate(text: str, flag: str) -> float:
    return number(text, flag, 0.0, 1e7, positive=True, unit='N/m', what='the spring rate')


def _centre_line(text: str, flag: str) -> float:
    return number(text, flag, -10.0, 10.0, unit='m')


def _points(text: str, flag: str, command: str) -> int:
    hi = MAX_PARETO_POINTS if command == 'pareto' else MAX_TRAVELS
    what = 'comfort shares' if command == 'pareto' else 'travels'
    return integer(text, flag, 2, hi, what)


#: every value the command line takes, by its ``dest``: (how it is named, its check)
ARGUMENTS: dict[str, tuple[str, Callable[[str, str], Any]]] = {
    'config': ('--config', path_value),
    'out': ('--out', path_value),
    'dir': ('DIR', path_value),
    'file': ('FILE', path_value),
    'mechanism': ('MECHANISM', text_value),
    'mechanisms': ('--mechanisms', _mechanisms),
    'segments': ('--segments', _segments),
    'order': ('--order', _count(2, MAX_ORDER, 'Radau points per segment')),
    'max_iter': ('--max-iter', _count(1, MAX_INT, 'IPOPT iterations')),
    'verify_jobs': ('--verify-jobs', _count(0, MAX_PROCESSES, 'background processes')),
    'workers': ('--workers', _count(1, MAX_PROCESSES, 'worker processes')),
    'scheduler': ('--scheduler', scheduler_address),
    'k': ('--k', _spring_rate),
    'travel': ('--travel', _travel),
    'centre_line': ('--centre-line', _centre_line),
    'study': ('--study', path_value),
    'start': ('--start', text_value),
    'design': ('--design', text_value),
}
#: values argparse itself checks (a choice among a few words) or flags without a value
CHOICES_AND_FLAGS = frozenset(
    {
        'command',
        'func',
        'fidelity',
        'mount',
        'normalization',
        'method',
        'model',
        'axle',
        'worker_start',
        'overwrite',
        'quiet',
        'no_verify',
        'retry_failed',
    }
)


def check_arguments(args: argparse.Namespace) -> argparse.Namespace:
    """Every value of the command line through its check (:data:`ARGUMENTS`), replaced by
    its parsed value: an empty or whitespace value, a sign or a magnitude a count cannot
    take, a malformed number, path or address is one line naming the option (exit 2)."""
    for dest, value in vars(args).items():
        if value is None or dest in CHOICES_AND_FLAGS:
            continue
        if dest == 'points':
            args.points = _points(value, '--points', args.command)
            continue
        if dest not in ARGUMENTS:  # a new option: tests/cli/test_input_layer.py asks for it
            continue
        flag, parse = ARGUMENTS[dest]
        setattr(args, dest, parse(value, flag))
    return args


def parse_design(text: str, flag: str, config: StudyConfig) -> dict[str, float]:
    """A design from ``--start``/``--design``: values in the design order, or name=value
    pairs (the rest from the configuration); checked finite, positive and in the bounds."""
    names = config.design_names()
    parts = items(text, flag, 'numbers in the design order, or name=value pairs')
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


def study_config(args: argparse.Namespace) -> StudyConfig:
    """The study description: the file (or the paper's defaults), then command-line overrides."""
    cfg = load_config(args.config) if args.config else StudyConfig()
    data = cfg.to_dict()
    if cfg.vehicle.model == 'quarter_car':  # keys the round trip writes and a quarter car refuses
        data['vehicle'].pop('rear', None)
        data['vehicle'].pop('chassis_pitch_inertia', None)
    if getattr(args, 'normalization', None):
        data['objective']['normalization'] = args.normalization
        if args.normalization != 'custom':
            data['objective']['scales'] = {}
    if getattr(args, 'segments', None) is not None:
        data['transcription']['segments'] = args.segments
    if getattr(args, 'order', None) is not None:
        data['transcription']['order'] = args.order
    if getattr(args, 'max_iter', None) is not None:
        data['optimizer']['max_iter'] = args.max_iter
    if getattr(args, 'mount', None):
        data['multibody']['mount'] = args.mount
    return config_from_dict(data)


def start_design(args: argparse.Namespace, config: StudyConfig) -> dict[str, float] | None:
    """``--start``: where IPOPT starts, inside the bounds. Only the free variables move:
    a variable with ``optimize = false`` keeps its configured value (it is not optimized).
    It is not the study's initial design, which also defines the ``reference``
    normalization (``docs/model.md``, "Objective"): an optimization from another start
    minimizes the same f."""
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


class Printer:
    """Progress lines on stderr: one per IPOPT iteration (under a header, repeated after
    every log line) and the steps of a study; ``quiet``: none."""

    def __init__(self, quiet: bool, names: tuple[str, ...]):
        self.quiet, self.names = quiet, names
        self.header = False

    @property
    def progress(self) -> Callable[[IterationInfo], None] | None:
        return None if self.quiet else self.iteration

    def iteration(self, info: IterationInfo) -> None:
        if not self.header:
            print(
                f'{"iter":>5} {"objective":>12} {"constr.viol":>11} {"elapsed":>8}  '
                + '  '.join(f'{n:>8}' for n in self.names),
                file=sys.stderr,
            )
            self.header = True
        d = {k.rsplit(':', 1)[-1]: v for k, v in info.design.items()}
        vals = '  '.join(f'{d[n]:8.1f}' for n in self.names if n in d)
        print(
            f'{info.iteration:5d} {info.objective:12.6f} {info.constraint_violation:11.2e} '
            f'{info.elapsed_s:7.1f}s  {vals}',
            file=sys.stderr,
            flush=True,
        )

    def log(self, msg: str) -> None:
        if self.quiet:
            return
        self.header = False
        print(f'[suspopt] {msg}', file=sys.stderr, flush=True)
