"""Exceptions that user functions raise inside compiled kernels.

A jitted user function reached from a kernel through a first-class function
type cannot pass an exception on to its caller: numba hands it to
``sys.unraisablehook`` (the "Exception ignored in ..." lines) and the call
returns garbage, so a run would go on with wrong values and end with
``success = True``.  ``catching(counters)`` records such exceptions while
kernels run: the first is kept and each one counted in ``counters[layout.RAISED]``, which
the step loop reads after every step (``loop.run``) and turns into a
failed step.  The hook is synchronous (the kernel holds the GIL when numba calls
it), per thread, and passes every other unraisable exception on unchanged.
"""

from __future__ import annotations

import contextlib
import sys
import threading
from collections.abc import Iterable, Iterator, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from ._kernels.layout import RAISED

if TYPE_CHECKING:
    import numpy.typing as npt


class UserFunctionError(ValueError):
    """A user function (``H``, ``grad_H``, ``S``, ``grad_S``, ``J`` or ``P``) raised at a state.

    ``function`` names it, ``x`` is the state, and the user's own exception is
    ``__cause__``.
    """

    def __init__(self, function: str, x: Iterable[float], error: BaseException | None, advice: str = "") -> None:
        self.function, self.x = function, list(x)
        super().__init__(f"the user function `{function}` raised {error!r} at x = {self.x}. {advice}".rstrip())


def wrote_into(function: str, before: npt.NDArray[np.float64], x: npt.NDArray[np.float64]) -> None:
    """Refuse a user function that changed its argument: ``x`` after the call of ``function``, ``before`` a copy
    taken before it (``x`` is put back first: the caller's state as it was).  The kernels pass a user function
    the step's own state, which such a function would corrupt; the checks would blame whichever function they
    call next."""
    if not np.array_equal(before, x, equal_nan=True):
        changed = x.tolist()
        x[:] = before
        raise ValueError(
            f"the user function `{function}` wrote into its argument x (called at x = {before.tolist()}, x became "
            f"{changed}): a user function must leave x unchanged (the kernels pass it the step's own state)."
        )


def raised_by(error: BaseException, functions: Mapping[str, Any]) -> str | None:
    """The name (a key of ``functions``, a dict of jitted functions) of the function ``error`` was raised in, from
    the frames numba writes into its traceback, or None."""
    codes = {
        (fn.py_func.__code__.co_filename, fn.py_func.__name__): name
        for name, fn in functions.items()
        if hasattr(fn, "py_func")
    }
    tb, found = error.__traceback__, None
    while tb is not None:
        found = codes.get((tb.tb_frame.f_code.co_filename, tb.tb_frame.f_code.co_name), found)
        tb = tb.tb_next
    return found


_active = threading.local()
_previous = None


_everywhere = []  # the records of ``catching_everywhere`` blocks running now (any thread)


def _hook(unraisable):
    record = getattr(_active, "record", None)
    if not str(unraisable.object).startswith("<numba."):
        _previous(unraisable)  # pyright: ignore[reportOptionalCall]  # set by _install before _hook is installed
    elif record is not None:
        if not record:
            record.append(unraisable.exc_value)
        if _active.counters is not None:
            _active.counters[RAISED] += 1
    elif _everywhere:  # a worker thread of a parallel kernel: no counter to say which trajectory
        _everywhere[-1].append(unraisable.exc_value)
    else:
        _previous(unraisable)  # pyright: ignore[reportOptionalCall]  # set by _install before _hook is installed


def _install():
    global _previous
    if sys.unraisablehook is not _hook:
        _previous, sys.unraisablehook = sys.unraisablehook, _hook


@contextlib.contextmanager
def catching_everywhere() -> Iterator[list[BaseException]]:
    """Record the exceptions user functions raise in kernels run by any thread during this block (a parallel
    kernel's workers): the list says *that* something raised, not in which trajectory."""
    _install()
    record = []
    _everywhere.append(record)
    try:
        yield record
    finally:
        _everywhere.remove(record)


def catching(counters: npt.NDArray[np.int64] | None = None) -> _Catching:
    """Record the first exception user functions raise inside kernels run in this block (a list, empty or of one).

    ``counters``: the run's counters array, whose ``RAISED`` entry counts them for the step loop.
    """
    return _Catching(counters)


class _Catching:
    """``catching``'s block (a class: entered and left at every ``solve``, where a generator costs more)."""

    __slots__ = ("counters", "outer")

    def __init__(self, counters: npt.NDArray[np.int64] | None) -> None:
        self.counters = counters

    def __enter__(self) -> list[BaseException]:
        _install()
        self.outer = getattr(_active, "record", None), getattr(_active, "counters", None)
        record: list[BaseException] = []
        _active.record, _active.counters = record, self.counters
        return record

    def __exit__(self, *exc_info: object) -> None:
        _active.record, _active.counters = self.outer
