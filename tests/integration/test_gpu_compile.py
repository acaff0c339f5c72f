"""The cuda backend's launchers compile for a real GPU: numba-cuda types the CPU step loops for
the CUDA target and NVVM turns them into PTX for sm_90 (no GPU needed, only the NVVM library of
the cuda extra).  The simulator tests run the same loops compiled for the CPU; this is the check
that the GPU compiler accepts them.

numba-cuda keeps no on-disk cache of ``compile_ptx`` (11-24 s a launcher), so the test keeps the
PTX it got in pytest's cache folder, named by a hash of everything the compile reads: the
package's sources, the scenarios, the test helpers, this script and the versions of the
compilers.  A run with the same inputs checks that PTX again instead of compiling it anew, as
numba's cache of the CPU loops does; an edit anywhere in those inputs compiles afresh."""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
from importlib import metadata

import pytest

from tests.helpers import ROOT
from vines_stoch.jit.cache import files_digest

pytestmark = pytest.mark.slow

#: Compiles the launcher of the scenario named by its argument (``contact_noise_parallel``:
#: kick-drift-kick with Hertz contact, impacts and white noise on the Brownian tree;
#: ``seed003_ds20``: RK4 with Hertz contact; every launcher holds the filters' stationary start;
#: ``stretcher``: the stretch launcher of a rare-event path with impacts, ``gpu.advance_many``);
#: prints one JSON line.  numba-cuda asks the current
#: device's compute capability when it compiles callees; with no device, sm_90 stands in.
SCRIPT = r"""
import json, sys
from numba.cuda import compile_ptx
import numba.cuda.dispatcher as dispatcher
try:
    compile_ptx(lambda a: None, "(float64[:],)", cc=(9, 0))
except Exception as exc:
    print(json.dumps({"skip": f"{type(exc).__name__}: {exc}"})); sys.exit(0)
class Sm90:
    compute_capability = (9, 0)
dispatcher.get_current_device = lambda: Sm90()
from tests.helpers import example_data, scene_from
from vines_stoch.gpu import launch_types
from vines_stoch.jit.frontend import compiling
from vines_stoch.kernels import kernel_for
from vines_stoch.kernels.launch import launcher
name = sys.argv[1]
if name == "stretcher":  # (a rare-event path: impacts under white noise, on Philox streams)
    from vines_stoch.gpu import stretch_types
    from vines_stoch.kernels import start_path
    from vines_stoch.kernels.launch import stretcher
    from vines_stoch.streams.rng import philox_stream
    from vines_stoch.streams import Streams
    scene = scene_from({"name": "stretch", "primary": {"mass": 1.0, "stiffness": 39.5, "damping": 0.6},
                        "absorbers": [{"type": "impact", "mass": 0.05, "clearance": 0.2, "restitution": 0.6}],
                        "loads": [{"type": "white-noise", "intensity": 5.0}],
                        "simulation": {"duration": 1.0, "dt": 0.01}})
    path = start_path(scene, Streams(*(philox_stream(1, p, 0) for p in range(3))))
    launch, types = stretcher(kernel_for(scene, gpu=True), False), stretch_types(path)
else:
    grid = {"contact_noise_parallel": (10, 5), "seed003_ds20": None}[name]
    data = example_data(name)
    data.pop("sweep", None)
    scene = scene_from(data, changes={"simulation.duration": 1.0, "simulation.metrics_from": 0.0})
    launch = launcher(kernel_for(scene, gpu=True), scene.mass.shape[0], False)
    types = launch_types(scene, grid)
with compiling("numba.cuda.core"):  # (the front end the backend compiles its launchers with)
    ptx, _ = compile_ptx(launch.py_func, types, cc=(9, 0))
with open(sys.argv[2], "w") as f:
    f.write(ptx)
print(json.dumps({"scene": name}))
"""
#: The distributions whose versions decide the PTX (NVVM comes with the nvcc wheel).
COMPILERS = ("numba", "numba-cuda", "llvmlite", "nvidia-cuda-nvcc-cu12", "cuda-bindings")


def inputs_hash(scene: str) -> str:
    """A hash of what the compile of ``scene``'s launcher reads (see the module's docstring)."""
    files = [*(ROOT / "vines_stoch").rglob("*.py"), *(ROOT / "scenarios").glob("*.toml"),
             ROOT / "tests" / "helpers.py"]
    h = hashlib.sha256(f"{SCRIPT}\0{scene}\0{files_digest(ROOT, sorted(files))}".encode())
    for dist in COMPILERS:
        try:
            h.update(f"{dist}={metadata.version(dist)}".encode())
        except metadata.PackageNotFoundError:
            h.update(f"{dist}: none".encode())
    return h.hexdigest()[:20]


