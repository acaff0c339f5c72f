"""The package's layout: no import circle; the validation floor (``vines_stoch.validation``)
stands on the engine and the engine never imports it (but lazily in two CLI commands); a run
needs neither sdeint nor matplotlib, which are extras (``[bench]``, ``[report]``); numba is left
as it ships, and the package compiles through its own ``njit``."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

import pytest

import vines_stoch
from tests.helpers import cli
from vines_stoch import plotting
from vines_stoch.scenario import load_scenario
from vines_stoch.validation import scenes

PACKAGE = Path(vines_stoch.__file__).resolve().parent
ROOT = PACKAGE.parent
VALIDATION = "vines_stoch.validation"


def _modules() -> dict[str, Path]:
    """Every module of the package by dotted name (packages by their ``__init__``)."""
    modules = {}
    for path in PACKAGE.rglob("*.py"):
        parts = path.relative_to(ROOT).with_suffix("").parts
        modules[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return modules


MODULES = _modules()


def _targets(module: str, path: Path, node: ast.Import | ast.ImportFrom) -> list[str]:
    """The package modules an import statement of ``module`` names (relative imports resolved;
    ``from . import x`` names the module ``x`` where there is one, else the package)."""
    if isinstance(node, ast.Import):
        names = [alias.name for alias in node.names]
    else:
        if node.level:
            package = module.split(".") if path.name == "__init__.py" else module.split(".")[:-1]
            base = ".".join(package[:len(package) - node.level + 1] + ([node.module] if node.module else []))
        else:
            base = node.module or ""
        names = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in MODULES else base
                 for alias in node.names]
    targets = []
    for name in names:
        while name and name not in MODULES:  # an attribute or a module outside the package
            name = name.rpartition(".")[0]
        if name:
            targets.append(name)
    return targets


def _imports() -> dict[str, list[tuple[str, bool]]]:
    """``module -> [(imported module, at module level)]`` for every import in the package, those
    inside functions included."""
    graph: dict[str, list[tuple[str, bool]]] = {}
    for module, path in MODULES.items():
        tree = ast.parse(path.read_text(), str(path))
        lazy = {id(node) for function in ast.walk(tree)
                if isinstance(function, (ast.FunctionDef, ast.AsyncFunctionDef))
                for node in ast.walk(function)}
        graph[module] = [(target, id(node) not in lazy) for node in ast.walk(tree)
                         if isinstance(node, (ast.Import, ast.ImportFrom))
                         for target in _targets(module, path, node)]
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in graph[v] - {v}:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in graph:
        if v not in index:
            visit(v)
    return found


def test_the_import_graph_sees_the_package():
    graph = _imports()
    bench = {(t, top) for t, top in graph["vines_stoch.validation.bench"]}
    assert ("vines_stoch.validation.stability", True) in bench
    assert ("vines_stoch.scenario.study", True) in graph["vines_stoch.validation.scenes"]
    assert ("vines_stoch.validation.bench", False) in graph["vines_stoch.cli"]


def test_no_import_cycle():
    """No circle among the package's modules, counting imports inside functions too."""
    graph = {module: {target for target, _ in targets} for module, targets in _imports().items()}
    assert _cycles(graph) == []


def test_the_engine_does_not_import_the_validation_floor():
    """Only the ``bench`` and ``reproduce`` commands of cli.py reach it, inside their functions."""
    offending = [(module, target, "module level" if top else "in a function")
                 for module, targets in _imports().items() if not (module + ".").startswith(VALIDATION + ".")
                 for target, top in targets if (target + ".").startswith(VALIDATION + ".")
                 and not (module == "vines_stoch.cli" and not top)]
    assert offending == []


RUN = """
import sys
from vines_stoch.cli import main
sys.argv = ["vines-stoch", "run", sys.argv[1], "--quiet", "--out", sys.argv[2]]
try:
    main()
except SystemExit as exc:
    assert not exc.code, exc.code
unwanted = ("sdeint", "matplotlib", "vines_stoch.validation", "distributed")
print(sorted(name for name in unwanted if name in sys.modules))
"""


