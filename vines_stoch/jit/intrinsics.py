"""Intrinsics of the step loops: arrays on the kernel's stack, constants made run-time values,
item-wise copies, reads and writes at a run-time index that keep stack arrays in registers, and
the type of the arrays a loop owns or borrows for its whole run (``StackArray``).
"""

from __future__ import annotations

from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.core.datamodel.models import ArrayModel
from numba.core.imputils import lower_cast
from numba.extending import intrinsic, register_model
from numba.np.arrayobj import make_array, populate_array

from .cache import njit
from .flags import INLINE, VECTOR_BITS


class StackArray(types.Array):
    """A numba array whose memory the step loop owns (``scratch``) or borrows for its whole run
    (``borrowed``): the same machine value as numba's arrays, typed apart so that its data
    model shows no memory info to reference counting.  numba then emits no increment or
    decrement for it at all: a null memory info made them no-ops at run time, but each was a
    call in the loop's IR, which LLVM optimised before pruning it (the contact-under-noise loop
    held 4,774 of them).  Views and copies of it are numba's arrays again (``Array.copy``)."""

    def __init__(self, dtype, ndim, layout, readonly=False, name=None, aligned=True):
        super().__init__(dtype, ndim, layout, readonly=readonly, aligned=aligned,
                         name=name or f"stack array({dtype}, {ndim}d, {layout})")


def _stack_array_model(base):
    """The data model of ``StackArray`` over a target's array model ``base``: its members as
    ``base``'s, none of them visible to reference counting."""

    class StackArrayModel(base):
        def traverse(self, builder):
            return []

        def inner_models(self):
            return []

    return StackArrayModel


register_model(StackArray)(_stack_array_model(ArrayModel))


@lower_cast(StackArray, types.Array)
def _stack_to_array(context, builder, fromty, toty, val):
    """A stack array where numba's array is expected (a variable that also holds one): the
    same value."""
    return val


def register_cuda_model() -> None:
    """``StackArray``'s data model in numba-cuda's registry too, where that is not numba's
    (numba-cuda without numba keeps copies of its own); called by ``kernels/launch.py``, which
    alone imports numba-cuda."""
    from numba.core.datamodel import registry as core_registry
    from numba.cuda.datamodel import models, registry

    if registry.default_manager is not core_registry.default_manager:
        registry.register_default(StackArray)(_stack_array_model(models.ArrayModel))


def _arrays_as(ty: types.Type, array) -> types.Type:
    """``ty`` with every array in it (nested in tuples and named tuples) replaced by
    ``array(that array's type)``."""
    if isinstance(ty, types.Array):
        return array(ty)
    if isinstance(ty, types.BaseTuple):
        members = [_arrays_as(t, array) for t in ty.types]
        homogeneous = bool(members) and all(m == members[0] for m in members)
        if isinstance(ty, types.NamedUniTuple | types.NamedTuple):
            if homogeneous:
                return types.NamedUniTuple(members[0], len(members), ty.instance_class)
            return types.NamedTuple(members, ty.instance_class)
        return types.UniTuple(members[0], len(members)) if homogeneous else types.Tuple(members)
    return ty


def stack_type(ty: types.Type) -> types.Type:
    """``ty`` with every array in it (nested in tuples and named tuples) a ``StackArray``."""
    return _arrays_as(ty, lambda a: StackArray(a.dtype, a.ndim, a.layout, readonly=not a.mutable,
                                               aligned=a.aligned))


def plain_type(ty: types.Type) -> types.Type:
    """``ty`` with every ``StackArray`` in it (nested in tuples) numba's array again."""
    return _arrays_as(ty, lambda a: types.Array(a.dtype, a.ndim, a.layout, readonly=not a.mutable,
                                                aligned=a.aligned) if isinstance(a, StackArray) else a)


@intrinsic
def plain(typingctx, value):
    """``value`` (an array or a tuple of values) with its stack arrays (``StackArray``) typed as
    numba's arrays: the arguments of an out-of-line function, which compiles for the argument
    types it is called with (a loop's stack arrays and a caller's numpy arrays would compile it
    twice).  The same machine value: a null memory info, which reference counting skips."""
    target = plain_type(value)

    def codegen(context, builder, signature, args):
        if context.enable_nrt:  # (a new reference, as numba expects of a returned value)
            context.nrt.incref(builder, target, args[0])
        return args[0]

    return target(value), codegen


