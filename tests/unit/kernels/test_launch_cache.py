"""The cuda backend's launchers on disk (``jit.cache.cache_on_disk``): in the folder of the
package's sources, their entries keyed by a description of the launcher's closure that is the
same in every process, where numba-cuda's own key (a pickle of the closure, whose step-loop
dispatcher pickles with an identity drawn afresh in each process) differs in every process.

Without a GPU nothing compiles for one: a stand-in kernel is saved and loaded through the
launcher's cache (the locator, the index file, its key); numba-cuda's pickling of a compiled
kernel and its rebuilding are left to a machine with a GPU (``make bench-gpu``)."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys

import numpy as np
import pytest

from tests.helpers import ROOT, example_data, scene_from
from vines_stoch.jit import cache
from vines_stoch.kernels import kernel_for

#: Makes the launcher of a scenario (argument 2, 1 s) without the simulator, then (argument 1)
#: ``save``: saves a stand-in kernel through its cache; ``load``: loads it through its cache,
#: and through numba-cuda's own key of the same function in the package's folder (the package's
#: cache without the launcher's key, ``cache.package_cache``).  Prints one JSON line.
SCRIPT = r'''
import json, sys
from tests.helpers import example_data, scene_from
from vines_stoch.gpu import launch_types
from vines_stoch.jit.cache import package_cache
from vines_stoch.kernels import kernel_for
from vines_stoch.kernels.launch import launcher
mode, name = sys.argv[1:]
data = example_data(name)
data.pop("sweep", None)
scene = scene_from(data, changes={"simulation.duration": 1.0, "simulation.metrics_from": 0.0})
launch = launcher(kernel_for(scene, gpu=True), scene.mass.shape[0], False)
class Codegen:
    def magic_tuple(self):
        return ("12.9", (9, 0))
class Context:
    def refresh(self):
        pass
    def codegen(self):
        return Codegen()
class StandIn:
    codegen = Codegen()
    def _reduce_states(self):
        return {"ptx": f"{name}'s launcher"}
sig = launch_types(scene)
out = {"path": launch.stats.cache_path}
if mode == "save":
    launch._cache.save_overload(sig, StandIn())
else:
    stock = package_cache(True)(launch.py_func)
    for own in (launch._cache, stock):
        own._impl.rebuild = lambda context, payload: payload
    out.update(loaded=launch._cache.load_overload(sig, Context()), stock=stock.load_overload(sig, Context()),
               same_folder=stock.cache_path == launch.stats.cache_path)
print(json.dumps(out))
'''


def _run(mode: str, name: str, folder) -> dict:
    path = os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))  # the caller's kept
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "0", "NUMBA_CACHE_DIR": str(folder), "PYTHONPATH": path}
    done = subprocess.run([sys.executable, "-c", SCRIPT, mode, name], capture_output=True, text=True, env=env,
                          cwd=ROOT)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.splitlines()[-1])


def test_a_launcher_saved_by_one_process_is_found_by_another(tmp_path):
    pytest.importorskip("numba_cuda")
    saved = _run("save", "contact_noise_parallel", tmp_path)
    assert saved["path"].startswith(str(tmp_path)) and saved["path"].endswith(f"vines-stoch-{cache.digest()}")
    found = _run("load", "contact_noise_parallel", tmp_path)
    assert found["path"] == saved["path"]
    assert found["loaded"] == {"ptx": "contact_noise_parallel's launcher"}
    # numba-cuda's own key of the same function, in the same folder, differs in every process
    assert found["same_folder"] and found["stock"] is None
    # another structure's launcher (the same function, another step loop and body count)
    other = _run("load", "seed003_ds20", tmp_path)
    assert other["path"] == saved["path"] and other["loaded"] is None


def _scene(name: str):
    data = example_data(name)
    data.pop("sweep", None)
    return scene_from(data, changes={"simulation.duration": 1.0, "simulation.metrics_from": 0.0})


def test_what_a_launcher_closes_over_is_described_by_value_and_name():
    """Constants by value; the step loops (and functions of the package's compiled sources) by
    module, name, options and closure; nothing else (an array, a function of other code)."""
    first, second = (kernel_for(_scene(n), gpu=True) for n in ("contact_noise_parallel", "seed003_ds20"))
    described = cache.described(first)
    # (its name tagged by a hash of its closure's descriptions: ``cache.stable_cache``)
    assert re.match(r"vines_stoch\.kernels\.driver\.step_loop\.<locals>\.kernel_[0-9a-f]{16}: tuple\(",
                    described)
    assert "('error_model', 'numpy')" in described  # (its options)
    assert "vines_stoch.kernels.kdk.kdk_step.<locals>.step" in described  # (the step it closes over)
    assert cache.described(second).startswith("vines_stoch.kernels.driver.step_loop.<locals>.kernel_")
    assert "vines_stoch.kernels.rk4.rk4_step.<locals>.step" in cache.described(second)
    assert cache.described(kernel_for(_scene("contact_noise_parallel"), gpu=False)) != described
    assert cache.described((1, 2.5, True, None, np.uint64(3))) == "tuple(1, 2.5, True, None, np.uint64(3))"
    assert cache.described(np.zeros(3)) is None and cache.described(object()) is None
    assert cache.described(lambda a: a) is None  # (this file is not among the sources the cache is named by)
    assert cache.described((first, np.zeros(3))) is None
