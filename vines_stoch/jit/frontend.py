"""numba's front end, faster: the same compiled code in less than half the time.

A step loop's cold compile is mostly numba's Python front end, not LLVM: a profile of the
contact-under-noise kernel spent 6 of 85 s in LLVM.  Three front-end passes grow as blocks
times variables, and inlining makes both large in the step loops; type inference repeats its
call resolutions:

* Inlining (``share_scope_copies``).  ``InlineWorker.inline_ir`` deep-copies the callee's IR
  twice, block by block, each block with a fresh ``copy.deepcopy`` memo.  Every variable refers
  to the function's one scope, so every block copies the whole scope again (numba issue #8989,
  numba-cuda issue #688 and pull request #689).  Giving the deep copies of one ``inline_ir``
  call one memo copies the scope once per copy of the IR; the inliner renames the variables in
  the copied blocks' one scope, then points every inlined block at the caller's scope, so
  nothing reads which copy a block held.  ``InlineWorker.inline_function`` (the inlining of
  ``inline="always"`` functions) hands ``inline_ir`` an IR it has just made from the function's
  bytecode, which nothing else holds, and no caller reads the unmutated copy ``inline_ir``
  returns: there it copies nothing.  Compilation holds numba's compiler lock, so the module
  attribute swapped for the call is seen by no other thread.
* Labels (``compact_labels``).  The inliner offsets a callee's block labels past numba's global
  label counter; a callee that inlined functions itself already holds labels as large as that
  counter, so each such inline doubles it, for the life of the process.  After some thousands of
  them (a test run compiling dozens of step loops) the block names pass LLVM's 1,024 characters
  and the IR no longer parses ("name is too long").  ``inline_function`` relabels the callee
  0, 1, 2, ... in its labels' order before the offset: the same order, the same code, a counter
  that grows by the blocks inlined.
* Liveness (``live_map_as_bits``).  ``analysis.compute_live_map`` runs after every inlining and
  rewrite; it iterates reaching definitions and then liveness to their least fixed points on
  Python sets, each union copying sets of thousands of names.  The same fixed points on integer
  bit sets (one machine-word OR per 64 names) are the same live maps.
* Dead maps (``dead_maps_as_bits``, ``live_variables_as_bits``).  After each liveness
  analysis numba finds where each variable dies and which are available at each block's entry,
  on the same Python sets, each union copying them.  The live map on bit sets keeps its bits;
  the dead maps and the available variables are made from them, the same maps with the same
  labels in the same order.  numba's front end only.
* SSA reconstruction (``ssa_on_named_blocks``).  ``ssa._run_ssa`` rewrites every block twice
  for each variable that has several definitions, though only the blocks that name it change;
  rewriting those blocks and keeping the others (in a private copy of the block map) makes the
  same blocks, with the same fresh names in the same order.
* Variable lists (``list_vars_once``).  Every analysis lists a statement's variables through
  ``Inst._rec_list_vars``, which tests each value against numba's classes in turn; the use-def
  maps (computed at every liveness analysis) list an assignment's value twice.  Telling the
  IR's plain containers and leaves apart by their exact type, and listing an assignment once,
  gives the same lists and maps.  numba's front end only: numba-cuda's lists the variables of
  its own and of numba's IR classes through helpers of its own.
* Call types (``memo_call_types``).  Type inference resolves each call site (every operator
  and indexing is one) again on every pass of its fixed point, and each resolution tries the
  function's typing templates in turn, literal arguments first, formatting an error for each
  that does not match: the contact-under-noise kernel resolves 17,912 calls, 432 of them
  distinct.  A resolved signature depends only on the function type, the typing context, its
  target and the argument types, so it is kept under those and handed out again, with the
  implementation key the resolution records (a failed resolution is not kept).
* Releases (``release_only_memory``).  Lowering keeps each variable that lives in several blocks
  in a stack slot; each store first loads the slot's old value to release it, and each ``del``
  loads the value, releases it and fills the slot with zeros (against a second release).  For a
  variable whose type holds no memory info (numbers, ``intrinsics.StackArray`` and tuples of
  them) the release is nothing, but the loads and zero stores stay in the IR, and each ``del``
  is one more definition of the variable: LLVM's SROA turns them into phi nodes wherever control
  merges (22,485 after SROA on the contact-under-noise loop), which LLVM's passes then carry and
  remove.  Leaving those loads and stores out computes the same (55 of the 56 cases of
  ``tests/integration/test_numbers_hold.py`` bitwise, the chaotic nine-storey wind case within
  3e-10); the optimised IR differs in block order and value names.  numba's lowering only
  (numba-cuda's runs without reference counts).

Measured on the contact-under-noise kernel (its 23 compiled functions, 2-core machine): 49.5 s
cold with the shared scope copies alone, 30.6 s with the bit-set live maps, 21.8 s with SSA on
named blocks too, and 17.2 s against 20.4 s with the kept call types (type inference 2.5 s
against 5.1 s); the variable lists took it from 14.2 s to 13.8 s and the dead maps from 13.7 s
to 13.3 s (means of three alternating compiles; the use-def maps 0.70 s against 0.40-0.51 s, the
dead maps 0.47 s against 0.22 s); the releases took LLVM's function passes on the driver's loop
from 7.6 s to 4.4 s.  All but the one-memo copies replace numba functions whose
source they were checked against (``VERIFIED``: a hash of that source, numba 0.68 and numba-cuda
0.30); another release keeps its own, and a ``FrontEndWarning`` says once a process which.

They are in place only while the package compiles its own loops: ``compiling(package)`` puts them
in numba's CPU compiler (``jit.cache.compile_once``, where every step loop compiles) or in
numba-cuda's copy of the front end (the launchers, ``kernels/launch.py``), holding that
compiler's lock, and puts numba's own back on leaving; other code of the process compiles with
numba's own.  ``VINES_STOCH_FAST_FRONTEND=0`` leaves numba's own in place throughout.
``tests/unit/kernels/test_compile.py`` compares the LLVM IR, the PTX, every live map, use-def
map and dead map with and without them.
"""

