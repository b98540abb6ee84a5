"""The ask/tell base class of every optimizer: validation, ids, counts, failures and state.

A plugin subclasses :class:`Optimizer` and implements two small hooks that work in the unit box
[0, 1]^d; the base class converts between the unit box and physical units in one place
(:meth:`Optimizer._to_physical`), validates every public argument and keeps the counts, as
nevergrad's ``optimization/base.py`` and pycma's ``interfaces.py`` do.

Semantics (also in ``docs/optimizer-plugins.md``):

- ``ask()`` returns a :class:`Batch` of ``batch_size`` new points with fresh integer ids
  (0, 1, 2, ... over the run), always inside the bounds.
- ``tell(ids, values)`` gives scores back (minimization) for any subset of the pending ids, in any
  order. A value that is None or not finite (nan, inf, -inf) marks a failed evaluation.
- Generation rule: a *generational* plugin (CMA-ES, PSO: ``generational = True``) hands out one
  whole generation per ask and sees it only once every point of it is told; asking again while
  points of the last generation are pending raises :class:`OptimizerStateError`. Non-generational
  plugins (BO, random) may be asked again while evaluations are pending (asynchronous use); they
  see each ``tell`` at once and know the pending points.
- Failures never reach a backend as nan or inf: the backend is told ``FailurePolicy.penalty``
  (by default the worst finite value told so far plus a margin), and the hook gets the failure
  mask so a plugin may do better.
- ``save_state(path)`` writes everything, pending points included, atomically;
  ``load_state(path)`` returns an optimizer that continues exactly as the saved one would.
"""

from __future__ import annotations

import abc
import copy
import hashlib
import math
import os
import pickle
import sys
import tempfile
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, TypeVar, cast

import numpy as np

from ._validation import (
    VALUE_MAX,
    SeedLike,
    check_batch_size,
    check_bounds,
    check_ids,
    check_path,
    check_values,
    make_rng,
)

__all__ = [
    "Batch",
    "FailurePolicy",
    "Optimizer",
    "OptimizerStateError",
    "PluginError",
    "Recommendation",
]

STATE_FORMAT = "tooldesign.optimizers.state"
STATE_VERSION = 1

# Points a plugin returns may stray from the unit box by rounding; more than this is a bug.
_UNIT_TOLERANCE = 1e-9

_O = TypeVar("_O", bound="Optimizer")


class PluginError(RuntimeError):
    """A bug of an optimizer plugin: a hook raised unexpectedly or broke its contract.

    Raised when a hook (``_ask``, ``_tell``, ``_backend_versions``), or the plugin's
    ``__init__`` called by :func:`optimizers.make`, raises an exception other than TypeError,
    ValueError and the errors of this module (the original exception is the ``__cause__``), and
    when a hook returns something the base class refuses (``_ask`` points of the wrong shape,
    not numbers, not finite or outside the unit box). The message starts with
    ``optimizer plugin MODULE.CLASS.HOOK``. A TypeError or ValueError raised inside a hook keeps
    its type and gets the same prefix; KeyboardInterrupt and other non-``Exception`` signals
    pass through unchanged.
    """


class OptimizerStateError(RuntimeError):
    """The call is not allowed in the optimizer's current state.

    Raised when a generational optimizer is asked again before its last generation is told, and
    by :meth:`Optimizer.recommend` before any finite value was told.
    """


def _named(error: TypeError | ValueError, where: str) -> TypeError | ValueError:
    """``error`` again, of its type, with a message that starts with ``where``.

    A TypeError or ValueError from inside a plugin keeps its type (the documented contract), but
    a bare ``operands could not be broadcast`` would read as bad user input: the new message
    says where it came from. An exception class that cannot be built from one message
    (``UnicodeDecodeError`` takes five arguments) is replaced by its nearest base that can.
    """
    message = f"{where} raised {type(error).__name__}: {error}"
    for kind in type(error).__mro__:
        if not issubclass(kind, (TypeError, ValueError)):
            continue
        try:
            named = kind(message)
        except Exception:  # a constructor with other arguments: try the base class
            continue
        if str(named) == message:
            return named
    return ValueError(message) if isinstance(error, ValueError) else TypeError(message)


@dataclass(frozen=True, eq=False)
class Batch:
    """Points handed out by one :meth:`Optimizer.ask`.

    Attributes:
        ids: One fresh int id per point, to pass back to :meth:`Optimizer.tell`.
        x: (batch_size, d) points in physical units, inside the bounds; read-only.
    """

    ids: tuple[int, ...]
    x: np.ndarray

    def __len__(self) -> int:
        return len(self.ids)


