"""Make a helper process die with the process that started it (Linux).

A SIGKILLed main process runs no cleanup, so its forkserver and pool workers would keep running.
``prctl(PR_SET_PDEATHSIG, SIGKILL)`` asks the kernel to kill the caller when its parent dies.
``benchmarks.execution._forkserver_preload``, imported by the forkserver, arms the server with
it; each worker's initializer arms the worker against the death of the server. On other systems
it does nothing, and a worker is orphaned until it next talks to its pool (see
docs/reliability.md).
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys

__all__ = ["die_with_parent"]

_PR_SET_PDEATHSIG = 1


def die_with_parent() -> bool:
    """Ask the kernel to SIGKILL this process when its parent exits.

    Returns:
        True if armed (Linux), False where it is not available.
    """
    if not sys.platform.startswith("linux"):
        return False
    parent = os.getppid()
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) != 0:
            return False
    except (OSError, AttributeError):
        return False
    if os.getppid() != parent or parent == 1:
        # The parent died before the request took effect: nobody is left to serve.
        os._exit(1)
    return True
