"""How the reports write numbers, verdicts and headings (one place for all of them)."""

from __future__ import annotations

from typing import Any

from suspopt.models.design import design_heading
from suspopt.models.objective import term_units
from suspopt.records.solve import SolveRecord, term_formula
from suspopt.spec.resolve import unique_names

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


def scenario_labels(config: dict[str, Any] | None, n: int) -> list[tuple[str, float]]:
    """(name, weight) of each of the ``n`` scenarios of a study description (plain data,
    as a record keeps it), named as the study resolves them
    (:func:`suspopt.spec.resolve.unique_names`)."""
    given = (config or {}).get('scenario') or []
    if not isinstance(given, list) or len(given) != n:
        return [('main', 1.0)] if n == 1 else [(f's{i}', 1.0) for i in range(n)]
    names = unique_names([str(sc.get('name') or '') for sc in given])
    return [(name, float(sc.get('weight', 1.0))) for name, sc in zip(names, given)]


def aggregate_formula(scenarios: list[tuple[str, float]], aggregate: str) -> str:
    """How the scenarios' ``f_s`` combine into ``f``, written out."""
    if aggregate == 'max':
        return 'max(' + ', '.join(f'f_{n}' for n, _ in scenarios) + ')'
    return ' + '.join(f'{w:g} f_{n}' for n, w in scenarios)


def scales_line(
    terms: tuple[str, ...],
    scales: tuple[dict[str, float], ...],
    normalization: str,
    weights: dict[str, float],
    scenarios: list[tuple[str, float]] | None = None,
    aggregate: str = 'sum',
) -> str:
    """The normalization and the objective, written out: with one scenario its scales
    and ``f``; with several, ``f`` as their aggregate and every scenario's scales (one
    Markdown line each). ``scenarios``: (name, weight) of each (default: by index)."""
    f_s = term_formula(terms, weights)
    if len(scales) == 1:
        s = scales[0]
        return (
            f'Normalization: `{normalization}`, s = ('
            + ', '.join(f'{t} {s[t]:.6g}' for t in terms)
            + f'); f = {f_s}.'
        )
    named = scenarios or [(f's{i}', 1.0) for i in range(len(scales))]
    lines = [
        f'Normalization: `{normalization}`, each scenario by its own scales s_k; '
        f'f = {aggregate_formula(named, aggregate)}, each f_s = {f_s} with its own s_k:',
        '',
    ]
    for (name, w), s in zip(named, scales):
        weight = '' if aggregate == 'max' else f' (w = {w:g})'
        lines.append(f'- {name}{weight}: s = (' + ', '.join(f'{t} {s[t]:.6g}' for t in terms) + ')')
    return '\n'.join(lines)


def study_scales_line(
    config: dict[str, Any] | None,
    terms: tuple[str, ...],
    scales: tuple[dict[str, float], ...],
    normalization: str,
    weights: dict[str, float],
) -> str:
    """:func:`scales_line` of a study record (its scenarios from its study description)."""
    objective = (config or {}).get('objective') or {}
    aggregate = objective.get('aggregate', 'sum') if isinstance(objective, dict) else 'sum'
    return scales_line(
        terms, scales, normalization, weights, scenario_labels(config, len(scales)), aggregate
    )


def record_scales_line(rec: SolveRecord) -> str:
    """:func:`scales_line` of one solve record (its scenarios' names, weights, scales)."""
    sc = rec.scenarios
    terms = tuple(sc[0].scales) if sc else ()
    return scales_line(
        terms,
        tuple(s.scales for s in sc),
        rec.normalization,
        rec.weights,
        [(s.name, s.weight) for s in sc],
        rec.aggregate,
    )


def scenario_terms(rec: SolveRecord | None) -> list[tuple[str, dict[str, float] | None]]:
    """(scenario name, its J_k) of every scenario of a record (J None unless a result;
    a record of one scenario: one row named '')."""
    if rec is None:
        return [('', None)]
    if len(rec.scenarios) <= 1:
        return [('', rec.terms)]
    return [(s.name, s.terms) for s in rec.scenarios]


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
        marched = '—' if k is None else fmt(k.value) + (' **violated**' if k.exceeded else '')
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