from __future__ import annotations

import copy
import hashlib
import importlib
import inspect
import linecache
import os
import re
import warnings
from collections import defaultdict
from collections.abc import Iterator
from contextlib import contextmanager
from importlib import metadata
from typing import Any

import numpy as np

#: Hashes of the numba sources the replacements were checked against (``_source_hash``), by
#: replacement (``REPLACEMENTS``): the inliner's ``inline_function``, the live-map function, the
#: variable lists and use-def maps, the dead maps, the SSA pass's driver, rewrites and handlers,
#: the function types' call resolution, the lowering's stores and deletions of variables; of
#: numba 0.68 and of numba-cuda 0.30's copy (which has four of them).
VERIFIED = {
    "numba.core": {"inlining": "1b53f183258e659d", "liveness": "713c4c094977e93b",
                   "variables": "b7264500be4efae6", "dead": "89d45f0cc5106279", "ssa": "9c0b3d5f348635ea",
                   "calls": "6559c167bfc0ad36", "release": "1d76cb623585a708"},
    "numba.cuda.core": {"inlining": "69a1df109038391f", "liveness": "cdb51290c1658e92",
                        "ssa": "0ad27c8ec5b7b4fd", "calls": "6559c167bfc0ad36"},
}
#: The releases ``VERIFIED`` holds (the bounds of ``pyproject.toml``).
VERIFIED_RELEASES = "numba 0.68, numba-cuda 0.30"
#: The distribution of each front end.
DISTRIBUTIONS = {"numba.core": "numba", "numba.cuda.core": "numba-cuda"}
#: The environment variable that turns the replacements off (``0``).
SWITCH = "VINES_STOCH_FAST_FRONTEND"
#: The call types ``memo_call_types`` keeps, for every compile of the process.
CALL_TYPES: dict = {}
#: The front ends a ``FrontEndWarning`` was given for in this process.
_WARNED: set[str] = set()
#: The modules of each front end that import ``compute_use_defs`` by name.
USE_DEFS_IMPORTERS = ("inline_closurecall", "ir_utils", "lowering", "transforms", "untyped_passes")
#: The module of each front end's function types (numba-cuda's is numba's where numba is
#: installed: the same classes).
FUNCTION_TYPES = {"numba.core": "numba.core.types.functions", "numba.cuda.core": "numba.cuda.types.functions"}
#: The SSA pass's pieces that ``ssa_on_named_blocks`` replaces or relies on.
SSA_PARTS = ("_run_ssa", "_fix_ssa_vars", "_fresh_vars", "_run_block_rewrite", "_make_states",
             "_FreshVarHandler", "_FixSSAVars")


class FrontEndWarning(RuntimeWarning):
    """A replacement does not apply to the installed numba: numba's own piece compiles."""


class Swaps(list):
    """The attributes put in place, each with what its owner (a module or class) held before
    (``restore`` puts those back, last first)."""

    _ABSENT = object()

    def put(self, owner: Any, name: str, value: Any) -> None:
        """Set ``owner.name`` to ``value``, keeping what was there."""
        self.append((owner, name, vars(owner).get(name, self._ABSENT)))
        setattr(owner, name, value)

    def restore(self) -> None:
        """Put back what every ``put`` replaced, last first."""
        while self:
            owner, name, value = self.pop()
            if value is self._ABSENT:
                delattr(owner, name)
            else:
                setattr(owner, name, value)


