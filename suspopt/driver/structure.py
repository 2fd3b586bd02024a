"""The model's declared structure, read from OpenMDAO: the one module with private names.

The exact total-Jacobian sparsity (:mod:`suspopt.driver.sparsity`) is propagated
through the model from each component's *declared* partial-derivative pattern and the
connections between variables. OpenMDAO 3.45 has no public API for either, so this module
reads them from its internals, and nothing else in suspopt does. Private names used:

* ``Component._subjacs_info`` — the declared sub-Jacobians: ``{(of, wrt): meta}`` with
  ``meta['rows']``, ``meta['cols']`` (sparse pattern), ``meta['diagonal']``,
  ``meta['shape']`` (absolute variable names), and ``meta['val']``, the values of the last
  linearization (read by :meth:`Subjac.values` for the propagated total derivatives);
* ``Group._conn_global_abs_in2out`` — every input's source output (absolute names);
* ``Driver._get_name()`` — the name a driver's recorded iterations carry (the
  fallback: its class name);
* ``System._var_abs2meta['input'][name]['src_inds_list']`` — the chain of source indices of
  a connected input (turned into one flat index array by OpenMDAO's public
  ``openmdao.utils.indexer.idx_list_to_index_array``).

:data:`TESTED_VERSIONS` lists the OpenMDAO versions this was written against;
:func:`supported` is False on any other, and the caller then uses OpenMDAO's public (dense)
total coloring instead. ``tests/test_sparsity.py`` checks that both give the same pattern.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np
import openmdao
import openmdao.api as om
from openmdao.utils.indexer import idx_list_to_index_array

#: OpenMDAO versions whose internals this module reads.
TESTED_VERSIONS = ('3.45.1',)


def supported() -> bool:
    """True if this OpenMDAO's internals are the ones this module was written against."""
    return openmdao.__version__ in TESTED_VERSIONS


@dataclass(frozen=True)
class Subjac:
    """One declared sub-Jacobian ``d of / d wrt`` of a component, as a coordinate pattern
    (local row and column indices; every entry when declared without a pattern)."""

    of: str
    wrt: str
    rows: np.ndarray
    cols: np.ndarray
    shape: tuple[int, int]
    _meta: dict = field(default_factory=dict, compare=False, repr=False)

    def values(self) -> np.ndarray:
        """The values at ``rows``/``cols`` from the component's last linearization."""
        val = np.asarray(self._meta['val'], dtype=float).ravel()
        return val if val.size == self.rows.size else np.broadcast_to(val, self.rows.shape)


def declared_subjacs(component: om.ExplicitComponent | om.ImplicitComponent) -> Iterator[Subjac]:
    """The declared partial derivatives of ``component`` (after ``final_setup``).

    An explicit component's identity ``d out / d out`` (its residual) is left out."""
    explicit = isinstance(component, om.ExplicitComponent)
    for (of, wrt), meta in component._subjacs_info.items():
        if explicit and of == wrt:
            continue
        shape = (int(meta['shape'][0]), int(meta['shape'][1]))
        if meta.get('rows') is not None:
            rows = np.asarray(meta['rows'], dtype=np.int64).ravel()
            cols = np.asarray(meta['cols'], dtype=np.int64).ravel()
        elif meta.get('diagonal'):
            rows = cols = np.arange(shape[0], dtype=np.int64)
        else:  # declared dense
            rows = np.repeat(np.arange(shape[0], dtype=np.int64), shape[1])
            cols = np.tile(np.arange(shape[1], dtype=np.int64), shape[0])
        yield Subjac(of=of, wrt=wrt, rows=rows, cols=cols, shape=shape, _meta=meta)


def input_sources(model: om.Group) -> dict[str, tuple[str, np.ndarray | None]]:
    """``{input: (source output, flat source index of each input entry or None)}`` for every
    connected input of ``model`` (absolute names)."""
    meta = model._var_abs2meta['input']
    out = {}
    for tgt, src in model._conn_global_abs_in2out.items():
        idx = None
        chain = meta[tgt].get('src_inds_list') if tgt in meta else None
        if chain:
            idx = np.asarray(idx_list_to_index_array(chain), dtype=np.int64).ravel()
        out[tgt] = (src, idx)
    return out


def driver_name(driver: om.Driver) -> str:
    """The name OpenMDAO's recorders give a driver's iterations (``Driver._get_name``, no
    public equivalent; its class name where that is missing)."""
    get = getattr(driver, '_get_name', None)
    return str(get()) if callable(get) else type(driver).__name__
