"""Intrinsics of the step loops: arrays on the kernel's stack, constants made run-time values,
item-wise copies, and reads and writes at a run-time index that keep stack arrays in registers.
"""

from __future__ import annotations

from llvmlite import ir
from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic
from numba.np.arrayobj import make_array, populate_array

from .flags import INLINE


def _stack_array(dtype, size):
    """Typing and code of a zeroed 1-D ``dtype`` array of ``size`` (a literal) on the stack."""
    if not isinstance(size, types.IntegerLiteral):
        return None
    n = size.literal_value
    array_type = types.Array(dtype, 1, "C")

    def codegen(context, builder, signature, args):
        data = cgutils.alloca_once(builder, context.get_data_type(dtype), size=max(n, 1))
        cgutils.memset(builder, data, ir.Constant(cgutils.intp_t, 8 * max(n, 1)), 0)
        array = make_array(array_type)(context, builder)
        populate_array(array, data=data, shape=[cgutils.intp_t(n)], strides=[cgutils.intp_t(8)],
                       itemsize=8, meminfo=None)
        return array._getvalue()

    return array_type(size), codegen


@intrinsic
def scratch(typingctx, size):
    """``np.zeros(size)`` on the kernel's stack, for a compile-time constant ``size`` (a kernel
    factory's body count): the compiler then knows these arrays alias nothing else and, with
    the loops over bodies unrolled, keeps the state in registers across steps.  (The same loop
    on heap arrays ran at 0.65-0.7x.)  The array must not outlive the kernel that makes it."""
    return _stack_array(types.float64, size)


@intrinsic
def int_scratch(typingctx, size):
    """``np.zeros(size, np.int64)`` on the kernel's stack (as ``scratch``): per-absorber flags."""
    return _stack_array(types.int64, size)


@intrinsic
def runtime_value(typingctx, value):
    """``value`` typed as a run-time value: a constant (a kernel factory's floor count, a flag
    written in the call) loses its literal type.  An out-of-line function called with literal
    arguments compiles once for each set of constants; called with these, it compiles once for
    every loop (``rk4.wall_accelerations``: once a process instead of twice a loop)."""
    plain = types.unliteral(value)

    def codegen(context, builder, signature, args):
        return context.cast(builder, args[0], value, plain)

    return plain(value), codegen


@intrinsic
def _copy_items(typingctx, dst, src):
    """Copy ``src``'s items into ``dst`` (1-D C arrays of one dtype, lengths equal)."""
    arrays = (dst, src)
    if not all(isinstance(a, types.Array) and a.ndim == 1 and a.layout == "C" for a in arrays) \
            or dst.dtype != src.dtype:
        return None

    def codegen(context, builder, signature, args):
        to, of = (make_array(t)(context, builder, a) for t, a in zip(signature.args, args))
        # a loop, which LLVM unrolls (a call of memcpy for three items took 6.5 ns against 3.6)
        with cgutils.for_range(builder, of.nitems) as loop:
            item = builder.load(builder.gep(of.data, [loop.index]))
            builder.store(item, builder.gep(to.data, [loop.index]))
        return context.get_dummy_value()

    return types.none(dst, src), codegen


@njit(**INLINE)
def copy_into(dst, src) -> None:
    """``dst[:] = src`` for 1-D C arrays of one length, one item at a time.  The slice assignment
    compiles numba's shape-mismatch error, which formats the shapes into its message: integer
    and string formatting, 1.9 s of the first Runge-Kutta loop a process compiled (12.2 s)."""
    if dst.shape[0] != src.shape[0]:
        raise ValueError("copy_into: arrays of different lengths")
    _copy_items(dst, src)


@njit(**INLINE)
def pick(a, j: int) -> float:
    """``a[j]`` for a run-time ``j``, as a scan over constant indices: an array on the stack
    (``scratch``) indexed only at constant positions stays in registers, one indexed at a
    run-time position is kept in memory, where every access waits on a store."""
    value = a[0]
    for b in range(1, a.shape[0]):
        if b == j:
            value = a[b]
    return value


@njit(**INLINE)
def put(a, j: int, value: float) -> None:
    """``a[j] = value`` for a run-time ``j`` (see ``pick``)."""
    for b in range(a.shape[0]):
        if b == j:
            a[b] = value


@njit(**INLINE)
def any_set(a) -> bool:
    """True if any entry of ``a`` is not zero (``a.any()``, which the GPU target lacks)."""
    for j in range(a.shape[0]):
        if a[j] != 0:
            return True
    return False


def _borrow(context, builder, ty, value):
    """``value`` of type ``ty`` with each array in it (nested in tuples) as a view whose memory
    info is null: reference counting skips it."""
    if isinstance(ty, types.Array):
        array = make_array(ty)(context, builder, value)
        array.meminfo = cgutils.get_null_value(array.meminfo.type)
        array.parent = cgutils.get_null_value(array.parent.type)
        return array._getvalue()
    if isinstance(ty, types.BaseTuple):
        items = [_borrow(context, builder, t, builder.extract_value(value, i)) for i, t in enumerate(ty)]
        return context.make_tuple(builder, ty, items)
    if context.enable_nrt:  # (what is not an array: a new reference, as numba expects; no NRT on a GPU)
        context.nrt.incref(builder, ty, value)
    return value


@intrinsic
def borrowed(typingctx, value):
    """``value`` (an array, or a tuple or named tuple holding arrays) with its arrays as views
    that reference counting skips.  An inlined function that takes heap arrays and spans loops
    costs an atomic increment and decrement of each a call (numba's pruning of reference
    counts works within simple regions of the control flow); the step loop passes its bundles
    and state to the scheme's step as borrowed views, once, outside the loop.  The views must
    not outlive the values they borrow from (the loop's arguments, a state it keeps)."""

    def codegen(context, builder, signature, args):
        return _borrow(context, builder, signature.args[0], args[0])

    return value(value), codegen
