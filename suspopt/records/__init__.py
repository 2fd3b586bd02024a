"""Typed records of what suspopt computes: trajectories, solves and their verifications,
and every study. Plain dataclasses with ``to_json()`` / ``from_json()``
(:mod:`suspopt.records.codec`); nothing here computes, and nothing here imports the
models: a record is read back without them."""
