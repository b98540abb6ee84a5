"""Reports: tables, figures and pages made from stored results alone (nothing is simulated).

- :mod:`~benchmarks.reports.stats`: intervals of means (Student t, percentile bootstrap), tests
  and effect sizes (no files).
- :mod:`~benchmarks.reports.markdown`: Markdown tables and the docs' generated blocks (no files).
- :mod:`~benchmarks.reports.plots`: the shared figure helpers (tool shapes, box paths, PNG bytes).
- :mod:`~benchmarks.reports.comparison`: the optimizer comparison of any run folder
  (convergence, summary, pairwise tests with the noise floor).
- :mod:`~benchmarks.reports.suite`: a suite's own figures and tables (Table I, tool shapes, ...).
- :mod:`~benchmarks.reports.rl`: the rl suite's tables, figures and page (``make_suite_report``
  hands an rl suite's folder to it).
- :mod:`~benchmarks.reports.retest`: the noise floor and the stress test of retested designs.
- :mod:`~benchmarks.reports.design_figures`: a design run's Figure 3 panels and robustness plot.
- :mod:`~benchmarks.reports.evaluation_figures`: one evaluated design's figures.
- :mod:`~benchmarks.reports.html`: one self-contained ``report.html`` of any run folder.
- :mod:`~benchmarks.reports.reproduction`: ``docs/reproduction.md``, each claim with its noise.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from tooldesign_env.lazy import lazy_attribute

if TYPE_CHECKING:
    from benchmarks.reports.design_figures import write_design_report
    from benchmarks.reports.evaluation_figures import (
        write_evaluation_figures,
        write_evaluation_report,
    )
    from benchmarks.reports.html import write_html_report
    from benchmarks.reports.suite import make_suite_report

#: Where each public name lives. They are imported on first use (PEP 562): the figures load
#: Matplotlib and the suite reports the simulation, and the command line's ``--help`` of a
#: command that only names this package should load neither.
_LAZY: dict[str, str] = {
    "make_suite_report": "benchmarks.reports.suite",
    "write_design_report": "benchmarks.reports.design_figures",
    "write_evaluation_figures": "benchmarks.reports.evaluation_figures",
    "write_evaluation_report": "benchmarks.reports.evaluation_figures",
    "write_html_report": "benchmarks.reports.html",
}

__all__ = [
    "make_suite_report",
    "write_design_report",
    "write_evaluation_figures",
    "write_evaluation_report",
    "write_html_report",
]


def __getattr__(name: str) -> Any:
    return lazy_attribute(__name__, _LAZY, name)


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})
