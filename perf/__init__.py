"""Developer scripts that measure the project and print their figures; no part of the library.

They are kept out of the installed packages (``pyproject.toml`` installs ``tooldesign_env``,
``optimizers`` and ``benchmarks`` only), as optuna keeps its asv suites and nevergrad its
experiments apart from the library: a user of the wheel needs none of them, and they may
import anything the project has. Sorted by purpose (docs/architecture.md, "Scripts outside the
packages"):

* ``perf.speed``: speed, memory and cost benchmarks, the figures of docs/performance.md;
* ``perf.studies``: science studies (noise floor, convergence, the cage scene, interval
  coverage), each with its docs page;
* ``perf/asv_benchmarks``: the same evaluation timings as asv benchmarks, to compare two
  commits with one command (``perf/asv.conf.json``);
* QA checks are tests: the input fuzzer is ``tests/test_fuzz_inputs.py``, the Dask cluster
  check runs in ``tests/test_dask_cluster.py``.

Run a script from the repository's root as a module, e.g. ``python -m perf.speed.evaluation_speed
--designs 12``: ``python -m`` puts the root first on ``sys.path``, so the scripts measure the
checkout they are run in and import their shared argument types as ``from perf import _args``.
"""
