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
is* (``geomint.model.identity.function_key``: its module, its qualified name,
a digest of its source file and of the globals numba compiles into it).  A
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

Editing the function's file (the function or a helper beside it) compiles the
kernels again, and so does a new value of a global numba froze into it (a size
read from the command line); a change in *another* file the function calls is
not seen (``geomint.model.identity``).

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

import os
import warnings
from typing import Any

import numba
from numba.core import types
from numba.core.datamodel.models import OpaqueModel
from numba.core.dispatcher import Dispatcher
from numba.core.errors import NumbaExperimentalFeatureWarning
from numba.core.types.function_type import CompileResultWAP
from numba.extending import register_model

from .functions import ACTION_SIGNATURE, SIGNATURE, compiled
from .identity import function_key

# numba warns at each compilation with a first-class function that the feature is experimental; the user cannot act
# on that, so this one warning is filtered (by its message, nothing else)
warnings.filterwarnings(
    "ignore", message=".*First-class function type feature is experimental", category=NumbaExperimentalFeatureWarning
)

#: the live type of each key in this process
_LIVE: dict[tuple[str, ...], Inlined] = {}


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


def kernel_handle(fn: Any, action: bool = False, inline: bool = True) -> Any:
    """A jitted user function as the kernels receive it: an :class:`InlinedHandle` where ``inline`` and it can be
    inlined and cached, else a first-class function object of ``(x, v, params)`` where ``action``, of
    ``(x, params)`` otherwise.  Under ``NUMBA_DISABLE_JIT=1`` the function itself."""
    if numba.config.DISABLE_JIT:  # pyright: ignore[reportPrivateImportUsage, reportAttributeAccessIssue]
        return fn
    signature = ACTION_SIGNATURE if action else SIGNATURE
    if signature not in fn.overloads:  # a system unpickled in another process (a Dask worker)
        compiled(fn, signature)
    key = function_key(fn) if inline else None
    if key is None:
        return CompileResultWAP(fn.overloads[signature])
    return InlinedHandle(fn, key)
