"""The benchmark protocol: many instances, a dimension axis, fixed targets, ECDFs and power.

Submodules, by responsibility (lower ones never import higher ones):

- :mod:`~benchmarks.protocol.instances`: the committed, versioned instance sets (goals, box
  masses and frictions), public and held-out: push's, and one per other task.
- :mod:`~benchmarks.protocol.dimensions`: the degree axis d = 3, 5, 8, its bounds, and how many
  random designs are buildable.
- :mod:`~benchmarks.protocol.suite`: :class:`ProtocolConfig` at the sizes smoke, quick, full,
  with its task axis; :func:`run_protocol` runs every (task, instance, d) cell as a resumable
  suite.
- :mod:`~benchmarks.protocol.references`: the best F known per cell, its noise floor, the
  straight tool and a random pool; the command that computes them.
- :mod:`~benchmarks.protocol.measures`: regret, targets, runtimes, ERT, ECDFs and their area.
- :mod:`~benchmarks.protocol.statistics`: paired Holm-corrected comparisons, ranking stability,
  power.
- :mod:`~benchmarks.protocol.effects`: the final-F difference of each pair against the noise
  floor, the rule that tells a pair apart, and each section's verdict sentence.
- :mod:`~benchmarks.protocol.ioh_export`: runs in the IOHprofiler format.
- :mod:`~benchmarks.protocol.report`: the report of one or more run folders, merged;
  :mod:`~benchmarks.protocol.task_report` its sections per task and pooled over tasks.
- :mod:`~benchmarks.protocol.claims`: the paper's claim (a) judged from a run's report, for
  the reproduction page (``tooldesign reproduce``).

Command: ``tooldesign bench protocol --size smoke|quick|full [--tasks TASK...|all] --out DIR``
(docs/protocol.md).
"""

from __future__ import annotations

from benchmarks.protocol.dimensions import DEGREES, bounds_of, buildable_fraction
from benchmarks.protocol.instances import (
    INSTANCE_VERSION,
    Instance,
    draw_task_instances,
    load_instances,
    select_instances,
)
from benchmarks.protocol.ioh_export import export_ioh
from benchmarks.protocol.references import (
    ReferencePlan,
    compute_references,
    load_references,
    packaged_references,
    reference_plan,
    verify_references,
)
from benchmarks.protocol.report import load_runs, make_protocol_report, measure_runs
from benchmarks.protocol.suite import (
    PROTOCOL_SIZES,
    PROTOCOL_SUITE_NAME,
    ProtocolConfig,
    protocol_config,
    read_protocol,
    resolve_tasks,
    run_protocol,
)

__all__ = [
    "DEGREES",
    "INSTANCE_VERSION",
    "PROTOCOL_SIZES",
    "PROTOCOL_SUITE_NAME",
    "Instance",
    "ProtocolConfig",
    "ReferencePlan",
    "bounds_of",
    "buildable_fraction",
    "compute_references",
    "draw_task_instances",
    "export_ioh",
    "load_instances",
    "load_references",
    "load_runs",
    "make_protocol_report",
    "measure_runs",
    "packaged_references",
    "protocol_config",
    "read_protocol",
    "reference_plan",
    "resolve_tasks",
    "run_protocol",
    "select_instances",
    "verify_references",
]
