"""``make bench-gpu``: path-steps per second of GPU ensembles (the cuda backend, ``gpu.py``).

For the smooth, impact-rich and SSVI ground-motion scenes at each path count: the time of
``gpu.simulate_many`` (after a warm-up launch that compiles, timed on its own), beside the CPU
figure of the same scene (``kernels.simulate`` on the CPU streams, one path a task on every
core) and, on the same GPU, a minimal numba-cuda loop of the smooth scene's scheme (the GPU
roofline, ``roofline_kernel``).  Then ``ensemble.run`` of the smooth scene at the largest path
count (set-up, transfers, metric table, Parquet) against its ``simulate_many`` time.

The report is one section of ``reports/benchmarks.md`` (``HEADING``): ``write_section``
replaces only that section, so ``vines-stoch bench`` (the CPU report) and this share the file.
"""

from __future__ import annotations

import math
import os
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from .. import gpu
from ..ensemble import run
from ..kernels import needed_streams, simulate
from ..outputs import E1_MAX, STATUS, STATUS_OK
from ..scene import Scene
from ..streams import INCREMENTS, streams
from ..streams.rng import stream_key
from . import scenes

#: The heading of the GPU section of the benchmark report.
HEADING = "## GPU ensembles (cuda backend)"
#: Clough-Penzien ground motion (medium soil, Jennings envelope) of the example scenario
#: ``seed003_ss_ground_motion.toml`` at its middle intensity (about 0.3 g peak ground acceleration).
GROUND_MOTION = {"type": "ground-motion", "model": "clough-penzien", "soil": "medium", "intensity": 0.3,
                 "envelope": {"type": "jennings", "rise": 2.0, "hold": 10.0, "decay": 0.25}}
#: The scenes, by their name in the report: (scene file of ``validation.scenes``, changes).
SCENES = {
    "smooth": ("smooth", {}),
    "impact-rich": ("smooth_impact", {}),
    "SSVI SS-1(60) under ground motion": ("ssvi", {"loads": [GROUND_MOTION]}),
}
#: Simulated time (s) of each scene in quick mode (the full bench keeps each file's own: 200 s
#: for the smooth and impact-rich scenes, 12 s for the SSVI scene; at 1e6 paths the smooth
#: scene is 2e11 path-steps, about 2 s at the target rate).
QUICK_DURATION = 0.05
#: Simulated time of the warm-up launches (the kernels take the step count as an argument).
WARM_DURATION = 0.01
#: Seed of the streams (the scene files' own).
SEED = 1
#: Targets (at 1e6 paths, float64): smooth scene path-steps/s, smooth / roofline,
#: impact-rich / smooth, whole run / kernel time (at most).
TARGET_RATE, TARGET_ROOFLINE, TARGET_IMPACT, TARGET_RUN = 1e11, 0.7, 0.5, 1.5


def _progress(message: str) -> None:
    """One line on standard error as each step of a long benchmark ends (the report comes last)."""
    print(f"bench-gpu: {message}", file=sys.stderr, flush=True)


def roofline_kernel():
    """The GPU roofline kernel (``gpu_roofline.roofline``; importing it needs numba-cuda)."""
    from .gpu_roofline import roofline as kernel

    return kernel


def roofline(n_paths: int, n_steps: int, dt: float, seed: int = SEED) -> tuple[float, np.ndarray]:
    """Seconds of one launch of the roofline kernel for ``n_paths`` paths of ``n_steps`` steps
    (with the copy of its results to the host), and its results (one per path)."""
    from numba import cuda

    kernel = roofline_kernel()
    out = cuda.device_array(n_paths)
    key = np.uint64(stream_key(seed, INCREMENTS))
    start = time.perf_counter()
    kernel[math.ceil(n_paths / gpu.THREADS), gpu.THREADS](key, n_steps, dt, out)
    cuda.synchronize()
    values = out.copy_to_host()
    return time.perf_counter() - start, values


