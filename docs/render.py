"""Render the results shown in the README and in ``docs/results.md`` from runs' own output.

Each section is a results directory written by a suspopt command (its ``table.md`` and
``figures/``); this script only copies them in, so a number on those pages is re-measured
by running the command again, then this script — never by a hand edit::

    python docs/render.py --run          # run every command below into results/, then render
    python docs/render.py                # render from the results/ directories already there

A section whose directory is missing is left as it was.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / 'results'
FIGURES = ROOT / 'docs' / 'figures'

#: (name, the command that writes results/<name>, title, figures to show, the pages it goes
#: to: each has a marker pair ``<!-- results:<name> -->`` ... ``<!-- /results:<name> -->``)
SECTIONS = (
    (
        'study',
        ['study', '--out', 'results/study', '--overwrite', '--quiet'],
        "The paper's two-step study (half car, two bumps at 10 m/s)",
        ('optima.png',),
        ('README.md', 'docs/results.md'),
    ),
    (
        'full_car',
        [
            'study',
            '--config',
            'results/full_car.toml',
            '--out',
            'results/full_car',
            '--overwrite',
            '--quiet',
        ],
        'The default full car (BMW E90) as an engineering study',
        ('optima.png', 'road.png'),
        ('README.md', 'docs/results.md'),
    ),
    (
        'robust',
        [
            'robust',
            '--config',
            'examples/robust.toml',
            '--out',
            'results/robust',
            '--overwrite',
            '--quiet',
        ],
        'Robust design over four load cases',
        ('robustness.png',),
        ('docs/results.md',),
    ),
    (
        'coupling',
        ['coupling', '--out', 'results/coupling', '--overwrite', '--quiet'],
        'The coupling of the linkage: on the ground (the paper) or on the chassis',
        ('coupling.png',),
        ('docs/results.md',),
    ),
    (
        'compare',
        ['compare', '--out', 'results/compare', '--overwrite', '--quiet'],
        'Suspension topologies side by side',
        ('cross.png', 'kinematics.png'),
        ('docs/results.md',),
    ),
    (
        'pareto',
        ['pareto', '--out', 'results/pareto', '--overwrite', '--quiet'],
        'Ride comfort against road holding (Pareto front, low fidelity)',
        ('pareto.png',),
        ('docs/results.md',),
    ),
    (
        'pareto_mixed',
        [
            'pareto',
            '--fidelity',
            'mixed',
            '--out',
            'results/pareto_mixed',
            '--overwrite',
            '--quiet',
        ],
        'Ride comfort against road holding (Pareto front, multibody model)',
        ('pareto.png',),
        ('docs/results.md',),
    ),
    (
        'kinematics_double_wishbone',
        ['kinematics', 'double_wishbone', '--out', 'results/kinematics_double_wishbone'],
        'Kinematic curves of the built-in double wishbone (roll centre and its migration)',
        ('kinematics_double_wishbone.png',),
        ('docs/results.md',),
    ),
    (
        'kinematics_sla_double_wishbone',
        ['kinematics', 'sla_double_wishbone', '--out', 'results/kinematics_sla_double_wishbone'],
        'Kinematic curves of the built-in sla double wishbone (roll centre and its migration)',
        ('kinematics_sla_double_wishbone.png',),
        ('docs/results.md',),
    ),
    (
        'kinematics_macpherson',
        ['kinematics', 'macpherson', '--out', 'results/kinematics_macpherson'],
        'Kinematic curves of the built-in macpherson (roll centre and its migration)',
        ('kinematics_macpherson.png',),
        ('docs/results.md',),
    ),
    (
        'multistart',
        # a rerun resumes the sweep (finished tasks kept): no --overwrite
        ['sweep', 'examples/multistart.toml', '--out', 'results/multistart', '--quiet'],
        'Multistart: 16 starting designs in both models',
        ('start.png',),
        ('docs/results.md',),
    ),
)


#: (benchmark result, figures under docs/figures it writes, pages): its section rendered
#: from ``benchmarks/results/<name>.json`` (``benchmarks/_common.write_result``) between
#: ``<!-- benchmark:NAME -->`` markers; re-measured by the command the file names
BENCHMARKS = (
    ('quarter_car_closed_form', (), ('README.md',)),
    ('spectral_time_domain', ('spectral_time_domain.png',), ('README.md',)),
    ('nonlinear_damper', ('nonlinear_damper.png',), ('README.md',)),
    ('codesign_benchmark', (), ('README.md',)),
    ('codesign_compare_low', ('codesign_half_car_low.png',), ('README.md',)),
)


def benchmark_section(name: str, figures: tuple[str, ...], page: str) -> str | None:
    """The Markdown of a benchmark's result file for ``page``, or None without one."""
    path = ROOT / 'benchmarks' / 'results' / f'{name}.json'
    if not path.is_file():
        return None
    rec = json.loads(path.read_text())
    if 'markdown' not in rec:
        return None
    where = 'docs/figures' if page == 'README.md' else 'figures'
    text = rec['markdown'].strip()
    if page == 'README.md':
        text = compact(text, 'docs/performance.md')
    lines = [
        *([] if text.startswith('#') else [f'### {rec["title"]}', '']),
        text,
        '',
        f'Measured by `{rec["command"]}` ({rec["date"][:10]}, {rec["machine"]}).',
        '',
    ]
    for fig in figures:
        if (FIGURES / fig).is_file():
            lines += [f'![{fig[:-4]}]({where}/{fig})', '']
    return '\n'.join(lines)


