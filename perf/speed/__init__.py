"""Speed, memory and cost benchmarks that print the figures of docs/performance.md.

Run each from the repository's root: ``python -m perf.speed.NAME --help``.
"""
