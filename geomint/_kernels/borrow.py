"""Arrays the step loop holds without counting references.

numba counts the references to every array a compiled function receives: on entry it increments the count in the
array's ``meminfo`` and on exit decrements it, each an atomic instruction (a locked add, ~20 cycles, and a
cache line that threads share when their arrays are views of one array).  The step's kernels call one another
with the same arrays (the state's buffer, the workspace, the user's ``params`` inside the model) dozens of
times a step: on the relaxing rigid body at rest those counts were 73 % of the samples of a Gonzalez step
(docs/engine_speed.md).

``borrowed(value)`` is ``value`` with every array in it (itself, or the members of a tuple or named tuple,
recursively) described without a ``meminfo``, which numba's counting skips (as for an array over memory it
does not own); data, shape and strides are the same.  It is safe only while something else holds the arrays:
``loop.run`` borrows its arguments, which its caller holds for the call, and its own buffer, which it keeps
until it returns.  In Python (``NUMBA_DISABLE_JIT=1``) it returns ``value`` itself.
"""

from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic

from .jit import typed_inline


def borrowed(value):
    """``value`` with every array in it uncounted (module docstring); ``value`` itself in Python."""
    return value


def _borrow(context, builder, ty, value):
    if isinstance(ty, types.Array):
        array = context.make_array(ty)(context, builder, value)
        array.meminfo = cgutils.get_null_value(array.meminfo.type)
        array.parent = cgutils.get_null_value(array.parent.type)
        return array._getvalue()
    if isinstance(ty, types.BaseTuple) and isinstance(value.type, ir.LiteralStructType | ir.ArrayType):
        out = value
        for k, member in enumerate(ty):  # pyright: ignore[reportArgumentType]  # numba's tuple types iterate
            out = builder.insert_value(out, _borrow(context, builder, member, builder.extract_value(value, k)), k)
        return out
    context.nrt.incref(builder, ty, value)  # anything else is handed on as a new reference, as numba expects
    return value


@intrinsic
def _uncounted(typingctx, value):
    def codegen(context, builder, signature, args):
        return _borrow(context, builder, signature.args[0], args[0])

    return value(value), codegen


@typed_inline(borrowed)
def _borrowed_typed(value):
    return lambda value: _uncounted(value)  # pyright: ignore[reportCallIssue]  # the typing context is numba's