class _NoCopy:
    """``copy`` as the inliner sees it for an IR that nothing else holds: ``deepcopy`` hands the
    object itself back."""

    @staticmethod
    def deepcopy(x: Any, memo: dict | None = None) -> Any:
        return x


class _OneMemo:
    """``copy.deepcopy`` with one memo for every call (the module ``copy`` as the inliner sees it)."""

    def __init__(self) -> None:
        self.memo: dict[int, Any] = {}

    def deepcopy(self, x: Any, memo: dict | None = None) -> Any:
        return copy.deepcopy(x, self.memo if memo is None else memo)


def share_scope_copies(package: str, swaps: Swaps) -> bool:
    """Put the one-memo deep copy in the inliner of ``package`` (numba's, or numba-cuda's
    ``numba.cuda.core``) wherever it copies through ``copy.deepcopy``, and no copy for the IR
    ``inline_function`` makes where that method's source is the verified one
    (``InlineWorker.inline_function.copies_nothing``); returns whether both are in place."""
    ic = importlib.import_module(f"{package}.inline_closurecall")
    worker = getattr(ic, "InlineWorker", None)
    inline_ir = getattr(worker, "inline_ir", None)
    if getattr(inline_ir, "shares_scope_copies", False):
        return getattr(worker.inline_function, "copies_nothing", False)
    if inline_ir is None or getattr(ic, "copy", None) is not copy:
        return False
    verified = _source_hash(worker.inline_function) == VERIFIED.get(package, {}).get("inlining")

    ir = importlib.import_module(f"{package}.ir")
    extensions = importlib.import_module(f"{package}.ir_utils").add_offset_to_labels_extensions

    def inline_function(self, caller_ir, block, i, function, arg_typs=None):
        callee_ir = self.run_untyped_passes(function)
        callee_ir.blocks = compact_labels(callee_ir.blocks, ir, tuple(extensions))
        freevars = function.__code__.co_freevars
        ic.copy = _NoCopy
        try:
            return inline_ir(self, caller_ir, block, i, callee_ir, freevars, arg_typs=arg_typs)
        finally:
            ic.copy = copy

    def shared(self, *args, **kwargs):
        ic.copy = _OneMemo()
        try:
            return inline_ir(self, *args, **kwargs)
        finally:
            ic.copy = copy

    shared.shares_scope_copies = True
    shared.__doc__ = inline_ir.__doc__
    swaps.put(worker, "inline_ir", shared)
    if verified:
        inline_function.copies_nothing = True
        inline_function.__doc__ = worker.inline_function.__doc__
        swaps.put(worker, "inline_function", inline_function)
    return verified


def compact_labels(blocks: dict, ir: Any, extended: tuple = ()) -> dict:
    """``blocks`` labelled 0, 1, 2, ... in the order of their labels, their jumps and branches
    with them (``ir``: the front end's IR module): the labels' order, and so the inlined code, is
    the same.  Left as they are where a statement of a type in ``extended`` (one that holds
    labels of its own, as numba's parfors do) is among them."""
    if extended and any(isinstance(inst, extended) for b in blocks.values() for inst in b.body):
        return blocks
    new = {label: n for n, label in enumerate(sorted(blocks))}
    for b in blocks.values():
        term = b.body[-1] if b.body else None
        # (new terminators, as numba's ``add_offset_to_labels`` makes: copies may share the old)
        if isinstance(term, ir.Jump):
            b.body[-1] = ir.Jump(new[term.target], term.loc)
        elif isinstance(term, ir.Branch):
            b.body[-1] = ir.Branch(term.cond, new[term.truebr], new[term.falsebr], term.loc)
    return {new[label]: b for label, b in blocks.items()}


def _source_hash(*objects: Any) -> str:
    """16 hex digits of a hash of the objects' source text ("" where it cannot be read)."""
    h = hashlib.sha256()
    try:
        for obj in objects:
            h.update(_source(obj).encode())
    except (OSError, TypeError):
        return ""
    return h.hexdigest()[:16]


