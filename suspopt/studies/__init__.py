"""The studies: optimize, evaluate, the two-step study, Pareto fronts, robust design,
topology and coupling comparisons (``docs/studies.md``)."""
