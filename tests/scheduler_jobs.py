"""Test helper: the smallest job of :class:`benchmarks.execution.Scheduler`."""

from __future__ import annotations

from benchmarks.execution import Outcome


class OneBatch:
    """A job of the scheduler: one batch of items, its outcomes kept."""

    def __init__(self, items: list[str]) -> None:
        self.items = items
        self.outcomes: list[Outcome] = []

    def start(self) -> list[str]:
        return self.items

    def advance(self, outcomes: list[Outcome]) -> None:
        self.outcomes = outcomes
