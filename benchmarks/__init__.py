"""benchmarks: drives tooldesign_env with optimizers; owns result files, tables and plots.

The ``tooldesign`` command line lives here (``benchmarks.cli``) because this is the one package
that may import both ``tooldesign_env`` and ``optimizers``.
"""

from __future__ import annotations

__all__: list[str] = []
