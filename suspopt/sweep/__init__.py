"""Many optimizations or studies side by side on Dask distributed (``suspopt sweep``,
``docs/sweeps.md``). ``dask worker --preload suspopt.sweep`` runs :func:`dask_setup` on a
worker of an external cluster."""

from suspopt.sweep.runner import dask_setup, run_sweep

__all__ = ['dask_setup', 'run_sweep']
