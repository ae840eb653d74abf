"""Numba types of the user functions and of the kernels that call them.

A system's functions all take ``(x, params)`` with ``x`` and ``params``
contiguous float64 vectors.  Scalars return float64; vectors return either a
3-tuple (no allocation: the fast form) or a float64 array; the Poisson tensor
is either the axial vector ``J`` (same form as the gradients) or the 3x3 matrix
``P``.  A kernel is compiled for one combination the first time a system of
that form uses it, and cached on disk, so a new system of a known form never
triggers a new compilation.
"""

from functools import cache

from numba import njit, types

f64 = types.float64
i64 = types.int64
vec = types.float64[::1]
mat = types.float64[:, ::1]
ivec = types.int64[::1]

_args = (vec, vec)
SCALAR_FN = types.FunctionType(f64(*_args))
TUPLE_FN = types.FunctionType(types.UniTuple(f64, 3)(*_args))
ARRAY_FN = types.FunctionType(vec(*_args))
MATRIX_FN = types.FunctionType(mat(*_args))

#: (gradient function type, Poisson function type) for every supported form.
MODEL_FORMS = {
    ("tuple", "axial"): (TUPLE_FN, TUPLE_FN),
    ("tuple", "matrix"): (TUPLE_FN, MATRIX_FN),
    ("array", "axial"): (ARRAY_FN, ARRAY_FN),
    ("array", "matrix"): (ARRAY_FN, MATRIX_FN),
}


class model_kernel:
    """Decorator for a kernel ``k(H, grad_H, S, grad_S, J, params, *trailing)``.

    ``kernel[form]`` is the dispatcher compiled (once, cached on disk) for the
    model form ``(vector_form, poisson_form)``.  One dispatcher per form: numba
    matches a jitted user function against a single first-class function type.
    """

    def __init__(self, return_type, *trailing):
        self.return_type = return_type
        self.trailing = trailing

    def __call__(self, fn):
        self.py_func = fn
        self.__doc__ = fn.__doc__
        return self

    @cache
    def __getitem__(self, form):
        if form not in MODEL_FORMS:  # NUMBA_DISABLE_JIT=1: plain Python
            return njit(self.py_func)
        grad, poisson = MODEL_FORMS[form]
        signature = self.return_type(SCALAR_FN, grad, SCALAR_FN, grad, poisson, vec, *self.trailing)
        return njit(signature, cache=True)(self.py_func)