def run(names: set[str] | None) -> None:
    """Run the commands of the sections (all, or ``names``) into ``results/``."""
    RESULTS.mkdir(exist_ok=True)
    init = ['init', '--model', 'full_car', 'results/full_car.toml', '--overwrite']
    subprocess.run([sys.executable, '-m', 'suspopt.cli', *init], cwd=ROOT, check=True)
    for name, command, *_ in SECTIONS:
        if names is None or name in names:
            print(f'running suspopt {" ".join(command)}', flush=True)
            subprocess.run([sys.executable, '-m', 'suspopt.cli', *command], cwd=ROOT, check=False)


def section(name: str, title: str, figures: tuple[str, ...], page: str) -> str | None:
    """The Markdown of one section from ``results/<name>`` for ``page`` (a level-3 heading
    and the table; the figures copied to docs/figures/, linked relative to the page)."""
    directory = RESULTS / name
    table = directory / 'table.md'
    if not table.is_file():  # a command writing its table under its own name (kinematics)
        table = directory / f'{name}.md'
    if not table.is_file():
        return None
    FIGURES.mkdir(parents=True, exist_ok=True)
    body = table.read_text().strip()
    lines = [
        f'### {title}',
        '',
        compact(body, 'docs/results.md') if page == 'README.md' else body,
        '',
    ]
    where = 'docs/figures' if page == 'README.md' else 'figures'
    for fig in figures:
        src = directory / 'figures' / fig
        if not src.is_file():
            src = directory / fig
        if src.is_file():
            dst = FIGURES / f'{name}_{fig}'
            shutil.copyfile(src, dst)
            lines += [f'![{name} {fig[:-4]}]({where}/{dst.name})', '']
    return '\n'.join(lines)


def compact(text: str, where: str, blocks: int = 2) -> str:
    """The README's cut of a table: its lead and its first ``blocks`` bold-titled parts
    (the full table is on docs/results.md or in the results directory)."""
    lines, out, seen = text.splitlines(), [], 0
    for line in lines:
        if line.startswith('**') and not line.startswith('**Infeasible'):
            seen += 1
            if seen > blocks:
                out += ['', f'(The rest: [{where}]({where}).)']
                break
        out.append(line)
    return '\n'.join(out)


def replace_between(text: str, name: str, body: str, kind: str = 'results') -> str:
    begin, end = f'<!-- {kind}:{name} -->', f'<!-- /{kind}:{name} -->'
    if begin not in text or end not in text:
        raise SystemExit(f'no markers {begin} ... {end}')
    head, rest = text.split(begin, 1)
    _, tail = rest.split(end, 1)
    return f'{head}{begin}\n{body}\n{end}{tail}'


def render() -> None:
    for name, _, title, figures, pages in SECTIONS:
        for page in pages:
            path = ROOT / page
            body = section(name, title, figures, page)
            if body is None:
                print(f'{name}: no results/{name}/table.md, section left as it was')
                break
            path.write_text(replace_between(path.read_text(), name, body))
            print(f'{name}: rendered into {page}')
    for name, figures, pages in BENCHMARKS:
        for page in pages:
            path = ROOT / page
            body = benchmark_section(name, figures, page)
            if body is None:
                print(f'{name}: no benchmarks/results/{name}.json, section left as it was')
                break
            path.write_text(replace_between(path.read_text(), name, body, 'benchmark'))
            print(f'{name}: rendered into {page}')


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--run', action='store_true', help='run the commands first')
    parser.add_argument('--only', nargs='*', help='section names (default: all)')
    args = parser.parse_args()
    if args.run:
        run(set(args.only) if args.only else None)
    render()


if __name__ == '__main__':
    main()
