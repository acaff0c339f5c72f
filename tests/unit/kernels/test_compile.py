"""numba's front end, faster (``vines_stoch.jit.frontend``): one scope copy per copy of an
inlined IR, live maps on bit sets, variable lists by exact type, dead maps from the live maps'
bits, SSA on the blocks that name a variable, call types resolved once, no release of what holds
no memory; the same compiled code
(for the CPU and, through numba-cuda's copy of the front end, PTX), the same live, use-def and
dead maps and call types, fewer copies and resolutions.  In place only while the package
compiles (``frontend.compiling``), never where ``VINES_STOCH_FAST_FRONTEND=0``; a replacement
that does not apply to the installed numba is named once a process."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import warnings

import pytest

from tests.helpers import ROOT
from vines_stoch.jit import frontend

#: Nested ``inline="always"`` functions with loops, branches and reassigned variables (many
#: blocks, SSA violators), compiled without the on-disk cache; prints the LLVM IR, the result,
#: the scope copies made, the live maps checked against numba's own, and the PTX numba-cuda's
#: front end makes of the same function (none where no NVVM is installed).
SCRIPT = r'''
import contextlib, copy, json, sys
import numpy as np
from numba import njit
from numba.core import ir, ssa
from tests.helpers import ROOT
from vines_stoch.jit import frontend
copies, checked, used, dead = [0], [0], [0], [0]
compiling = contextlib.ExitStack()  # (the replacements stay in place until the script ends)
def watch(package):
    """Check every live map of ``package``'s front end, and (fast) every use-def map, against
    its own functions."""
    module = __import__(f"{package}.analysis", fromlist=["analysis"])
    own = module.compute_live_map
    installed = compiling.enter_context(frontend.compiling(package)) if sys.argv[1] == "fast" else {}
    assert all(on for part, on in installed.items() if part not in ("variables", "dead", "release"))
    if installed:  # (numba's only: numba-cuda's lists the variables of two IR modules, lowers of its own)
        numba_s = package == "numba.core"
        assert installed["variables"] == installed["dead"] == installed["release"] == numba_s
    if installed.get("variables"):
        inst = __import__(f"{package}.ir", fromlist=["ir"]).Inst
        fast_defs, fast_vars = module.compute_use_defs, inst._rec_list_vars
        def use_defs(blocks):
            mine = fast_defs(blocks)
            inst._rec_list_vars = fast_vars.__wrapped__  # (numba's own, all through)
            try:
                theirs = fast_defs.__wrapped__(blocks)
            finally:
                inst._rec_list_vars = fast_vars
            assert (mine.usemap, mine.defmap) == (theirs.usemap, theirs.defmap), "use-def maps differ"
            used[0] += 1
            return mine
        module.compute_use_defs = use_defs
        fast_dead, fast_live = module.compute_dead_maps, module.compute_live_variables
        def dead_maps(cfg, blocks, live_map, defs):
            args = (cfg, blocks, live_map, defs)
            mine, theirs = fast_dead(*args), fast_dead.__wrapped__(*args)
            assert tuple(map(dict, mine)) == tuple(map(dict, theirs)), "dead maps differ"
            assert [list(d) for d in mine] == [list(d) for d in theirs]  # (the same labels in the same order)
            dead[0] += 1
            return mine
        def live_variables(cfg, blocks, defs, dead_map):
            args = (cfg, blocks, defs, dead_map)
            mine, theirs = fast_live(*args), fast_live.__wrapped__(*args)
            assert dict(mine) == dict(theirs) and list(mine) == list(theirs), "live variables differ"
            return mine
        module.compute_dead_maps, module.compute_live_variables = dead_maps, live_variables
    installed = module.compute_live_map
    def compared(cfg, blocks, use, defs):
        mine = installed(cfg, blocks, use, defs)
        assert mine == own(cfg, blocks, use, defs), "live maps differ"
        checked[0] += 1
        return mine
    module.compute_live_map = compared
watch("numba.core")
from numba.core.types import functions
calls = [0]
resolving = functions.BaseFunction.get_call_type
def counting(self, context, args, kws):
    calls[0] += 1
    return resolving(self, context, args, kws)
counting.kept = getattr(resolving, "kept", False)  # (installed beneath the count, for numba-cuda's front end)
functions.BaseFunction.get_call_type = counting
def counted(self, memo):
    copies[0] += 1
    new = ir.Scope.__new__(ir.Scope)
    memo[id(self)] = new
    for key, value in self.__dict__.items():
        setattr(new, key, copy.deepcopy(value, memo))
    return new
ir.Scope.__deepcopy__ = counted

@njit(inline="always")
def leaf(a, k):
    s = 0.0
    for i in range(a.shape[0]):
        if a[i] > k:
            s += a[i] * k
        elif a[i] < -k:
            s -= a[i]
        else:
            s += 1.0
    return s

@njit(inline="always")
def middle(a, k):
    t = 0.0
    for j in range(3):
        t += leaf(a, k + j) if j % 2 == 0 else -leaf(a, k - j)
    return t

from numba.extending import overload
def scaled(a, k):
    pass
@overload(scaled, inline="always")  # (inlined after typing: the inliner's copies of a shared IR)
def _scaled(a, k):
    def impl(a, k):
        s = 0.0
        for i in range(a.shape[0]):
            s += a[i] * k if a[i] > k else -a[i]
        return s
    return impl

@njit
def outer(a):
    return middle(a, 0.5) + middle(a, 1.5) * leaf(a, 2.0)

@njit
def typed(a):  # (the CPU's: numba-cuda's lowering does not take this overload)
    return outer(a) + scaled(a, 0.25)

a = np.linspace(-3.0, 3.0, 7)
value = typed(a)
from numba.core import inline_closurecall as ic
ptx = None
try:
    from numba import cuda
    from numba.cuda import compile_ptx
    import numba.cuda.dispatcher as dispatcher
    class Sm90:
        compute_capability = (9, 0)
    dispatcher.get_current_device = lambda: Sm90()
    watch("numba.cuda.core")
    ptx, _ = compile_ptx(outer.py_func, "(float64[:],)", device=True, cc=(9, 0))
except ImportError:
    pass
named = getattr(ssa._run_ssa, "named_blocks", False)
compiling.close()
print(json.dumps({"llvm": [f.inspect_llvm(f.signatures[0]) for f in (outer, typed)], "value": value.hex(),
                  "copies": copies[0], "restored": ic.copy is copy, "checked": checked[0], "used": used[0],
                  "dead": dead[0], "ssa": named, "left": getattr(ssa._run_ssa, "named_blocks", False),
                  "ptx": ptx, "calls": calls[0], "kept": len(getattr(resolving, "resolved", ()))}))
'''


def _compile(mode: str) -> dict:
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "0", "NUMBA_DISABLE_CACHE": "1", frontend.SWITCH: "1"}
    done = subprocess.run([sys.executable, "-c", SCRIPT, mode], capture_output=True, text=True, env=env)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.splitlines()[-1])


def _numbered(llvm: str) -> str:
    """LLVM IR with the numbers of numba's function identities in inlined names left out."""
    return re.sub(r"_v\d+_", "_v_", llvm)


