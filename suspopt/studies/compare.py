"""The topology study (issue 12): the same car with different suspension linkages.

The paper argues for a multibody suspension because a mass-spring-damper "will not
capture the behavioural differences between different types of suspension designs, e.g.,
a double-wishbone design vs. a MacPherson design". :func:`run_compare` measures it:

1. the low-fidelity model (half or full car, no linkage) optimized once from the initial
   design;
2. for every *topology* (a mechanism on both axles, or ``FRONT+REAR``), the
   mixed-fidelity model optimized from that low-fidelity optimum;
3. the cross table: every design (the initial design, the low-fidelity optimum and every
   topology's optimum) evaluated by collocation in every model (the low-fidelity model
   and every topology), each cell verified by time marching;
4. the kinematic curves of every mechanism (:mod:`suspopt.multibody.kinematics`) on a
   common wheel-travel range.

Everything goes to a results directory as it goes: ``compare.json`` (atomic, after every
step and cell), the case recorders ``low.sql`` and ``mixed_<topology>.sql`` (the
trajectory of every cell, as case ``<design key>``), and at the end ``table.md`` and
``figures/`` (:mod:`suspopt.compare_report`; ``suspopt report DIR`` re-renders them from
the directory alone). A failed optimization or cell is kept with ``success: false`` and
the study goes on with the others; only a failed low-fidelity step stops it (every
topology starts from its optimum).

Design keys: ``initial``, ``low_optimum`` and ``optimum:<topology>``; model keys: ``low``
and ``mixed:<topology>``; a cell is ``cells["<design>|<model>"]``.
"""

from __future__ import annotations

import re
import shutil
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from suspopt.errors import ConfigError, ModelError, RunError
from suspopt.output.rundir import RunDirectory, write_json
from suspopt.spec.load import config_from_dict
from suspopt.spec.schema import StudyConfig
from suspopt.studies.run import Interrupted, Progress, StepFailed, evaluate, optimize
from suspopt.transcription.problem import VehicleProblem
from suspopt.verification.scales import resolve_scales
from suspopt.verification.verify import VERIFY_TOLERANCE, verified

#: the shipped topologies, in the order the paper names them (and the SLA variation)
DEFAULT_MECHANISMS = ('double_wishbone', 'sla_double_wishbone', 'macpherson')
LOW = 'low'
#: points of the kinematic curves
KINEMATIC_POINTS = 41


def design_key(topology: str) -> str:
    return f'optimum:{topology}'


def model_key(topology: str) -> str:
    return f'mixed:{topology}'


def cell_key(design: str, model: str) -> str:
    return f'{design}|{model}'


def _safe(label: str) -> str:
    return re.sub(r'[^A-Za-z0-9_.+-]', '_', label)


def parse_topologies(text: str | list[str] | tuple[str, ...]) -> list[tuple[str, str]]:
    """``"a,b,c"`` (or a list) → [(front, rear)]: each entry one mechanism for both axles
    or ``FRONT+REAR``; a built-in name or a mechanism TOML path. Refuses empty entries and
    duplicates (ConfigError naming ``--mechanisms``)."""
    from suspopt.multibody.mechanism import builtin_mechanisms

    items = [s.strip() for s in (text.split(',') if isinstance(text, str) else text)]
    if not items or any(not s for s in items):
        raise ConfigError(
            f'--mechanisms: expected a comma-separated list of mechanisms '
            f'(built-in: {", ".join(builtin_mechanisms())}, or TOML paths; '
            f'FRONT+REAR for one per axle), got {text!r}'
        )
    out = []
    for s in items:
        parts = [p.strip() for p in s.split('+')]
        if len(parts) > 2 or any(not p for p in parts):
            raise ConfigError(f'--mechanisms: {s!r}: one mechanism, or FRONT+REAR')
        front, rear = parts if len(parts) == 2 else (parts[0], parts[0])
        fix = lambda p: p if p in builtin_mechanisms() else str(Path(p).resolve())  # noqa: E731
        out.append((fix(front), fix(rear)))
    if len(set(out)) != len(out):
        raise ConfigError(f'--mechanisms: a topology is listed twice in {text!r}')
    return out


