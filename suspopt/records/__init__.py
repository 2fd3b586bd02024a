"""Typed records of what suspopt computes: trajectories, solves and their verifications,
and every study (``docs/results.md``). Plain dataclasses with ``to_json()`` /
``from_json()`` (:mod:`suspopt.records.codec`); nothing here computes."""
