"""numba's cache keyed by the physics and kernel sources (``vines_stoch.jit.cache``): an edited
formula that a cached function inlines is compiled afresh, never run stale."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from tests.helpers import ROOT, example_data, scene_from
from vines_stoch.jit import cache
from vines_stoch.kernels import kernel_for, simulate
from vines_stoch.kernels.paths import _STARTED

#: Stored energy of a primary with one linear absorber (``kernels.common.stored_energy``
#: inlines ``physics.spring_damper_energy``), printed in full.
SCRIPT = r'''
import numpy as np
from vines_stoch.kernels.common import stored_energy
from vines_stoch.physics.absorbers import ROW
x, v = np.array([0.1, 0.3]), np.array([0.0, 0.0])
rows = np.zeros((1, ROW)); rows[0, 0] = 2.0  # (every column of a row: the loops read them all)
print(repr(stored_energy(x, v, np.array([1.0, 0.1]), 1, np.array([1.0]), np.zeros(1, np.int64),
                         np.zeros(1, np.int64), rows)))
'''


def _run(root: Path, numba_cache: Path) -> float:
    env = {**os.environ, "PYTHONPATH": str(root), "NUMBA_CACHE_DIR": str(numba_cache)}
    done = subprocess.run([sys.executable, "-c", SCRIPT], cwd=root, env=env, capture_output=True, text=True,
                          check=True)
    return float(done.stdout)


def test_an_edited_formula_is_compiled_afresh(tmp_path):
    root = tmp_path / "tree"
    shutil.copytree(cache.PACKAGE, root / "vines_stoch", ignore=shutil.ignore_patterns("__pycache__"))
    numba_cache = tmp_path / "numba"
    before = _run(root, numba_cache)
    assert before == _run(root, numba_cache)  # (now from the cache)
    physics = root / "vines_stoch" / "physics" / "absorbers.py"
    text = physics.read_text()
    start = text.index("def spring_damper_energy")
    body = text.index("return", start)
    physics.write_text(text[:body] + "return 2.0 * " + text[body + len("return "):])
    after = _run(root, numba_cache)
    # the absorber spring's energy doubled: 0.5 k u^2 = 0.04 more
    assert after != before and abs(after - before - 0.5 * 2.0 * 0.2**2) < 1e-12
    folders = {p.name for p in numba_cache.rglob("vines-stoch-*")}
    assert len(folders) == 2, folders


def test_the_digest_follows_every_source(tmp_path):
    root = tmp_path / "vines_stoch"
    shutil.copytree(cache.PACKAGE, root, ignore=shutil.ignore_patterns("__pycache__"))
    first = cache.digest(root)
    assert first == cache.digest(cache.PACKAGE)
    for name in ("physics/absorbers.py", "jit/intrinsics.py", "outputs.py", "kernels/loads.py",
                 "kernels/common.py", "signals.py", "streams/__init__.py", "streams/rng.py",
                 "streams/pcg.py"):
        path = root / name
        path.write_text(path.read_text() + "\n# edited\n")
        assert cache.digest(root) != first, name
        first = cache.digest(root)


def test_a_package_in_a_zip_archive_keeps_numba_s_own_locations(tmp_path):
    """Sources that are not files (a zip archive: nothing to edit) are not hashed."""
    import zipfile

    archive = tmp_path / "vs.zip"
    with zipfile.ZipFile(archive, "w") as z:
        for f in cache.PACKAGE.rglob("*.py"):
            z.write(f, f.relative_to(cache.PACKAGE.parent))
    env = {**os.environ, "PYTHONPATH": str(archive)}
    done = subprocess.run([sys.executable, "-c", "import vines_stoch.jit, vines_stoch.jit.cache as c; "
                           "print(repr(c.cache_folder()), c.PACKAGE)"], cwd=tmp_path, env=env,
                          capture_output=True, text=True, check=True)
    assert done.stdout.startswith("'' ") and "vs.zip" in done.stdout


#: Two processes wait for a go file, then start the same cold cached function (``slow_compile``,
#: ``STATEMENTS`` long) through ``cache.compile_once``, or (argument ``unlocked``) straight
#: through numba; each prints its cache misses and hits.
RACE = r'''
import json, pathlib, sys, time
sys.path.insert(0, sys.argv[1])
import numpy as np
from vines_stoch.jit import cache
from slow_compile import f
folder = pathlib.Path(sys.argv[1])
(folder / f"ready-{sys.argv[2]}").touch()
while not (folder / "go").exists():
    time.sleep(0.002)
args = (np.zeros(3),)
if sys.argv[3] == "unlocked":
    f.compile(tuple(type(f).typeof_pyval(f, a) for a in args))
else:
    cache.compile_once(f, args)
f(*args)
print(json.dumps({"misses": sum(f.stats.cache_misses.values()), "hits": sum(f.stats.cache_hits.values())}))
'''


#: Statements of ``slow_compile.f``: about 0.5 s to compile, far longer than the two processes'
#: start apart.
STATEMENTS = 60


def _race(folder: Path, mode: str) -> list[dict]:
    """Start the two processes of ``RACE`` together; their outputs."""
    lines = "\n".join(f"    a[{i % 3}] = a[{(i + 1) % 3}] * {i}.5 + math.sin(a[{(i + 2) % 3}])"
                      for i in range(STATEMENTS))
    (folder / "slow_compile.py").write_text(f"import math\nfrom numba import njit\n\n\n@njit(cache=True)\n"
                                            f"def f(a):\n{lines}\n    return a\n")
    env = {**os.environ, "NUMBA_CACHE_DIR": str(folder / "numba")}
    processes = [subprocess.Popen([sys.executable, "-c", RACE, str(folder), str(i), mode], env=env,
                                  stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
                 for i in range(2)]
    deadline = time.monotonic() + 120
    while not all((folder / f"ready-{i}").exists() for i in range(2)):
        assert time.monotonic() < deadline and all(p.poll() is None for p in processes)
        time.sleep(0.01)
    (folder / "go").touch()
    outputs = [p.communicate(timeout=300) for p in processes]
    assert all(p.returncode == 0 for p in processes), [err[-2000:] for _, err in outputs]
    return [json.loads(out) for out, _ in outputs]


def test_processes_starting_the_same_loop_compile_it_once(tmp_path):
    """Through ``compile_once`` one process compiles and the other loads its result; straight
    through numba, both compile (the race the lock removes)."""
    (tmp_path / "locked").mkdir()
    (tmp_path / "unlocked").mkdir()
    locked = _race(tmp_path / "locked", "locked")
    assert sorted((r["misses"], r["hits"]) for r in locked) == [(0, 1), (1, 0)]
    unlocked = _race(tmp_path / "unlocked", "unlocked")
    assert [(r["misses"], r["hits"]) for r in unlocked] == [(1, 0), (1, 0)]


def test_the_first_run_of_a_loop_in_a_process_compiles_nothing_more():
    """``kernels.simulate`` compiles a loop for the very argument types it then runs it with (a
    short path's: the general loop)."""
    scene = scene_from(example_data("cubic_nes_impulse"), changes={"simulation.duration": 1.0})
    kernel = kernel_for(scene, general=True)
    for started in [s for s in _STARTED if s[0] is kernel]:
        _STARTED.discard(started)
    simulate(scene)
    count = len(kernel.overloads)
    simulate(scene, np.random.default_rng(0))
    assert any(s[0] is kernel for s in _STARTED) and len(kernel.overloads) == count


#: A process that runs one short path of a primary alone in the step loop specialised to it (the
#: cheapest to compile: about 10 s from an empty cache, against 26 s for the general RK4 loop)
#: and prints that loop's cache misses and hits (``NUMBA_CACHE_DIR`` names the cache).
RUN_ONE = r'''
import json, sys
from tests.helpers import scene_from
from vines_stoch.kernels import advance, kernel_for, start_path
scene = scene_from({"name": "small", "primary": {"mass": 1.0, "stiffness": 1.0, "damping": 0.1},
                    "loads": [{"type": "impulse", "velocity": 1.0}],
                    "simulation": {"duration": 0.1, "dt": 1e-2}})
advance(start_path(scene, general=False), scene.n_steps)
k = kernel_for(scene)
print(json.dumps({"misses": sum(k.stats.cache_misses.values()), "hits": sum(k.stats.cache_hits.values())}))
'''


def test_a_step_loop_compiled_by_one_process_is_loaded_by_the_next(tmp_path):
    """The loop driver closes over its scheme's step functions, which numba's own cache key
    pickles with an identity new in each process: keyed by their descriptions
    (``cache.stable_cache``), the second process loads what the first compiled."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    runs = []
    for _ in range(2):
        done = subprocess.run([sys.executable, "-c", RUN_ONE], cwd=ROOT, env=env, capture_output=True,
                              text=True, timeout=600)
        assert done.returncode == 0, done.stderr[-2000:]
        runs.append(json.loads(done.stdout.splitlines()[-1]))
    assert runs == [{"misses": 1, "hits": 0}, {"misses": 0, "hits": 1}]


#: A process that runs the chunk of a noisy oscillator for each argument, without history
#: rows (``plain``) or with them (``history``: a loop of the same closure and argument types
#: that records them), and prints the history rows.
RUN_CHUNKS = r'''
import json, sys
from tests.helpers import scene_from
from vines_stoch.kernels.chunk import simulate_chunk
data = {"name": "symbols", "primary": {"mass": 1.0, "stiffness": 39.5, "damping": 0.6},
        "loads": [{"type": "white-noise", "intensity": 2.0}], "simulation": {"duration": 3.0, "dt": 0.01}}
scene = scene_from(data)
out = {}
for which in sys.argv[1:]:
    grid = (10, 30) if which == "history" else None
    chunk = simulate_chunk(scene, 2, 0, 0, 6, history=grid, signals=("x1",) if grid else None)
    out[which] = chunk.history[:, :, 0].tolist() if grid else None
print(json.dumps(out))
'''


def test_two_loops_of_one_closure_compiled_by_two_processes_run_apart_in_a_third(tmp_path):
    """One process compiles the chunk loop without history rows, another the one with them,
    both against the same cached helpers (so with the same count of functions compiled before
    the loops: numba names a symbol by the qualified name, the types and that count), and a
    third that loads both runs each its own (``cache.stable_cache`` names each loop by its
    closure too): its history rows are those the second process found, not NaN (the rows of
    the loop without history, run in place of the other, as before that naming)."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba")}

    def run(*which: str) -> dict:
        done = subprocess.run([sys.executable, "-c", RUN_CHUNKS, *which], cwd=ROOT, env=env,
                              capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stderr[-2000:]
        return json.loads(done.stdout.splitlines()[-1])

    run("plain")  # (the helpers cached; then the loops' entries removed, so both compile them)
    for path in (tmp_path / "numba").rglob("*"):
        if path.name.startswith(("chunk.chunk_loop", "driver.step_loop")):
            path.unlink()
    run("plain")
    alone = np.array(run("history")["history"])
    assert not np.isnan(alone).any()
    np.testing.assert_array_equal(np.array(run("plain", "history")["history"]), alone)


def test_the_signatures_of_one_function_are_saved_one_process_at_a_time():
    """numba names a new cache entry's data file after the index it has just read: two processes
    saving two signatures of one function at once could pick one name (the later write winning,
    the other entry loading the wrong machine code).  Every cache of this package's functions
    saves under a lock on the index: the stable-keyed caches of the step loops and the package's
    cache of the others (``cache.package_cache``, which ``jit.njit`` gives them); a function
    outside the package keeps numba's own cache and save."""
    from filelock import FileLock, Timeout
    from numba import njit
    from numba.core.caching import FunctionCache

    from vines_stoch.kernels.chunk import parameter_draws

    shift = 3.0

    @njit(cache=True)
    def shifted(x):
        return x + shift

    def held_while_saving(store) -> bool:
        index = store._cache_file._index_path
        held = []

        def save(sig, data):
            try:
                FileLock(f"{index}.lock", timeout=0).acquire()
                held.append(False)
            except Timeout:
                held.append(True)

        store._save_overload = save
        store.save_overload(None, None)
        return held == [True]

    from vines_stoch.kernels.common import stored_energy

    assert held_while_saving(cache._stable_cache(False)(stored_energy.py_func, []))
    assert held_while_saving(parameter_draws._cache)  # (the package's cache of a plain function)
    assert not held_while_saving(shifted._cache)
    assert type(shifted._cache) is FunctionCache and isinstance(parameter_draws._cache, FunctionCache)


def test_an_index_is_stamped_by_its_folders_sources_and_a_loop_compiled_after_an_edit_is_not_saved(
        monkeypatch):
    """numba stamps a cache index with a hash of the function's source file, read when the cache
    was opened: two processes that opened it on either side of an edit would each find the
    other's index stale and rewrite it, reusing data file names that the other still lists (a
    scene then ran on another structure's loop).  The stable-keyed folders stamp their indexes
    with the folder's own digest, and a loop compiled after the sources changed under a running
    process is not saved into the folder of the sources it started with."""
    import warnings

    from vines_stoch.kernels.common import stored_energy

    folder = f"vines-stoch-{cache.digest()}"
    locator = stored_energy._cache._impl.locator
    assert locator.get_source_stamp() == folder and stored_energy._cache._cache_path.endswith(folder)
    stable = cache._stable_cache(False)(stored_energy.py_func, [])
    saved = []
    stable._save_overload = lambda sig, data: saved.append(sig)
    stable.save_overload("sig", None)
    assert saved == ["sig"]
    monkeypatch.setattr(cache, "digest", lambda package=cache.PACKAGE: "0" * 16)  # (an edit since)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        stable.save_overload("later", None)
    assert saved == ["sig"] and "sources changed since this process started" in str(caught[0].message)