def _renamed(llvm: str) -> str:
    """LLVM IR with its local values and blocks named in order of first appearance: numba
    names them from counters that count every instruction and variable version lowered, also
    those LLVM removes, so the releases left out of lowering (``frontend.release_only_memory``)
    shift the names, not the code, and its blocks from their labels (``frontend.compact_labels``)."""
    names: dict[str, str] = {}

    def name(m: re.Match) -> str:
        return m.group(1) + names.setdefault(m.group(2), f"v{len(names)}")

    renamed = re.sub(r'(%|^)("[^"]*"|[-\w.$]+)(?=[\s,:)\]])', name, llvm, flags=re.M)
    return re.sub(r" +; preds", " ; preds", renamed)  # (LLVM pads the comment by the label's length)


def test_the_faster_front_end_compiles_the_same_code_with_the_same_live_maps():
    plain, fast = _compile("plain"), _compile("fast")
    assert fast["ssa"] and not plain["ssa"] and not fast["left"]
    assert _renamed(fast["llvm"][0]) == _renamed(plain["llvm"][0])
    # the overload's IR is made fewer times (its call type is kept): numba numbers each function
    # identity it makes, and the variables inlined from it carry that number in their names
    assert [_numbered(_renamed(f)) for f in fast["llvm"]] == [_numbered(_renamed(f)) for f in plain["llvm"]]
    assert fast["value"] == plain["value"]
    assert fast["restored"]
    assert fast["checked"] > 10  # every live map of the compile equals numba's own
    assert fast["used"] > 10 and plain["used"] == 0  # and every use-def map
    assert fast["dead"] > 10 and plain["dead"] == 0  # and every dead map, on the bit sets
    # one copy of the scope per copy of an IR instead of one per block
    assert 0 < fast["copies"] < plain["copies"] / 4
    # each call type resolved once, then handed out again
    assert plain["kept"] == 0 and 0 < fast["kept"] < fast["calls"] / 2
    if plain["ptx"] is None:
        pytest.skip("numba-cuda is not installed: its front end is not checked")
    assert fast["ptx"] == plain["ptx"] and ".visible .func" in fast["ptx"]


