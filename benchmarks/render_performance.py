"""Render ``docs/performance.md`` from the benchmarks' own result files.

Every benchmark script writes ``benchmarks/results/<name>.json`` (``_common.write_result``):
its tables, the date, the machine, the versions and the command. This script only
assembles them, so re-measuring a figure is running its benchmark, then this script;
nothing on the page is typed by hand.

    python benchmarks/render_performance.py
"""

from __future__ import annotations

import json
from pathlib import Path

HERE = Path(__file__).resolve().parent
PAGE = HERE.parent / 'docs' / 'performance.md'

INTRO = """# Performance

Every section below was written by the benchmark named in it, on the machine and date it
states; to re-measure, run the command shown, then `python benchmarks/render_performance.py`.
Timings on a shared 2-core machine vary from day to day: compare figures measured in one
run (the ratios), not across sections.
"""


def render(results_dir: Path = HERE / 'results') -> str:
    parts = [INTRO]
    for path in sorted(results_dir.glob('*.json')):
        rec = json.loads(path.read_text())
        if 'markdown' not in rec:  # a data file (e.g. codesign_reference.json), no section
            continue
        versions = ', '.join(f'{k} {v}' for k, v in rec.get('versions', {}).items())
        parts += [
            f'## {rec["title"]}',
            '',
            f'`{rec["command"]}` — {rec["date"]}, {rec["machine"]}; {versions}.',
            '',
            rec['markdown'].rstrip(),
            '',
        ]
    return '\n'.join(parts)


def main() -> None:
    PAGE.parent.mkdir(exist_ok=True)
    PAGE.write_text(render())
    print(f'wrote {PAGE}')


if __name__ == '__main__':
    main()