def mechanism_label(mechanism: str) -> str:
    """A built-in name as it is; a file by its stem."""
    from suspopt.multibody.mechanism import builtin_mechanisms

    return mechanism if mechanism in builtin_mechanisms() else Path(mechanism).stem


def topology_labels(topologies: list[tuple[str, str]]) -> list[str]:
    """Unique, file-name-safe labels: ``macpherson``, ``macpherson+double_wishbone``."""
    labels, seen = [], set()
    for front, rear in topologies:
        lab = (
            mechanism_label(front)
            if front == rear
            else f'{mechanism_label(front)}+{mechanism_label(rear)}'
        )
        lab = _safe(lab)
        base, i = lab, 2
        while lab in seen:
            lab, i = f'{base}-{i}', i + 1
        seen.add(lab)
        labels.append(lab)
    return labels


def topology_config(
    config: StudyConfig, front: str, rear: str, where: str = '--mechanisms'
) -> StudyConfig:
    """``config`` with ``front``/``rear`` as the axles' mechanisms (validated: a bad
    mechanism is a ConfigError naming ``where``)."""
    d = config.to_dict()
    d['vehicle']['front']['mechanism'] = front
    d['vehicle']['rear']['mechanism'] = rear
    try:
        return config_from_dict(d)
    except ConfigError as err:
        raise ConfigError([f'{where}: {p}' for p in err.problems]) from None


def common_travel(mechanisms: list) -> tuple[float, float]:
    """The wheel-travel range every mechanism passes (the intersection of theirs)."""
    lo = max(m.travel[0] for m in mechanisms)
    hi = min(m.travel[1] for m in mechanisms)
    if not lo < hi:
        raise ConfigError(
            '--mechanisms: the mechanisms share no wheel-travel range '
            f'({", ".join(f"{m.name}: {m.travel}" for m in mechanisms)})'
        )
    return lo, hi


def kinematics_record(mechanisms: dict[str, str], spring_rate: float) -> dict[str, Any]:
    """Kinematic curves of every mechanism (label → file) on the common travel range, as
    plain lists, with the reference-pose values (travel 0) picked out."""
    from suspopt.multibody.kinematics import kinematic_curves
    from suspopt.multibody.mechanism import load_mechanism

    mechs = {lab: load_mechanism(src, suspension=True) for lab, src in mechanisms.items()}
    travel = common_travel(list(mechs.values()))
    out: dict[str, Any] = {
        'travel_range': list(travel),
        'spring_rate': spring_rate,
        'points': KINEMATIC_POINTS,
        'curves': {},
    }
    for lab, mech in mechs.items():
        c = kinematic_curves(mech, travel, spring_rate, KINEMATIC_POINTS)
        curves = {
            k: (np.asarray(v).tolist() if isinstance(v, np.ndarray) else v) for k, v in c.items()
        }
        w = np.asarray(c['travel'])
        curves['at_reference'] = {
            k: float(np.interp(0.0, w, c[k])) for k in ('motion_ratio', 'wheel_rate')
        }
        curves['moving_mass_kg'] = float(sum(b.mass for b in mech.bodies if not b.fixed))
        out['curves'][lab] = curves
    return out


def _copy_mechanisms(out: Path, topologies: list[tuple[str, str]]) -> dict[str, str]:
    """Copy every mechanism file (not the built-in ones) into ``inputs/``: file → its copy
    relative to ``out`` (``inputs/mechanism_<i>_<name>``; a built-in name maps to itself)."""
    from suspopt.multibody.mechanism import builtin_mechanisms

    copies: dict[str, str] = {}
    for src in dict.fromkeys(m for t in topologies for m in t):
        if src in builtin_mechanisms():
            copies[src] = src
            continue
        dst = out / 'inputs' / f'mechanism_{len(copies)}_{Path(src).name}'
        try:
            dst.parent.mkdir(exist_ok=True)
            shutil.copyfile(src, dst)
        except OSError as err:
            raise RunError(f'cannot copy {src} into {dst.parent}: {err.strerror}') from None
        copies[src] = f'inputs/{dst.name}'
    return copies