def _numba_s_own() -> dict:
    """Where each replacement goes, and what is there now."""
    from numba.core import analysis, ir, ir_utils, lowering, ssa
    from numba.core import inline_closurecall as ic
    from numba.core.types import functions

    return {"store": lowering.Lower.storevar, "del": lowering.Lower.delvar,
            "inline_ir": ic.InlineWorker.inline_ir, "inline_function": ic.InlineWorker.inline_function,
            "live": analysis.compute_live_map, "live (ir_utils)": ir_utils.compute_live_map,
            "use-defs": analysis.compute_use_defs, "use-defs (ir_utils)": ir_utils.compute_use_defs,
            "vars": ir.Inst._rec_list_vars, "dead": analysis.compute_dead_maps,
            "live variables": analysis.compute_live_variables, "ssa": ssa._run_ssa,
            "calls": functions.BaseFunction.get_call_type}


def test_the_kernels_compile_with_the_faster_front_end():
    from numba.core import analysis, ir_utils, ssa
    from numba.core import inline_closurecall as ic
    from numba.core.types import functions

    own = _numba_s_own()
    with frontend.compiling() as placed:
        assert placed == {"inlining": True, "liveness": True, "variables": True, "dead": True, "ssa": True,
                          "calls": True, "release": True}
        worker = ic.InlineWorker
        assert worker.inline_ir.shares_scope_copies and worker.inline_function.copies_nothing
        assert analysis.compute_live_map.as_bits and ssa._run_ssa.named_blocks
        assert analysis.compute_use_defs.lists_once and ir_utils.compute_use_defs is analysis.compute_use_defs
        assert analysis.compute_dead_maps.as_bits and analysis.compute_live_variables.as_bits
        assert functions.BaseFunction.get_call_type.kept
        from numba.core import lowering
        assert lowering.Lower.storevar.releases_memory_only
        inside = _numba_s_own()
        with frontend.compiling() as again:  # (nested: the same ones, left in place)
            assert again == placed and _numba_s_own() == inside
        assert _numba_s_own() == inside
    assert all(inside[k] is not own[k] for k in own)
    assert all(now is own[k] for k, now in _numba_s_own().items())


def test_kept_call_types_are_numba_s_own_and_failures_are_not_kept():
    """Each kept signature and implementation key is the one numba's own resolution gives; a
    call that does not type raises numba's error each time and is not kept."""
    import operator

    from numba.core import errors, types
    from numba.core.registry import cpu_target
    from numba.core.types import functions

    with frontend.compiling():
        kept = functions.BaseFunction.get_call_type
    own, resolved = kept.__wrapped__, kept.resolved
    assert own is functions.BaseFunction.get_call_type and resolved is frontend.CALL_TYPES
    context = cpu_target.typing_context
    context.refresh()
    cases = [(operator.add, (types.float64, types.float64)), (operator.mul, (types.int64, types.float64)),
             (operator.lt, (types.float64, types.int64)), (abs, (types.float64,))]
    for fn, args in cases:
        fnty = context.resolve_value_type(fn)
        first = kept(fnty, context, args, {})
        again = kept(fnty, context, args, {})
        impl = fnty._impl_keys[again.args]
        assert first == again == own(fnty, context, args, {}) and fnty._impl_keys[again.args] == impl
    add = context.resolve_value_type(operator.add)
    before = len(resolved)
    for _ in range(2):
        with pytest.raises(errors.TypingError):
            kept(add, context, (types.float64, types.unicode_type), {})
    assert len(resolved) == before


