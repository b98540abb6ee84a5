"""The protocol's instances (see :mod:`benchmarks.design.instances`, where they are defined).

The committed sets stay in ``benchmarks/protocol/data/``; the code that draws, writes and reads
them lives in the design layer so that the rl layer, below the protocol, can read the held-out
instances too. These names are the protocol's public ones.
"""

from __future__ import annotations

from benchmarks.design.instances import (
    INSTANCE_SEED,
    INSTANCE_SETS,
    INSTANCE_VERSION,
    PUSH_TASK,
    TASK_INSTANCES,
    Instance,
    committed_tasks,
    draw_instances,
    draw_task_instances,
    instance_file_name,
    instances_json,
    load_instances,
    select_instances,
    task_key,
)

__all__ = [
    "INSTANCE_SEED",
    "INSTANCE_SETS",
    "INSTANCE_VERSION",
    "PUSH_TASK",
    "TASK_INSTANCES",
    "Instance",
    "committed_tasks",
    "draw_instances",
    "draw_task_instances",
    "instance_file_name",
    "instances_json",
    "load_instances",
    "select_instances",
    "task_key",
]
