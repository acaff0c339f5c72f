"""``make bench-gpu`` (validation/bench_gpu.py) on numba-cuda's simulator (or a GPU), in quick mode: its
section of the report, with the device and finite rates, replaces only its own section; the GPU
roofline is the smooth scene's scheme on the same Philox normals; without a GPU the command
stops with one error line."""

from __future__ import annotations

import math
import os
import subprocess
import sys

import numpy as np
import pytest

from tests.helpers import ROOT, cli
from vines_stoch import gpu
from vines_stoch.kernels import simulate
from vines_stoch.outputs import E1_MAX
from vines_stoch.streams import BRIDGE, FILTER, INCREMENTS, Streams
from vines_stoch.streams.rng import philox_stream
from vines_stoch.validation import bench_gpu

needs_cuda = pytest.mark.skipif(gpu.unavailable() is not None, reason=f"cuda backend: {gpu.unavailable()}")

REPORT = """# Benchmarks

Machine: 2 cores.

## Smooth scene

CPU figures.

## GPU ensembles (cuda backend)

figures of an earlier run

## Scale

scale figures
"""


def _rates(section: str) -> list[float]:
    """The path-steps/s column of the section's timing table (its first table)."""
    lines = section.splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith("| "))
    end = next(i for i in range(first, len(lines)) if not lines[i].startswith("| "))
    rows = [line.split("|")[1:-1] for line in lines[first:end]]
    header = [cell.strip() for cell in rows[0]]
    column = header.index("path-steps/s")
    return [float(row[column]) for row in rows[2:]]


@needs_cuda
def test_the_gpu_bench_writes_its_section_and_keeps_the_others(tmp_path):
    report = tmp_path / "benchmarks.md"
    report.write_text(REPORT)
    text = bench_gpu.main(report, paths=(5, 3), quick=True)
    assert text.startswith(bench_gpu.HEADING) and f"Device: {gpu.device_name()}." in text
    rates = _rates(text)
    assert len(rates) == 2 * (1 + len(bench_gpu.SCENES))  # the roofline and each scene at 3 and 5 paths
    assert all(math.isfinite(r) and r > 0 for r in rates)
    assert ("not assessed (simulator)" in text) == gpu.simulating()  # on a GPU: pass or FAIL, at 5 paths
    assert "| SSVI SS-1(60) under ground motion | 5 |" in text
    after = report.read_text()
    assert "figures of an earlier run" not in after and after.count(bench_gpu.HEADING) == 1
    assert after.startswith("# Benchmarks\n\nMachine: 2 cores.\n\n## Smooth scene\n\nCPU figures.\n\n")
    assert after.endswith("\n\n## Scale\n\nscale figures\n")
    assert bench_gpu.section_of(after).rstrip() == text.rstrip()
    # a new report holds the section alone; the CPU report (bench.py) keeps it when rewritten
    alone = tmp_path / "new" / "benchmarks.md"
    assert bench_gpu.write_section(alone, text) == text
    cpu = "# Benchmarks\n\n## Smooth scene\n\nnew CPU figures\n"
    assert bench_gpu.replace_section(cpu, bench_gpu.section_of(after)) == cpu + "\n" + text


@needs_cuda
def test_the_roofline_is_the_smooth_scenes_scheme_on_the_same_normals():
    """Its one result a path is the step loop's ``e1_max`` of the smooth scene on the Philox
    increments stream of that path (to rounding)."""
    seconds, e_max = bench_gpu.roofline(4, 2000, 1e-3)
    assert seconds > 0 and e_max.shape == (4,) and np.isfinite(e_max).all()
    assert len(set(e_max)) == 4  # four paths of their own
    scene = bench_gpu.bench_scene("smooth", 2.0)
    purposes = (INCREMENTS, BRIDGE, FILTER)  # the bench's loop: its three streams, two of them unused
    loop = [simulate(scene, Streams(*(philox_stream(bench_gpu.SEED, p, r) for p in purposes)))[E1_MAX]
            for r in range(4)]
    np.testing.assert_allclose(e_max, loop, rtol=1e-12)


def test_bench_cuda_without_a_gpu_is_one_error_line(tmp_path):
    if gpu.unavailable() is None and not gpu.simulating():
        pytest.skip("a GPU is present")
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_ENABLE_CUDASIM"}
    out = tmp_path / "bench.md"
    done = subprocess.run([sys.executable, "-m", "vines_stoch.cli", "bench", "--backend", "cuda",
                           "--paths", "100", "--out", str(out)], capture_output=True, text=True, env=env,
                          cwd=ROOT, timeout=300)
    assert done.returncode == 2, done.stderr
    assert done.stderr.startswith("error: --backend cuda: ") and done.stderr.count("\n") == 1
    assert "Traceback" not in done.stderr and not out.exists()
    for args, message in ((("--backend", "tpu"), "--backend tpu: must be one of cpu, cuda"),
                          (("--backend", "cuda", "--paths", "10,x"), "--paths 10,x: give positive"),
                          (("--paths", "10"), "--paths: only with --backend cuda")):
        code, err = cli("bench", "--out", out, *args)
        assert code == 2 and message in err and "Traceback" not in err
