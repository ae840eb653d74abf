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
the discrete field with ``polish`` and ``discrete_axial``): numba compiles each
once, as any ``inner`` kernel, and marks it for LLVM to inline into its
callers (numba's ``forceinline``), sparing the thirty-odd scalar arguments
and the result through memory of a call.  ``forceinline`` is inherited by
the kernels that a kernel's compilation compiles first, so ``inner`` turns
it off explicitly.  Measurements: docs/design.md sections 5 and 5a.
"""

from typing import Any

from numba import njit

# (no_cpython_wrapper and no_cfunc_wrapper are numba's own options, which its stubs for njit do not list)
inner = njit(
    error_model="numpy",
    no_cpython_wrapper=True,
    no_cfunc_wrapper=True,  # pyright: ignore[reportCallIssue]
    forceinline=False,
)
hot = njit(
    error_model="numpy",
    no_cpython_wrapper=True,
    no_cfunc_wrapper=True,  # pyright: ignore[reportCallIssue]
    forceinline=True,
)

#: the compile options of the kernels' overloads (``numba.extending.overload``): numba compiles each overload's
#: implementation on its own before it inlines or calls it, and, as for ``inner``, no Python or C wrapper is ever
#: called
#: (typed ``Any``: numba's stubs for ``jit_options`` do not list its wrapper options, as for ``inner`` above)
OVERLOADED: Any = {"error_model": "numpy", "no_cpython_wrapper": True, "no_cfunc_wrapper": True}