@dataclass(frozen=True, eq=False)
class Recommendation:
    """The incumbent: the best finite value told so far (the earliest one on ties).

    Attributes:
        x: (d,) its point in physical units; read-only.
        value: Its value.
        id: Its id.
    """

    x: np.ndarray
    value: float
    id: int


@dataclass(frozen=True, kw_only=True)
class FailurePolicy:
    """What a backend is told for a failed evaluation (it is never told nan or inf).

    The penalty is ``fixed`` if given; otherwise ``worst + margin * spread``, with ``worst`` and
    ``best`` the largest and smallest finite values told so far (the failed point's own batch
    included) and ``spread = worst - best`` (``max(|worst|, 1)`` while all are equal); and
    ``fallback`` while no finite value has been told yet.

    Like a told value, a penalty lies within +-1e100 (``VALUE_MAX``): ``fallback`` and ``fixed``
    beyond it are refused, and the adaptive penalty stops at it (a Gaussian process fitted to
    1e155 and 1 sees NaN).

    Attributes:
        margin: Fraction of the spread added to the worst value, >= 0.
        fallback: Penalty before any finite value is known; choose it above any real value.
        fixed: A constant penalty instead of the adaptive one, or None.
    """

    margin: float = 0.1
    fallback: float = 1.0e10
    fixed: float | None = None

    def __post_init__(self) -> None:
        for name in ("margin", "fallback", "fixed"):
            value = getattr(self, name)
            if value is None and name == "fixed":
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
                raise TypeError(f"FailurePolicy.{name} must be a number, got {value!r}")
            if not math.isfinite(value):
                raise ValueError(f"FailurePolicy.{name} must be finite, got {value!r}")
            if name != "margin" and abs(value) > VALUE_MAX:
                raise ValueError(
                    f"FailurePolicy.{name} must lie within +-{VALUE_MAX:g}, as told values do, "
                    f"got {value!r}"
                )
        if self.margin < 0:
            raise ValueError(f"FailurePolicy.margin must be >= 0, got {self.margin!r}")

    def penalty(self, best: float | None, worst: float | None) -> float:
        """The value a backend is told for a failed evaluation.

        Args:
            best: Smallest finite value told so far, or None if there is none.
            worst: Largest finite value told so far, or None if there is none.

        Returns:
            A finite penalty.
        """
        if self.fixed is not None:
            return float(self.fixed)
        if best is None or worst is None:
            return float(self.fallback)
        spread = worst - best
        if not spread > 0:
            spread = max(abs(worst), 1.0)
        value = worst + self.margin * spread
        # Huge values or margins must not take the penalty past what a backend can fit.
        return float(min(value, VALUE_MAX))


