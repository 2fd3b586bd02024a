"""How the reports write numbers, verdicts and headings (one place for all of them)."""

from __future__ import annotations

from suspopt.models.design import design_heading
from suspopt.models.objective import term_units
from suspopt.records.solve import SolveRecord, term_formula

FIDELITY_LABELS = {'low': 'low-fidelity', 'mixed': 'mixed-fidelity (multibody)'}


def fmt(x: float | None, digits: int = 4) -> str:
    return '—' if x is None else f'{x:.{digits}g}'


def obj(x: float | None) -> str:
    """An objective value (normalized: f = 1 at the reference), to four decimals."""
    return '—' if x is None else f'{x:.4f}'


def verdict(rec: SolveRecord | None) -> str:
    """How a result is to be read: verified, NOT verified, unchecked or failed."""
    if rec is None:
        return '—'
    if not rec.success:
        return 'NOT converged'
    return {True: 'verified', False: '**NOT verified**', None: 'not checked'}[rec.verified]


def design_columns(names: tuple[str, ...] | list[str]) -> str:
    """The design variables' column headings, ``k_S1 [N/m] | ...``."""
    return ' | '.join(design_heading(n) for n in names)


def term_columns(terms: tuple[str, ...] | list[str]) -> str:
    """The objective terms' column headings, ``J_heave [(m/s²)²·s] | ...``."""
    return ' | '.join(f'J_{t} [{term_units(t)}]' for t in terms)


def scales_line(
    terms: tuple[str, ...],
    scales: tuple[dict[str, float], ...],
    normalization: str,
    weights: dict[str, float],
) -> str:
    """The normalization and the objective, written out (the first scenario's scales)."""
    s = scales[0]
    return (
        f'Normalization: `{normalization}`, s = ('
        + ', '.join(f'{t} {s[t]:.6g}' for t in terms)
        + f'); f = {term_formula(terms, weights)}.'
    )


def constraint_table(res: SolveRecord) -> list[str]:
    """The engineering constraints of a result (``docs/metrics.md``, "Constraints"): each
    side's bound, its worst value by collocation and by time marching, the margin (the
    collocation's; negative: violated) and whether the design lies on it. Empty if the
    study has none."""
    rows = res.constraint_rows()
    if not rows:
        return []
    lines = [
        '| constraint | bound | collocation | time marching | margin | active | worst at |',
        '|---|---|---|---|---|---|---|',
    ]
    for v, k in rows:
        unit = f' {v.units}' if v.units else ''
        marched = '—' if k is None else fmt(k.value) + (' **violated**' if k.violated else '')
        lines.append(
            f'| `{v.name}` | {"≤" if v.upper else "≥"} {v.bound:g}{unit} | {fmt(v.value)} | '
            f'{marched} | {fmt(v.margin, 3)} | {"**active**" if v.active else "no"} | '
            f'{v.where or "—"} |'
        )
    active = [v.name for v, _ in rows if v.active]
    lines += [
        '',
        'Active constraints: ' + (', '.join(f'`{n}`' for n in active) if active else 'none') + '.',
    ]
    if res.infeasibility is not None:
        lines += ['', f'**Infeasible:** {res.infeasibility.describe()}.']
    return lines
