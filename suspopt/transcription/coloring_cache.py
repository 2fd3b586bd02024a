"""Cache of total-derivative colorings, keyed by the model's structure; beside it, the
cache of the ``reference`` normalization's scales.

Beside each constraint-Jacobian coloring, the exact Hessian's structure
(:class:`~suspopt.driver.hessian.HessianStructure`) where it was used.

The total-Jacobian sparsity and its coloring (:mod:`suspopt.driver.sparsity`) depend only
on the model's structure —
fidelity, grid, the mechanisms' topology, the forms of the suspension's curves and the code
that builds the model — not on numbers (masses, road, design), so one coloring serves
every study with the same structure. The key hashes exactly that structure, including
the OpenMDAO/Dymos versions and a digest of suspopt's model-building source, so a code
change never reuses a stale coloring.

The reference scales (time-marched objective terms at the initial design,
:func:`suspopt.verification.timemarching.reference_scales`) are kept in the same way,
under a key the time marching computes from everything they depend on
(:func:`load_scales`, :func:`store_scales`).

Location: ``$SUSPOPT_CACHE_DIR`` or ``~/.cache/suspopt``, in ``colorings/`` and
``scales/`` (never a results folder). Files are written atomically, so parallel studies
can share the cache.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from pathlib import Path

import dymos
import openmdao

from suspopt.driver.hessian import HessianStructure
from suspopt.driver.sparsity import Coloring
from suspopt.spec.hardware import curves_structure
from suspopt.spec.schema import StudyConfig
from suspopt.transcription.constraints import structure as constraint_structure

_MODEL_SOURCES = (
    'models',
    'multibody/components.py',
    'multibody/suspension.py',
    'transcription',
    'road',
    'driver',
)


def cache_root() -> Path:
    root = os.environ.get('SUSPOPT_CACHE_DIR')
    return Path(root) if root else Path.home() / '.cache' / 'suspopt'


def cache_dir() -> Path:
    return cache_root() / 'colorings'


def scales_dir() -> Path:
    return cache_root() / 'scales'


def source_digest(entries: tuple[str, ...] = _MODEL_SOURCES) -> str:
    """Digest of suspopt's source files under ``entries`` (paths in the package)."""
    pkg = Path(__file__).resolve().parents[1]
    h = hashlib.sha256()
    for entry in entries:
        path = pkg / entry
        files = sorted(path.rglob('*.py')) if path.is_dir() else [path]
        for f in files:
            h.update(f.relative_to(pkg).as_posix().encode())
            h.update(f.read_bytes())
    return h.hexdigest()


def coloring_key(config: StudyConfig, fidelity: str) -> str:
    """Hex digest identifying the total-Jacobian structure of one problem."""
    from suspopt.multibody.mechanism import load_mechanism

    v = config.vehicle
    structure = {
        'fidelity': fidelity,
        'vehicle': [v.model, [ax.anti_roll_bar for ax in v.axles]],
        'design': list(config.design_names()),
        'grids': [(sc.segments, sc.order) for sc in config.scenarios()],
        'aggregate': config.objective.aggregate,
        # an actuator's controls, gains and path bounds; the travel path constraint
        'control': [
            config.control.kind,
            config.control.law,
            list(config.controlled()),
            bool(config.control.force_max),
            bool(config.control.power_max),
        ],
        'seats': len(config.comfort.seats),
        'constraints': constraint_structure(config),
        'versions': [openmdao.__version__, dymos.__version__],
        'source': source_digest(),
    }
    curves = curves_structure(config)
    if curves is not None:  # the hardware's curve forms (their parameters' inputs)
        structure['curves'] = curves
    if fidelity == 'mixed':
        structure['mechanisms'] = [
            load_mechanism(ax.mechanism, suspension=True).structure() for ax in v.axles
        ]
        structure['mount'] = config.multibody.mount
    blob = json.dumps(structure, sort_keys=True, default=str).encode()
    return hashlib.sha256(blob).hexdigest()[:32]


def _file(key: str, kind: type) -> Path:
    return cache_dir() / (f'{key}-hessian.npz' if kind is HessianStructure else f'{key}.npz')


def load(key: str) -> Coloring | None:
    """The cached :class:`~suspopt.driver.sparsity.Coloring` for ``key``, or None."""
    path = _file(key, Coloring)
    try:
        return Coloring.load(path) if path.is_file() else None
    except Exception:  # unreadable or damaged: recompute
        return None


def load_hessian(key: str) -> HessianStructure | None:
    """The cached :class:`~suspopt.driver.hessian.HessianStructure` for ``key``, or None."""
    path = _file(key, HessianStructure)
    try:
        return HessianStructure.load(path) if path.is_file() else None
    except Exception:  # unreadable or damaged: recompute
        return None


def store(key: str, coloring: Coloring | HessianStructure) -> Path | None:
    """Save a coloring (or a Hessian structure) under ``key`` atomically; a read-only cache
    is silently skipped."""
    directory = cache_dir()
    try:
        directory.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=directory, suffix='.tmp')
        os.close(fd)
        coloring.save(tmp)
        path = _file(key, type(coloring))
        os.replace(tmp, path)
        return path
    except OSError:
        return None


def load_scales(key: str) -> dict[str, float] | None:
    """The cached scales (term -> value) for ``key``, or None."""
    path = scales_dir() / f'{key}.json'
    try:
        data = json.loads(path.read_text()) if path.is_file() else None
        if not isinstance(data, dict) or data.get('key') != key:
            return None
        return {str(t): float(v) for t, v in data['scales'].items()}
    except Exception:  # unreadable or damaged: recompute
        return None


def store_scales(key: str, scales: dict[str, float]) -> Path | None:
    """Save ``scales`` under ``key`` atomically; a read-only cache is silently skipped."""
    directory = scales_dir()
    try:
        directory.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=directory, suffix='.tmp')
        with os.fdopen(fd, 'w') as fh:
            json.dump({'key': key, 'scales': scales}, fh)
        path = directory / f'{key}.json'
        os.replace(tmp, path)
        return path
    except OSError:
        return None