def bench_scene(name: str, duration: float | None = None, realizations: int | None = None) -> Scene:
    """The Scene of a benchmark scene (a key of ``SCENES``), with ``duration`` (default: its file's)."""
    file, changes = SCENES[name]
    changes = dict(changes)
    if duration is not None:
        changes["simulation.duration"] = duration
    return scenes.scene(file, changes)


def _gpu_seconds(scene: Scene, n_paths: int) -> tuple[float, int]:
    """Seconds of ``gpu.simulate_many`` on ``n_paths`` paths, and the paths that did not end ok."""
    start = time.perf_counter()
    raw = gpu.simulate_many(scene, SEED, 0, 0, n_paths).raw
    elapsed = time.perf_counter() - start
    bad = int(np.count_nonzero((raw[:, STATUS] != STATUS_OK) | ~np.isfinite(raw[:, E1_MAX])))
    return elapsed, bad


def cpu_rate(scene: Scene, n_paths: int, threads: int | None = None) -> float:
    """Path-steps/s of ``kernels.simulate`` on the CPU streams, ``n_paths`` paths one a task on
    ``threads`` threads (default: every core), after one path that compiles or loads the loop."""
    increments, bridge, filters = needed_streams(scene)

    def one(r: int) -> None:
        simulate(scene, streams(SEED, 0, r, increments=increments, bridge=bridge, filters=filters))

    one(n_paths)
    with ThreadPoolExecutor(threads or os.cpu_count() or 1) as pool:
        start = time.perf_counter()
        list(pool.map(one, range(n_paths)))
        elapsed = time.perf_counter() - start
    return n_paths * scene.n_steps / elapsed


@dataclass
class Row:
    """One timing: scene (or the roofline), paths, steps a path, seconds, paths not ok."""

    scene: str
    paths: int
    steps: int
    seconds: float
    bad: int = 0

    @property
    def rate(self) -> float:
        """Path-steps per second."""
        return self.paths * self.steps / self.seconds


@dataclass
class Results:
    """What ``measure`` found; ratios are taken within one run."""

    device: str
    simulated: bool
    paths: tuple[int, ...]
    rows: list[Row]
    roofline: list[Row]
    compile_s: dict[str, float]
    cpu: dict[str, float]
    cpu_paths: int
    run_paths: int
    run_s: float
    run_kernel_s: float
    roofline_finite: bool
    cores: int = field(default_factory=lambda: os.cpu_count() or 1)

    def rate(self, scene: str, paths: int) -> float:
        """Path-steps/s of a scene (``"roofline"``: the GPU roofline) at a path count."""
        rows = self.roofline if scene == "roofline" else self.rows
        return next(r.rate for r in rows if r.scene == scene and r.paths == paths)


