"""How the user's functions reach the kernels: inlined where they can be cached, first-class elsewhere.

A kernel that receives a user function as a numba *first-class function*
(``CompileResultWAP``) is compiled once for every system of that form and
cached on disk, but every call it makes goes through a function pointer:
numba cannot inline it, so each evaluation of H or of the field pays a call,
its arguments through memory, and the optimisations across the call are lost.
That costs more than the step's own arithmetic on small systems (the relaxing
rigid body: RK4 371 ns a step through first-class functions, 105 ns with the
functions inlined; docs/engine_speed.md).

A kernel that receives the user's numba dispatcher itself is compiled for that
function: the call is direct and LLVM inlines it.  numba keys such a
compilation by the dispatcher *object*, so its on-disk cache never hits in
another process and every process would pay the compilation again.  This
module gives each user function a numba type of its own, :class:`Inlined`,
that calls it as a dispatcher type does but is keyed by *what the function
is*: its module, its qualified name and a digest of its source file.  A
second process that builds the same system finds the kernels compiled for it
on disk.

:func:`kernel_handle` picks the form per function:

* a module-level numba function, found again under its module and name
  (``module.qualname`` is the same object), is handed over as an
  :class:`InlinedHandle`: the kernels are specialised to it and cached;
* anything else (a function made inside another function, a lambda, a
  function whose module cannot be found again) is handed over first-class, as
  before: one compilation per system form, cached, calls not inlined.  Caching
  a kernel specialised to such a function would be keyed by nothing stable.

The digest covers the function's whole source file, so editing the file (the
function or a helper beside it) compiles the kernels again, and the values of
the globals the function reads (and the numba functions it calls read),
which numba freezes into the compiled code as constants: numbers, strings,
tuples of them and arrays.  A script that reads a size from its command line
into a global gets kernels of that size, not those cached for the last one
(numba's own cache keys by the file alone, and would serve them).  A change
in *another* file the function calls is not seen: clear the cache
(``geomint._cache``) after such a change.

Where it pays: a system in R^3 is specialised by default; a system in R^n
is handed over first-class (:func:`enabled`).  ``GEOMINT_INLINE=all`` in the
environment specialises R^n systems too, ``GEOMINT_INLINE=0`` neither (one
compilation per form, e.g. for many throw-away systems).

Pickling: numba stores the argument types of each cached compilation in an
index shared by all systems.  An :class:`Inlined` type pickles to its key and
unpickles to the live type of that key in this process, or, when no function
of that key is live here, to :class:`Unloaded`, which matches nothing and
pickles back to the same key, so that one process rewriting the index never
erases another system's entry.
"""

from __future__ import annotations

import hashlib
import inspect
import os
import sys
import warnings
from typing import Any

import numba
import numpy as np
from numba.core import types
from numba.core.datamodel.models import OpaqueModel
from numba.core.dispatcher import Dispatcher
from numba.core.errors import NumbaExperimentalFeatureWarning
from numba.core.types.function_type import CompileResultWAP
from numba.extending import register_model

from .functions import ACTION_SIGNATURE, SIGNATURE

# numba warns at each compilation with a first-class function that the feature is experimental; the user cannot act
# on that, so this one warning is filtered (by its message, nothing else)
warnings.filterwarnings(
    "ignore", message=".*First-class function type feature is experimental", category=NumbaExperimentalFeatureWarning
)

#: the live type of each key in this process
_LIVE: dict[tuple[str, ...], Inlined] = {}
#: the digest of each source file this process has read
_FILES: dict[str, str] = {}


def _rebuild(key: tuple[str, ...]) -> types.Type:
    """The type of ``key`` as this process has it: the live :class:`Inlined`, else an :class:`Unloaded`."""
    live = _LIVE.get(key)
    return live if live is not None else Unloaded(key)


