"""Compiled kernels: numba only, no classes, no validation, no I/O.

Every kernel trusts its caller (`geomint.solve` or `MetriplecticSystem`) to have
checked shapes, finiteness and function types.  The model reaches a kernel as
one value, ``layout.Model``: the user functions and the params.  Where a user
function can be found again by its module and name it arrives as a type of
its own and is inlined into kernels compiled for it; elsewhere as a typed
first-class function, so that one cached compilation serves every system of
the same function types (``geomint.model.handles``, docs/design.md section 5).

Importing this package loads no numba: ``layout`` (codes, constants, named
tuples) is plain Python, so the layers that only need its names (integrators,
run status, checkpoints) import without a compiler.  The cache of these
kernels is dropped when any of their sources changed (``geomint._cache``).
"""