def test_a_run_imports_neither_sdeint_nor_matplotlib(tmp_path):
    """A run on the embedded scheduler imports neither the bench's peers, nor the validation
    floor, nor dask.distributed."""
    scenario = ROOT / "scenarios/cubic_nes_impulse.toml"
    done = subprocess.run([sys.executable, "-c", RUN, str(scenario), str(tmp_path)],
                          cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split("\n")[-2] == "[]"
    assert (tmp_path / "summary.parquet").is_file()


@pytest.mark.parametrize("name", scenes.names())
def test_every_scene_file_is_a_valid_scenario(name):
    study = load_scenario(scenes.FOLDER / f"{name}.toml")
    assert study.name and len(study.points) == 1
    assert scenes.scene_data(name) == study.data and scenes.scene_data(name) is not scenes.scene_data(name)


def test_scene_changes_create_missing_tables_and_copy():
    data = scenes.scene_data("impulse")
    noise = scenes.scene_data("smooth")["loads"]
    changed = scenes.changed(data, {"ensemble.realizations": 4, "loads": noise, "absorbers.0.damping": 0.02})
    assert changed["ensemble"] == {"realizations": 4} and "ensemble" not in data
    assert changed["loads"] == noise and changed["loads"] is not noise
    assert changed["absorbers"][0]["damping"] == 0.02 and data["absorbers"][0]["damping"] == 0.01
    assert scenes.study(changed).base.ensemble.realizations == 4


def test_without_matplotlib_plots_are_skipped_with_one_line(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib raises ImportError
    assert not plotting.available()
    assert plotting.pyplot("x.png") is None
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "x.png" in err and 'pip install "vines-stoch[report]"' in err


def test_bench_without_sdeint_names_the_extra(monkeypatch, tmp_path):
    monkeypatch.setitem(sys.modules, "sdeint", None)
    code, err = cli("bench", "--out", tmp_path / "bench.md")
    assert code == 2 and err.count("\n") == 1 and 'pip install "vines-stoch[bench]"' in err
    assert not (tmp_path / "bench.md").exists()


def _reach(start: str) -> set[str]:
    """The modules importing ``start`` loads: its module-level imports, each one's parent
    packages (Python runs a package's ``__init__`` before its modules), and so on."""
    graph = _imports()
    seen: set[str] = set()
    todo = [start]
    while todo:
        module = todo.pop()
        if module in seen:
            continue
        seen.add(module)
        parts = module.split(".")
        todo += [".".join(parts[:k]) for k in range(2, len(parts)) if ".".join(parts[:k]) in MODULES]
        todo += [target for target, top in graph.get(module, ()) if top]
    return seen - {start}


FLOORS = {
    # the physics floor: formulae only, on the compile options; no step loop, no front end
    "vines_stoch.physics": ("vines_stoch.kernels", "vines_stoch.jit.frontend"),
    # the scene and the scenario files: codes from the physics floor and outputs, never the loops
    "vines_stoch.scene": ("vines_stoch.kernels",),
    "vines_stoch.scenario": ("vines_stoch.kernels", "vines_stoch.jit"),
}


@pytest.mark.parametrize("floor", sorted(FLOORS))
def test_the_floors_stand_on_what_is_below_them(floor):
    modules = [m for m in MODULES if m == floor or m.startswith(floor + ".")]
    assert modules
    for module in modules:
        reached = _reach(module)
        banned = [m for m in reached for b in FLOORS[floor] if m == b or m.startswith(b + ".")]
        assert banned == [], (module, banned)


#: The schemes' steps (``kernels/protocol.py``) and the executors that run them: the scalar loop,
#: the SIMD lanes, the cuda kernel, and the chunk and path runners around them.
SCHEMES = ("vines_stoch.kernels.kdk", "vines_stoch.kernels.sra3", "vines_stoch.kernels.rk4")
EXECUTORS = ("vines_stoch.kernels.driver", "vines_stoch.kernels.lanes", "vines_stoch.kernels.launch",
             "vines_stoch.kernels.chunk", "vines_stoch.kernels.paths", "vines_stoch.kernels")


def _imported(start: str) -> set[str]:
    """The modules ``start`` imports, directly or through the modules it imports (inside
    functions too), not counting the packages Python runs first."""
    graph = _imports()
    seen: set[str] = set()
    todo = [start]
    while todo:
        module = todo.pop()
        if module not in seen:
            seen.add(module)
            todo += [target for target, _ in graph.get(module, ())]
    return seen - {start}


@pytest.mark.parametrize("scheme", SCHEMES)
def test_a_scheme_imports_no_executor(scheme):
    """A step knows the protocol (``kernels/protocol.py``), not the loops that run it."""
    assert scheme in MODULES
    assert sorted(set(EXECUTORS) & _imported(scheme)) == []


def test_nothing_outside_the_kernels_imports_a_kernel_module():
    """The kernels' one front is their package (``kernels/__init__.py``): no module of the package
    outside ``kernels/`` imports ``kernels.<module>``, at module level or inside a function."""
    inside = "vines_stoch.kernels."
    found = [(module, target) for module, targets in _imports().items() if not module.startswith(inside)
             and module != "vines_stoch.kernels" for target, _ in targets if target.startswith(inside)]
    assert found == []
    assert any(target == "vines_stoch.kernels" for targets in _imports().values() for target, _ in targets)


#: The step loops still longer than ``LONGEST`` lines, at their length today: the rewrite of the
#: loops around one step protocol takes them apart.  None may grow, and none may join them.  (The
#: scalar loops grew by a line a flag they read when the general loop reads it at run time:
#: ``common.bit_set``, written out where used so that numba prunes a constant's dead branches.)
LONG_LOOPS = {"vines_stoch.kernels.lanes.lane_loop": 427, "vines_stoch.kernels.kdk.kdk_step": 303,
              "vines_stoch.kernels.driver.step_loop": 183, "vines_stoch.kernels.rk4.rk4_step": 189,
              "vines_stoch.kernels.kdk.advance": 185, "vines_stoch.kernels.driver.kernel": 164}
LONGEST = 150


def test_no_function_is_longer_than_150_lines():
    lengths = {}
    for module, path in MODULES.items():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                lengths[f"{module}.{node.name}"] = node.end_lineno - node.lineno + 1
    long = {name: n for name, n in lengths.items() if n > LONGEST}
    assert set(long) <= set(LONG_LOOPS), {name: long[name] for name in set(long) - set(LONG_LOOPS)}
    grown = {name: (long[name], LONG_LOOPS[name]) for name in long if long[name] > LONG_LOOPS[name]}
    assert not grown, grown


#: A process that lists every attribute of numba's and numba-cuda's modules and of their classes
#: (by identity), then imports the package, compiles a kernel through the package's compile
#: (``jit.compile_once``: the faster front end in place while it compiles; saved in the package's
#: disk cache) and runs it, and lists them again: the names whose values changed.
NUMBA_UNTOUCHED = r'''
import sys
import numba, numba.core.caching, numba.core.compiler, numba.core.typed_passes
import numba.core.untyped_passes, numba.core.inline_closurecall, numba.core.analysis, numba.core.ssa
import numba.core.lowering, numba.core.ir, numba.core.typeinfer, numba.core.types.functions


def code(value):
    """Whether ``value`` is code (a function, a class, a method's descriptor), not numba's data
    (its caches and lazy tables, which compiling fills)."""
    return callable(value) or isinstance(value, (staticmethod, classmethod, property))


def snapshot():
    seen = {}
    for name, module in list(sys.modules.items()):
        if not name.startswith("numba") or module is None:
            continue
        for attr, value in list(vars(module).items()):
            if code(value):
                seen[f"{name}.{attr}"] = id(value)
            if isinstance(value, type) and value.__module__ == name:
                for key, item in list(vars(value).items()):
                    if code(item):
                        seen[f"{name}.{attr}.{key}"] = id(item)
                    elif isinstance(item, list) and all(isinstance(i, type) for i in item):
                        seen[f"{name}.{attr}.{key}[]"] = tuple(map(id, item))  # (the cache's locators)
    return seen


before = snapshot()
import numpy as np
from vines_stoch.jit import compile_once
from vines_stoch.kernels.common import stored_energy
from vines_stoch.physics.absorbers import ROW
args = (np.zeros(2), np.zeros(2), np.ones(2), 1, np.ones(1), np.zeros(1, np.int64), np.zeros(1, np.int64),
        np.zeros((1, ROW)))
compile_once(stored_energy, args)
stored_energy(*args)
after = snapshot()
print(sorted(k for k in before if k in after and before[k] != after[k]))
'''


def test_the_package_leaves_numba_as_it_ships(tmp_path):
    """No module of the package assigns into numba's modules or classes for good: after the
    package is imported and a kernel compiled (from an empty cache: the faster front end of
    ``jit.frontend`` in numba's compiler for that compile alone) and run, every function and
    class of numba's modules and every method of their classes is the object it was, and each
    class's lists of classes (numba's cache locators among them) hold the same items."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    done = subprocess.run([sys.executable, "-c", NUMBA_UNTOUCHED], cwd=ROOT, env=env, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip().splitlines()[-1] == "[]"


def test_the_package_compiles_through_its_own_njit():
    """Every module of the package but ``jit/cache.py`` takes ``njit`` from ``vines_stoch.jit``
    (numba's, with the package's disk cache keyed by its sources): none imports numba's own
    ``njit`` or calls ``numba.njit``."""
    own = PACKAGE / "jit" / "cache.py"
    found = []
    for module, path in MODULES.items():
        if path == own:
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("numba") and any(
                    alias.name == "njit" for alias in node.names):
                found.append(module)
            elif isinstance(node, ast.Attribute) and node.attr == "njit" and isinstance(
                    node.value, ast.Name) and node.value.id == "numba":
                found.append(module)
    assert found == []
