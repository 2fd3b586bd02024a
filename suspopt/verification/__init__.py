"""The time-marching verification of every collocation result (``docs/model.md``,
"Verification"): the integrator, the check and its tolerances, background checks."""
