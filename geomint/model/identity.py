"""What a user function *is*, across processes: its module, its name, its source and the globals compiled into it.

numba keys what it compiles by the dispatcher object, which another process
does not share.  :func:`function_key` names a module-level numba function by
``(module, qualname, digest, options)``: ``digest`` covers the function's whole
source file and the values of the globals it reads (and the numba functions it
calls read), which numba freezes into the compiled code as constants: numbers,
strings, tuples of them and arrays.  A script that reads a size from its
command line into a global gets code compiled for that size, not the code
cached for the last one (numba's own cache checks the file alone, and would
serve it).  A change in *another* file the function calls is not seen: clear
the cache (``geomint._cache``) after such a change.

Two caches are keyed by it: the step loops specialised to a system's functions
(``geomint.model.handles``) and the user's functions' own compiled code, kept
under geomint's cache folder (``geomint.model.functions.compiled``), so that a
second process that builds the same system compiles nothing.

A function made inside another function, a lambda, or one whose module cannot be
found again under its name has no key: nothing stable names it.
"""

from __future__ import annotations

import hashlib
import inspect
import sys
from typing import Any

import numpy as np
from numba.core.dispatcher import Dispatcher

#: the digest of each source file this process has read
_FILES: dict[str, str] = {}

#: the global values numba freezes into compiled code as constants (``_frozen_globals``)
_CONSTANTS = (bool, int, float, complex, str, bytes, type(None), np.generic)


def _file_digest(path: str) -> str | None:
    if path not in _FILES:
        try:
            with open(path, "rb") as f:
                _FILES[path] = hashlib.sha1(f.read()).hexdigest()[:16]
        except OSError:
            return None
    return _FILES[path]


def _constant_digest(value: Any) -> bytes | None:
    """The bytes that fix ``value`` as numba freezes it, None for what it does not freeze (modules, functions)."""
    if isinstance(value, _CONSTANTS):
        return f"{type(value).__name__}:{value!r}".encode()
    if isinstance(value, np.ndarray):
        return f"{value.dtype.str}{value.shape}".encode() + np.ascontiguousarray(value).tobytes()
    if isinstance(value, tuple):
        parts = [part for part in map(_constant_digest, value) if part is not None]
        return b"(" + b",".join(parts) + b")" if len(parts) == len(value) else None
    return None


def _names(code: Any) -> set[str]:
    """The global names a code object and the code objects nested in it read."""
    names = set(code.co_names)
    for const in code.co_consts:
        if inspect.iscode(const):
            names |= _names(const)
    return names


def _frozen_globals(py_func: Any, seen: set[int] | None = None) -> str:
    """A digest of the values of the globals ``py_func`` reads that numba compiles in as constants, and of
    those the numba functions it calls read (followed once each)."""
    seen = set() if seen is None else seen
    seen.add(id(py_func))
    digest = hashlib.sha1()
    # co_names also lists attribute names (x.shape) and builtins (range): only the module's globals are frozen in
    for name in sorted(_names(py_func.__code__) & py_func.__globals__.keys()):
        value = py_func.__globals__[name]
        frozen = _constant_digest(value)
        if frozen is not None:
            digest.update(name.encode() + b"=" + frozen + b";")
        elif isinstance(value, Dispatcher) and id(value.py_func) not in seen:
            digest.update(f"{name}->{_frozen_globals(value.py_func, seen)};".encode())
    return digest.hexdigest()[:16]


def function_key(fn: Any) -> tuple[str, ...] | None:
    """``(module, qualname, digest of the source file and of the globals frozen in, digest of the compile
    options)`` of a module-level numba function found again under its module and name, else None (see the module
    docstring)."""
    if not isinstance(fn, Dispatcher):
        return None
    py_func = fn.py_func
    module, qualname = py_func.__module__, py_func.__qualname__
    if "<" in qualname or module not in sys.modules:  # <locals>, <lambda>
        return None
    found: Any = sys.modules[module]
    for part in qualname.split("."):
        found = getattr(found, part, None)
    if found is not fn:
        return None
    try:
        source = inspect.getsourcefile(py_func)
    except TypeError:
        source = None
    digest = _file_digest(source) if source else None
    if digest is None:
        return None
    digest = f"{digest}.{_frozen_globals(py_func)}"
    options = repr(sorted(fn.targetoptions.items()))  # fastmath, error_model ... change the compiled code
    return (module, qualname, digest, hashlib.sha1(options.encode()).hexdigest()[:8])


def unseen_part(key: tuple[str, ...]) -> str:
    """The part of a :func:`function_key` numba's own cache does not check: the digests of the globals frozen in
    and of the compile options (numba checks the source file itself)."""
    return f"{key[2].partition('.')[2]}.{key[3]}"