def _stack_array(dtype, size, room=None):
    """Typing and code of a zeroed 1-D ``dtype`` array of ``size`` on the stack: a literal (a
    kernel factory's count), or a run-time integer within ``room`` (a literal: the room the
    frame reserves; a size the loop reads from its arguments).  The room is reserved with the
    function's frame either way, where LLVM may keep the array in registers (a room taken at
    run time, ``alloca`` of a run-time count, cost the scalar impact scene a fifth of its
    speed)."""
    if not isinstance(size, types.Integer) or not (room is None or isinstance(room, types.IntegerLiteral)):
        return None
    literal = isinstance(size, types.IntegerLiteral)
    if room is None and not literal:
        return None
    array_type = StackArray(dtype, 1, "C")
    reserved = max(size.literal_value if literal else room.literal_value, 1)

    def codegen(context, builder, signature, args):
        data = cgutils.alloca_once(builder, context.get_data_type(dtype), size=reserved)
        cgutils.memset(builder, data, ir.Constant(cgutils.intp_t, 8 * reserved), 0)
        n = context.cast(builder, args[0], signature.args[0], types.intp)
        return _stack_view(context, builder, array_type, data, n)

    return (array_type(size) if room is None else array_type(size, room)), codegen


def _stack_view(context, builder, array_type, data, n):
    """The array of ``n`` items at ``data`` (no memory info)."""
    array = make_array(array_type)(context, builder)
    populate_array(array, data=data, shape=[n], strides=[cgutils.intp_t(8)], itemsize=8, meminfo=None)
    return array._getvalue()


@intrinsic
def scratch(typingctx, size):
    """``np.zeros(size)`` on the kernel's stack, for a compile-time constant ``size`` (a kernel
    factory's body count): the compiler then knows these arrays alias nothing else and, with
    the loops over bodies unrolled, keeps the state in registers across steps.  (The same loop
    on heap arrays ran at 0.65-0.7x.)  The array must not outlive the kernel that makes it."""
    return _stack_array(types.float64, size)


@intrinsic
def scratch_within(typingctx, size, room):
    """``scratch`` of a run-time ``size`` (a count the loop reads from its arguments) of at most
    ``room`` (a literal), the room the kernel's frame reserves."""
    return _stack_array(types.float64, size, room)


def scratch_of(room: int):
    """``scratch_within`` with its room fixed to ``room``: an intrinsic of one argument, the size
    (a literal, or a run-time count of at most ``room``)."""
    room_type = types.IntegerLiteral(room)

    @intrinsic
    def scratch_in_room(typingctx, size):
        return _stack_array(types.float64, size, room_type)

    return scratch_in_room


@intrinsic
def int_scratch(typingctx, size):
    """``np.zeros(size, np.int64)`` on the kernel's stack (as ``scratch``): per-absorber flags."""
    return _stack_array(types.int64, size)


#: The float types whose bits ``float_bits`` and ``bits_float`` cast, with the unsigned integer of
#: their width.
_BIT_TYPES = {types.float64: (types.uint64, ir.DoubleType(), 64),
              types.float32: (types.uint32, ir.FloatType(), 32)}


@intrinsic
def float_bits(typingctx, value):
    """The bits of a ``float64`` as a ``uint64``, of a ``float32`` as a ``uint32`` (a bit cast, no
    conversion: the exponent and mantissa of ``rng.log_positive``'s argument)."""
    if value not in _BIT_TYPES:
        return None
    unsigned, _, width = _BIT_TYPES[value]

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.IntType(width))

    return unsigned(value), codegen


@intrinsic
def bits_float(typingctx, value):
    """The ``float64`` whose bits are a ``uint64``, the ``float32`` whose bits are a ``uint32``
    (``float_bits``'s inverse)."""
    floats = {unsigned: (real, llvm_type) for real, (unsigned, llvm_type, _) in _BIT_TYPES.items()}
    if value not in floats:
        return None
    real, llvm_type = floats[value]

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], llvm_type)

    return real(value), codegen


@intrinsic
def fused(typingctx, a, b, c):
    """``a b + c`` rounded once (``llvm.fma``), for ``float64`` operands or ``float32`` ones: the
    only fused multiply-adds of the loops, which take no fast-math licence (``jit.flags.KERNEL``),
    so that every loop that writes the same arithmetic computes the same bits, however the
    compiler unrolls or vectorises it (the scalar, lane, pass and general loops)."""
    if a not in _BIT_TYPES or not b == c == a:
        return None
    llvm_type = _BIT_TYPES[a][1]

    def codegen(context, builder, signature, args):
        fma = builder.module.declare_intrinsic("llvm.fma", [llvm_type],
                                               ir.FunctionType(llvm_type, [llvm_type] * 3))
        return builder.call(fma, args)

    return a(a, a, a), codegen