def _front_end_warnings(caught: list) -> list[str]:
    return [str(w.message) for w in caught if issubclass(w.category, frontend.FrontEndWarning)]


def test_other_sources_keep_their_own_passes_and_say_so_once(monkeypatch):
    """A numba whose passes are not the verified ones keeps them (nothing replaced), and one
    ``FrontEndWarning`` a process names them and the numba release.  numba's passes are stubbed
    while this test holds numba's compiler lock: a compile in another thread of the process (a
    worker of an earlier run) would otherwise run on the stubs, or save them as numba's own."""
    from numba.core.compiler_lock import global_compiler_lock

    with global_compiler_lock, monkeypatch.context() as patch:
        _other_sources(patch)


def _other_sources(monkeypatch):
    from importlib import metadata

    from numba.core import analysis, ssa
    from numba.core.types import functions

    wrong = dict.fromkeys(("liveness", "ssa", "calls", "variables", "dead"), "0" * 16)
    monkeypatch.setitem(frontend.VERIFIED, "numba.core", {**frontend.VERIFIED["numba.core"], **wrong})
    monkeypatch.setattr(frontend, "_WARNED", set())

    def own_live(cfg, blocks, use, defs):
        return {}

    def own_ssa(blocks):
        return blocks

    def own_calls(self, context, args, kws):
        return None

    def own_use_defs(blocks):
        return None

    def own_dead(cfg, blocks, live_map, defs):
        return None

    monkeypatch.setattr(analysis, "compute_live_map", own_live)
    monkeypatch.setattr(analysis, "compute_use_defs", own_use_defs)
    monkeypatch.setattr(analysis, "compute_dead_maps", own_dead)
    monkeypatch.setattr(ssa, "_run_ssa", own_ssa)
    monkeypatch.setattr(functions.BaseFunction, "get_call_type", own_calls)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for _ in range(3):
            with frontend.compiling() as installed:
                assert not installed["liveness"] and not installed["ssa"] and not installed["calls"]
                assert not installed["variables"] and analysis.compute_use_defs is own_use_defs
                assert not installed["dead"] and analysis.compute_dead_maps is own_dead
                assert analysis.compute_live_map is own_live and ssa._run_ssa is own_ssa
                assert functions.BaseFunction.get_call_type is own_calls
                assert installed["inlining"]  # (verified, in place)
    [message] = _front_end_warnings(caught)
    assert "\n" not in message and frontend.SWITCH in message
    release = metadata.version("numba")
    assert f"replacements liveness, variables, dead, ssa, calls do not apply to numba {release} (" in message


def test_a_missing_piece_keeps_numba_s_own_and_says_so(monkeypatch):
    """A front end without a piece a replacement takes the place of (another release) keeps
    its own passes for it, the others in place, and says which."""
    from numba.core import analysis, ssa

    monkeypatch.setattr(frontend, "_WARNED", set())
    monkeypatch.delattr(ssa, "_FixSSAVars")
    monkeypatch.delattr(analysis, "compute_dead_maps")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with frontend.compiling() as installed:
            assert not installed["ssa"] and not installed["dead"]
            assert not getattr(ssa._run_ssa, "named_blocks", False)
            assert installed["liveness"] and installed["calls"] and installed["inlining"]
        with frontend.compiling():
            pass
    [message] = _front_end_warnings(caught)
    assert "replacements dead, ssa do not apply" in message
    assert not hasattr(analysis, "compute_dead_maps")  # (nothing left behind)


