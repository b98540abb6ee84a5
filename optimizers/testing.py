"""Conformance checks an optimizer plugin runs on itself (like optuna's ``pytest_samplers``).

Every check takes a *factory*: a callable ``factory(bounds=..., batch_size=..., seed=...)``
returning an :class:`~optimizers.base.Optimizer` (a plugin class is one), and raises
``AssertionError("CHECK_NAME: ...")`` on a violation, also when the plugin itself raises (a
``PluginError``, the ``ValueError`` of its ``_tell``, the ``TypeError`` of an unpicklable
state): that exception is then the ``__cause__``. Run them all::

    from optimizers.testing import check_optimizer
    check_optimizer(MyOptimizer)

or one pytest test per check::

    import pytest
    from optimizers.testing import CHECKS

    @pytest.mark.parametrize("check", CHECKS, ids=lambda c: c.__name__)
    def test_conformance(check):
        check(MyOptimizer)

A check that does not apply to a method (different seeds giving different asks, for a
deterministic one) is declared on the plugin class, so that every runner of the checks (your
tests, :func:`check_optimizer`, the tests of a package the plugin is installed beside) leaves
it out::

    class MyOptimizer(Optimizer):
        conformance_skip = ("check_seed_changes_asks",)

Such a check then raises ``unittest.SkipTest``, which pytest reports as a skip with the reason.

The checks need only numpy (no pytest) and take a few seconds for a fast plugin.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import os
import tempfile
import unittest
from collections.abc import Callable, Iterable
from typing import Any, cast

import numpy as np

from .base import Batch, Optimizer, OptimizerStateError, Recommendation

__all__ = [
    "CHECKS",
    "ConformanceReport",
    "check_asks_inside_bounds",
    "check_bad_inputs_raise",
    "check_counts",
    "check_failures_never_reach_backend",
    "check_generation_rule",
    "check_ids_unique",
    "check_improves_on_sphere",
    "check_interleaved_instances_independent",
    "check_optimizer",
    "check_recommend",
    "check_same_seed_same_asks",
    "check_save_load_continues_identically",
    "check_seed_changes_asks",
    "declared_skips",
    "shifted_sphere",
]

Factory = Callable[..., Optimizer]

#: The 3-D box of the checks: [-1.5, 1.5]^2 x [-0.5, 0.5], like the tool's coefficient bounds.
BOUNDS = np.array([[-1.5, 1.5], [-1.5, 1.5], [-0.5, 0.5]])
_SHIFT = np.array([0.4, -0.7, 0.2])


def shifted_sphere(x: np.ndarray) -> np.ndarray:
    """Sum of squares around (0.4, -0.7, 0.2) (inside :data:`BOUNDS`), minimum 0.

    Args:
        x: (n, 3) points.

    Returns:
        (n,) values.
    """
    return cast("np.ndarray", np.sum((np.asarray(x) - _SHIFT) ** 2, axis=1))


def _make(factory: Factory, *, bounds: Any = BOUNDS, batch_size: int = 4, seed: Any = 0) -> Any:
    optimizer = factory(bounds=bounds, batch_size=batch_size, seed=seed)
    assert isinstance(optimizer, Optimizer), (
        f"the factory must return an optimizers.Optimizer, got {type(optimizer).__name__}"
    )
    return optimizer


def _step(
    optimizer: Optimizer, objective: Callable[[np.ndarray], np.ndarray] = shifted_sphere
) -> Batch:
    """One ask, evaluate, tell round; returns the batch."""
    batch = optimizer.ask()
    optimizer.tell(batch.ids, objective(batch.x))
    return batch


def _run(optimizer: Optimizer, iterations: int) -> list[np.ndarray]:
    return [np.array(_step(optimizer).x) for _ in range(iterations)]


def _same(a: list[np.ndarray], b: list[np.ndarray]) -> bool:
    return len(a) == len(b) and all(
        x.shape == y.shape and np.array_equal(x, y) for x, y in zip(a, b, strict=True)
    )


def _check_declaration(cls: type) -> frozenset[str]:
    """``cls.conformance_skip``, checked to name checks of :data:`CHECKS`."""
    declared = getattr(cls, "conformance_skip", ())
    where = f"{cls.__module__}.{cls.__qualname__}.conformance_skip"
    if not (
        isinstance(declared, (tuple, list, set, frozenset))
        and all(isinstance(name, str) for name in declared)
    ):
        raise TypeError(
            f"{where} must be a tuple of check names, got {declared!r} (a single name needs a "
            "trailing comma: (name,))"
        )
    known = {check.__name__ for check in CHECKS}
    unknown = set(declared) - known
    if unknown:
        raise ValueError(f"{where} names unknown checks {sorted(unknown)}; known: {sorted(known)}")
    return frozenset(declared)


def declared_skips(factory: Factory) -> frozenset[str]:
    """The checks a plugin declares not to apply to it: its class's ``conformance_skip``.

    Args:
        factory: A plugin class, or a factory; a factory is called once (as the checks call
            it) to see the class of what it makes.

    Returns:
        Names of checks of :data:`CHECKS`; empty if the class declares none.

    Raises:
        TypeError: ``conformance_skip`` is not a tuple of str.
        ValueError: ``conformance_skip`` names a check that does not exist.
    """
    cls = factory if isinstance(factory, type) else type(_make(factory))
    return _check_declaration(cls)


def _applicable(check: Callable[[Factory], None]) -> Callable[[Factory], None]:
    """``check``, skipped (``unittest.SkipTest``) for a plugin that declares it inapplicable.

    Whatever the plugin raises while checked (a ``PluginError`` for points outside the box, the
    ``ValueError`` of its ``_tell``, the ``TypeError`` of an unpicklable state) fails the check:
    ``AssertionError("CHECK: ...")`` with the original exception as its ``__cause__``.
    """

    @functools.wraps(check)
    def run(factory: Factory) -> None:
        if isinstance(factory, type):
            cls: type | None = factory
        else:
            try:
                cls = type(_make(factory))
            except Exception:  # the check itself calls the factory and reports the failure
                cls = None
        if cls is not None and check.__name__ in _check_declaration(cls):
            raise unittest.SkipTest(
                f"{check.__name__} does not apply: listed in "
                f"{cls.__module__}.{cls.__qualname__}.conformance_skip"
            )
        try:
            check(factory)
        except unittest.SkipTest:
            raise
        except AssertionError as error:
            raise AssertionError(f"{check.__name__}: {error}") from error
        except Exception as error:  # a bug of the plugin fails the check, named
            raise AssertionError(
                f"{check.__name__}: raised {type(error).__name__}: {error}"
            ) from error

    return run


@_applicable
def check_asks_inside_bounds(factory: Factory) -> None:
    """Batches have the right types and shapes, are read-only, finite and inside the bounds."""
    boxes = [
        BOUNDS,
        np.array([[-3.0e-6, -1.0e-6], [2.0e5, 7.0e5], [0.0, 1.0], [-1.0, 4.0]]),
        np.array([[10.0, 10.5], [-100.0, -99.0]]),
    ]
    for bounds in boxes:
        d = len(bounds)
        optimizer = _make(factory, bounds=bounds, batch_size=5, seed=3)
        for _ in range(3):
            batch = optimizer.ask()
            assert isinstance(batch, Batch), f"ask() must return a Batch, got {type(batch)}"
            assert isinstance(batch.ids, tuple) and all(
                isinstance(i, int) and not isinstance(i, bool) for i in batch.ids
            ), f"Batch.ids must be a tuple of int, got {batch.ids!r}"
            assert len(batch.ids) == 5, f"expected 5 ids, got {len(batch.ids)}"
            x = batch.x
            assert isinstance(x, np.ndarray) and x.shape == (5, d) and x.dtype == np.float64, (
                f"Batch.x must be a float64 array of shape (5, {d}), got {type(x)} "
                f"{getattr(x, 'shape', None)} {getattr(x, 'dtype', None)}"
            )
            assert not x.flags.writeable, "Batch.x must be read-only"
            assert np.all(np.isfinite(x)), "Batch.x must be finite"
            inside = (x >= bounds[:, 0]) & (x <= bounds[:, 1])
            assert np.all(inside), (
                f"points outside the bounds {bounds.tolist()}: {x[~inside.all(1)]}"
            )
            center = bounds.mean(axis=1)
            optimizer.tell(batch.ids, np.sum(((x - center) / np.ptp(bounds, axis=1)) ** 2, axis=1))


@_applicable
def check_ids_unique(factory: Factory) -> None:
    """Ids are distinct ints over a run."""
    optimizer = _make(factory)
    ids = [i for _ in range(5) for i in _step(optimizer).ids]
    assert len(set(ids)) == len(ids), f"ids repeat: {ids}"


@_applicable
def check_same_seed_same_asks(factory: Factory) -> None:
    """Equal seeds (an int, its SeedSequence or a Generator from it) give equal asks."""
    reference = _run(_make(factory, seed=123), 5)
    for seed in (123, np.random.SeedSequence(123), np.random.default_rng(123)):
        assert _same(reference, _run(_make(factory, seed=seed), 5)), (
            f"the same seed ({seed!r}) gave other asks"
        )


@_applicable
def check_seed_changes_asks(factory: Factory) -> None:
    """Different seeds give different asks (skip this one for a deterministic method)."""
    a, b = _run(_make(factory, seed=1), 2), _run(_make(factory, seed=2), 2)
    assert not _same(a, b), "seeds 1 and 2 gave the same asks"


@_applicable
def check_interleaved_instances_independent(factory: Factory) -> None:
    """Two instances stepped in turns ask what each asks alone; np.random is left alone.

    The caller's own ``np.random`` draws between the steps must not shift the optimizers, and
    ask/tell must leave the caller's ``np.random`` state as it was.
    """
    alone = _run(_make(factory, seed=7), 5)
    first, second = _make(factory, seed=7), _make(factory, seed=8)
    together = []
    for _ in range(5):
        np.random.random(3)  # noqa: NPY002 - the caller's global draws must not shift them
        before = np.random.get_state(legacy=True)  # noqa: NPY002
        together.append(np.array(_step(first).x))
        _step(second)
        after = np.random.get_state(legacy=True)  # noqa: NPY002
        assert _same_global_state(before, after), (
            "ask/tell changed numpy's global random state (np.random)"
        )
    assert _same(alone, together), "an instance asked other points when another one ran beside it"


def _same_global_state(before: Any, after: Any) -> bool:
    """Whether two ``np.random.get_state(legacy=True)`` tuples are equal."""
    return bool(
        before[0] == after[0] and np.array_equal(before[1], after[1]) and before[2:] == after[2:]
    )


@_applicable
def check_failures_never_reach_backend(factory: Factory) -> None:
    """nan, inf, -inf and None are failures that no backend sees.

    They are counted and never recommended, the plugin's hook (hence its backend) sees only
    finite values, and a first batch that failed entirely is handled.
    """
    optimizer = _make(factory, batch_size=4, seed=5)
    seen: list[np.ndarray] = []
    hook = optimizer._tell

    def spy(ids: Any, x: Any, values: Any, failed: Any) -> None:
        seen.append(np.array(values, dtype=np.float64))
        hook(ids, x, values, failed)

    optimizer._tell = spy
    batch = optimizer.ask()
    optimizer.tell(batch.ids, [math.nan, math.inf, None, -math.inf])
    assert optimizer.n_failed == 4 and optimizer.n_told == 4, "failures must be counted"
    try:
        optimizer.recommend()
    except OptimizerStateError:
        pass
    else:
        raise AssertionError("recommend() must raise OptimizerStateError when everything failed")
    for k in range(4):
        batch = optimizer.ask()
        values: list[Any] = list(shifted_sphere(batch.x))
        values[k % len(values)] = [math.nan, None, math.inf, -math.inf][k]
        optimizer.tell(batch.ids, values)
        assert np.all((batch.x >= BOUNDS[:, 0]) & (batch.x <= BOUNDS[:, 1])), "asks left the box"
    assert optimizer.n_failed == 8, f"n_failed must be 8, got {optimizer.n_failed}"
    assert seen, "the plugin's _tell hook was never called"
    for told in seen:
        assert np.all(np.isfinite(told)), f"non-finite values reached the plugin: {told}"
    best = optimizer.recommend()
    assert math.isfinite(best.value), "the recommendation must be a finite value"
    del optimizer._tell


@_applicable
def check_save_load_continues_identically(factory: Factory) -> None:
    """A saved and loaded run continues with the asks of an uninterrupted run.

    Saved after full iterations and with points pending; the write leaves no temporary file.
    """
    reference = _make(factory, seed=11)
    expected = _run(reference, 6)
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "state.pkl")
        optimizer = _make(factory, seed=11)
        got = _run(optimizer, 3)
        optimizer.save_state(path)
        optimizer.save_state(path)  # overwriting is fine
        assert os.listdir(folder) == ["state.pkl"], f"save_state left files: {os.listdir(folder)}"
        restored = type(optimizer).load_state(path)
        assert type(restored) is type(optimizer), "load_state returned another class"
        assert restored.n_told == optimizer.n_told and restored.iteration == 3, "counts differ"
        got += _run(restored, 3)
        assert _same(expected, got), "the loaded optimizer asked other points than the original"

        # Interrupted between ask and tell: the pending points are part of the state.
        optimizer = _make(factory, seed=11)
        _run(optimizer, 2)
        batch = optimizer.ask()
        optimizer.save_state(path)
        restored = Optimizer.load_state(path)
        assert restored.pending_ids == batch.ids, "pending ids were not restored"
        restored.tell(batch.ids, shifted_sphere(batch.x))
        got = _run(_make(factory, seed=11), 2) + [np.array(batch.x)] + _run(restored, 2)
        assert _same(expected[:5], got), "a state saved with pending points continued differently"


@_applicable
def check_improves_on_sphere(factory: Factory) -> None:
    """On a shifted sphere in 3-D, 12 iterations of 8 beat the first batch's best.

    In at least 2 of 3 seeds, so that random sampling passes too (it fails a seed with
    probability 1/12).
    """
    wins = 0
    for seed in (0, 1, 2):
        optimizer = _make(factory, batch_size=8, seed=seed)
        first = float(np.min(shifted_sphere(_step(optimizer).x)))
        for _ in range(11):
            _step(optimizer)
        wins += optimizer.recommend().value < first
    assert wins >= 2, f"improved on its first batch in only {wins} of 3 seeds"


@_applicable
def check_generation_rule(factory: Factory) -> None:
    """A generational plugin refuses to ask with points pending; others ask on.

    The generational refusal holds also when the batch is told in parts; non-generational
    plugins hand out new ids while points are pending.
    """
    optimizer = _make(factory, batch_size=4)
    first = optimizer.ask()
    if optimizer.generational:
        for told in (0, 2):
            if told:
                optimizer.tell(first.ids[:told], shifted_sphere(first.x[:told]))
            try:
                optimizer.ask()
            except OptimizerStateError:
                pass
            else:
                raise AssertionError(
                    "a generational optimizer must refuse to ask with points pending"
                )
        optimizer.tell(first.ids[2:], shifted_sphere(first.x[2:]))
        assert optimizer.iteration == 1, "the generation told in two parts must complete it"
        optimizer.ask()
    else:
        second = optimizer.ask()
        assert not set(first.ids) & set(second.ids), "two pending batches share ids"
        assert optimizer.n_pending == 8, f"expected 8 pending points, got {optimizer.n_pending}"
        optimizer.tell(second.ids[::-1], shifted_sphere(second.x[::-1]))
        optimizer.tell(first.ids, shifted_sphere(first.x))
        assert optimizer.iteration == 2, "two batches told must make two iterations"
        optimizer.ask()


@_applicable
def check_recommend(factory: Factory) -> None:
    """recommend() raises before any value, then returns the best value and its asked point."""
    optimizer = _make(factory)
    try:
        optimizer.recommend()
    except OptimizerStateError:
        pass
    else:
        raise AssertionError("recommend() must raise OptimizerStateError before any tell")
    asked: dict[int, np.ndarray] = {}
    told: dict[int, float] = {}
    for _ in range(3):
        batch = optimizer.ask()
        values = shifted_sphere(batch.x)
        asked.update(zip(batch.ids, np.array(batch.x), strict=True))
        told.update(zip(batch.ids, values.tolist(), strict=True))
        optimizer.tell(batch.ids, values)
    best = optimizer.recommend()
    assert isinstance(best, Recommendation), (
        f"recommend() must return a Recommendation, got {best!r}"
    )
    best_id = min(told, key=lambda i: (told[i], i))
    assert best.id == best_id and best.value == told[best_id], "not the best value told"
    assert np.array_equal(best.x, asked[best_id]), "the recommended x is not the asked point"
    assert not best.x.flags.writeable, "Recommendation.x must be read-only"


@_applicable
def check_counts(factory: Factory) -> None:
    """n_asked, n_told, n_failed, n_pending and iteration count what happened."""
    optimizer = _make(factory, batch_size=4)
    assert (optimizer.n_asked, optimizer.n_told, optimizer.iteration) == (0, 0, 0)
    batch = optimizer.ask()
    assert (optimizer.n_asked, optimizer.n_pending) == (4, 4)
    optimizer.tell(batch.ids[:1], [None])
    optimizer.tell(batch.ids[1:], shifted_sphere(batch.x[1:]))
    counts = (optimizer.n_told, optimizer.n_failed, optimizer.n_pending, optimizer.iteration)
    assert counts == (4, 1, 0, 1), f"(n_told, n_failed, n_pending, iteration) = {counts}"
    assert optimizer.n_dims == 3 and optimizer.batch_size == 4
    assert np.array_equal(optimizer.bounds, BOUNDS)


def _raises(kinds: tuple[type[BaseException], ...], call: Callable[[], Any], what: str) -> None:
    try:
        call()
    except kinds:
        return
    except Exception as error:  # the wrong kind is as bad as none
        raise AssertionError(
            f"{what}: raised {type(error).__name__} ({error}), expected {kinds}"
        ) from error
    raise AssertionError(f"{what}: nothing raised, expected {kinds}")


@_applicable
def check_bad_inputs_raise(factory: Factory) -> None:
    """Bad arguments of every entry point raise TypeError or ValueError.

    The constructor, tell, save_state and load_state are tried; a rejected tell changes
    nothing.
    """
    value_or_type = (ValueError, TypeError)
    for bounds in (
        [[1.0, 0.0], [0.0, 1.0]],
        [[0.0, math.nan], [0.0, 1.0]],
        [0.0, 1.0],
        [["a", "b"]],
    ):
        _raises(
            value_or_type,
            functools.partial(factory, bounds=bounds, batch_size=4, seed=0),
            f"bounds={bounds!r}",
        )
    for batch_size in (0, -1, 2.5, True):
        _raises(
            value_or_type,
            functools.partial(factory, bounds=BOUNDS, batch_size=batch_size, seed=0),
            f"batch_size={batch_size!r}",
        )
    for seed in (-1, 1.5, "seed"):
        _raises(
            value_or_type,
            functools.partial(factory, bounds=BOUNDS, batch_size=4, seed=seed),
            f"seed={seed!r}",
        )

    optimizer = _make(factory, batch_size=4)
    batch = optimizer.ask()
    good = shifted_sphere(batch.x)
    bad_tells: list[tuple[Any, Any, str]] = [
        (batch.ids[:3], good, "more values than ids"),
        (batch.ids, good[:3], "fewer values than ids"),
        ((batch.ids[0], batch.ids[0]), good[:2], "a repeated id"),
        ((max(batch.ids) + 100,), good[:1], "an id never asked"),
        ((-1,), good[:1], "a negative id"),
        ((1.0,), good[:1], "a float id"),
        ((True,), good[:1], "a bool id"),
        (batch.ids[0], good[:1], "ids not a sequence"),
        (batch.ids, ["a"] * 4, "string values"),
        (batch.ids, good.reshape(2, 2), "2-D values"),
        (batch.ids, [True] * 4, "bool values"),
    ]
    for ids, values, what in bad_tells:
        _raises(value_or_type, functools.partial(optimizer.tell, ids, values), f"tell with {what}")
    assert optimizer.n_told == 0 and optimizer.n_pending == 4, "a rejected tell changed the counts"
    optimizer.tell(batch.ids, good)
    _raises(
        value_or_type, lambda: optimizer.tell(batch.ids[:1], good[:1]), "tell of an id already told"
    )

    with tempfile.TemporaryDirectory() as folder:
        _raises(value_or_type, lambda: optimizer.save_state(folder), "save_state to a folder")
        _raises(value_or_type, lambda: optimizer.save_state(3), "save_state to an int")
        junk = os.path.join(folder, "junk.pkl")
        with open(junk, "wb") as handle:
            handle.write(b"not a state")
        _raises(value_or_type, lambda: Optimizer.load_state(junk), "load_state of junk")
        _raises(value_or_type, lambda: Optimizer.load_state(None), "load_state of None")  # type: ignore[arg-type]


CHECKS: tuple[Callable[[Factory], None], ...] = (
    check_asks_inside_bounds,
    check_ids_unique,
    check_same_seed_same_asks,
    check_seed_changes_asks,
    check_interleaved_instances_independent,
    check_failures_never_reach_backend,
    check_save_load_continues_identically,
    check_improves_on_sphere,
    check_generation_rule,
    check_recommend,
    check_counts,
    check_bad_inputs_raise,
)


@dataclasses.dataclass(frozen=True)
class ConformanceReport:
    """What :func:`check_optimizer` ran: printed, one line that says the plugin passed.

    Attributes:
        plugin: The plugin's ``module.Class``, or the factory's repr.
        passed: Names of the checks that ran and passed, in :data:`CHECKS` order.
        declared: Checks the class declares inapplicable (``conformance_skip``): not run.
        skipped: Checks left out by ``skip=``: not run.
    """

    plugin: str
    passed: tuple[str, ...]
    declared: tuple[str, ...] = ()
    skipped: tuple[str, ...] = ()

    def __str__(self) -> str:
        """E.g. ``tooldesign_hillclimb.HillClimb: all 14 conformance checks passed``."""
        total = len(self.passed) + len(self.declared) + len(self.skipped)
        if not self.declared and not self.skipped:
            return f"{self.plugin}: all {total} conformance checks passed"
        text = f"{self.plugin}: {len(self.passed)} of {total} conformance checks passed"
        if self.declared:
            text += f"; not run, declared in conformance_skip: {', '.join(self.declared)}"
        if self.skipped:
            text += f"; not run, left out by skip=: {', '.join(self.skipped)}"
        return text


def _plugin_name(factory: Factory) -> str:
    target = factory.func if isinstance(factory, functools.partial) else factory
    if isinstance(factory, functools.partial) and factory.args:
        return f"{getattr(target, '__name__', repr(target))}({factory.args[0]!r})"
    module, name = getattr(target, "__module__", None), getattr(target, "__qualname__", None)
    return f"{module}.{name}" if module and name else repr(factory)


def check_optimizer(factory: Factory, *, skip: Iterable[str] = ()) -> ConformanceReport:
    """Run every check of :data:`CHECKS` on a plugin, but those it declares inapplicable.

    Args:
        factory: Called as ``factory(bounds=..., batch_size=..., seed=...)``; a plugin class is
            one. Checks use batch sizes 4, 5 and 8 and 2 to 4 dimensions.
        skip: Names of further checks not to run, besides those in the class's
            ``conformance_skip`` (see :func:`declared_skips`).

    Returns:
        What ran and passed; ``print(check_optimizer(MyOptimizer))`` prints one line, e.g.
        ``tooldesign_hillclimb.HillClimb: all 14 conformance checks passed``.

    Raises:
        AssertionError: The first check that fails, with its name in the message.
        TypeError: The class's ``conformance_skip`` is not a tuple of str.
        ValueError: An unknown name in ``skip`` or in ``conformance_skip``.
    """
    names = {check.__name__ for check in CHECKS}
    left_out = set(skip)
    unknown = left_out - names
    if unknown:
        raise ValueError(f"unknown checks in skip: {sorted(unknown)}; known: {sorted(names)}")
    passed, declared = [], []
    for check in CHECKS:
        if check.__name__ in left_out:
            continue
        try:
            check(factory)
        except unittest.SkipTest:  # declared inapplicable by the plugin
            declared.append(check.__name__)
            continue
        passed.append(check.__name__)
    return ConformanceReport(
        plugin=_plugin_name(factory),
        passed=tuple(passed),
        declared=tuple(declared),
        skipped=tuple(c.__name__ for c in CHECKS if c.__name__ in left_out),
    )
