"""Many optimizations or studies side by side on Dask distributed (``suspopt sweep``,
``docs/sweeps.md``).

* :mod:`~suspopt.sweep.spec` — the sweep file: schema, validation, the tasks it makes;
* :mod:`~suspopt.sweep.tasks` — a task's identity (its inputs by content), its payload,
  what a worker runs and returns;
* :mod:`~suspopt.sweep.store` — the directory: written once, appended per task, resumed;
* :mod:`~suspopt.sweep.summary` — CSV, table and figures from the records (``render``);
* :mod:`~suspopt.sweep.cluster` — the Dask cluster, the worker preload, shutdown;
* :mod:`~suspopt.sweep.runner` — :func:`run_sweep`: submission, records, signals.

``dask worker --preload suspopt.sweep`` runs :func:`dask_setup` on a worker of an external
cluster."""

from suspopt.sweep.cluster import dask_setup
from suspopt.sweep.runner import Outcome, run_sweep
from suspopt.sweep.spec import Sweep, load_sweep
from suspopt.sweep.summary import render
from suspopt.sweep.tasks import Task, TaskPayload, TaskRecord, noop_task, run_task

__all__ = [
    'Outcome',
    'Sweep',
    'Task',
    'TaskPayload',
    'TaskRecord',
    'dask_setup',
    'load_sweep',
    'noop_task',
    'render',
    'run_sweep',
    'run_task',
]