class Inlined(types.Dispatcher):
    """The numba type of one user function, called directly (and inlined), keyed by ``(module, qualname, digest)``."""

    def __init__(self, dispatcher: Dispatcher, key: tuple[str, ...]) -> None:
        self._stable = key
        super().__init__(dispatcher)
        self.name = f"inlined({'.'.join(key[:2])}@{key[2]})"

    @property
    def key(self) -> Any:
        return self._stable

    def __eq__(self, other: object) -> bool:
        return type(self) is type(other) and self.key == other.key  # pyright: ignore[reportAttributeAccessIssue]

    def __hash__(self) -> int:
        return hash(self._stable)

    def __reduce__(self) -> Any:
        return (_rebuild, (self._stable,))


class Unloaded(types.Opaque):
    """An :class:`Inlined` key read from the cache index in a process where no function has it: matches nothing,
    pickles back to the same key."""

    def __init__(self, key: tuple[str, ...]) -> None:
        self._stable = key
        super().__init__(f"unloaded({'.'.join(key[:2])}@{key[2]})")

    def __reduce__(self) -> Any:
        return (_rebuild, (self._stable,))


register_model(Inlined)(OpaqueModel)


class InlinedHandle:
    """A user function as the kernels receive it when it can be inlined: numba types it as :class:`Inlined`."""

    __slots__ = ("dispatcher", "key")

    def __init__(self, dispatcher: Dispatcher, key: tuple[str, ...]) -> None:
        self.dispatcher, self.key = dispatcher, key

    @property
    def _numba_type_(self) -> Inlined:
        live = _LIVE.get(self.key)
        if live is None or live.dispatcher is not self.dispatcher:
            live = _LIVE[self.key] = Inlined(self.dispatcher, self.key)
        return live

    def __call__(self, *args: Any) -> Any:
        return self.dispatcher(*args)

    def __reduce__(self) -> Any:  # another process (a Dask worker) hands it over anew
        return (kernel_handle, (self.dispatcher, False, True))


def _file_digest(path: str) -> str | None:
    if path not in _FILES:
        try:
            with open(path, "rb") as f:
                _FILES[path] = hashlib.sha1(f.read()).hexdigest()[:16]
        except OSError:
            return None
    return _FILES[path]


#: the global values numba freezes into compiled code as constants (``_frozen_globals``)
_CONSTANTS = (bool, int, float, complex, str, bytes, type(None), np.generic)


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


def enabled(rn: bool = False) -> bool:
    """Whether the step loop of a system in R^3 (``rn`` False) or in R^n inlines its user functions, by
    ``GEOMINT_INLINE``: unset or ``1``, in R^3 only; ``all``, in R^n too; ``0``, nowhere (every function handed
    over first-class).

    In R^n inlining is off by default: it saves less there (the user's functions return arrays and do O(n)
    work a call; the engine's own work dominates from a few dozen coordinates on), and specialising the larger
    R^n step to each new system compiles many times longer than the first-class step, which is compiled once
    for every system of its form (docs/startup.md, "R^n systems first-class")."""
    setting = os.environ.get("GEOMINT_INLINE", "1")
    return setting == "all" or (setting != "0" and not rn)


def inline_key(fn: Any) -> tuple[str, ...] | None:
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


def kernel_handle(fn: Any, action: bool = False, inline: bool = True) -> Any:
    """A jitted user function as the kernels receive it: an :class:`InlinedHandle` where ``inline`` and it can be
    inlined and cached, else a first-class function object of ``(x, v, params)`` where ``action``, of
    ``(x, params)`` otherwise.  Under ``NUMBA_DISABLE_JIT=1`` the function itself."""
    if numba.config.DISABLE_JIT:  # pyright: ignore[reportPrivateImportUsage, reportAttributeAccessIssue]
        return fn
    signature = ACTION_SIGNATURE if action else SIGNATURE
    if signature not in fn.overloads:  # a system unpickled in another process (a Dask worker)
        fn.compile(signature)
    key = inline_key(fn) if inline else None
    if key is None:
        return CompileResultWAP(fn.overloads[signature])
    return InlinedHandle(fn, key)
