"""numba's inliner with one scope copy per copy of an IR (``vines_stoch.inlining``): the same
compiled code, fewer copies."""

from __future__ import annotations

import json
import subprocess
import sys

from vines_stoch.inlining import share_scope_copies

#: Nested ``inline="always"`` functions with loops and branches (many blocks), compiled without
#: the on-disk cache; prints the kernel's LLVM IR, its result and the scope copies made.
SCRIPT = r'''
import copy, json, sys
import numpy as np
from numba import njit
from numba.core import ir
if sys.argv[1] == "shared":
    from vines_stoch.inlining import share_scope_copies
    assert share_scope_copies()
copies = [0]
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

@njit
def outer(a):
    return middle(a, 0.5) + middle(a, 1.5) * leaf(a, 2.0)

a = np.linspace(-3.0, 3.0, 7)
value = outer(a)
from numba.core import inline_closurecall as ic
print(json.dumps({"llvm": outer.inspect_llvm(outer.signatures[0]), "value": value.hex(),
                  "copies": copies[0], "restored": ic.copy is copy}))
'''


def _compile(mode: str) -> dict:
    done = subprocess.run([sys.executable, "-c", SCRIPT, mode], capture_output=True, text=True, check=True)
    return json.loads(done.stdout)


def test_shared_scope_copies_compile_the_same_code_with_fewer_copies():
    plain, shared = _compile("plain"), _compile("shared")
    assert shared["llvm"] == plain["llvm"]
    assert shared["value"] == plain["value"]
    assert shared["restored"]
    # one copy of the scope per copy of an IR instead of one per block
    assert 0 < shared["copies"] < plain["copies"] / 4


def test_the_kernels_inline_with_shared_scope_copies():
    from numba.core import inline_closurecall as ic

    import vines_stoch.physics  # noqa: F401  (installs it)

    assert share_scope_copies()
    assert ic.InlineWorker.inline_ir.shares_scope_copies