def measure(paths: tuple[int, ...] = (10_000, 100_000, 1_000_000), quick: bool = False,
            cpu_paths: int | None = None) -> Results:
    """Time every scene at every path count on the GPU, the roofline, the CPU figure and the
    whole run (``quick``: ``QUICK_DURATION`` of simulated time, for tests)."""
    gpu.require()
    paths = tuple(sorted(set(paths)))
    duration = QUICK_DURATION if quick else None
    cpu_paths = cpu_paths or (2 if quick else max(256, 64 * (os.cpu_count() or 1)))
    compile_s = {}
    for name in SCENES:  # compile (numba-cuda has no on-disk cache of these launchers)
        start = time.perf_counter()
        gpu.simulate_many(bench_scene(name, WARM_DURATION), SEED, 0, 0, min(paths[0], gpu.THREADS))
        compile_s[name] = time.perf_counter() - start
        _progress(f"compiled {name} in {compile_s[name]:.1f} s")
    smooth = bench_scene("smooth", duration)
    start = time.perf_counter()
    roofline(min(paths[0], gpu.THREADS), 10, smooth.dt)
    compile_s["roofline"] = time.perf_counter() - start
    rows, roof, finite = [], [], True
    for n in paths:
        seconds, values = roofline(n, smooth.n_steps, smooth.dt)
        finite &= bool(np.isfinite(values).all() and (values > 0).all())
        roof.append(Row("roofline", n, smooth.n_steps, seconds))
        _progress(f"roofline, {n:,} paths: {seconds:.3g} s, {roof[-1].rate:.3g} path-steps/s")
        for name in SCENES:
            scene = bench_scene(name, duration)
            rows.append(Row(name, n, scene.n_steps, *_gpu_seconds(scene, n)))
            _progress(f"{name}, {n:,} paths: {rows[-1].seconds:.3g} s, {rows[-1].rate:.3g} path-steps/s")
    cpu = {}
    for name in SCENES:
        cpu[name] = cpu_rate(bench_scene(name, duration), cpu_paths)
        _progress(f"{name} on the CPU, {cpu_paths} paths: {cpu[name]:.3g} path-steps/s")
    top = paths[-1]
    file, changes = SCENES["smooth"]
    with tempfile.TemporaryDirectory() as tmp:
        warm = {**changes, "simulation.duration": WARM_DURATION, "ensemble.realizations": 2}
        run(scenes.study(file, warm), Path(tmp) / "warm", backend="cuda")  # the CPU side's tables
        whole = {**changes, "ensemble.realizations": top}
        if duration is not None:
            whole["simulation.duration"] = duration
        start = time.perf_counter()
        run(scenes.study(file, whole), Path(tmp) / "run", backend="cuda")
        run_s = time.perf_counter() - start
        _progress(f"whole run, {top:,} realisations: {run_s:.3g} s")
    kernel_s = next(r.seconds for r in rows if r.scene == "smooth" and r.paths == top)
    return Results(gpu.device_name(), gpu.simulating(), paths, rows, roof, compile_s, cpu, cpu_paths, top,
                   run_s, kernel_s, finite)


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("numba-cuda")
    except PackageNotFoundError:
        return "not installed"