@pytest.mark.parametrize("scene", ["contact_noise_parallel", "seed003_ds20", "stretcher"])
def test_the_launchers_compile_to_ptx_for_sm_90(scene, request):
    """One scene a test (a process each), so that the two compiles can run side by side."""
    kept = request.config.cache.mkdir("ptx") / f"{scene}-{inputs_hash(scene)}.ptx"
    if not kept.exists():
        env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "0", "PYTHONPATH": str(ROOT)}
        fresh = kept.with_suffix(f".{os.getpid()}")
        done = subprocess.run([sys.executable, "-c", SCRIPT, scene, str(fresh)], cwd=ROOT, env=env,
                              capture_output=True, text=True, timeout=1800)
        assert done.returncode == 0, done.stderr[-3000:]
        lines = [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]
        if lines and "skip" in lines[0]:
            pytest.skip(f"no NVVM to compile with: {lines[0]['skip']}")
        assert [line["scene"] for line in lines] == [scene]
        fresh.replace(kept)  # (whole: a run cut off while writing leaves no PTX to trust)
    ptx = kept.read_text()
    assert ".entry" in ptx and ".target sm_90" in ptx and len(ptx) > 10_000


def test_the_kept_ptx_is_named_by_every_input_of_the_compile(tmp_path, monkeypatch):
    """Another scene, an edited source or scenario, or another compiler version names another
    PTX; the same inputs in another folder name the same."""
    first = inputs_hash("seed003_ds20")
    assert inputs_hash("contact_noise_parallel") != first
    copy = tmp_path / "checkout"
    shutil.copytree(ROOT / "vines_stoch", copy / "vines_stoch", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copytree(ROOT / "scenarios", copy / "scenarios", ignore=shutil.ignore_patterns("records"))
    (copy / "tests").mkdir()
    shutil.copy(ROOT / "tests" / "helpers.py", copy / "tests")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", copy)
    assert inputs_hash("seed003_ds20") == first
    for edited in (copy / "vines_stoch" / "kernels" / "loads.py", copy / "scenarios" / "seed003_ds20.toml"):
        text = edited.read_text()
        edited.write_text(text + "\n")
        assert inputs_hash("seed003_ds20") != first, edited
        edited.write_text(text)
    assert inputs_hash("seed003_ds20") == first
    monkeypatch.setattr(metadata, "version", lambda dist: "0.0" if dist == "numba-cuda" else "1.0")
    assert inputs_hash("seed003_ds20") != first


#: Compiles ``rng.fast_pair`` (a block's two float32 Box-Muller pairs) in a kernel for sm_90 and
#: prints its PTX.
FAST_PAIR = r"""
import sys
from numba.cuda import compile_ptx
import numba.cuda.dispatcher as dispatcher
try:
    compile_ptx(lambda a: None, "(float64[:],)", cc=(9, 0))
except Exception as exc:
    print("skip:", type(exc).__name__, exc); sys.exit(0)
class Sm90:
    compute_capability = (9, 0)
dispatcher.get_current_device = lambda: Sm90()
from vines_stoch.streams.rng import fast_pair
def kernel(words, out):
    out[0], out[1] = fast_pair(words[0], words[1])
print(compile_ptx(kernel, "(uint64[:], float32[:])", cc=(9, 0))[0])
"""


def test_the_fast_pairs_leave_the_gpu_compiler_nothing_to_fuse():
    """NVVM fuses a product into a sum where it chooses, and ptxas an unrounded ``mul.f32`` into
    the ``add.f32`` that reads it: the ``float32`` normals would round apart on a GPU (``6e-8`` a
    normal).  The fast pairs write every product that meets a sum as a ``fused`` multiply-add:
    their PTX holds those and no other (``fma.rn.f32``, one a ``fused`` call of ``rng.log1p_f32``
    and ``rng.sincos_word``), and no ``add.f32`` or ``sub.f32`` reads a ``mul.f32``'s register, so
    a GPU computes the CPU's bits."""
    import inspect

    from vines_stoch.streams import rng

    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "0", "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-c", FAST_PAIR], cwd=ROOT, env=env, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    if done.stdout.startswith("skip:"):
        pytest.skip(f"no NVVM to compile with: {done.stdout.strip()}")
    ptx = done.stdout
    written = sum(inspect.getsource(f).count("fused(") for f in (rng.log1p_f32, rng.sincos_word))
    assert ptx.count("fma.rn.f32") == written > 0
    products = set(re.findall(r"^\s*mul\.f32\s+(%f\d+),", ptx, re.M))
    sums = re.findall(r"^\s*(?:add|sub)\.f32\s+%f\d+,\s*([^;]+);", ptx, re.M)
    assert products and sums
    assert not [s for s in sums if products & {a.strip() for a in s.split(",")}], "a product meets a sum"
