"""Science studies (noise floor, convergence, the cage scene, interval coverage, rl baselines).

Each prints the figures of its docs page (docs/architecture.md lists them). Run each from the
repository's root: ``python -m perf.studies.NAME --help``.
"""
