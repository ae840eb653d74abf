"""How the kernels are compiled.

Entry points, the kernels Python calls (``loop.run``, ``batch.run_batch``
...), are ``njit(cache=CACHE, error_model="numpy")``: cached on disk
(``geomint._cache``), and with numpy's floating-point semantics (a division
by zero gives inf or NaN, which the steps report as non-finite, instead of
raising).  Every other kernel is only ever called from compiled code, and is
compiled as a function of its own, is decorated with ``inner``: the same
semantics, compiled into its callers (and cached with them), without the
Python and C wrappers numba otherwise builds for each function, which are
never called.  (The few kernels numba inlines, ``inline="always"``, are
never compiled on their own and need neither.)

``hot`` is ``inner`` for what the loop runs at every step or iteration
(``loop._attempted``, ``runge_kutta.rk4_step``, ``dg_step.discrete_gradient_step``,
the composition's ``composed_step`` and ``_composition``, ``newton.newton`` and
the discrete field with ``polish`` and ``discrete_axial``; in R^n the discrete
field, its discrete gradients and projections, ``vecn``'s small loops, the field
and its Jacobian by differences, and the Newton matrix's refresh, factors and
solve): numba compiles each
once, as any ``inner`` kernel, and marks it for LLVM to inline into its
callers (numba's ``forceinline``), sparing the thirty-odd scalar arguments
and the result through memory of a call.  ``forceinline`` is inherited by
the kernels that a kernel's compilation compiles first, so ``inner`` turns
it off explicitly.  Measurements: docs/design.md sections 5 and 5a.

``inner`` and ``hot`` kernels are cached on disk, each on its own, but only their compilations for arguments
that hold no user function specialised into them (``geomint.model.handles.Inlined``, a numba dispatcher type):
``_ModelFreeCache``.  A kernel compiled for a new system (``loop.run`` with the system's functions inlined)
then loads the kernels it calls that do not depend on the system (the workspace's predictor, the state's flush,
the saved rows ...) instead of compiling them again; what depends on the system is compiled for it, and cached
only inside ``run``'s own compilation, so that a new system adds one entry to the cache, not one per kernel.  A
cached kernel's library keeps its LLVM bitcode, so ``hot`` kernels are still inlined by LLVM into their callers
(numba's ``serialize_using_object_code``).  Closures made by factories (``discrete_field._discrete_field_with``)
are not cached: numba keys them by a pickle of their cells, which holds kernels pickled anew by each process.

``typed_inline(fn)`` is numba's ``overload(fn, inline="always")`` for the
kernels' choices by type (the step by the method's type, the controller's
parts by the controller's, R^3 or R^n by the model's): the implementation the
overload returns is typed and inlined into its caller, as numba does, but not
first compiled to machine code on its own.  numba's ``overload`` compiles each
such implementation completely, the kernels it calls linked and optimised
again, only to learn its type, then throws that code away: a quarter of the
first solve of a new system, an eighth of a cold command line (docs/startup.md).
``typed_inline`` subclasses numba's overload template for that one step, for
the numba versions it was checked with (``TYPED_INLINE``); with others it is
numba's ``overload`` itself: the same code, compiled slower.
"""

from typing import Any, Callable

import numba
from numba import njit
from numba.core import caching, types
from numba.core.typing import templates
from numba.extending import overload

from .._cache import CACHE


def _specialised(ty: Any) -> bool:
    """Whether the numba type ``ty`` is, or holds in a tuple, a function's dispatcher type (an inlined user
    function, ``geomint.model.handles.Inlined``): compiled code specialised to one function object."""
    if isinstance(ty, types.Dispatcher):
        return True
    members = getattr(ty, "types", None) if isinstance(ty, types.BaseTuple) else None
    return members is not None and any(_specialised(member) for member in members)


class _ModelFreeCache(caching.FunctionCache):
    """numba's on-disk cache of one kernel, saving only its compilations whose arguments hold no user function
    specialised into them (the module docstring)."""

    def save_overload(self, sig: Any, data: Any) -> None:
        arguments = sig.args if hasattr(sig, "args") else sig
        if not any(_specialised(ty) for ty in arguments):
            super().save_overload(sig, data)


def _kernel(**options: Any) -> Callable[[Callable[..., Any]], Any]:
    """``njit(**options)`` with the kernel's model-free compilations cached (``_ModelFreeCache``)."""
    decorate = njit(**options)

    def make(fn: Callable[..., Any]) -> Any:
        dispatcher: Any = decorate(fn)
        if CACHE and fn.__closure__ is None and hasattr(dispatcher, "_cache"):  # (not under NUMBA_DISABLE_JIT)
            dispatcher._cache = _ModelFreeCache(fn)
        return dispatcher

    return make


# (no_cpython_wrapper and no_cfunc_wrapper are numba's own options, which its stubs for njit do not list)
inner = _kernel(error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True, forceinline=False)
hot = _kernel(error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True, forceinline=True)

#: the compile options of the kernels' overloads (``numba.extending.overload``): numba compiles each overload's
#: implementation on its own before it inlines or calls it, and, as for ``inner``, no Python or C wrapper is ever
#: called
#: (typed ``Any``: numba's stubs for ``jit_options`` do not list its wrapper options, as for ``inner`` above)
OVERLOADED: Any = {"error_model": "numpy", "no_cpython_wrapper": True, "no_cfunc_wrapper": True}


#: the numba versions (major, minor) whose overload template ``typed_inline`` was written against and run with
#: (0.68.1); any other is given numba's ``overload`` itself
CHECKED_NUMBA = ((0, 68), (0, 68))
#: whether ``typed_inline`` skips numba's compilation of the implementations (False: it is numba's ``overload``)
TYPED_INLINE = CHECKED_NUMBA[0] <= tuple(int(part) for part in numba.__version__.split(".")[:2]) <= CHECKED_NUMBA[1]


class _Uncompiled:
    """Put before numba's overload template (``make_overload_template``): its ``_build_impl`` for an
    implementation that is only ever inlined, the dispatcher made but not compiled (numba's ``generic`` types its
    IR for the caller, which inlines it)."""

    def _build_impl(self: Any, cache_key, args, kws):
        implementation = self._overload_func(*args, **kws)
        if implementation is None:
            self._impl_cache[cache_key] = None, None
            return None, None
        dispatcher = self._get_jit_decorator()(**self._jit_options)(implementation)
        dispatcher._can_compile = False  # numba's get_call_template compiles a dispatcher that can
        self._impl_cache[cache_key] = dispatcher, args
        return dispatcher, args


def typed_inline(fn: Callable[..., Any]) -> Callable[[Any], Any]:
    """``numba.extending.overload(fn, inline="always", jit_options=OVERLOADED)`` whose implementations are typed
    and inlined into their callers without being compiled on their own (the module docstring)."""
    if not TYPED_INLINE:
        return overload(fn, inline="always", jit_options=OVERLOADED)

    def decorate(overload_func: Callable[..., Any]) -> Callable[..., Any]:
        options = {"nopython": True, **OVERLOADED}  # numba's overload adds nopython to the options it is given
        made: Any = templates.make_overload_template(fn, overload_func, options, False, "always")

        class TypedInline(_Uncompiled, made):
            pass

        templates.infer(TypedInline)
        templates.infer_global(fn, types.Function(TypedInline))
        return overload_func

    return decorate
