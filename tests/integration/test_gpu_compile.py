"""The cuda backend's launchers compile for a real GPU: numba-cuda types the CPU step loops for
the CUDA target and NVVM turns them into PTX for sm_90 (no GPU needed, only the NVVM library of
the cuda extra).  The simulator tests run the same loops compiled for the CPU; this is the check
that the GPU compiler accepts them."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from tests.helpers import ROOT

pytestmark = pytest.mark.slow

#: Compiles the launcher of the scenario named by its argument (``contact_noise_parallel``:
#: kick-drift-kick with Hertz contact, impacts and white noise on the Brownian tree;
#: ``seed003_ds20``: RK4 with Hertz contact; every launcher holds the filters' stationary start);
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
from vines_stoch.kernels import kernel_for
from vines_stoch.kernels.launch import launcher
name = sys.argv[1]
grid = {"contact_noise_parallel": (10, 5), "seed003_ds20": None}[name]
data = example_data(name)
data.pop("sweep", None)
scene = scene_from(data, changes={"simulation.duration": 1.0, "simulation.metrics_from": 0.0})
launch = launcher(kernel_for(scene, gpu=True), scene.mass.shape[0], False)
ptx, _ = compile_ptx(launch.py_func, launch_types(scene, grid), cc=(9, 0))
print(json.dumps({"scene": name, "entry": ".entry" in ptx, "sm_90": ".target sm_90" in ptx,
                  "chars": len(ptx)}))
"""


@pytest.mark.parametrize("scene", ["contact_noise_parallel", "seed003_ds20"])
def test_the_launchers_compile_to_ptx_for_sm_90(scene):
    """One scene a test (a process each), so that the two compiles can run side by side."""
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "0", "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-c", SCRIPT, scene], cwd=ROOT, env=env, capture_output=True,
                          text=True, timeout=1800)
    assert done.returncode == 0, done.stderr[-3000:]
    lines = [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]
    if lines and "skip" in lines[0]:
        pytest.skip(f"no NVVM to compile with: {lines[0]['skip']}")
    assert [line["scene"] for line in lines] == [scene]
    assert lines[0]["entry"] and lines[0]["sm_90"] and lines[0]["chars"] > 10_000
