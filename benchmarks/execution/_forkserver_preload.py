"""Arms the process pool's forkserver to die with the main process.

Imported by the forkserver only, never by the main process (see
:mod:`benchmarks.execution._parent_death`).
"""

from __future__ import annotations

from benchmarks.execution._parent_death import die_with_parent

die_with_parent()
