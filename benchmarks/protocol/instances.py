"""The protocol's instances (see :mod:`benchmarks.design.instances`, where they are defined).

The committed set stays ``benchmarks/protocol/data/instances-v1.json``; the code that draws,
writes and reads it lives in the design layer so that the rl layer, below the protocol, can
read the held-out instances too. These names are the protocol's public ones.
"""

from __future__ import annotations

from benchmarks.design.instances import (
    INSTANCE_SEED,
    INSTANCE_SETS,
    INSTANCE_VERSION,
    Instance,
    draw_instances,
    instances_json,
    load_instances,
    select_instances,
)

__all__ = [
    "INSTANCE_SEED",
    "INSTANCE_SETS",
    "INSTANCE_VERSION",
    "Instance",
    "draw_instances",
    "instances_json",
    "load_instances",
    "select_instances",
]
