"""The table of a stationary (spectral) run (:class:`~suspopt.records.spectral.SpectralRecord`
in ``spectral.json``; ``docs/spectral.md``, section 9): the design, the objective and the
stationary RMS of every metric at the start and at the result, with the RMS limits."""

from __future__ import annotations

from pathlib import Path

from suspopt.models.metrics import METRICS, term_kind
from suspopt.output.format import design_columns, fmt
from suspopt.output.rundir import write_text
from suspopt.records.spectral import RmsLimit, SpectralRecord, SpectralScenario


def rms_units(term: str) -> str:
    """The units of a metric's RMS."""
    return METRICS[term_kind(term)].units


def _road(sc: SpectralScenario) -> str:
    r = sc.road
    tracks = f', {r.tracks} tracks {r.separation:g} m apart' if r.tracks != 'identical' else ''
    pade = (
        f'wheelbase delay by a Padé approximation of order {sc.pade_order} (estimated RMS '
        f'error {sc.pade_error:.1g})'
        if sc.pade_order
        else 'no wheelbase delay'
    )
    return (
        f'ISO 8608 class {r.road_class} (G_d(n0) = {r.displacement_psd_n0:.3g} m³) at '
        f'{r.speed:g} m/s{tracks}; {pade}'
    )


def _limit(lim: RmsLimit | None) -> str:
    if lim is None:
        return ''
    flag = ' **active**' if lim.active else ''
    return f'≤ {fmt(lim.rms_limit, 4)} ({lim.sigmas:g}σ ≤ {fmt(lim.bound, 4)}, `{lim.key}`){flag}'


def spectral_markdown(rec: SpectralRecord) -> str:
    """One spectral run as Markdown."""
    ok = rec.success
    names = list(rec.design)
    head = f'**Stationary (spectral) {rec.mode}** of the low-fidelity vehicle — ' + (
        'converged'
        if ok and rec.mode == 'optimize'
        else 'stationary response'
        if ok
        else 'NOT converged'
    )
    head += f' ({rec.status})'
    if rec.iterations is not None:
        head += f', {rec.iterations} IPOPT iterations'
    head += f', solve {fmt(rec.solve_time_s, 3)} s, total {fmt(rec.wall_time_s, 3)} s'
    lines = [head, '', f'| | {design_columns(names)} | f |', '|---|' + '---|' * (len(names) + 1)]
    rows = [('start', rec.start, rec.objective_start)] if rec.mode == 'optimize' else []
    label = 'optimum' if rec.mode == 'optimize' else 'design'
    rows.append((label if ok else 'stopped at (not a result)', rec.design, rec.objective))
    for name, design, f in rows:
        lines.append(
            f'| {name} | '
            + ' | '.join(f'{design[n]:.0f}' for n in names)
            + f' | {"—" if f is None else f"{f:.4f}"} |'
        )
    limits = {lim.term: lim for lim in rec.limits}
    for sc in rec.scenarios:
        title = f'Scenario `{sc.name}`: ' if len(rec.scenarios) > 1 else ''
        lines += ['', f'{title}{_road(sc)}.', '']
        cols = ['metric', 'units', 'weight']
        if sc.rms_start:
            cols.append('RMS at the start')
        cols.append('RMS' if rec.mode == 'evaluate' else 'RMS at the optimum')
        if limits:
            cols.append('limit')
        lines += ['| ' + ' | '.join(cols) + ' |', '|' + '---|' * len(cols)]
        terms = list(sc.rms or sc.rms_start)
        for t in terms:
            cells = [t, rms_units(t), fmt(rec.weights.get(t, 0.0), 3)]
            if sc.rms_start:
                cells.append(fmt(sc.rms_start[t], 5))
            cells.append(fmt(sc.rms[t], 5) if sc.rms is not None else '—')
            if limits:
                cells.append(_limit(limits.get(t)))
            lines.append('| ' + ' | '.join(cells) + ' |')
        if sc.not_stationary:
            lines += [
                '',
                f'Not stationary on this road (infinite variance): {", ".join(sc.not_stationary)}.',
            ]
    sc0 = rec.scenarios[0] if rec.scenarios else None
    if sc0 is not None:
        weighted = [t for t, w in rec.weights.items() if w and t in sc0.scales]
        lines += [
            '',
            f'{rec.formula()}; normalization `{rec.normalization}`, mean squares s = ('
            + ', '.join(f'{t} {fmt(sc0.scales[t], 6)}' for t in weighted)
            + ').',
        ]
    for w in rec.warnings:
        lines += ['', f'Warning: {w}']
    if rec.message and not ok:
        lines += ['', f'Message: {rec.message}']
    return '\n'.join(lines) + '\n'


def render_spectral(out: Path, rec: SpectralRecord) -> list[Path]:
    """Write ``table.md`` of a spectral run's directory."""
    write_text(out / 'table.md', spectral_markdown(rec))
    return [out / 'table.md']