def _source(obj: Any) -> str:
    """``inspect.getsource(obj)``, a class's found without ``ast``: CPython 3.11 finds a class by
    parsing its whole module, and its parser's shared recursion count can fail a parse that runs
    beside another thread's (``SystemError: AST constructor recursion depth mismatch``,
    python/cpython#106905; seen in a dask worker compiling a loop).  The class statement (with its
    decorators) is found in the module's lines by name instead, and its block by ``inspect``'s
    tokenizer, as ``inspect.getsource`` cuts it."""
    if not inspect.isclass(obj):
        return inspect.getsource(obj)
    lines = linecache.getlines(inspect.getsourcefile(obj) or "")
    statement = re.compile(rf"\s*class\s+{re.escape(obj.__name__)}\b")
    for number, line in enumerate(lines):
        if statement.match(line):
            while number > 0 and lines[number - 1].lstrip().startswith("@"):
                number -= 1
            return "".join(inspect.getblock(lines[number:]))
    raise OSError(f"could not find class {obj.__qualname__}")


def live_map_as_bits(cfg, blocks: dict, var_use_map: dict, var_def_map: dict, forward: list,
                     backward: list) -> dict:
    """The variables live at each block's entry, as numba's ``compute_live_map`` finds them: the
    definitions reaching each block (a forward sweep over the labels ``forward``, to the least
    fixed point), then liveness (a backward sweep over ``backward``: a variable live at a block's
    entry is live at its predecessor's entry where a definition of it reaches the predecessor
    and the predecessor does not define it), on integer bit sets."""
    index: dict[str, int] = {}
    names: list[str] = []
    use = {k: _bits(v, index, names) for k, v in var_use_map.items()}
    defs = {k: _bits(v, index, names) for k, v in var_def_map.items()}
    reach: defaultdict[Any, int] = defaultdict(int)
    succ = {o: [s for s, _ in cfg.successors(o)] for o in forward}
    changed = True
    while changed:
        changed = False
        for o in forward:
            r = reach[o] | defs[o] | use[o]
            if r != reach[o]:
                reach[o], changed = r, True
            for s in succ[o]:
                t = reach[s] | r
                if t != reach[s]:
                    reach[s], changed = t, True
    live = {o: use[o] for o in blocks}
    pred = {o: [p for p, _ in cfg.predecessors(o)] for o in backward}
    changed = True
    while changed:
        changed = False
        for o in backward:
            here = live[o]
            for p in pred[o]:
                t = live[p] | (here & reach[p] & ~defs[p])
                if t != live[p]:
                    live[p], changed = t, True
    table = np.array(names, dtype=object)
    out = _LiveMap()
    for o, m in live.items():
        out[o] = _by_table(m, table)
    out.index, out.names, out.live, out.defs, out.var_def_map = index, names, live, defs, var_def_map
    out.table = table
    return out


class _LiveMap(dict):
    """A live map (label -> names) that keeps the bit sets it was made of: ``live`` and ``defs``
    (label -> int) over ``names`` (bit i: ``names[i]``, also as the array ``table``; ``index``
    the other way), for the definitions ``var_def_map``."""

    index: dict
    names: list
    table: np.ndarray
    live: dict
    defs: dict
    var_def_map: dict


class _DeadMap(dict):
    """The combined dead map (label -> names) with its bit sets (``bits``) and the live map
    whose names they index (``live_map``)."""

    bits: dict
    live_map: _LiveMap


def _bits(vs, index: dict, names: list) -> int:
    """The bit set of the names ``vs`` (bit i: ``names[i]``; ``index`` the other way; new names
    take new bits)."""
    m = 0
    for n in vs:
        i = index.get(n)
        if i is None:
            i = index[n] = len(names)
            names.append(n)
        m |= 1 << i
    return m


