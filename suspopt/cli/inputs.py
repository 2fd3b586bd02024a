"""What the command line's arguments say: the study description with its overrides, a
design given on the command line, and the progress lines."""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable
from typing import TYPE_CHECKING

from suspopt.errors import ConfigError
from suspopt.spec.load import config_from_dict, load_config
from suspopt.spec.schema import StudyConfig

if TYPE_CHECKING:  # the driver imports OpenMDAO and IPOPT: not before the input is checked
    from suspopt.driver import IterationInfo


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


def study_config(args: argparse.Namespace) -> StudyConfig:
    """The study description: the file (or SPEC defaults), then command-line overrides."""
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