def _strip(record: dict[str, Any]) -> dict[str, Any]:
    """A cell's record without the per-iteration history (kept for the optimizations)."""
    v = record.get('verification') or {}
    v.pop('trajectories', None)
    if record.get('mode') == 'evaluate':
        record.pop('history', None)
    return record


def _failed_record(
    fid: str, mode: str, design: dict[str, float], err: Exception, config: StudyConfig
) -> dict[str, Any]:
    return {
        'fidelity': fid,
        'mode': mode,
        'method': 'collocation',
        'design': design,
        'start': design,
        'objective': None,
        'terms': None,
        'success': False,
        'status': 'Model_Error',
        'message': str(err),
        'iterations': 0,
        'verified': None,
        'verification': {'verified': None, 'note': 'not verified: the model failed'},
        'normalization': config.objective.normalization,
    }


def run_compare(
    config: StudyConfig,
    out_dir: str | Path | RunDirectory,
    mechanisms: str | list[str] | tuple[str, ...] = DEFAULT_MECHANISMS,
    *,
    progress: Progress | None = None,
    log: Callable[[str], None] | None = None,
    verify: bool = True,
) -> dict[str, Any]:
    """The topology study (see the module docstring), written to ``out_dir`` as it goes.

    ``mechanisms``: topologies as for :func:`parse_topologies`. ``config`` gives the car
    (half or full), road, grid, design space and objective; its own mechanisms are
    replaced by each topology's. Returns the ``compare.json`` dictionary; ``failures``
    lists what did not converge or failed, ``verified`` is False if a cell's collocation
    and time marching disagree (None with ``verify=False``). Raises
    :class:`~suspopt.study.StepFailed` if the low-fidelity optimization fails and
    KeyboardInterrupt (after saving, ``interrupted: true``) on an interrupt."""
    import suspopt.output.compare_report as compare_report  # matplotlib only when figures are drawn

    out = out_dir.path if isinstance(out_dir, RunDirectory) else Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    say = log or (lambda msg: None)
    t_start = time.perf_counter()
    topologies = parse_topologies(mechanisms)
    labels = topology_labels(topologies)
    cfgs = {lab: topology_config(config, f, r) for lab, (f, r) in zip(labels, topologies)}
    copies = _copy_mechanisms(out, topologies)
    config_dict = (
        out_dir.keep_inputs(config.to_dict())
        if isinstance(out_dir, RunDirectory)
        else config.to_dict()
    )
    scales = resolve_scales(config)  # the low-fidelity model's: no linkage, one for all
    models = [LOW] + [model_key(lab) for lab in labels]
    designs_order = ['initial', 'low_optimum'] + [design_key(lab) for lab in labels]
    data: dict[str, Any] = {
        'kind': 'compare',
        'config': config_dict,
        'vehicle_model': config.vehicle.model,
        'topologies': [
            {
                'label': lab,
                'front': copies[f],
                'rear': copies[r],
                'front_label': mechanism_label(f),
                'rear_label': mechanism_label(r),
                'model': model_key(lab),
                'optimum': design_key(lab),
                'recorder': f'mixed_{lab}.sql',
            }
            for lab, (f, r) in zip(labels, topologies)
        ],
        'models': models,
        'design_order': designs_order,
        'recorders': {LOW: 'low.sql', **{model_key(lab): f'mixed_{lab}.sql' for lab in labels}},
        'scales': list(scales),
        'terms': list(config.terms()),
        'design_names': list(config.design_names()),
        'normalization': config.objective.normalization,
        'weights': dict(config.objective.weights),
        'verify': verify,
        'tolerance': VERIFY_TOLERANCE,
        'steps': {},
        'designs': {'initial': config.design.initial()},
        'cells': {},
        'failures': [],
        'complete': False,
        'interrupted': False,
    }
    save = lambda: write_json(out / 'compare.json', data)  # noqa: E731
    save()
    mech_files = {
        mechanism_label(m): m if copies[m] == m else str(out / copies[m])
        for t in topologies
        for m in t
    }
    k0 = next((v for n, v in config.design.initial().items() if n.startswith('k_S')), None)
    data['kinematics'] = kinematics_record(mech_files, float(k0) if k0 else 30000.0)
    save()
    problems: dict[str, VehicleProblem] = {}
    n_steps = 1 + len(labels)

    def keep(design: str, model: str, record: dict[str, Any]) -> dict[str, Any]:
        data['cells'][cell_key(design, model)] = _strip(record)
        if not record.get('success'):
            data['failures'].append(
                {
                    'what': 'evaluation',
                    'design': design,
                    'model': model,
                    'status': record.get('status'),
                    'message': record.get('message', ''),
                }
            )
        save()
        return record

    def cell(design: str, model: str, fid: str, cfg: StudyConfig, guess='auto'):
        try:
            rec = evaluate(
                cfg,
                fid,
                data['designs'][design],
                scales=scales,
                problem=problems[model],
                label=design,
                guess=guess,
                verify=verify,
            )
        except ModelError as err:
            rec = _failed_record(fid, 'evaluate', data['designs'][design], err, cfg)
        except Interrupted as stop:  # kept if IPOPT had converged (then unchecked)
            if stop.result and stop.result.get('success'):
                keep(design, model, stop.result)
            raise
        return keep(design, model, rec)

    def opt(model: str, fid: str, cfg: StudyConfig, start: str, result: str, guess='keep'):
        """Optimize ``model`` from design ``start`` (with ``guess='keep'`` from the
        collocation solution of its cell, just solved on the same problem)."""
        try:
            res = optimize(
                cfg,
                fid,
                start=data['designs'][start],
                scales=scales,
                problem=problems[model],
                guess=guess,
                label=result,
                verify=verify,
            )
        except ModelError as err:
            res = _failed_record(fid, 'optimize', data['designs'][start], err, cfg)
        except Interrupted as stop:  # a converged optimum is kept (then unchecked)
            if stop.result and stop.result.get('success'):
                data['steps'][model] = stop.result
                data['designs'][result] = stop.result['design']
                data['cells'][cell_key(result, model)] = stop.result
                save()
            raise
        data['steps'][model] = _strip(res)
        if res['success']:
            data['designs'][result] = res['design']
            data['cells'][cell_key(result, model)] = res
        else:
            data['failures'].append(
                {
                    'what': 'optimization',
                    'model': model,
                    'status': res.get('status'),
                    'message': res.get('message', ''),
                }
            )
        save()
        return res

    def summary(res: dict[str, Any]) -> str:
        if not res['success']:
            return f'FAILED ({res["status"]})'
        v = res.get('verification') or {}
        check = (
            ''
            if 'max_rel_diff' not in v
            else f', time marching {100 * v["max_rel_diff"]:.3g} % off: '
            + ('verified' if v['verified'] else 'NOT verified')
        )
        return f'f = {res["objective"]:.6f}, {res["iterations"]} iterations{check}'

    try:
        say(
            f'1/{n_steps} low-fidelity model ({config.vehicle.model}, no linkage): the initial '
            'design, then its optimum from there'
        )
        problems[LOW] = VehicleProblem(
            config, 'low', scales, recorder=out / 'low.sql', progress=progress
        )
        cell('initial', LOW, 'low', config)
        low = opt(LOW, 'low', config, 'initial', 'low_optimum')
        say(f'   low-fidelity optimum: {summary(low)}')
        if not low['success']:
            raise StepFailed('low', low)
        low_guess = [problems[LOW].timeseries(i) for i in range(len(problems[LOW].scenarios))]
        for i, lab in enumerate(labels):
            model = model_key(lab)
            say(
                f'{i + 2}/{n_steps} mixed-fidelity model, {lab}: the low-fidelity optimum, '
                'then its optimum from there'
            )
            problems[model] = VehicleProblem(
                cfgs[lab], 'mixed', scales, recorder=out / f'mixed_{lab}.sql', progress=progress
            )
            start = cell('low_optimum', model, 'mixed', cfgs[lab], guess=low_guess)
            guess = 'keep'
            if not start['success']:
                say(
                    f'   {lab}: the low-fidelity optimum failed in this model '
                    f"({start['status']}); optimizing from the half car's time marching"
                )
                guess = 'auto'
            res = opt(model, 'mixed', cfgs[lab], 'low_optimum', design_key(lab), guess)
            say(f'   {lab} optimum: {summary(res)}')
        todo = [
            (d, m)
            for m in models
            for d in designs_order
            if d in data['designs'] and cell_key(d, m) not in data['cells']
        ]
        for j, (d, m) in enumerate(todo):
            fid, cfg = ('low', config) if m == LOW else ('mixed', cfgs[m.split(':', 1)[1]])
            rec = cell(d, m, fid, cfg)
            say(f'cross-evaluation {j + 1}/{len(todo)}: {d} in {m}: {summary(rec)}')
        data['problems'] = {m: p.stats() for m, p in problems.items()}
    except KeyboardInterrupt:
        data['interrupted'] = True
        data['wall_time_s'] = time.perf_counter() - t_start
        save()
        raise
    finally:
        for p in problems.values():
            p.cleanup()
    finish(data)
    if data['warnings']:
        say(f'warning: {data["warnings"][-1]}')
    data['wall_time_s'] = time.perf_counter() - t_start
    data['complete'] = True
    save()
    say('writing table and figures')
    compare_report.render_compare(out)
    return data