class Optimizer(abc.ABC):
    """Base class of the ask/tell optimizers (minimization in a box).

    Subclasses implement :meth:`_ask` and :meth:`_tell` in the unit box [0, 1]^d and may take
    extra keyword-only settings. Not thread-safe.

    Args:
        bounds: (d, 2) [low, high] per dimension in physical units; or None with ``low`` and
            ``high``.
        low: (d,) lower bounds, instead of ``bounds``.
        high: (d,) upper bounds, instead of ``bounds``.
        batch_size: Points per :meth:`ask`, >= ``min_batch_size`` (the population size of
            population-based methods).
        seed: An int >= 0, a ``numpy.random.SeedSequence``, a ``numpy.random.Generator`` (used
            as is: two optimizers given the same Generator share it) or None (fresh entropy).
            Equal seeds give equal sequences of asks for equal tells.
        failure_policy: What backends are told for failed evaluations; ``FailurePolicy()`` if
            None.

    Raises:
        TypeError: An argument of the wrong type.
        ValueError: An argument of the right type with a wrong value.
    """

    #: Whether a whole batch must be told before the next ask (see the module docstring).
    generational: ClassVar[bool] = False
    #: Smallest batch_size the method works with.
    min_batch_size: ClassVar[int] = 1
    #: Smallest number of dimensions the method works with.
    min_dims: ClassVar[int] = 1
    #: Names of the checks of :mod:`optimizers.testing` that do not apply to the method, e.g.
    #: ``("check_seed_changes_asks",)`` for a deterministic one; those checks skip it.
    conformance_skip: ClassVar[tuple[str, ...]] = ()

    def __init__(
        self,
        bounds: Any = None,
        *,
        low: Any = None,
        high: Any = None,
        batch_size: int = 8,
        seed: SeedLike = None,
        failure_policy: FailurePolicy | None = None,
    ) -> None:
        self._low, self._high = check_bounds(bounds, low, high)
        self._span = self._high - self._low
        if self._low.size < self.min_dims:
            raise ValueError(
                f"{type(self).__name__} needs at least {self.min_dims} dimensions, got bounds for "
                f"{self._low.size}"
            )
        self._batch_size = check_batch_size(batch_size, self.min_batch_size, type(self).__name__)
        self._rng = make_rng(seed)
        if failure_policy is None:
            failure_policy = FailurePolicy()
        if not isinstance(failure_policy, FailurePolicy):
            raise TypeError(
                f"failure_policy must be a FailurePolicy or None, got {failure_policy!r}"
            )
        self._failure_policy = failure_policy
        self._next_id = 0
        self._pending: dict[int, np.ndarray] = {}  # id -> (d,) point in the unit box
        self._batch_of: dict[int, int] = {}  # pending id -> number of the batch it came in
        self._open: dict[int, int] = {}  # batch number -> points of it still pending
        self._n_batches = 0
        self._iteration = 0
        self._n_told = 0
        self._n_failed = 0
        self._best_value = math.inf
        self._worst_value = -math.inf
        self._best_id: int | None = None
        self._best_x: np.ndarray | None = None
        # Told points of the current generation not yet given to a generational backend.
        self._held: list[tuple[int, np.ndarray, float, bool]] = []

    # --- hooks -------------------------------------------------------------------------------

    @abc.abstractmethod
    def _ask(self, ids: tuple[int, ...]) -> np.ndarray:
        """New points in the unit box.

        Args:
            ids: The ids the points will be handed out with, one per point to make.

        Returns:
            (len(ids), d) points in [0, 1]^d.
        """

    @abc.abstractmethod
    def _tell(
        self, ids: tuple[int, ...], x: np.ndarray, values: np.ndarray, failed: np.ndarray
    ) -> None:
        """Results for the backend; all finite (failures replaced by the penalty).

        Called once per :meth:`tell`, or, for a generational plugin, once per generation with
        the whole generation in ask order.

        Args:
            ids: Ids of the points.
            x: (m, d) points in the unit box, as returned by :meth:`_ask`.
            values: (m,) finite values to minimize.
            failed: (m,) True where the evaluation failed and ``values`` holds the penalty.
        """

    def _backend_versions(self) -> dict[str, str]:
        """Versions of the backend packages, recorded in saved states (override to add)."""
        return {}

    # --- helpers for plugins -----------------------------------------------------------------

    def _to_physical(self, u: np.ndarray) -> np.ndarray:
        """Points of the unit box in physical units, clipped into the bounds.

        Args:
            u: (..., d) points in [0, 1]^d.

        Returns:
            (..., d) points in [low, high]; the clip removes rounding past a bound.
        """
        return cast("np.ndarray", np.clip(self._low + u * self._span, self._low, self._high))

    def _to_unit(self, x: Any, name: str = "x0") -> np.ndarray:
        """A physical point, checked to be inside the bounds, in the unit box.

        Args:
            x: (d,) point in physical units.
            name: Argument name for the error message.

        Returns:
            (d,) point in [0, 1]^d.

        Raises:
            TypeError: Not numbers.
            ValueError: Wrong shape or outside the bounds.
        """
        try:
            point = np.asarray(x, dtype=np.float64)
        except (TypeError, ValueError):
            raise TypeError(f"{name} must be a (d,) array of numbers, got {x!r}") from None
        if point.shape != self._low.shape:
            raise ValueError(f"{name} must have shape {self._low.shape}, got {point.shape}")
        if not np.all((point >= self._low) & (point <= self._high)):
            raise ValueError(
                f"{name} must be inside the bounds low={self._low.tolist()} "
                f"high={self._high.tolist()}, got {point.tolist()}"
            )
        return cast("np.ndarray", np.clip((point - self._low) / self._span, 0.0, 1.0))

    def _pending_unit(self) -> np.ndarray:
        """(p, d) points asked and not told yet, in the unit box (ask order)."""
        if not self._pending:
            return np.empty((0, self.n_dims))
        return np.array(list(self._pending.values()))

    def pending_points(self, *, unit: bool = False) -> np.ndarray:
        """The points asked and not told yet, in ask order (the order of :attr:`pending_ids`).

        Args:
            unit: give them in the unit box [0, 1]^d the hooks work in, instead of in the
                physical bounds.

        Returns:
            A new (p, d) array; (0, d) when nothing is pending.

        Raises:
            TypeError: ``unit`` is not a bool.
        """
        if not isinstance(unit, (bool, np.bool_)):
            raise TypeError(f"unit must be a bool, got {type(unit).__name__}")
        u = self._pending_unit()
        return u.copy() if unit else self._to_physical(u)

    def _hook_name(self, method: str) -> str:
        """``optimizer plugin MODULE.CLASS.METHOD``, how errors name a hook of this plugin."""
        cls = type(self)
        return f"optimizer plugin {cls.__module__}.{cls.__qualname__}.{method}"

    def _call_hook(self, method: str, *args: Any) -> Any:
        """Call the plugin hook ``method``; a failure names the plugin and the hook.

        TypeError and ValueError keep their type (see :func:`_named`); other exceptions become
        :class:`PluginError`; errors of this module and non-``Exception`` signals pass through.
        """
        try:
            return getattr(self, method)(*args)
        except (OptimizerStateError, PluginError):
            raise
        except (TypeError, ValueError) as error:
            raise _named(error, self._hook_name(method)) from error
        except Exception as error:
            raise PluginError(
                f"{self._hook_name(method)} raised {type(error).__name__}: {error}"
            ) from error

    def _failure_penalty(self) -> float:
        """The current penalty for a failed evaluation (see :class:`FailurePolicy`)."""
        known = self._best_id is not None
        return self._failure_policy.penalty(
            self._best_value if known else None, self._worst_value if known else None
        )

    # --- public interface --------------------------------------------------------------------

    @property
    def bounds(self) -> np.ndarray:
        """(d, 2) [low, high] per dimension in physical units (a copy)."""
        return np.column_stack([self._low, self._high])

    @property
    def n_dims(self) -> int:
        """d, the number of dimensions."""
        return int(self._low.size)

    @property
    def batch_size(self) -> int:
        """Points per ask."""
        return self._batch_size

    @property
    def failure_policy(self) -> FailurePolicy:
        """What backends are told for failed evaluations."""
        return self._failure_policy

    @property
    def n_asked(self) -> int:
        """Points handed out so far."""
        return self._next_id

    @property
    def n_told(self) -> int:
        """Points told so far, failures included."""
        return self._n_told

    @property
    def n_failed(self) -> int:
        """Points told as failed so far."""
        return self._n_failed

    @property
    def n_pending(self) -> int:
        """Points asked and not told yet."""
        return len(self._pending)

    @property
    def pending_ids(self) -> tuple[int, ...]:
        """Ids asked and not told yet, in ask order."""
        return tuple(self._pending)

    @property
    def iteration(self) -> int:
        """Batches whose every point has been told (completed ask/evaluate/tell rounds)."""
        return self._iteration

    def ask(self) -> Batch:
        """New points to evaluate.

        Returns:
            A :class:`Batch` of ``batch_size`` points with fresh ids, inside the bounds.

        Raises:
            OptimizerStateError: A generational optimizer still has pending points.
            PluginError: The plugin's ``_ask`` raised, or returned points of the wrong shape,
                not finite or outside the unit box.
        """
        if self.generational and self._pending:
            pending = list(self._pending)
            raise OptimizerStateError(
                f"{type(self).__name__} is generational: tell every point of the last batch "
                f"before asking the next one; {len(pending)} still pending (ids {pending}). "
                "Tell failed evaluations as nan or None."
            )
        n = self._batch_size
        ids = tuple(range(self._next_id, self._next_id + n))
        u = self._check_unit(self._call_hook("_ask", ids), n)
        x = self._to_physical(u)
        x.setflags(write=False)
        self._next_id += n
        batch = self._n_batches
        self._n_batches += 1
        self._open[batch] = n
        for i, row in zip(ids, u, strict=True):
            self._pending[i] = row
            self._batch_of[i] = batch
        return Batch(ids=ids, x=x)

    def tell(self, ids: Sequence[int] | np.ndarray, values: Sequence[Any] | np.ndarray) -> None:
        """Scores of asked points (to minimize).

        Any subset of the pending ids may be told, in any order, each once; an empty tell does
        nothing. Nothing changes if an argument is rejected, and if the backend (the plugin's
        ``_tell``) raises, the points stay pending and uncounted, so the same tell may be tried
        again; what the backend did to itself before it raised is the plugin's to undo.

        Args:
            ids: Ids from :meth:`ask`, e.g. ``batch.ids``.
            values: One score per id; None or a non-finite number (nan, inf, -inf) marks a
                failed evaluation (an invalid design, a crashed worker).

        Raises:
            TypeError: ids not ints, or values not numbers or None.
            ValueError: Unequal lengths; an id repeated, never asked, or already told.
        """
        ids_t = check_ids(ids)
        vals, failed = check_values(values, len(ids_t))
        if len(set(ids_t)) != len(ids_t):
            repeated = sorted({i for i in ids_t if ids_t.count(i) > 1})
            raise ValueError(f"ids must be unique within one tell; repeated: {repeated}")
        for i in ids_t:
            if i not in self._pending:
                state = "was already told" if 0 <= i < self._next_id else "was never asked"
                raise ValueError(
                    f"id {i} {state}; the pending ids are {list(self._pending)[:20]}"
                    f"{' ...' if len(self._pending) > 20 else ''}"
                )
        if not ids_t:
            return
        saved = self._bookkeeping()
        try:
            u = np.array([self._pending.pop(i) for i in ids_t])
            self._record(ids_t, u, vals, failed)
            if self.generational:
                self._held.extend(zip(ids_t, u, vals, failed, strict=True))
                if not self._pending:
                    held = sorted(self._held, key=lambda item: item[0])
                    self._held = []
                    self._feed(
                        tuple(int(item[0]) for item in held),
                        np.array([item[1] for item in held]),
                        np.array([item[2] for item in held]),
                        np.array([item[3] for item in held]),
                    )
            else:
                self._feed(ids_t, u, vals, failed)
        except BaseException:
            self._restore(saved)
            raise

    def recommend(self) -> Recommendation:
        """The incumbent: the best finite value told so far.

        Returns:
            Its point (physical units), value and id.

        Raises:
            OptimizerStateError: No finite value has been told yet.
        """
        if self._best_id is None or self._best_x is None:
            raise OptimizerStateError(
                f"nothing to recommend yet: no finite value told ({self._n_told} told, "
                f"{self._n_failed} failed)"
            )
        x = self._best_x.copy()
        x.setflags(write=False)
        return Recommendation(x=x, value=float(self._best_value), id=self._best_id)

    def save_state(self, path: str | os.PathLike[str]) -> str:
        """Write the whole optimizer, pending points included, to ``path`` atomically.

        The file is written to a temporary file in the same folder and moved into place with
        ``os.replace``, so ``path`` holds either the old or the new state, never half of one.
        The format is a pickle (the backends' states can only be pickled), and unpickling a
        file can run code: record the returned digest and pass it to :meth:`load_state` for a
        file that has left your hands.

        Args:
            path: File to write; its folder must exist.

        Returns:
            The hex SHA-256 of the file written.

        Raises:
            TypeError: path is not a str or os.PathLike.
            ValueError: path is a folder, or names one (it is empty or ends in a separator,
                ``.`` or ``..``).
            FileNotFoundError: The folder of path does not exist.
            PluginError: The plugin's ``_backend_versions`` raised or returned no dict of str,
                or the plugin cannot be pickled (it holds a lock, an open file, ...).
        """
        target = check_path(path)
        if os.path.isdir(target):
            raise ValueError(f"path must be a file, {target!r} is a folder")
        if os.path.basename(target) in ("", ".", ".."):
            # "dir/" names a folder even when none exists: os.replace would fail with
            # NotADirectoryError, after the folder check below had looked at dir's parent.
            raise ValueError(
                f"path must be a file, {target!r} names a folder (it is empty or ends in a "
                "separator, '.' or '..'); give a file name, e.g. state.pkl"
            )
        folder = os.path.dirname(os.path.abspath(target))
        if not os.path.isdir(folder):
            raise FileNotFoundError(f"cannot save the state to {target!r}: no folder {folder!r}")
        cls = type(self)
        payload = {
            "format": STATE_FORMAT,
            "version": STATE_VERSION,
            "class": f"{cls.__module__}:{cls.__qualname__}",
            "versions": self._versions(),
            # Pickled separately so that a file of an uninstalled plugin still reads its header.
            "optimizer": self._pickled(),
        }
        data = pickle.dumps(payload, protocol=pickle.HIGHEST_PROTOCOL)
        fd, tmp = tempfile.mkstemp(
            prefix=f".{os.path.basename(target)}.", suffix=".tmp", dir=folder
        )
        try:
            with os.fdopen(fd, "wb") as handle:
                handle.write(data)
                handle.flush()
                os.fsync(handle.fileno())
            os.replace(tmp, target)
        except BaseException:
            if os.path.exists(tmp):
                os.unlink(tmp)
            raise
        return hashlib.sha256(data).hexdigest()

    def _pickled(self) -> bytes:
        """The optimizer pickled; a plugin that cannot be is a :class:`PluginError` saying why."""
        try:
            return pickle.dumps(self, protocol=pickle.HIGHEST_PROTOCOL)
        except (TypeError, AttributeError, pickle.PicklingError) as error:
            cls = type(self)
            raise PluginError(
                f"optimizer plugin {cls.__module__}.{cls.__qualname__} cannot be pickled "
                f"({type(error).__name__}: {error}); give it __getstate__/__setstate__ that leave "
                "out what cannot be pickled (a lock, an open file, a logger with a stream) and "
                "rebuild it, as optimizers/pso.py does, so that save_state can write its state"
            ) from error

    @classmethod
    def load_state(cls: type[_O], path: str | os.PathLike[str], *, sha256: str | None = None) -> _O:
        """Read an optimizer written by :meth:`save_state`; it continues exactly where it was.

        Call it on :class:`Optimizer` to accept any plugin, or on a plugin class to insist on
        it. Warns (RuntimeWarning) if numpy or a backend has another version than at saving,
        since the continuation may then differ. The file is a pickle, which can run code when
        loaded: without ``sha256`` load only files you wrote yourself; with it, the file is
        read only if its bytes have that digest (the one :meth:`save_state` returned), so a
        replaced, edited or truncated file is refused before anything is unpickled.

        Args:
            path: File written by :meth:`save_state`.
            sha256: Hex SHA-256 the file must have, from a record you trust.

        Returns:
            The optimizer.

        Raises:
            TypeError: path is not a str or os.PathLike, or the file holds another class.
            ValueError: The file is not an optimizer state of this format.
            FileNotFoundError: No such file.
            ImportError: The plugin's module cannot be imported.
            PluginError: The plugin's ``_backend_versions`` raised or returned no dict of str.
        """
        source = check_path(path)
        with open(source, "rb") as handle:
            data = handle.read()
        if sha256 is not None:
            if not isinstance(sha256, str):
                raise TypeError(f"sha256 must be a hex digest str, got {sha256!r}")
            actual = hashlib.sha256(data).hexdigest()
            if actual != sha256.lower():
                raise ValueError(
                    f"{source!r} has sha256 {actual}, not the expected {sha256}: the file was "
                    "replaced, edited or truncated; it was not loaded"
                )
        try:
            payload = pickle.loads(data)
        except Exception as error:  # any unpickling failure means: not our file
            raise ValueError(
                f"{source!r} is not an optimizer state file ({type(error).__name__}: {error})"
            ) from error
        if not (
            isinstance(payload, dict)
            and payload.get("format") == STATE_FORMAT
            and isinstance(payload.get("optimizer"), bytes)
        ):
            raise ValueError(
                f"{source!r} is not an optimizer state file (no {STATE_FORMAT} header)"
            )
        if payload.get("version") != STATE_VERSION:
            raise ValueError(
                f"{source!r} has state format version {payload.get('version')!r}; this version "
                f"reads {STATE_VERSION}"
            )
        try:
            optimizer = pickle.loads(payload["optimizer"])
        except (ImportError, AttributeError) as error:
            raise ImportError(
                f"{source!r} holds a {payload.get('class')} whose module cannot be imported: "
                f"{error}"
            ) from error
        except Exception as error:  # a corrupted body behind a good header
            raise ValueError(
                f"{source!r} holds a corrupted optimizer state ({type(error).__name__}: {error})"
            ) from error
        if not isinstance(optimizer, cls):
            raise TypeError(
                f"{source!r} holds a {type(optimizer).__name__}, not a {cls.__name__}; load it "
                "with Optimizer.load_state"
            )
        saved, now = payload.get("versions", {}), optimizer._versions()
        changed = {k: (saved.get(k), now.get(k)) for k in saved.keys() | now.keys()}
        changed = {k: v for k, v in changed.items() if v[0] != v[1]}
        if changed:
            detail = ", ".join(f"{k} {a} -> {b}" for k, (a, b) in sorted(changed.items()))
            warnings.warn(
                f"{source!r} was saved with other package versions ({detail}); the run may not "
                "continue exactly as it would have",
                RuntimeWarning,
                stacklevel=2,
            )
        return optimizer

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}(n_dims={self.n_dims}, batch_size={self._batch_size}, "
            f"iteration={self._iteration}, n_told={self._n_told}, n_pending={self.n_pending})"
        )

    # --- internals ---------------------------------------------------------------------------

    def _versions(self) -> dict[str, str]:
        versions = {"numpy": np.__version__, "python": sys.version.split()[0]}
        versions.update(self._versions_of_backend())
        return versions

    def _versions_of_backend(self) -> dict[str, str]:
        """:meth:`_backend_versions`, checked to be a dict of str to str."""
        versions = self._call_hook("_backend_versions")
        if not (
            isinstance(versions, dict)
            and all(isinstance(k, str) and isinstance(v, str) for k, v in versions.items())
        ):
            raise PluginError(
                f"{self._hook_name('_backend_versions')} returned {versions!r}, expected a dict "
                "of package names to version strings"
            )
        return versions

    def _check_unit(self, u: Any, n: int) -> np.ndarray:
        """What ``_ask`` returned, checked: (n, d) finite numbers in the unit box (copied).

        Raises:
            PluginError: Anything else; the plugin broke its contract.
        """
        name = self._hook_name("_ask")
        if u is None:
            raise PluginError(f"{name} returned something that is not numbers: None")
        try:
            array = np.array(u, dtype=np.float64)  # a copy: the plugin may reuse its buffer
        except (TypeError, ValueError) as error:
            raise PluginError(f"{name} returned something that is not numbers: {error}") from None
        if array.shape != (n, self.n_dims):
            raise PluginError(f"{name} returned shape {array.shape}, expected {(n, self.n_dims)}")
        if not np.all(np.isfinite(array)):
            raise PluginError(f"{name} returned non-finite points")
        if np.any(array < -_UNIT_TOLERANCE) or np.any(array > 1.0 + _UNIT_TOLERANCE):
            raise PluginError(
                f"{name} returned points outside the unit box [0, 1]^d "
                f"(min {array.min()}, max {array.max()})"
            )
        return np.clip(array, 0.0, 1.0)

    #: What :meth:`tell` changes in this class, restored when the backend raises.
    _TELL_STATE: ClassVar[tuple[str, ...]] = (
        "_pending",
        "_batch_of",
        "_open",
        "_held",
        "_iteration",
        "_n_told",
        "_n_failed",
        "_best_value",
        "_worst_value",
        "_best_id",
        "_best_x",
    )

    def _bookkeeping(self) -> dict[str, Any]:
        """The :data:`_TELL_STATE`, copied (its containers shallowly), for :meth:`_restore`."""
        return {name: copy.copy(getattr(self, name)) for name in self._TELL_STATE}

    def _restore(self, saved: dict[str, Any]) -> None:
        for name, value in saved.items():
            setattr(self, name, value)

    def _record(
        self, ids: tuple[int, ...], u: np.ndarray, values: np.ndarray, failed: np.ndarray
    ) -> None:
        """Counts, completed batches, incumbent and the range of finite values."""
        self._n_told += len(ids)
        self._n_failed += int(failed.sum())
        for i in ids:
            batch = self._batch_of.pop(i)
            self._open[batch] -= 1
            if self._open[batch] == 0:
                del self._open[batch]
                self._iteration += 1
        for i, row, value, bad in zip(ids, u, values, failed, strict=True):
            if bad:
                continue
            self._worst_value = max(self._worst_value, float(value))
            if value < self._best_value:
                self._best_value = float(value)
                self._best_id = i
                self._best_x = self._to_physical(row)

    def _feed(
        self, ids: tuple[int, ...], u: np.ndarray, values: np.ndarray, failed: np.ndarray
    ) -> None:
        told = np.where(failed, self._failure_penalty(), values)
        if not np.all(np.isfinite(told)):  # the promise of this class; -O must not drop it
            raise RuntimeError(f"non-finite values would reach the backend: {told}")
        self._call_hook("_tell", ids, u, told, failed.copy())