def test_an_unverified_inline_function_keeps_its_copies(monkeypatch):
    """Where numba's ``InlineWorker.inline_function`` is not the verified source, the one-memo
    copies are put in place and ``inline_function`` is left as it is, and the warning names
    the inlining."""
    from numba.core import inline_closurecall as ic

    wrong = {**frontend.VERIFIED["numba.core"], "inlining": "0" * 16}
    monkeypatch.setitem(frontend.VERIFIED, "numba.core", wrong)
    monkeypatch.setattr(frontend, "_WARNED", set())
    own = ic.InlineWorker.inline_function
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with frontend.compiling() as installed:
            assert not installed["inlining"] and installed["ssa"]
            assert ic.InlineWorker.inline_ir.shares_scope_copies
            assert ic.InlineWorker.inline_function is own
    assert not getattr(ic.InlineWorker.inline_ir, "shares_scope_copies", False)
    [message] = _front_end_warnings(caught)
    assert "replacements inlining do not apply" in message


def test_the_switch_leaves_numba_s_own_front_end(monkeypatch):
    """``VINES_STOCH_FAST_FRONTEND=0``: nothing replaced, nothing said (the sources may differ)."""
    own = _numba_s_own()
    monkeypatch.setitem(frontend.VERIFIED, "numba.core", dict.fromkeys(frontend.VERIFIED["numba.core"], ""))
    monkeypatch.setattr(frontend, "_WARNED", set())
    for off in ("0", "false", " OFF "):
        monkeypatch.setenv(frontend.SWITCH, off)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            with frontend.compiling() as installed:
                assert not any(installed.values())
                assert all(now is own[k] for k, now in _numba_s_own().items())
        assert not _front_end_warnings(caught)
    monkeypatch.setenv(frontend.SWITCH, "1")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with frontend.compiling():
            assert _numba_s_own()["ssa"] is own["ssa"]  # (the wrong hashes: numba's own)
    assert len(_front_end_warnings(caught)) == 1


#: A process that imports the package, then compiles functions of its own (each with a probe
#: that records, while numba types it, which of numba's front-end pieces are the replacements):
#: after the import, through ``jit.cache.compile_once`` (in place), after a step loop ran
#: (``kernels.simulate``: numba's own again), and in another thread while ``compiling`` is held
#: (it waits for the compiler's lock, then compiles with numba's own).  Prints one JSON line.
PROBES = r'''
import json, threading
from numba import njit, types
from numba.core import analysis, ssa
from numba.core.types import functions
from numba.extending import intrinsic
own = (analysis.compute_live_map, ssa._run_ssa, functions.BaseFunction.get_call_type)
import vines_stoch.jit
from vines_stoch.jit import cache, frontend
seen = {}
def probed(label):
    @intrinsic
    def probe(typingctx):
        now = (analysis.compute_live_map, ssa._run_ssa, functions.BaseFunction.get_call_type)
        seen.setdefault(label, []).append([a is not b for a, b in zip(now, own)])
        return types.none(), lambda context, builder, signature, args: context.get_dummy_value()
    @njit
    def user():
        probe()
        return 1
    return user
probed("imported")()
cache.compile_once(probed("compile_once"), ())
from tests.helpers import example_data, scene_from
from vines_stoch.kernels import simulate
simulate(scene_from(example_data("cubic_nes_impulse"), changes={"simulation.duration": 0.5}))
probed("after a loop")()
waiting = probed("waiting")
with frontend.compiling():
    thread = threading.Thread(target=waiting)
    thread.start()
    thread.join(timeout=3.0)
    blocked = thread.is_alive()
thread.join()
print(json.dumps({"seen": seen, "blocked": blocked,
                  "left": [a is b for a, b in zip(own, (analysis.compute_live_map, ssa._run_ssa,
                                                          functions.BaseFunction.get_call_type))]}))
'''


def test_code_outside_the_package_compiles_with_numba_s_own_front_end():
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "0", frontend.SWITCH: "1", "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-c", PROBES], capture_output=True, text=True, env=env, cwd=ROOT)
    assert done.returncode == 0, done.stderr[-3000:]
    out = json.loads(done.stdout.splitlines()[-1])
    seen = out["seen"]
    assert set(seen) == {"imported", "compile_once", "after a loop", "waiting"}
    assert all(probe == [True, True, True] for probe in seen["compile_once"])
    for label in ("imported", "after a loop", "waiting"):
        assert all(probe == [False, False, False] for probe in seen[label]), label
    assert out["blocked"] and out["left"] == [True, True, True]


