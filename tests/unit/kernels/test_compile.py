"""numba's front end, faster (``vines_stoch.frontend``): one scope copy per copy of an inlined
IR, live maps on bit sets, variable lists by exact type, dead maps from the live maps' bits,
SSA on the blocks that name a variable, call types resolved once; the same compiled code (for
the CPU and, through numba-cuda's copy of the front end, PTX), the same live, use-def and dead
maps and call types, fewer copies and resolutions."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys

import pytest

from vines_stoch.jit import frontend

#: Nested ``inline="always"`` functions with loops, branches and reassigned variables (many
#: blocks, SSA violators), compiled without the on-disk cache; prints the LLVM IR, the result,
#: the scope copies made, the live maps checked against numba's own, and the PTX numba-cuda's
#: front end makes of the same function (none where no NVVM is installed).
SCRIPT = r'''
import copy, json, sys
import numpy as np
from numba import njit
from numba.core import ir, ssa
from vines_stoch.jit import frontend
copies, checked, used, dead = [0], [0], [0], [0]
def watch(package):
    """Check every live map of ``package``'s front end, and (fast) every use-def map, against
    its own functions."""
    module = __import__(f"{package}.analysis", fromlist=["analysis"])
    own = module.compute_live_map
    installed = frontend.install(package) if sys.argv[1] == "fast" else {}
    assert all(on for part, on in installed.items() if part not in ("variables", "dead"))
    if installed:  # (numba's front end only: numba-cuda's lists the variables of two IR modules)
        assert installed["variables"] == installed["dead"] == (package == "numba.core")
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
print(json.dumps({"llvm": [f.inspect_llvm(f.signatures[0]) for f in (outer, typed)], "value": value.hex(),
                  "copies": copies[0], "restored": ic.copy is copy, "checked": checked[0], "used": used[0],
                  "dead": dead[0],
                  "ssa": getattr(ssa._run_ssa, "named_blocks", False), "ptx": ptx, "calls": calls[0],
                  "kept": len(getattr(resolving, "resolved", ()))}))
'''


def _compile(mode: str) -> dict:
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "0", "NUMBA_DISABLE_CACHE": "1"}
    done = subprocess.run([sys.executable, "-c", SCRIPT, mode], capture_output=True, text=True, env=env)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.splitlines()[-1])


def _numbered(llvm: str) -> str:
    """LLVM IR with the numbers of numba's function identities in inlined names left out."""
    return re.sub(r"_v\d+_", "_v_", llvm)


def test_the_faster_front_end_compiles_the_same_code_with_the_same_live_maps():
    plain, fast = _compile("plain"), _compile("fast")
    assert fast["ssa"] and not plain["ssa"]
    assert fast["llvm"][0] == plain["llvm"][0]
    # the overload's IR is made fewer times (its call type is kept): numba numbers each function
    # identity it makes, and the variables inlined from it carry that number in their names
    assert [_numbered(f) for f in fast["llvm"]] == [_numbered(f) for f in plain["llvm"]]
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


def test_the_kernels_compile_with_the_faster_front_end():
    from numba.core import analysis, ir_utils, ssa
    from numba.core import inline_closurecall as ic
    from numba.core.types import functions

    import vines_stoch.jit  # noqa: F401  (installs it)

    assert frontend.install() == {"inlining": True, "liveness": True, "variables": True, "dead": True,
                                  "ssa": True, "calls": True}
    assert ic.InlineWorker.inline_ir.shares_scope_copies and ic.InlineWorker.inline_function.copies_nothing
    assert analysis.compute_live_map.as_bits and ssa._run_ssa.named_blocks
    assert analysis.compute_use_defs.lists_once and ir_utils.compute_use_defs is analysis.compute_use_defs
    assert analysis.compute_dead_maps.as_bits and analysis.compute_live_variables.as_bits
    assert functions.BaseFunction.get_call_type.kept


def test_kept_call_types_are_numba_s_own_and_failures_are_not_kept():
    """Each kept signature and implementation key is the one numba's own resolution gives; a
    call that does not type raises numba's error each time and is not kept."""
    import operator

    from numba.core import errors, types
    from numba.core.registry import cpu_target
    from numba.core.types import functions

    import vines_stoch.jit  # noqa: F401  (installs it)

    kept = functions.BaseFunction.get_call_type
    own, resolved = kept.__wrapped__, kept.resolved
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


def test_other_sources_keep_their_own_passes(monkeypatch):
    """A numba whose passes are not the verified ones keeps them (nothing replaced)."""
    from numba.core import analysis, ssa
    from numba.core.types import functions

    wrong = dict.fromkeys(("live", "ssa", "calls", "vars", "dead"), "0" * 16)
    monkeypatch.setitem(frontend.VERIFIED, "numba.core", wrong)

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
    installed = frontend.install()
    assert not installed["liveness"] and not installed["ssa"] and not installed["calls"]
    assert not installed["variables"] and analysis.compute_use_defs is own_use_defs
    assert not installed["dead"] and analysis.compute_dead_maps is own_dead
    assert analysis.compute_live_map is own_live and ssa._run_ssa is own_ssa
    assert functions.BaseFunction.get_call_type is own_calls


def test_an_unverified_inline_function_keeps_its_copies():
    """Where numba's ``InlineWorker.inline_function`` is not the verified source, the one-memo
    copies are installed and ``inline_function`` is left as it is (a process of its own: the
    front end is installed once a process)."""
    code = ("from vines_stoch.jit import frontend\n"
            "frontend.VERIFIED['numba.core']['inline'] = '0' * 16\n"
            "from numba.core import inline_closurecall as ic\n"
            "own = ic.InlineWorker.inline_function\n"
            "assert frontend.install()['inlining']\n"
            "assert ic.InlineWorker.inline_ir.shares_scope_copies\n"
            "assert ic.InlineWorker.inline_function is own\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]
