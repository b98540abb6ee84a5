"""Errors of the executors that are not a design's own failure."""

from __future__ import annotations

__all__ = ["ClusterLost", "ClusterMismatch"]


class ClusterLost(BaseException):
    """The Dask cluster went away while designs were being evaluated; the run must stop.

    A :class:`BaseException`, like :class:`KeyboardInterrupt`: the executors' callers take every
    :class:`Exception` of a work item as that item's outcome (a failed evaluation), and a lost
    cluster says nothing about the design. The run folder stays resumable.
    """


class ClusterMismatch(RuntimeError):
    """A worker of the Dask cluster runs other code or libraries than this process."""