def section(res: Results) -> str:
    """The report's GPU section (Markdown, from ``HEADING`` on)."""
    top = res.paths[-1]
    smooth = res.rate("smooth", top)
    roof = res.rate("roofline", top)
    impact = res.rate("impact-rich", top)
    ratio_run = res.run_s / res.run_kernel_s
    targets = [
        (f"smooth scene, float64, {top:,} paths", f">= {TARGET_RATE:.0e} path-steps/s", f"{smooth:.3g}",
         smooth >= TARGET_RATE),
        ("smooth scene / GPU roofline", f">= {TARGET_ROOFLINE}", f"{smooth / roof:.2f}",
         smooth / roof >= TARGET_ROOFLINE),
        ("impact-rich / smooth scene", f">= {TARGET_IMPACT}", f"{impact / smooth:.2f}",
         impact / smooth >= TARGET_IMPACT),
        ("whole `run` / kernel time", f"<= {TARGET_RUN}", f"{ratio_run:.2f}", ratio_run <= TARGET_RUN),
    ]

    def verdict(ok: bool) -> str:
        if res.simulated:
            return "not assessed (simulator)"
        note = "" if top >= 1_000_000 else f" (at {top:,} paths, not 1e6)"
        return ("pass" if ok else "FAIL") + note

    lines = [
        HEADING,
        "",
        f"Device: {res.device}. numba-cuda {_version()}. {datetime.now(UTC):%Y-%m-%d %H:%M} UTC. "
        f"Host: {res.cores} cores. All figures from one run of `make bench-gpu` "
        "(`vines-stoch bench --backend cuda`); ratios are within that run.",
        "",
        "`gpu.simulate_many` (one thread a path; the step loops of the CPU compiled by numba-cuda; "
        "Philox streams; float64), timed after a warm-up launch that compiles, with the transfers "
        "of the scene and of the metric rows. GPU roofline: a minimal numba-cuda loop of the smooth "
        "scene's scheme (kick-drift-kick Euler-Maruyama, the load from a turned phasor, the same "
        "Philox normals, the running maximum of E1 as its one result a path). CPU: "
        f"`kernels.simulate` on the CPU streams, {res.cpu_paths} paths, one a task on {res.cores} "
        "threads.",
        "",
        "| scene | paths | steps a path | time (s) | path-steps/s | ratio to the GPU roofline | "
        "CPU path-steps/s (all cores) | GPU / CPU | paths not ok |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for n in res.paths:
        r = next(r for r in res.roofline if r.paths == n)
        lines.append(f"| GPU roofline (minimal numba-cuda loop) | {n:,} | {r.steps:,} | {r.seconds:.3g} | "
                     f"{r.rate:.3g} | 1.00 | - | - | - |")
        for row in (row for row in res.rows if row.paths == n):
            lines.append(f"| {row.scene} | {n:,} | {row.steps:,} | {row.seconds:.3g} | {row.rate:.3g} | "
                         f"{row.rate / r.rate:.2f} | {res.cpu[row.scene]:.3g} | "
                         f"{row.rate / res.cpu[row.scene]:.3g} | {row.bad} |")
    lines += [
        "",
        "Compile time (the warm-up launch of a few paths: numba-cuda compiles each launcher once a "
        "process): " + ", ".join(f"{name} {s:.1f} s" for name, s in res.compile_s.items()) + ". "
        f"The roofline's result (the E1 maximum) finite and positive on every path: "
        f"{'yes' if res.roofline_finite else 'NO'}.",
        "",
        f"Whole run: `ensemble.run(study, directory, backend=\"cuda\")` of the smooth scene with "
        f"{res.run_paths:,} realisations (set-up, transfers, metric table, Parquet) took {res.run_s:.3g} s "
        f"against {res.run_kernel_s:.3g} s of `gpu.simulate_many`: {ratio_run:.2f}x.",
        "",
        "| target | wanted | measured | result |",
        "| --- | --- | ---: | --- |",
        *(f"| {what} | {wanted} | {got} | {verdict(ok)} |" for what, wanted, got, ok in targets),
        "",
    ]
    return "\n".join(lines)


def _bounds(lines: list[str], heading: str) -> tuple[int, int] | None:
    """Line range of the section under ``heading``: to the next ``## `` heading or the end."""
    start = next((i for i, line in enumerate(lines) if line.rstrip() == heading), None)
    if start is None:
        return None
    end = next((j for j in range(start + 1, len(lines)) if lines[j].startswith("## ")), len(lines))
    return start, end


def replace_section(text: str, new: str, heading: str = HEADING) -> str:
    """``text`` with its section under ``heading`` replaced by ``new`` (appended when absent)."""
    lines = text.splitlines(keepends=True)
    where = _bounds(lines, heading)
    block = new.rstrip("\n") + "\n"
    if where is None:
        return (text.rstrip("\n") + "\n\n" if text.strip() else "") + block
    start, end = where
    return "".join(lines[:start]) + block + ("\n" if end < len(lines) else "") + "".join(lines[end:])


def section_of(text: str, heading: str = HEADING) -> str | None:
    """The section under ``heading`` of ``text``, or None."""
    lines = text.splitlines(keepends=True)
    where = _bounds(lines, heading)
    return None if where is None else "".join(lines[where[0]:where[1]])


def write_section(out: Path, new: str) -> str:
    """Put the section ``new`` into the report ``out`` (replacing only its own section; a new
    file holds just that section); returns the file's text."""
    text = replace_section(out.read_text() if out.exists() else "", new)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    return text


def main(out: Path = Path("reports/benchmarks.md"), paths: tuple[int, ...] = (10_000, 100_000, 1_000_000),
         quick: bool = False, cpu_paths: int | None = None) -> str:
    """Run the GPU benchmark and write its section into ``out``; returns the section."""
    text = section(measure(paths, quick, cpu_paths))
    write_section(out, text)
    print(text)
    return text


__all__ = ["HEADING", "Results", "cpu_rate", "main", "measure", "replace_section", "roofline",
           "roofline_kernel", "section", "section_of", "write_section"]
