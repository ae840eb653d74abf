"""The numba type of a kernel model, worked out once per model object instead of at every kernel call.

A ``layout.Model`` (``ModelN``) is a namedtuple of user-function handles and
arrays; numba's dispatcher cannot fingerprint it in C, so at every call of a
kernel it types it in Python, handle by handle (~25 us for an inlined model,
~100 us for a first-class one: each function type rebuilt from its signature),
which is most of what a short ``solve`` costs.  A system builds its models
once (``MetriplecticSystem.model``, ``inlined_model``) and hands the same
objects to every kernel, so the type found for an object is kept and given
again while that object is passed: the same type numba would find (a
namedtuple's fields are fixed; the arrays' writeability, which their type
records, is checked on each hit).  The last ``KEPT`` models are remembered.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba.core.typing.typeof import Purpose, _TypeofContext, typeof_impl

from .._kernels.layout import Model, ModelN

#: models whose type is remembered (the oldest forgotten first)
KEPT = 64

#: ``(id(model), purpose) -> (model, type, writeable flags of its arrays)``; the model is held so its id stays its own
_TYPES: dict[tuple[int, Any], tuple[tuple, Any, tuple[bool, ...]]] = {}

#: numba's own typing of a tuple (a namedtuple's type from its fields' types)
_typeof_tuple = typeof_impl.dispatch(tuple)


def _writeable(model: tuple) -> tuple[bool, ...]:
    return tuple(v.flags.writeable for v in model if type(v) is np.ndarray)


def _typeof_model(model: tuple, c: Any) -> Any:
    key = (id(model), c.purpose)
    kept = _TYPES.get(key)
    if kept is not None and kept[0] is model and kept[2] == _writeable(model):
        return kept[1]
    ty = _typeof_tuple(model, c)
    if ty is not None:
        if len(_TYPES) >= KEPT and key not in _TYPES:
            del _TYPES[next(iter(_TYPES))]
        _TYPES[key] = (model, ty, _writeable(model))
    return ty


def _argument_type(model: tuple) -> Any:
    """The model's type as a kernel argument (``_typeof_model``), read by numba's dispatcher from its C side
    (the ``_numba_type_`` of a value it cannot fingerprint) without going back to Python's ``typeof``."""
    return _typeof_model(model, _ARGUMENT)


_ARGUMENT = _TypeofContext(Purpose.argument)

typeof_impl.register(Model)(_typeof_model)
typeof_impl.register(ModelN)(_typeof_model)
Model._numba_type_ = property(_argument_type)  # pyright: ignore[reportAttributeAccessIssue]  # numba's hook
ModelN._numba_type_ = property(_argument_type)  # pyright: ignore[reportAttributeAccessIssue]