def _by_table(m: int, table: np.ndarray) -> set:
    """The names of the bits set in ``m`` (bit i: ``table[i]``), through numpy."""
    width = max((table.shape[0] + 7) // 8, 1)
    on = np.flatnonzero(np.unpackbits(np.frombuffer(m.to_bytes(width, "little"), np.uint8),
                                      bitorder="little"))
    return set(table[on].tolist())


def _names(m: int, live_map: _LiveMap) -> set:
    """The names of the bits set in ``m``: bit by bit for a few, else through numpy."""
    names = live_map.names
    if m.bit_count() <= 32:
        out = set()
        while m:
            low = m & -m
            out.add(names[low.bit_length() - 1])
            m ^= low
        return out
    if live_map.table.shape[0] != len(names):
        live_map.table = np.array(names, dtype=object)
    return _by_table(m, live_map.table)


def dead_maps_as_bits(cfg, blocks: dict, live_map: _LiveMap, own: Any):
    """numba's ``compute_dead_maps`` (``own``: its result type and the error it raises) on the
    live map's bit sets: the variables to delete inside each block (``internal``: live in it and
    in none of its successors nor its terminator), at the start of each successor
    (``escaping``) and at the exit, checked to cover every live variable; ``combined`` keeps
    its bit sets for ``live_variables_as_bits``."""
    live, defs = live_map.live, live_map.defs
    internal: defaultdict = defaultdict(int)
    escaping: defaultdict = defaultdict(int)
    exits = 0
    every = 0
    for offset, ir_block in blocks.items():
        here = live[offset] | defs[offset]
        successors = dict.fromkeys(s for s, _ in cfg.successors(offset))
        terminator = _bits((v.name for v in ir_block.terminator.list_vars()), live_map.index, live_map.names)
        kept = terminator
        for s in successors:
            kept |= live[s]
        internal[offset] = inside = here & ~kept
        leaving = here & ~inside
        for s in successors:
            escaping[s] |= leaving & ~(live[s] | defs[s])
        if not successors:
            exits |= terminator
    for m in live.values():
        every |= m
    dead = exits
    for m in internal.values():
        dead |= m
    for m in escaping.values():
        dead |= m
    missing = every & ~dead
    if missing and cfg.exit_points():
        raise RuntimeError(f"liveness info missing for vars: {_names(missing, live_map)}")
    combined = _DeadMap()
    combined.bits = {}
    for k in blocks:
        combined.bits[k] = m = internal[k] | escaping[k]
        combined[k] = _names(m, live_map)
    combined.live_map = live_map
    as_sets = defaultdict(set)
    as_sets.update((k, _names(m, live_map)) for k, m in internal.items())
    leaving_sets = defaultdict(set)
    leaving_sets.update((k, _names(m, live_map)) for k, m in escaping.items())
    return own(internal=as_sets, escaping=leaving_sets, combined=combined)


def live_variables_as_bits(cfg, var_def_map: dict, dead: _DeadMap) -> defaultdict:
    """numba's ``compute_live_variables`` on bit sets: the variables available at each block's
    entry (defined on some path to it and not deleted since), to the least fixed point of a
    sweep in the CFG's topological order."""
    live_map = dead.live_map
    defs, gone = live_map.defs, dead.bits
    entry: defaultdict = defaultdict(int)
    order = cfg.topo_order()
    successors = {o: [s for s, _ in cfg.successors(o)] for o in order}
    changed = True
    while changed:
        changed = False
        for o in order:
            avail = (entry[o] | defs[o]) & ~gone[o]
            for s in successors[o]:
                t = entry[s] | avail
                if t != entry[s]:
                    entry[s], changed = t, True
    out = defaultdict(set)
    out.update((k, _names(m, live_map)) for k, m in entry.items())
    return out


def _dead_maps(package: str, swaps: Swaps) -> bool:
    """Put ``dead_maps_as_bits`` and ``live_variables_as_bits`` in ``package`` (numba's front
    end, where their sources are the verified ones), each used where its inputs are the bit
    sets' own maps (a live map of ``live_map_as_bits``, the dead map made from it) and numba's
    own function otherwise; returns whether they are in place."""
    analysis = importlib.import_module(f"{package}.analysis")
    own_dead, own_live = analysis.compute_dead_maps, analysis.compute_live_variables
    if getattr(own_dead, "as_bits", False):
        return True
    if _source_hash(own_dead, own_live) != VERIFIED.get(package, {}).get("dead"):
        return False
    result = analysis._dead_maps_result

    def compute_dead_maps(cfg, blocks, live_map, var_def_map):
        if isinstance(live_map, _LiveMap) and live_map.var_def_map is var_def_map:
            return dead_maps_as_bits(cfg, blocks, live_map, result)
        return own_dead(cfg, blocks, live_map, var_def_map)

    def compute_live_variables(cfg, blocks, var_def_map, var_dead_map):
        if isinstance(var_dead_map, _DeadMap) and var_dead_map.live_map.var_def_map is var_def_map:
            return live_variables_as_bits(cfg, var_def_map, var_dead_map)
        return own_live(cfg, blocks, var_def_map, var_dead_map)

    for new, own in ((compute_dead_maps, own_dead), (compute_live_variables, own_live)):
        new.as_bits, new.__wrapped__, new.__doc__ = True, own, own.__doc__
    swaps.put(analysis, "compute_dead_maps", compute_dead_maps)
    swaps.put(analysis, "compute_live_variables", compute_live_variables)
    return True


def _live_maps(package: str, swaps: Swaps) -> bool:
    """Put ``live_map_as_bits`` as ``package``'s ``compute_live_map`` (where its source is
    the verified one); returns whether it is in place.  numba sweeps its CFG's topological
    order (reversed for liveness), numba-cuda the block maps' order: the sweeps' domains."""
    analysis = importlib.import_module(f"{package}.analysis")
    ir_utils = importlib.import_module(f"{package}.ir_utils")
    own = analysis.compute_live_map
    if getattr(own, "as_bits", False):
        return True
    if _source_hash(own) != VERIFIED.get(package, {}).get("liveness"):
        return False
    topological = package == "numba.core"

    def compute_live_map(cfg, blocks, var_use_map, var_def_map):
        if topological:
            order = list(cfg.topo_order())
            return live_map_as_bits(cfg, blocks, var_use_map, var_def_map, order, order[::-1])
        return live_map_as_bits(cfg, blocks, var_use_map, var_def_map, list(var_def_map), list(blocks))

    compute_live_map.as_bits = True
    compute_live_map.__doc__ = own.__doc__
    swaps.put(analysis, "compute_live_map", compute_live_map)
    if getattr(ir_utils, "compute_live_map", None) is own:
        swaps.put(ir_utils, "compute_live_map", compute_live_map)
    return True


def ssa_on_named_blocks(package: str, swaps: Swaps) -> bool:
    """Put in ``package``'s SSA pass a driver that rewrites, for each variable with several
    definitions, only the blocks whose statements name it (where the pass's source is the
    verified one); returns whether it is in place."""
    ssa = importlib.import_module(f"{package}.ssa")
    if getattr(ssa._run_ssa, "named_blocks", False):
        return True
    parts = (getattr(ssa, part, None) for part in SSA_PARTS)
    if _source_hash(*parts) != VERIFIED.get(package, {}).get("ssa"):
        return False
    block = ssa.ir.Block

    def rewrite(blocks, states, handler, named):
        new = {}
        for label, blk in blocks.items():
            if label not in named:  # no statement names the variable: the pass keeps it as it is
                new[label] = blk
                continue
            states["label"], states["block"] = label, blk
            new[label] = fresh = block(scope=blk.scope, loc=blk.loc)
            fresh.body = list(ssa._run_ssa_block_pass(states, blk, handler))
        return new

    def _run_ssa(blocks):
        if not blocks:
            return {}
        cfg = ssa.compute_cfg_from_blocks(blocks)
        df_plus = ssa._iterated_domfronts(cfg)
        violators = ssa._find_defs_violators(blocks, cfg)
        cache_list_vars = ssa._CacheListVars()
        copied = {}
        where = defaultdict(set)  # variable name -> labels of the blocks that name it
        for label, blk in blocks.items():
            copied[label] = own = block(scope=blk.scope, loc=blk.loc)
            own.body = list(blk.body)
            for stmt in blk.body:
                for var in cache_list_vars.get(stmt):
                    where[var.name].add(label)
        blocks = copied
        for varname in violators:
            named = where[varname]
            defmap = defaultdict(list)
            states = ssa._make_states(blocks)
            states.update(varname=varname, defmap=defmap)
            blocks = rewrite(blocks, states, ssa._FreshVarHandler(), named)
            states = ssa._make_states(blocks)
            states.update(varname=varname, defmap=defmap, phimap=defaultdict(list), cfg=cfg,
                          phi_locations=ssa._compute_phi_locations(df_plus, defmap))
            blocks = rewrite(blocks, states, ssa._FixSSAVars(cache_list_vars), named)
            for label, philist in states["phimap"].items():
                blocks[label].body = philist + blocks[label].body
        if ssa.compute_cfg_from_blocks(blocks) != cfg:
            raise ssa.errors.CompilerError("CFG mutated in SSA pass")
        return blocks

    _run_ssa.named_blocks = True
    _run_ssa.__doc__ = ssa._run_ssa.__doc__
    swaps.put(ssa, "_run_ssa", _run_ssa)
    return True


def memo_call_types(package: str, swaps: Swaps) -> bool:
    """Put in ``package``'s function types a ``get_call_type`` that keeps each resolved
    signature under (function type, typing context, target, argument types) in ``CALL_TYPES``
    and hands it out again with its implementation key (where the method's source is the
    verified one); returns whether it is in place."""
    functions = importlib.import_module(FUNCTION_TYPES[package])
    base = functions.BaseFunction
    own = base.get_call_type
    if getattr(own, "kept", False):
        return True
    if _source_hash(own) != VERIFIED.get(package, {}).get("calls"):
        return False
    from numba.core.target_extension import get_local_target

    resolved = CALL_TYPES

    def get_call_type(self, context, args, kws):
        try:
            key = (self, context, get_local_target(context), tuple(args), tuple(sorted(kws.items())))
            hit = resolved.get(key)
        except TypeError:  # (an unhashable argument type: resolved as numba does)
            return own(self, context, args, kws)
        if hit is not None:
            sig, impl = hit
            self._impl_keys[sig.args] = impl  # (as the resolution records it)
            return sig
        sig = own(self, context, args, kws)
        if sig is not None:
            resolved[key] = sig, self._impl_keys[sig.args]
        return sig

    get_call_type.kept = True
    get_call_type.resolved = resolved
    get_call_type.__wrapped__ = own
    get_call_type.__doc__ = own.__doc__
    swaps.put(base, "get_call_type", get_call_type)
    return True


def _variable_lister(ir: Any):
    """``Inst._rec_list_vars`` of the IR module ``ir``: the variables in a value, depth first,
    with the containers and leaves the IR holds most told apart by their exact type first."""
    var, inst = ir.Var, ir.Inst
    leaves = frozenset({str, int, float, bool, type(None), ir.Loc})

    def collect(val: Any, out: list) -> None:
        t = type(val)
        if t is var:
            out.append(val)
        elif t is list or t is tuple:
            for v in val:
                collect(v, out)
        elif t is dict:
            for v in val.values():
                collect(v, out)
        elif t in leaves:
            return
        elif isinstance(val, var):  # (numba's own order of tests, for subclasses)
            out.append(val)
        elif isinstance(val, inst):
            out.extend(val.list_vars())
        elif isinstance(val, (list, tuple)):
            for v in val:
                collect(v, out)
        elif isinstance(val, dict):
            for v in val.values():
                collect(v, out)

    def _rec_list_vars(self, val):
        out: list = []
        collect(val, out)
        return out

    _rec_list_vars.__wrapped__ = ir.Inst._rec_list_vars
    return _rec_list_vars


def _use_defs_once(ir: Any, analysis: Any):
    """``analysis.compute_use_defs`` listing a plain assignment's variables once: numba lists
    its value's variables, then the statement's (the value's again and the target).  Other
    statements as numba does."""
    assign, inst, var = ir.Assign, ir.Inst, ir.Var
    atoms = (ir.Arg, ir.Const, ir.Global, ir.FreeVar)

    def rhs_names(value: Any) -> list:
        if isinstance(value, inst):
            return [v.name for v in value.list_vars()]
        if isinstance(value, var):
            return [value.name]
        if isinstance(value, atoms):
            return []
        raise AssertionError('unreachable', type(value))

    def compute_use_defs(blocks):
        var_use_map, var_def_map = {}, {}
        extensions = analysis.ir_extension_usedefs
        for offset, ir_block in blocks.items():
            var_use_map[offset] = use_set = set()
            var_def_map[offset] = def_set = set()
            for stmt in ir_block.body:
                if type(stmt) in extensions:
                    extensions[type(stmt)](stmt, use_set, def_set)
                    continue
                if type(stmt) is assign and len(stmt.__dict__) == 3:  # (value, target, loc)
                    rhs = rhs_names(stmt.value)
                    target = stmt.target.name
                    if target not in rhs:
                        def_set.add(target)
                    for name in rhs:  # the statement's variables: the value's, then the target
                        if name not in def_set:
                            use_set.add(name)
                    if target not in def_set:
                        use_set.add(target)
                    continue
                if isinstance(stmt, assign) and stmt.target.name not in rhs_names(stmt.value):
                    def_set.add(stmt.target.name)
                for v in stmt.list_vars():
                    if v.name not in def_set:
                        use_set.add(v.name)
        return analysis._use_defs_result(usemap=var_use_map, defmap=var_def_map)

    return compute_use_defs


def list_vars_once(package: str, swaps: Swaps) -> bool:
    """Put in ``package`` the faster ``Inst._rec_list_vars`` and ``compute_use_defs`` (where
    their sources are the verified ones); returns whether they are in place."""
    ir = importlib.import_module(f"{package}.ir")
    analysis = importlib.import_module(f"{package}.analysis")
    own = analysis.compute_use_defs
    if getattr(own, "lists_once", False):
        return True
    if _source_hash(ir.Inst._rec_list_vars, own) != VERIFIED.get(package, {}).get("variables"):
        return False
    swaps.put(ir.Inst, "_rec_list_vars", _variable_lister(ir))
    fast = _use_defs_once(ir, analysis)
    fast.lists_once = True
    fast.__wrapped__ = own
    fast.__doc__ = own.__doc__
    swaps.put(analysis, "compute_use_defs", fast)
    for name in USE_DEFS_IMPORTERS:
        try:
            module = importlib.import_module(f"{package}.{name}")
        except ImportError:
            continue
        if getattr(module, "compute_use_defs", None) is own:
            swaps.put(module, "compute_use_defs", fast)
    return True


def release_only_memory(package: str, swaps: Swaps) -> bool:
    """Put in ``package``'s lowering (numba's; where ``Lower.storevar`` and ``Lower.delvar`` are
    the verified ones) a store and a deletion that neither load, release nor zero a variable
    whose type holds no memory info; returns whether they are in place."""
    if package != "numba.core":
        return False
    lowering = importlib.import_module(f"{package}.lowering")
    lower = lowering.Lower
    store, delete = lower.storevar, lower.delvar
    if getattr(store, "releases_memory_only", False):
        return True
    if _source_hash(store, delete) != VERIFIED[package].get("release"):
        return False

    def holds_memory(self, fetype) -> bool:
        return self._disable_sroa_like_opt or self.context.data_model_manager[fetype].contains_nrt_meminfo()

    def storevar(self, value, name, argidx=None):
        fetype = self.typeof(name)
        if argidx is not None or name in self._singly_assigned_vars or holds_memory(self, fetype):
            return store(self, value, name, argidx)
        self._alloca_var(name, fetype)
        ptr = self.getvar(name)
        if value.type != ptr.type.pointee:
            raise AssertionError(f"Storing {value.type} to ptr of {ptr.type.pointee} ('{name}'). FE type "
                                 f"{fetype}")
        self.builder.store(value, ptr)

    def delvar(self, name):
        fetype = self.typeof(name)
        if holds_memory(self, fetype):
            return delete(self, name)
        if name not in self._blk_local_varmap:  # (as numba's: a later store goes to the slot)
            self._singly_assigned_vars.discard(name)
        self._alloca_var(name, fetype)

    storevar.releases_memory_only = True
    storevar.__doc__, delvar.__doc__ = store.__doc__, delete.__doc__
    swaps.put(lower, "storevar", storevar)
    swaps.put(lower, "delvar", delvar)
    return True


#: Each replacement by name, in the order they are put in place.
REPLACEMENTS = {"inlining": share_scope_copies, "liveness": _live_maps, "variables": list_vars_once,
                "dead": _dead_maps, "ssa": ssa_on_named_blocks, "calls": memo_call_types,
                "release": release_only_memory}


def enabled() -> bool:
    """Whether the replacements are wanted: ``VINES_STOCH_FAST_FRONTEND`` is not ``0`` (nor
    ``false``, ``no``, ``off``)."""
    return os.environ.get(SWITCH, "1").strip().lower() not in ("0", "false", "no", "off")


def _warn_once(package: str, placed: dict[str, bool]) -> None:
    """One ``FrontEndWarning`` a process and front end naming the replacements verified for
    ``package`` that are not in place, with the release installed."""
    missing = [part for part in VERIFIED.get(package, {}) if not placed.get(part)]
    if not missing or package in _WARNED:
        return
    _WARNED.add(package)
    try:
        release = f"{DISTRIBUTIONS[package]} {metadata.version(DISTRIBUTIONS[package])}"
    except (KeyError, metadata.PackageNotFoundError):
        release = package
    warnings.warn(f"vines_stoch: the front-end replacements {', '.join(missing)} do not apply to {release} "
                  f"(verified against {VERIFIED_RELEASES}); numba's own pieces compile in their place and "
                  f"cold compiles take longer ({SWITCH}=0 turns the replacements off and silences this)",
                  FrontEndWarning, stacklevel=4)  # (the ``with`` of ``compiling``)


@contextmanager
def compiling(package: str = "numba.core") -> Iterator[dict[str, bool]]:
    """The replacements in ``package`` (numba's front end, or numba-cuda's ``numba.cuda.core``)
    while the block runs, holding ``package``'s compiler lock, so that no other thread compiles
    with them; numba's own are put back on leaving.  Yields which are in place (none where
    ``enabled`` is False); one whose numba source is not the verified one is left out, and a
    ``FrontEndWarning`` says so once a process."""
    if not enabled():
        yield dict.fromkeys(REPLACEMENTS, False)
        return
    lock = importlib.import_module(f"{package}.compiler_lock").global_compiler_lock
    swaps = Swaps()
    with lock:
        try:
            placed = {}
            for part, put in REPLACEMENTS.items():
                try:
                    placed[part] = put(package, swaps)
                except (AttributeError, ImportError):  # (another release's front end lacks a piece)
                    placed[part] = False
            _warn_once(package, placed)
            yield placed
        finally:
            swaps.restore()
