"""asv benchmarks: the evaluation timings of ``perf.speed.evaluation_speed`` per commit.

asv imports this folder as a package of its own (``benchmark_dir`` in ``perf/asv.conf.json``)
and runs each ``time_*`` method against the commit installed in its environment, so that
``asv continuous --config perf/asv.conf.json main HEAD`` compares two commits with one command.
Only the public API of ``tooldesign_env`` is used, so older commits run them too.
"""
