"""Arrays the kernels hold without counting references.

numba counts the references to every array it passes: a kernel that receives an array (the state's buffer, the
workspace, the user's ``params`` inside the model) increments its count on entry and decrements it on exit,
each an atomic instruction on the array's ``meminfo``.  The step's kernels call one another with these arrays
dozens of times per step, and those counts were most of a step's cost (73 % of the samples at rest on the
relaxing rigid body, docs/engine_speed.md).

``borrowed(value)`` is the same value with every array in it (itself, or the members of a tuple or named tuple,
recursively) re-described without a ``meminfo``: numba's reference counting skips an array without one, as it
does for an array viewing foreign memory.  The data, shape and strides are the same.  Safe only while something
else holds the arrays: ``loop.run`` borrows its arguments, which its caller holds for the call, and its own
buffer, which it keeps until it returns.
"""

from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic


def _borrow(context, builder, ty, value):
    if isinstance(ty, types.Array):
        array = context.make_array(ty)(context, builder, value)
        array.meminfo = cgutils.get_null_value(array.meminfo.type)
        array.parent = cgutils.get_null_value(array.parent.type)
        return array._getvalue()
    if isinstance(ty, types.BaseTuple) and isinstance(value.type, ir.LiteralStructType | ir.ArrayType):
        out = value
        for k, member in enumerate(ty):
            out = builder.insert_value(out, _borrow(context, builder, member, builder.extract_value(value, k)), k)
        return out
    context.nrt.incref(builder, ty, value)  # anything else: handed on as a new reference, as numba expects
    return value


@intrinsic
def borrowed(typingctx, value):
    """``value`` with every array in it uncounted (module docstring)."""

    def codegen(context, builder, signature, args):
        return _borrow(context, builder, signature.args[0], args[0])

    return value(value), codegen
