"""Success rates, as the reports show them: :mod:`benchmarks.design.success`, re-exported.

The module lives with the design runs (layer ``benchmarks.design``) because a design run writes
each evaluation's success into its log (``evaluations.csv``'s ``success`` column) and the
reports, a layer above, read it; this name is kept for the reports and for users' imports.
"""

from benchmarks.design.success import *  # noqa: F403 - the same public names
from benchmarks.design.success import __all__ as __all__