def finish(data: dict[str, Any]) -> dict[str, Any]:
    """The verdicts of a finished study, from its cells: ``best`` (:func:`best_designs`),
    ``warnings`` (the cells whose collocation and time marching disagree) and ``verified``
    (None when verification was skipped)."""
    data['best'] = best_designs(data)
    unverified = [k for k, c in data['cells'].items() if verified(c) is False]
    data['warnings'] = []
    if unverified:
        worst = max(unverified, key=lambda k: data['cells'][k]['verification']['max_rel_diff'])
        v = data['cells'][worst]['verification']
        data['warnings'].append(
            f'not verified: {len(unverified)} of {len(data["cells"])} cells; worst '
            f'{worst}: collocation and time marching differ by {100 * v["max_rel_diff"]:.2g} % '
            f'on {v["scenarios"][0]["worst_term"]} (tolerance {100 * data["tolerance"]:g} %): '
            'the grid is too coarse for this car and road; more --segments'
        )
    data['verified'] = None if not data.get('verify', True) else not unverified
    return data


def best_designs(data: dict[str, Any]) -> dict[str, Any]:
    """Per model: the design with the lowest f among the converged cells, and each
    design's excess ``f / f_own - 1`` over the model's own optimum (None where missing)."""
    out = {}
    own = {LOW: 'low_optimum', **{t['model']: t['optimum'] for t in data['topologies']}}
    for m in data['models']:
        fs = {
            d: c['objective']
            for d in data['design_order']
            for c in [data['cells'].get(cell_key(d, m))]
            if c and c.get('success') and c.get('objective') is not None
        }
        f_own = fs.get(own[m])
        out[m] = {
            'best': min(fs, key=fs.get) if fs else None,
            'own_optimum': own[m],
            'f_own': f_own,
            'excess': {d: (f / f_own - 1.0 if f_own else None) for d, f in fs.items()},
        }
    return out


def exit_code(data: dict[str, Any]) -> int:
    """The command line's exit code of a topology study: 1 if something failed, 3 if a
    cell is not verified, else 0 (130 is the interrupt, handled by the caller)."""
    if data.get('failures'):
        return 1
    if data.get('verified') is False:
        return 3
    return 0
