"""Tables and figures of a run, rendered from its results directory (``suspopt report DIR``).

It reads the directory's ``manifest.json`` (the kind of run and the format of its
records), then the run's typed record (:mod:`suspopt.records`), validated, and renders it
with the renderer of that kind. It reads only what the run wrote: the record, the SQLite
case recorders (the trajectories of every design in each model), ``time_marching.npz``
and the study description inside the record (the road as used, with copies of its files
under ``inputs/``); never the user's original files.

A damaged or incomplete directory — a file the user can have broken — is a one-line
:class:`~suspopt.errors.ConfigError` naming the file and the key. Anything else that goes
wrong while rendering is a bug of suspopt, and is not disguised as damaged input. What did
not converge is shown as such, never with a value as a result; trajectories are drawn
only of converged results. It writes ``table.md`` and ``figures/*.png``.
"""

from __future__ import annotations

from pathlib import Path

from suspopt import interrupts
from suspopt.output.rundir import read_manifest, read_record
from suspopt.records.codesign import CodesignStudy
from suspopt.records.compare import CompareStudy
from suspopt.records.coupling import CouplingStudy
from suspopt.records.pareto import ParetoFront
from suspopt.records.robust import RobustStudy
from suspopt.records.solve import SolveRecord
from suspopt.records.spectral import SpectralRecord
from suspopt.records.twostep import TwoStepStudy


def render(out_dir: str | Path) -> list[Path]:
    """Write ``table.md`` and the figures of a run directory of any kind, possibly
    partial (the kind from its manifest). A damaged or incomplete one is a ConfigError."""
    out = Path(out_dir)
    interrupts.stage('render')
    manifest = read_manifest(out)
    record = read_record(out)
    file = str(out / manifest.record)
    match record:
        case TwoStepStudy():
            from suspopt.output.study_report import render_study

            return render_study(out, record, file)
        case SolveRecord():
            from suspopt.output.solve_report import render_run

            return render_run(out, record, file)
        case ParetoFront():
            from suspopt.output.pareto_report import render_pareto

            return render_pareto(out, record)
        case RobustStudy():
            from suspopt.output.robust_report import render_robust

            return render_robust(out, record)
        case CouplingStudy():
            from suspopt.output.coupling_report import render_coupling

            return render_coupling(out, record)
        case CompareStudy():
            from suspopt.output.compare_report import render_compare

            return render_compare(out, record, file)
        case SpectralRecord():
            from suspopt.output.spectral_report import render_spectral

            return render_spectral(out, record)
        case CodesignStudy():
            from suspopt.output.codesign_report import render_codesign

            return render_codesign(out, record)
    raise AssertionError(f'no renderer of a {manifest.kind} run')  # a bug: DOCUMENTS grew
