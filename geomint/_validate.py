"""Numbers at the boundary: one rule for every argument that must be a real number.

Strings, bools and non-numbers are refused (``"0.1"`` and ``True`` are not
step sizes), integers too large for float64 are refused rather than raising
OverflowError, and every error names the argument.
"""

from __future__ import annotations

import collections
import functools
import numbers
import os
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Iterable

    import numpy.typing as npt


def real(name: str, value: object) -> float:
    """``value`` as a float, or a TypeError/ValueError naming ``name``."""
    if type(value) is float:
        return value
    if isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iuf":
        value = value[()]  # a 0-d array: its number, as numpy's own functions take it
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"`{name}` must be a real number; got {value!r} ({type(value).__name__}).")
    try:
        return float(value)
    except OverflowError:
        raise ValueError(
            f"`{name}` must be finite in float64; got an integer of {len(str(abs(value)))} digits."
        ) from None


def reals(name: str, values: object) -> npt.NDArray[np.float64]:
    """``values`` (a number or a 1-D sequence of real numbers, all finite) as a float64 array, or a
    TypeError/ValueError naming ``name``."""
    try:
        array = np.asarray(values)
    except (TypeError, ValueError):  # ragged
        array = None
    if array is None or array.dtype.kind not in "iuf":
        raise TypeError(f"`{name}` must be a sequence of real numbers; got {values!r}.")
    if array.ndim > 1:
        raise ValueError(f"`{name}` must be 1-dimensional; got shape {array.shape}.")
    array = array.astype(np.float64).reshape(-1)
    if not np.all(np.isfinite(array)):
        raise ValueError(f"`{name}` must be finite; got {array.tolist()!r}.")
    return array


def flag(name: str, value: object) -> bool:
    """``value`` as a bool where it is True or False (numpy's too), else a TypeError naming ``name`` ("no" or 0 is
    not taken for a truth value)."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"`{name}` must be True or False; got {value!r}.")
    return bool(value)


def repeated(names: Iterable[str]) -> list[tuple[str, int]]:
    """The names given more than once, sorted, each with its count (in linear time: a system's variables can
    number in the hundreds of thousands)."""
    return sorted((name, count) for name, count in collections.Counter(names).items() if count > 1)


def memory_problem(nbytes: int) -> str | None:
    """None when ``nbytes`` fits in half this machine's memory, else the figures as text."""
    available = _physical_memory()
    if available is None or nbytes <= available // 2:
        return None
    return f"needs {nbytes / 2**30:.3g} GiB, more than half this machine's memory ({available / 2**30:.3g} GiB)"


def did_you_mean(key: object, known: Iterable[object]) -> str:
    """``"; did you mean `name`?"`` for the known name nearest ``key`` (difflib), else ``"."``: the end of an
    "unknown key" message."""
    import difflib

    nearest = difflib.get_close_matches(str(key), [str(k) for k in known], n=1, cutoff=0.6)
    return f"; did you mean `{nearest[0]}`?" if nearest else "."


@functools.cache
def _physical_memory() -> int | None:
    """This machine's memory in bytes (None where the system does not say), read once."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return None
