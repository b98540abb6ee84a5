"""The line a speed script prints first: the cores and the load it measured under.

A rate measured on a loaded machine says little; the line lets a reader of the output see the
load (``os.getloadavg``'s 1, 5 and 15 minute averages) beside the figures.
"""

from __future__ import annotations

import os


def machine_line() -> str:
    """``cores: N, load average: a, b, c``."""
    load = ", ".join(f"{v:.2f}" for v in os.getloadavg())
    return f"cores: {os.cpu_count()}, load average: {load}"