def _zeroed_slots(compile_in) -> tuple[int, float]:
    """The stores of a double zero in the unoptimised IR of a small loop compiled in the context
    ``compile_in`` (its ``0.0`` constant's and the zeroed slots of deleted variables), and its
    value."""
    import numpy as np
    from numba import njit
    from numba.core import codegen

    seen = []
    own = codegen.CPUCodeLibrary._optimize_functions

    def kept(self, module):
        seen.append(str(module))
        return own(self, module)

    @njit(cache=False)
    def loop(a):
        s, t = 0.0, 1.0
        for i in range(a.shape[0]):
            u = a[i] * t
            if u > 0.5:
                s += u
            else:
                t = t * 0.5 + u
        return s + t

    codegen.CPUCodeLibrary._optimize_functions = kept
    try:
        with compile_in():
            value = loop(np.linspace(0.0, 1.0, 9))
    finally:
        codegen.CPUCodeLibrary._optimize_functions = own
    return sum(ir.count("store double 0.0") for ir in seen), value


def test_what_holds_no_memory_is_neither_released_nor_zeroed():
    """numba's lowering zeroes each deleted variable's slot (against a second release) and
    loads a slot's old value to release it before each store; for numbers there is nothing to
    release, and the replacement leaves those loads and stores out: the same value."""
    from contextlib import nullcontext

    zeroed_fast, fast = _zeroed_slots(frontend.compiling)
    zeroed_own, own = _zeroed_slots(nullcontext)
    assert 0 < zeroed_fast < zeroed_own  # (the constant's stores are left)
    assert fast == own


def test_a_class_s_source_is_read_without_parsing_its_module(monkeypatch):
    """The verified hashes read numba's SSA classes: ``frontend._source`` gives the text of
    ``inspect.getsource`` without the module-wide ``ast.parse`` whose shared recursion count
    fails beside another thread's parse on CPython 3.11 (python/cpython#106905)."""
    import ast
    import inspect

    from numba.core import ssa

    classes = [getattr(ssa, name) for name in frontend.SSA_PARTS if inspect.isclass(getattr(ssa, name))]
    assert len(classes) == 2
    expected = [inspect.getsource(c) for c in classes]

    def refuse(*args, **kwargs):
        raise AssertionError("ast.parse called")

    monkeypatch.setattr(ast, "parse", refuse)
    assert [frontend._source(c) for c in classes] == expected


def _labels_after_compiles(count: int) -> list[int]:
    """numba's global block-label counter after each of ``count`` compiles of a fresh function
    that inlines a function that inlines another (``frontend.compiling``)."""
    from numba import njit
    from numba.core import ir_utils

    @njit(inline="always")
    def inner(x):
        return x + 1.0 if x > 0.0 else x - 1.0

    @njit(inline="always")
    def middle(x):
        return inner(x) * inner(-x)

    def outer(x):
        return middle(x) + middle(2.0 * x)

    seen = []
    for _ in range(count):
        with frontend.compiling():
            njit(outer).compile("float64(float64)")
        seen.append(ir_utils._the_max_label._value)
    return seen


def test_inlined_labels_grow_by_the_blocks_inlined_not_twice_over(monkeypatch):
    """numba offsets an inlined function's labels by its global label counter, and the callee's
    own labels are already as large as the counter where it inlined functions itself: each such
    inline doubles the counter, for the life of the process, until LLVM refuses the block names
    (over 1,024 characters).  The compacted callee labels (``frontend.compact_labels``) make it
    grow by the blocks inlined.  (The same code: the first test's LLVM IR.)"""
    monkeypatch.setenv(frontend.SWITCH, "1")
    fast = _labels_after_compiles(20)
    assert max(b - a for a, b in zip(fast, fast[1:])) < 1000
    monkeypatch.setenv(frontend.SWITCH, "0")
    plain = _labels_after_compiles(20)
    assert plain[-1] > plain[0] * 2**20  # (numba's own: at least one doubling per compile)