@intrinsic
def prefer_vectors(typingctx):
    """Ask LLVM to vectorise the loops of the calling function with ``flags.VECTOR_BITS``-bit
    vectors (the string attribute ``"prefer-vector-width"`` on the function being compiled, which
    the x86 back end reads a function at a time): called first in each function that holds a loop
    over SIMD lanes, and by no other, so that the rest of the package keeps LLVM's own choice."""

    def codegen(context, builder, signature, args):
        # llvmlite's attribute set knows no string attributes: added past its check, it prints as
        # given in the function's definition
        set.add(builder.function.attributes, f'"prefer-vector-width"="{VECTOR_BITS}"')
        return context.get_dummy_value()

    return types.none(), codegen


def _selected(a: types.Type, b: types.Type, predicate: str):
    """The signature and code of ``b if b <predicate> a else a`` for two ``float64`` values (an
    ordered comparison: numba's ``max`` and ``min`` of floats); None for other types."""
    if not (a == types.float64 and b == types.float64):
        return None

    def codegen(context, builder, signature, args):
        first, second = args
        return builder.select(builder.fcmp_ordered(predicate, second, first), second, first)

    return types.float64(types.float64, types.float64), codegen


@intrinsic
def larger(typingctx, a, b):
    """``max(a, b)`` of two floats, bit for bit as numba's builtin (``b`` where ``b > a``, else
    ``a``: NaN and signed zeros alike), as one select in place.  numba's ``max`` and ``min`` are
    functions the loop calls, which LLVM's inliner leaves as calls in a loop as large as an
    impact scene's lane loop, and a call keeps a loop from vectorising."""
    return _selected(a, b, ">")


@intrinsic
def smaller(typingctx, a, b):
    """``min(a, b)`` of two floats, bit for bit as numba's builtin (``larger``'s twin)."""
    return _selected(a, b, "<")


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
    """``value`` of type ``ty`` with each array in it (nested in tuples) as a ``StackArray``
    view whose memory info is null."""
    if isinstance(ty, types.Array):
        array = make_array(ty)(context, builder, value)
        array.meminfo = cgutils.get_null_value(array.meminfo.type)
        array.parent = cgutils.get_null_value(array.parent.type)
        return array._getvalue()
    if isinstance(ty, types.BaseTuple):
        items = [_borrow(context, builder, t, builder.extract_value(value, i)) for i, t in enumerate(ty)]
        return context.make_tuple(builder, stack_type(ty), items)
    if context.enable_nrt:  # (what is not an array: a new reference, as numba expects; no NRT on a GPU)
        context.nrt.incref(builder, ty, value)
    return value


@intrinsic
def borrowed(typingctx, value):
    """``value`` (an array, or a tuple or named tuple holding arrays) with its arrays as views
    that reference counting skips (``StackArray``: no increment or decrement is emitted).  An
    inlined function that takes heap arrays and spans loops costs an atomic increment and
    decrement of each a call (numba's pruning of reference counts works within simple regions
    of the control flow); the step loop takes its bundles and the scheme's state as borrowed
    views, once, outside the loop.  The views must not outlive the values they borrow from
    (the loop's arguments, a state it keeps)."""

    def codegen(context, builder, signature, args):
        return _borrow(context, builder, signature.args[0], args[0])

    return stack_type(value)(value), codegen


@intrinsic
def no_builtins(typingctx):
    """Keep LLVM from turning the calling function's loops into C library calls (the string
    attribute ``"no-builtins"`` on the function being compiled): its loop-idiom pass makes a
    ``memset`` or ``memmove`` call of each loop that zeroes or copies an array, worth it for long
    arrays, a call of a few ns for the loops of a few bodies, floors or load rows that a step
    loop runs at each stage of a step where their counts are run-time values (the general
    loops).  Called first in the general scalar step loops (``driver.step_loop``): the general
    RK4 loop of a seed 003 design went from 152-170 to 129-133 ns a step (from 139-140 to 117-118
    without an absorber), the general kick-drift-kick loop of the impact-rich scene from 7.9-8.3
    to 9.5-10.0 M path-steps/s (alternating runs on one 2-core host).  Not in the loops
    specialised to a structure, whose copies have constant lengths and whose kick-drift-kick
    loops ran 3-7 % slower with it."""

    def codegen(context, builder, signature, args):
        set.add(builder.function.attributes, '"no-builtins"')
        return context.get_dummy_value()

    return types.none(), codegen
