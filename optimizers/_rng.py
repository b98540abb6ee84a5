"""A private stream for backends that draw from numpy's global (legacy) random generator.

pycma and pyswarms call ``np.random.*`` directly, so two optimizers in one process, or the
user's own ``np.random`` calls, would otherwise shift each other's sequences. Each optimizer that
drives such a backend keeps its own legacy state and swaps it into ``np.random`` only for the
duration of a backend call; afterwards the caller's global state is exactly as it was.

Not thread-safe: another thread using ``np.random`` during a backend call would draw from the
optimizer's stream (optimizers are not thread-safe in any case).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np

__all__ = ["GlobalRandomState"]


class GlobalRandomState:
    """A legacy ``np.random`` state of one optimizer, active only inside :meth:`active`.

    Public as ``optimizers.GlobalRandomState`` for plugin backends that call ``np.random``::

        self._global = GlobalRandomState(int(self._rng.integers(2**32)))
        with self._global.active():
            x = backend.ask()

    Args:
        seed: Seed of the private Mersenne Twister stream, in [0, 2**32).

    Raises:
        TypeError: ``seed`` is not an int.
        ValueError: ``seed`` is outside [0, 2**32).
    """

    def __init__(self, seed: int) -> None:
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
            raise TypeError(f"seed must be an int in [0, 2**32), got {type(seed).__name__}")
        if not 0 <= seed < 2**32:
            raise ValueError(f"seed must be in [0, 2**32), got {seed}")
        self._state: tuple[Any, ...] = np.random.RandomState(seed).get_state(legacy=True)  # type: ignore[assignment]

    @contextmanager
    def active(self) -> Iterator[None]:
        """Make this stream numpy's global one for the duration of the block.

        Yields:
            None; on exit the stream's new state is kept and the caller's restored.
        """
        # The legacy global functions are the point here: they are what the backends call.
        outer = np.random.get_state(legacy=True)  # noqa: NPY002
        np.random.set_state(self._state)  # noqa: NPY002
        try:
            yield
        finally:
            self._state = np.random.get_state(legacy=True)  # type: ignore[assignment]  # noqa: NPY002
            np.random.set_state(outer)  # noqa: NPY002
