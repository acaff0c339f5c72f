"""Compile time of numba's ``inline="always"``: one copy of the callee's scope per inlining.

numba's ``InlineWorker.inline_ir`` deep-copies the callee's IR twice, block by block, each
block with a fresh ``copy.deepcopy`` memo.  Every variable refers to the function's one scope,
so every block copies the whole scope again (all the callee's variables, those of the
functions inlined into it included): the cost grows as blocks times variables, and nested
inlining makes both large (numba issue #8989, numba-cuda issue #688 and pull request #689).
In the step loops this was about half of a kernel's cold compile time.

``share_scope_copies`` gives the deep copies of one ``inline_ir`` call one memo, so each copy
of the IR copies the scope once, as one deep copy of the whole IR would. The inliner asks the
copied blocks for their one scope (it asserts there is one) and renames its variables there,
then points every inlined block at the caller's scope, so nothing reads which scope copy a
block held: the compiled code is the same (``tests/unit/kernels/test_compile.py`` checks the LLVM IR of
nested inlined functions with and without it, and the scenario outputs did not change).
Compilation holds numba's global compiler lock, so the module attribute swapped for the call is
seen by no other thread. Where numba's inliner has another shape (a later release), nothing is
changed.
"""

from __future__ import annotations

import copy
from typing import Any


class _OneMemo:
    """``copy.deepcopy`` with one memo for every call (the module ``copy`` as the inliner sees it)."""

    def __init__(self) -> None:
        self.memo: dict[int, Any] = {}

    def deepcopy(self, x: Any, memo: dict | None = None) -> Any:
        return copy.deepcopy(x, self.memo if memo is None else memo)


def share_scope_copies() -> bool:
    """Install the one-memo deep copy in numba's inliner (once); returns whether it is in place."""
    from numba.core import inline_closurecall as ic

    worker = getattr(ic, "InlineWorker", None)
    inline_ir = getattr(worker, "inline_ir", None)
    if inline_ir is None or getattr(ic, "copy", None) is not copy:
        return getattr(inline_ir, "shares_scope_copies", False)
    if getattr(inline_ir, "shares_scope_copies", False):
        return True

    def shared(self, *args, **kwargs):
        ic.copy = _OneMemo()
        try:
            return inline_ir(self, *args, **kwargs)
        finally:
            ic.copy = copy

    shared.shares_scope_copies = True
    shared.__doc__ = inline_ir.__doc__
    worker.inline_ir = shared
    return True
