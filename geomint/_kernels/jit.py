"""How the kernels are compiled.

Entry points, the kernels Python calls (``driver.integrate``,
``adaptive.march`` ...), are ``njit(cache=CACHE, error_model="numpy")``: cached
on disk (``geomint._cache``), and with numpy's floating-point semantics (a
division by zero gives inf or NaN, which the steps report as non-finite,
instead of raising).  Every other kernel is only ever called from compiled
code, and is compiled as a function of its own, is decorated with ``inner``:
the same semantics, compiled into its callers (and cached with them),
without the Python and C wrappers numba otherwise builds for each function.
(The few kernels numba inlines, ``inline="always"``, are never compiled on
their own and need neither.)  Those wrappers are never called;
without them a Gonzalez run compiles in 12.5 s instead of 15.4 s (empty
cache, this machine).

``hot`` is ``inner`` for the steps a step loop calls once per step
(``steps.rk4_step``, ``steps.discrete_gradient_step``, the composition's
``composed_step`` and ``_composition``): numba compiles each once, as any
``inner`` kernel, and marks it for LLVM to inline into its callers (numba's
``forceinline``).  A call passes the model, the state and the method's data
as some thirty scalar arguments and returns a nine-field result through
memory; inlined, a Gonzalez step went from 626 to 373 ns and a
Yoshida4(Gonzalez) step from 2195 to 1498 ns, for the same compilation time
(docs/design.md section 5).  ``forceinline`` is inherited by the kernels
that a kernel's compilation compiles first, so ``inner`` turns it off
explicitly.
"""

from numba import njit

inner = njit(error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True, forceinline=False)
hot = njit(error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True, forceinline=True)
