"""``make bench``: throughput and error side by side, in one run.

- The smooth scene (LPO m = k = 1, cubic NES eps = 0.05, c = 0.01, k3 = 1; load 0.1 cos t plus
  white noise 0.05; T = 200, dt = 1e-3) through ``vines_stoch.run`` with 1 and 2 threads and
  through a minimal semi-implicit Euler-Maruyama loop in the same process.
- The impact-rich stochastic scene: the same plus an impact NES (clearance 0.2, r = 0.6), the
  parallel NES of seed 000.
- Contact under noise: the SSVI design SS-2(20) of seed 003 under stochastic ground motion and
  the steel-on-steel chatter scene (example scenarios) as ratios to the smooth scene, and the
  work-precision of Hertz contact and impacts under noise on one Brownian path.
- The SSVI design SS-1(60) of seed 003 (12 s from rest): vines_stoch against scipy DOP853
  with event location at the loosest tolerance that reaches the same ``e1_max`` error.
- A seismic scene (1 Hz primary with a cubic NES) under a synthetic accelerogram against the
  same scene under a harmonic force: the cost of record interpolation and break points.
- Work-precision diagrams against scipy and sdeint (``vines_stoch.validation.precision``), the
  stability suite (``vines_stoch.validation.stability``) and compile and start-up times of the CLI.
- Scale: 10^4 realisations of the smooth scene (T = 20) on the embedded scheduler and on a local
  ``dask.distributed`` cluster of worker processes (the overhead of the distributed
  scheduler), and the peak memory of 10^4 and 10^5 realisations with history statistics on a
  1000-point grid (each in a fresh process).

The scenes are the files of ``vines_stoch.validation.scenes``; the example scenarios it times
(``scenarios/``) are read from the repository, so ``make bench`` runs from its root.  The GPU
section of the report (``make bench-gpu``, ``bench_gpu.py``) is kept when the report is rewritten.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any
from unittest.mock import patch

import numpy as np

from ..ensemble import run
from ..environment import GENERAL_SWITCH
from ..jit import njit
from ..jit.flags import KERNEL, VECTOR_BITS
from ..kernels import LANES, SPARE_ROWS, lane_normals, load_history, needed_streams, simulate, simulate_chunk
from ..outputs import ABSORBER_DISS, E1_MAX, FINAL_ENERGY, IMPACT_LOSS, INPUT, PRIMARY_DISS
from ..physics.hertz import hertz_constant
from ..records import G, write_at2
from ..scenario import Study
from ..scene import build_scene
from ..streams import streams
from ..streams.pcg import state_of
from ..streams.rng import normal
from . import bench_rare, precision, scenes, stability
from .bench_gpu import replace_section, section_of
from .reference import hertz_reference

#: The repository this module sits in (its ``scenarios/`` folder holds the example scenarios).
REPOSITORY = Path(__file__).resolve().parents[2]


@njit(**KERNEL)
def minimal_kdk(n_steps: int, dt: float, gen, metrics: bool = False, recurrence: bool = False) -> float:
    """The smooth scene as the shortest loop of the same scheme, kick-drift-kick with the same
    noise and load evaluations (the roofline): no generality, and no metrics unless
    ``metrics`` (then the same ones as the step loops: input energy, absorber dissipation, the
    integrals of ``E1`` and ``x1^2``, the maxima of ``E1`` and ``|x1|``).  The load is
    ``0.1 cos t`` by a ``cos`` call a step, or with ``recurrence`` as the step loops evaluate
    it: a phasor turned by one step's angle, set exactly every 1024 steps."""
    x1 = v1 = x2 = v2 = 0.0
    s = 0.5 * 0.05 * np.sqrt(dt)  # half of sigma dW in each kick
    h = 0.5 * dt
    load = 0.1
    pc, ps, rc, rs = 1.0, 0.0, np.cos(dt), np.sin(dt)
    acc = work = dissipation = e_int = x2_int = e_max = x_max = e_prev = x2_prev = 0.0
    for i in range(n_steps):
        if recurrence and i % 1024 == 0:
            pc, ps = np.cos(i * dt), np.sin(i * dt)
        u, w = x2 - x1, v2 - v1
        f = -u * u * u - 0.01 * w
        dw = s * normal(gen)
        v1n = v1 + h * (load - x1 - f) + dw
        v2n = v2 + h * f / 0.05
        if metrics:
            work += (h * load + dw) * 0.5 * (v1 + v1n)
            dissipation += 0.01 * w * h * 0.5 * (v2n - v1n + w)
        v1, v2 = v1n, v2n
        x1 += dt * v1
        x2 += dt * v2
        u, w = x2 - x1, v2 - v1
        f = -u * u * u - 0.01 * w
        if recurrence:
            pc, ps = pc * rc - ps * rs, ps * rc + pc * rs
            load = 0.1 * pc
        else:
            load = 0.1 * np.cos((i + 1) * dt)
        v1n = v1 + h * (load - x1 - f) + dw
        v2n = v2 + h * f / 0.05
        if metrics:
            work += (h * load + dw) * 0.5 * (v1 + v1n)
            dissipation += 0.01 * w * h * 0.5 * (v2n - v1n + w)
            e1 = 0.5 * (v1n * v1n + x1 * x1)
            e_int += 0.5 * (e1 + e_prev) * dt
            x2_int += 0.5 * (x1 * x1 + x2_prev) * dt
            x2_prev = x1 * x1
            e_max = max(e_max, e1)
            x_max = max(x_max, abs(x1))
            e_prev = e1
        v1, v2 = v1n, v2n
        acc += x1 * x1
    return acc + work + dissipation + e_int + x2_int + e_max + x_max


@njit(**KERNEL)
def minimal_euler(n_steps: int, dt: float, gen) -> float:
    """The smooth scene as the shortest semi-implicit Euler-Maruyama loop (one force evaluation
    a step; a lower-order scheme, for reference)."""
    x1 = v1 = x2 = v2 = 0.0
    s = 0.05 * np.sqrt(dt)
    acc = 0.0
    for i in range(n_steps):
        u = x2 - x1
        f = -u * u * u - 0.01 * (v2 - v1)
        v1 += dt * (0.1 * np.cos(i * dt) - x1 - f) + s * normal(gen)
        v2 += dt * f / 0.05
        x1 += dt * v1
        x2 += dt * v2
        acc += x1 * x1
    return acc


def _general_work(value: str) -> Any:
    """A block inside which runs below ``value`` path-steps take the general loops
    (``VINES_STOCH_GENERAL_WORK``: ``"0"`` none, ``"inf"`` every run); the variable as it was
    after it."""
    return patch.dict(os.environ, {GENERAL_SWITCH: value})


def _fresh_env(**more: str) -> dict[str, str]:
    """The environment of a fresh process that runs as a user's would: the default choice of loops
    (no ``VINES_STOCH_GENERAL_WORK``), with ``more`` set."""
    env = {key: value for key, value in os.environ.items() if key != GENERAL_SWITCH}
    return {**env, **more}


def _general_path(scene, gen) -> None:
    """One path of ``scene`` in the general loop of its scheme (``simulate``)."""
    with _general_work("inf"):
        simulate(scene, gen)


def _step_loop_rates(n_paths: int, n_steps: int = 200_000, dt: float = 1e-3,
                     only: tuple[str, ...] | None = None) -> dict[str, float]:
    """Path-steps/s of the smooth scene's step loop (``simulate``, seeded as in an ensemble)
    and of the minimal loops (or of the runners named in ``only``), one path of each in turn,
    so that every runner sees the same machine (its speed drifts by up to 1.5x on a shared
    host)."""
    scene = scenes.scene("smooth", {"ensemble.realizations": 1})
    assert scene.n_steps == n_steps and scene.dt == dt
    runners = {
        # (the rooflines draw from the generator's state as the step loops do: ``pcg.state_of``)
        "roofline": lambda gen: minimal_kdk(n_steps, dt, state_of(gen), False),
        "roofline with metrics": lambda gen: minimal_kdk(n_steps, dt, state_of(gen), True),
        "recurrence roofline": lambda gen: minimal_kdk(n_steps, dt, state_of(gen), False, True),
        "recurrence roofline with metrics": lambda gen: minimal_kdk(n_steps, dt, state_of(gen), True, True),
        "euler": lambda gen: minimal_euler(n_steps, dt, state_of(gen)),
        "step loop": lambda gen: simulate(scene, gen),
        "general loop": lambda gen: _general_path(scene, gen),
    }
    runners = {name: runner for name, runner in runners.items() if only is None or name in only}
    seconds = dict.fromkeys(runners, 0.0)
    for r in range(-1, n_paths):  # path -1 compiles or loads the loops
        for name, runner in runners.items():
            start = time.perf_counter()
            runner(np.random.default_rng(r + 1))
            if r >= 0:
                seconds[name] += time.perf_counter() - start
    return {name: n_paths * n_steps / t for name, t in seconds.items()}


def _api_rate(n_paths: int, workers: int, directory: Path, impacts: bool = False) -> tuple[float, float]:
    """Path-steps/s and the largest energy residual of ``vines_stoch.run`` on the smooth scene
    (with ``impacts``: plus the impact NES) with ``n_paths`` realisations."""
    study = scenes.study("smooth_impact" if impacts else "smooth", {"ensemble.realizations": n_paths})
    n_steps = 200_000
    start = time.perf_counter()
    realizations, _ = run(study, directory, workers=workers)
    elapsed = time.perf_counter() - start
    return n_paths * n_steps / elapsed, float(realizations["energy_residual"].abs().max())


#: Realisations of the lanes' runs (T = 20): 32 chunks of lanes for 2 threads.
LANE_PATHS = 4096
#: The scenes of the lanes' runs, by their name in the report: (scene file of ``validation.scenes``
#: or scenario of the repository, realisations).  The contact scene's steps with events or an
#: absorber stuck are finished by the scalar step, at its speed: fewer paths keep its runs as short
#: as the others'.  The filtered-noise scene (the parallel NES under filtered noise from its
#: stationary law) advances each lane's filter.
LANE_SCENES = {"smooth": ("smooth", LANE_PATHS),
               "impact-rich": ("smooth_impact", LANE_PATHS),
               "contact under noise": ("scenarios/contact_noise_parallel.toml", 256),
               "filtered noise": ("scenarios/filtered_noise.toml", LANE_PATHS)}


def _scenario_study(path: str, point: int = 0, changes: Mapping[str, Any] | None = None) -> Study:
    """The one-point study of sweep point ``point`` of the repository's scenario ``path``, with
    ``changes`` (dotted keys) on top of the point's own."""
    from ..scenario import load_scenario

    study = load_scenario(REPOSITORY / path)
    data = {key: value for key, value in study.data.items() if key != "sweep"}
    return scenes.study(data, {**study.grid[point], **(changes or {})}, source=study.source,
                        directory=study.directory)


def _lane_runs(study: Study, directory: Path, rounds: int) -> dict[str, float]:
    """Path-steps/s of ``run`` of ``study`` in SIMD lanes (1 and 2 threads, into a folder and
    in memory) and in the scalar loop on PCG64 streams (``executor="scalar"``), in turn, the
    best of ``rounds``, and the means of ``x1_rms`` of the two with their standard errors."""
    sim = study.points[0].simulation
    paths, steps = study.points[0].ensemble.realizations, round(sim.duration / sim.dt)
    # (name, threads, the scalar loop, into a folder)
    runners = (("scalar", 1, True, True), ("lanes", 1, False, True), ("lanes, 2 threads", 2, False, True),
               ("lanes, in memory", 1, False, False), ("lanes, 2 threads, in memory", 2, False, False))

    def timed(folder: str | None, workers: int, scalar: bool) -> tuple[float, Any]:
        start = time.perf_counter()
        realizations, _ = run(study, folder and directory / folder, workers=workers,
                              executor="scalar" if scalar else "lanes")
        return paths * steps / (time.perf_counter() - start), realizations

    run(study, directory / "warm-scalar", workers=1, realizations=8, executor="scalar")
    run(study, directory / "warm-lanes", workers=1, realizations=8)
    best = {"paths": paths, **{runner: 0.0 for runner, *_ in runners}}
    tables = {}
    for r in range(rounds):
        for runner, workers, scalar, into_folder in runners:
            folder = f"{r}-{runner}".replace(", ", "-").replace(" ", "-") if into_folder else None
            rate, tables[runner] = timed(folder, workers, scalar)
            best[runner] = max(best[runner], rate)
    for runner in ("scalar", "lanes"):
        x = tables[runner]["x1_rms"].to_numpy()
        best[f"{runner} mean"] = float(x.mean())
        best[f"{runner} sem"] = float(x.std(ddof=1) / np.sqrt(x.size))
    return best


def _lanes(directory: Path, rounds: int = 3) -> dict[str, Any]:
    """``_lane_runs`` of each of ``LANE_SCENES`` (T = 20); the rate of the lanes' normals alone
    and of the scalar loop's draws from a Philox and from a PCG64 stream."""
    from ..streams.rng import philox_stream, stream_key

    out: dict[str, Any] = {"scenes": {}, "budget": _lane_budget()}
    for k, (name, (source, paths)) in enumerate(LANE_SCENES.items()):
        changes = {"ensemble.realizations": paths, "simulation.duration": 20.0}
        toml = source.endswith(".toml")
        study = _scenario_study(source, 0, changes) if toml else scenes.study(source, changes)
        out["scenes"][name] = _lane_runs(study, directory / f"lanes{k}", rounds)
    z, spare = np.zeros(LANES), np.zeros((SPARE_ROWS, LANES))
    key, places = np.uint64(stream_key(1, 0)), np.arange(LANES, dtype=np.uint64)
    _lane_normal_sum(z, spare, key, places, 4)
    draws, best = 1 << 16, 0.0
    for _ in range(rounds):
        start = time.perf_counter()
        _lane_normal_sum(z, spare, key, places, draws)
        best = max(best, LANES * draws / (time.perf_counter() - start))
    out["normals"] = best
    count = 4_000_000
    for name, gen in (("philox", philox_stream(1, 0, 0)), ("pcg", state_of(np.random.default_rng(1)))):
        _draw_sum(gen, 10)
        start = time.perf_counter()
        _draw_sum(gen, count)
        out[f"{name} ns"] = (time.perf_counter() - start) / count * 1e9
    return out


def _lane_budget(paths: int = 512, rounds: int = 3) -> dict[str, float]:
    """Where a lane-step of the smooth scene (T = 20) goes: path-steps/s of one chunk
    (``simulate_chunk``, no files) in lanes with the scene's white noise and without it (the
    same kick-drift-kick update, no normals drawn), and of the scalar loop on PCG64 streams with
    it, in turn, the best of ``rounds``."""
    from ..kernels import simulate_chunk

    noisy = scenes.scene("smooth", {"simulation.duration": 20.0})
    quiet = scenes.scene("smooth", {"simulation.duration": 20.0, "loads.1.intensity": 0.0,
                                    "simulation.scheme": "euler-maruyama"})
    runners = {"scalar": (noisy, True), "lanes": (noisy, False), "lanes, no noise": (quiet, False)}
    best = dict.fromkeys(runners, 0.0)
    for r in range(-1, rounds):  # round -1 compiles or loads the loops
        for name, (scene, scalar) in runners.items():
            start = time.perf_counter()
            simulate_chunk(scene, 1, 0, 0, paths if r >= 0 else 2, executor="scalar" if scalar else "lanes")
            if r >= 0:
                best[name] = max(best[name], paths * scene.n_steps / (time.perf_counter() - start))
    return best


def _lane_rows(lanes: dict[str, Any]) -> str:
    """The rows of the lanes' table: each scene's five runners."""
    rows = []
    for name, r in lanes["scenes"].items():
        scalar, memory1, memory2 = r["scalar"], r["lanes, in memory"], r["lanes, 2 threads, in memory"]
        rows += [f"| {name} | {r['paths']:,} | scalar loop, PCG64 streams | 1 | {scalar / 1e6:.1f} | 1.00 | "
                 f"{r['scalar mean']:.5f} ({r['scalar sem']:.5f}) |",
                 f"| {name} | {r['paths']:,} | lanes, Philox streams | 1 | {r['lanes'] / 1e6:.1f} | "
                 f"{r['lanes'] / scalar:.2f} | {r['lanes mean']:.5f} ({r['lanes sem']:.5f}) |",
                 f"| {name} | {r['paths']:,} | lanes, Philox streams | 2 | "
                 f"{r['lanes, 2 threads'] / 1e6:.1f} | {r['lanes, 2 threads'] / scalar:.2f} (1 -> 2 threads: "
                 f"{r['lanes, 2 threads'] / r['lanes']:.2f}x) | - |",
                 f"| {name} | {r['paths']:,} | lanes, in memory | 1 | {memory1 / 1e6:.1f} | "
                 f"{memory1 / scalar:.2f} | - |",
                 f"| {name} | {r['paths']:,} | lanes, in memory | 2 | {memory2 / 1e6:.1f} | "
                 f"{memory2 / scalar:.2f} (1 -> 2 threads: {memory2 / memory1:.2f}x) | - |"]
    return "\n".join(rows)


@njit(**KERNEL)
def _lane_normal_sum(z, spare, key, places, draws: int) -> float:
    """Draws ``0 .. draws - 1`` of the Philox streams ``(key, places[lane])`` of a batch of
    ``LANES`` lanes, each drawn as the lane loop draws it (``kernels.lane_normals``, called from
    compiled code), and the sum of lane 0's."""
    total = 0.0
    for d in range(draws):
        lane_normals(z, spare, LANES, d, key, places, 0)
        total += z[0]
    return total


@njit(**KERNEL)
def _draw_sum(gen, n: int) -> float:
    """The sum of ``n`` normals of ``gen`` drawn one at a time (the scalar loop's draws)."""
    total = 0.0
    for _ in range(n):
        total += normal(gen)
    return total


#: Steps ``2^-level`` of the same-path work-precision study of contact and impacts under noise.
SAME_PATH_LEVELS = [6, 7, 8, 9, 10, 11]
#: Contact under noise: the SSVI design SS-2(20) of seed 003 under Clough-Penzien ground motion
#: (intensity 0.3) and the steel-on-steel double-sided NES beside a plastic impact NES under
#: harmonic + white noise (the example scenarios), run at one sweep point with ``n`` paths.
#: The header of the contact scenes' table.
CONTACT_HEADER = ("| scene | M path-steps/s | ratio to the smooth scene (`run`) | ratio of the step loops | "
                  "contacts and impacts a path | max abs energy residual |\n"
                  "| --- | ---: | ---: | ---: | ---: | ---: |")
CONTACT_SCENES = {"SSVI SS-2(20) under ground motion": ("scenarios/seed003_ss_ground_motion.toml", 1),
                  "steel-on-steel DSVI + plastic impact NES, harmonic + white noise":
                      ("scenarios/contact_noise_parallel.toml", 0)}


def _contact_rates(n_paths: int, directory: Path) -> list[tuple[str, float, float, float, float]]:
    """``(scene, path-steps/s, max abs energy residual, contacts a path, step loop ratio)`` of
    ``vines_stoch.run`` with one thread on the ``CONTACT_SCENES``; the last, the scene's step
    loop (``simulate``) against the smooth scene's, one path of each in turn (``_loop_ratio``)."""
    rows = []
    for k, (name, (path, point)) in enumerate(CONTACT_SCENES.items()):
        one = _scenario_study(path, point)
        run(one, directory / f"warm{k}", workers=1, realizations=2)  # compile or load outside the timing
        start = time.perf_counter()
        realizations, _ = run(one, directory / f"contact{k}", workers=1, realizations=n_paths)
        elapsed = time.perf_counter() - start
        sim = one.points[0].simulation
        rows.append((name, n_paths * sim.duration / sim.dt / elapsed,
                     float(realizations["energy_residual"].abs().max()),
                     float(realizations["impacts"].mean()), _loop_ratio(build_scene(one.points[0]))))
    return rows


def _loop_ratio(scene, rounds: int = 20) -> float:
    """Path-steps/s of ``scene``'s step loop over the smooth scene's, one smooth path and about as
    many steps of ``scene`` in turn (paths seeded as in an ensemble), so that both see the same
    machine: a run's fixed costs (its folder, its tables) weigh on short paths, the loops'
    ratio is the engine's."""
    smooth = scenes.scene("smooth", {"ensemble.realizations": 1})
    increments, bridge, filters = needed_streams(scene)
    per = max(1, round(smooth.n_steps / scene.n_steps))
    seconds = [0.0, 0.0]
    for r in range(-1, rounds):  # round -1 compiles or loads the loops
        start = time.perf_counter()
        simulate(smooth, np.random.default_rng(r + 2))
        middle = time.perf_counter()
        for q in range(per):
            simulate(scene, streams(1, 0, (r + 1) * per + q, increments=increments, bridge=bridge,
                                    filters=filters))
        if r >= 0:
            seconds[0] += middle - start
            seconds[1] += time.perf_counter() - middle
    return (per * scene.n_steps / seconds[1]) / (smooth.n_steps / seconds[0])


def _ssvi() -> dict[str, float]:
    """SS-1(60): vines_stoch at dt = 1e-3 and DOP853 at the loosest tolerance that matches its
    ``e1_max`` error (both against DOP853 at rtol 1e-11)."""
    scene = scenes.scene("ssvi")
    simulate(scene)
    start = time.perf_counter()
    repeats = 20
    for _ in range(repeats):
        e1 = simulate(scene)[E1_MAX]
    ours = (time.perf_counter() - start) / repeats
    k_left = hertz_constant([2.1e11, 2.21e7], [0.3, 0.3], 1.0)
    k_right = hertz_constant([2.1e11, 2.05e7], [0.3, 0.3], 1.0)
    args = (1000.0, 3.95e4, 452.0, 60.0, 215.0, 232.0, 0.06, k_left, k_right, (0.0, 0.36), 800.0, 6.3, 0.06,
            np.array([12.0]))
    _, exact = hertz_reference(*args, e1_step=2e-5)
    error = abs(e1 / exact - 1.0)
    figures = {"ours_s": ours, "ours_error": error}
    for rtol in (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10):
        start = time.perf_counter()
        _, e1_ref = hertz_reference(*args, rtol=rtol, atol=rtol * 1e-3, e1_step=2e-5)
        elapsed = time.perf_counter() - start
        if abs(e1_ref / exact - 1.0) <= error:
            figures.update(scipy_s=elapsed, scipy_rtol=rtol, scipy_error=abs(e1_ref / exact - 1.0))
            break
    return figures


def _seismic(directory: Path, repeats: int = 30) -> dict[str, tuple[float, float, float]]:
    """Path-steps/s, energy residual and ``e1_max`` change on halving dt, under a synthetic
    accelerogram (0.01 s samples, PGA 0.3 g) and under a harmonic force of the same peak."""
    generator = scenes.scene("seismic")
    _, _, ground = load_history(generator, np.random.default_rng(1940))
    ground *= 0.3 * G / np.max(np.abs(ground))
    write_at2(directory / "synthetic.AT2", 0.01, ground / G, "bench")
    loads = {"record": {"type": "record", "file": "synthetic.AT2", "units": "g"},
             "harmonic": {"type": "harmonic", "amplitude": 1000.0 * 0.3 * G, "frequency": 6.0}}
    figures = {}
    for name, load in loads.items():
        coarse, fine = (scenes.scene("seismic", {"loads": [load], "simulation.dt": dt}, directory=directory)
                        for dt in (2e-3, 1e-3))
        raw_fine = simulate(fine)
        raw = simulate(coarse)
        start = time.perf_counter()
        for _ in range(repeats):
            simulate(coarse)
        rate = repeats * coarse.n_steps / (time.perf_counter() - start)
        dissipated = raw[PRIMARY_DISS] + raw[ABSORBER_DISS] + raw[IMPACT_LOSS]
        residual = (raw[INPUT] - dissipated - raw[FINAL_ENERGY]) / raw[INPUT]
        figures[name] = (rate, abs(residual), abs(raw[E1_MAX] / raw_fine[E1_MAX] - 1.0))
    return figures


_PEAK_MEMORY = """
import resource, sys, time
from pathlib import Path
from vines_stoch import parse_scenario, run
start = time.perf_counter()
realizations, _ = run(parse_scenario(sys.argv[1]), Path(sys.argv[2]))
print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, time.perf_counter() - start,
      len(realizations))
"""


def _floors(counts: tuple[int, ...] = (1, 3, 9, 20),
            repeats: int = 5) -> list[tuple[str, float, float, float]]:
    """Cost against size: rows ``(scene, M steps/s, ns a step, first call s)`` of ``n``-storey
    buildings (unit floor masses, storey stiffness ``4 n^2``: the first mode near 1 rad/s) with
    a cubic NES on the roof and an impact absorber on the floor below it, under white noise on
    the roof (kick-drift-kick, best of ``repeats`` paths), and of the seed 001 nine-storey frame
    (RK4, two Hertz NES)."""
    rows = []
    for n in counts:
        building = {"primary.masses": [1.0] * n, "primary.stiffnesses": [4.0 * n * n] * n,
                    "primary.dampings": [0.05] * n, "absorbers.1.floor": max(1, n - 1)}
        rows.append((f"{n} floor{'s' * (n > 1)}, kick-drift-kick, white noise",
                     *_path_rate(scenes.scene("floors", building), repeats)))
    nine = REPOSITORY / "scenarios/seed001_nine_storey_ssvi.toml"
    if nine.exists():
        from ..scenario import load_scenario
        from ..scene import build_scene

        rows.append(("seed 001 nine-storey frame, RK4, 2 Hertz NES (outer steps)",
                     *_path_rate(build_scene(load_scenario(nine).points[0]), 2)))
    return rows


def _frames(counts: tuple[int, ...] = (1, 2, 3, 5, 9), paths: int = 256,
            rounds: int = 3) -> list[tuple[str, float, float, float, float, float]]:
    """Frames in SIMD lanes: rows ``(frame, first call s, pass loop, specialised lane loop, scalar
    loop M path-steps/s, specialised first call s)`` of ``n``-storey frames (unit masses,
    storey stiffness ``4 n^2``) with a cubic NES on the roof (six on the top three floors of
    nine storeys) under white noise and a harmonic force, 20 s, the pass loop as a short run
    takes it (one storey: two bodies, which a long run runs in the specialised lane loop): the
    first call of a structure the process has not run (the pass loop compiled before, on a bare
    four-storey frame), and the
    best of ``rounds`` chunks of ``paths`` paths of each loop (the scalar loop a quarter of them)."""
    rows = []
    cubic = {"type": "cubic", "mass": 0.05, "stiffness": 100.0, "damping": 0.02}
    bare = {"primary": {"masses": [1.0] * 4, "stiffnesses": [64.0] * 4, "dampings": [0.05] * 4},
            "absorbers": []}
    simulate_chunk(scenes.scene("smooth", bare), 1, 0, 0, 2)  # (the pass loop, on a frame not timed)
    for n in counts:
        roof = [{**cubic, "floor": f} for f in ((9, 9, 8, 8, 7, 7) if n == 9 else (n,))]
        scene = scenes.scene("smooth", {"primary": {"masses": [1.0] * n, "stiffnesses": [4.0 * n * n] * n,
                                                    "dampings": [0.05] * n},
                                        "absorbers": roof, "simulation.duration": 20.0})
        timed = {}
        for name, options, count in (("pass", {"general": True}, paths),
                                     ("specialised", {"specialised": True}, paths),
                                     ("scalar", {"executor": "scalar"}, paths // 4)):
            start = time.perf_counter()
            simulate_chunk(scene, 1, 0, 0, 2, **options)
            timed[name + " first"] = time.perf_counter() - start
            for _ in range(rounds):
                start = time.perf_counter()
                simulate_chunk(scene, 1, 0, 0, count, **options)
                rate = count * scene.n_steps / (time.perf_counter() - start)
                timed[name] = max(timed.get(name, 0.0), rate / 1e6)
        rows.append((f"{n} storey{'s' if n > 1 else ''}, {len(roof)} NES", timed["pass first"], timed["pass"],
                     timed["specialised"], timed["scalar"], timed["specialised first"]))
    return rows


def _path_rate(scene, repeats: int) -> tuple[float, float, float]:
    """``(M steps/s, ns a step, s of the first call)`` of single paths of ``scene``."""
    from ..streams import streams

    start = time.perf_counter()
    simulate(scene, streams(1, 0, 0))
    first = time.perf_counter() - start
    best = 0.0
    for r in range(repeats):
        start = time.perf_counter()
        simulate(scene, streams(1, 0, r + 1))
        best = max(best, scene.n_steps / (time.perf_counter() - start))
    return best / 1e6, 1e9 / best, first


def _peak_memory(n: int, directory: Path) -> tuple[float, float]:
    """Peak RSS (MiB) and wall time (s) of a fresh process running ``n`` realisations of the
    2-DOF history scene (1001-point grid)."""
    text = scenes.text(scenes.changed(scenes.scene_data("history"), {"ensemble.realizations": n}))
    out = subprocess.run([sys.executable, "-c", _PEAK_MEMORY, text, str(directory)],
                         check=True, capture_output=True, text=True).stdout.split()
    assert int(out[2]) == n
    return float(out[0]), float(out[1])


def _load_kernels(scene: str) -> None:
    """Compile or load the kernels of a scene (in a worker process, before timing)."""
    simulate(scenes.scene(scene, {"simulation.duration": 0.1}), np.random.default_rng(0))


def _distributed_overhead(directory: Path, n: int = 10_000) -> tuple[float, float, int]:
    """Seconds for ``n`` realisations of the smooth scene (T = 20) on the embedded scheduler (all
    cores as threads) and on a local cluster of one single-threaded worker process per core."""
    from dask.distributed import Client, LocalCluster

    study = scenes.study("smooth", {"ensemble.realizations": n, "simulation.duration": 20.0})
    cores = os.cpu_count() or 1
    start = time.perf_counter()
    embedded, _ = run(study, directory / "embedded", workers=cores)
    t_embedded = time.perf_counter() - start
    with LocalCluster(n_workers=cores, threads_per_worker=1, processes=True, dashboard_address=None,
                      host="127.0.0.1") as cluster, Client(cluster) as client:
        client.run(_load_kernels, "smooth")
        start = time.perf_counter()
        distributed, _ = run(study, directory / "distributed", scheduler=cluster.scheduler_address)
        t_distributed = time.perf_counter() - start
    same = int(embedded.drop(columns="regime").equals(distributed.drop(columns="regime")))
    return t_embedded, t_distributed, same


#: Short and long paths of the linear oscillator under white noise (``scenes/linear.toml`` at dt
#: = 0.01): (steps, realisations) each, the same path-steps for the last two.
SHORT_PATHS = {"10-step paths": (10, 100_000), "1,000-step paths": (1_000, 50_000),
               "100,000-step paths": (100_000, 500)}
_PATH_RATE = """
import sys, time
from vines_stoch.ensemble import run
from vines_stoch.validation import scenes
steps, n, workers, rounds = (int(a) for a in sys.argv[1:5])
study = scenes.study("linear", {"simulation.dt": 0.01, "simulation.duration": steps * 0.01,
                                "simulation.metrics_from": 0.0, "ensemble.realizations": n})
run(study, workers=workers, realizations=min(n, 64))  # (the loop loaded, the threads started)
best = float("inf")
for _ in range(rounds):
    start = time.perf_counter()
    results = run(study, workers=workers)
    best = min(best, time.perf_counter() - start)
    assert len(results.realizations) == n
print(best)
"""


def _path_seconds(steps: int, n: int, workers: int, rounds: int = 3, copies: int = 1) -> float:
    """Best of ``rounds`` wall times of ``vines_stoch.run`` in memory of ``n`` realisations of
    ``steps`` steps (``SHORT_PATHS``) on ``workers`` threads, in a fresh process; with ``copies``
    processes running it side by side, their mean."""
    command = [sys.executable, "-c", _PATH_RATE, str(steps), str(n), str(workers), str(rounds)]
    jobs = [subprocess.Popen(command, stdout=subprocess.PIPE, text=True) for _ in range(copies)]
    times = [float(job.communicate()[0].split()[-1]) for job in jobs]
    assert all(job.returncode == 0 for job in jobs)
    return sum(times) / len(times)


def _short_paths() -> dict[str, float]:
    """Path-steps/s of one worker on short and long paths (``SHORT_PATHS``), the fixed cost of a
    realisation (10-step paths, less their steps at the long paths' rate), and the scaling from
    one worker to two on 1,000- and 100,000-step paths beside the host's own: two processes of
    one worker side by side against one alone."""
    figures = {}
    for name, (steps, n) in SHORT_PATHS.items():
        figures[name] = steps * n / _path_seconds(steps, n, 1)
    long_rate = figures["100,000-step paths"]
    steps, n = SHORT_PATHS["10-step paths"]
    figures["fixed cost (us)"] = (steps * n / figures["10-step paths"] - steps * n / long_rate) / n * 1e6
    for name in ("1,000-step paths", "100,000-step paths"):
        steps, n = SHORT_PATHS[name]
        # one and two workers in turn, twice, the best of each (the host's speed drifts between
        # minutes: a figure of each taken in one minute alone can be 30 % apart)
        pairs = [(_path_seconds(steps, n, 1), _path_seconds(steps, n, 2)) for _ in range(2)]
        one, two = min(p[0] for p in pairs), min(p[1] for p in pairs)
        alone = _path_seconds(steps, n, 1, rounds=2)
        side_by_side = _path_seconds(steps, n, 1, rounds=2, copies=2)
        figures[f"{name}: 2 workers"] = one / two
        figures[f"{name}: 2 processes"] = 2 * alone / side_by_side
    return figures


#: The scenes of "Dynamics outputs": a linear oscillator under white noise (kick-drift-kick) and a
#: cubic NES under a harmonic force (rk4), each asked for nothing and then for one output.
_NOISE = {"name": "outputs-noise", "primary": {"mass": 1.0, "stiffness": 1.0, "damping": 0.4},
          "loads": [{"type": "white-noise", "intensity": 1.0}],
          "simulation": {"duration": 400.0, "dt": 0.02, "metrics_from": 100.0},
          "ensemble": {"realizations": 200, "seed": 1}}
_HARMONIC = {"name": "outputs-harmonic", "primary": {"mass": 1.0, "stiffness": 1.0, "damping": 0.01},
             "absorbers": [{"type": "cubic", "mass": 0.05, "stiffness": 1.0, "damping": 0.002}],
             "loads": [{"type": "harmonic", "amplitude": 0.02, "frequency": 1.05}],
             "simulation": {"duration": 2000.0, "dt": 0.02, "metrics_from": 1000.0, "scheme": "rk4"},
             "sweep": {"loads.0.frequency": {"linspace": [0.95, 1.15, 20]}}}
OUTPUT_CASES = {
    "white noise: nothing asked": (_NOISE, {}, False),
    "white noise: history statistics of x1, e1 (1000 points)": (_NOISE, {"simulation.history": True}, False),
    "white noise: paths of x1, e1 kept (paths=True, 1000 points)": (_NOISE, {}, True),
    "white noise: spectra of x1 (every step)": (_NOISE, {"output.spectra": {"signals": ["x1"]}}, False),
    "cubic NES, harmonic: nothing asked": (_HARMONIC, {}, False),
    "cubic NES, harmonic: Poincare sections": (_HARMONIC, {"output.poincare": True}, False),
    "cubic NES, harmonic: energy_share_mean and energy_share_max": (
        _HARMONIC, {"output.metrics": ["energy_share_mean", "energy_share_max"]}, False),
}


def _output_costs(rounds: int = 3) -> dict[str, float]:
    """Seconds of ``run`` in memory (one worker, the best of ``rounds`` after a warm-up) of each
    of ``OUTPUT_CASES``."""
    times = {}
    for name, (data, changes, paths) in OUTPUT_CASES.items():
        study = scenes.changed(data, changes)
        run(study, workers=1, paths=paths)
        best = float("inf")
        for _ in range(rounds):
            start = time.perf_counter()
            run(study, workers=1, paths=paths)
            best = min(best, time.perf_counter() - start)
        times[name] = best
    return times


def _startup(directory: Path) -> list[tuple[str, float, float]]:
    """Wall time of ``vines-stoch run`` in a fresh process on a cold numba cache (first run:
    compilation) and again on the warm cache: rows ``(scenario, cold s, cached s)``."""
    smooth = directory / "smooth.toml"
    smooth.write_text(scenes.text(scenes.changed(scenes.scene_data("smooth"),
                                                 {"ensemble.realizations": 4, "simulation.duration": 20.0})))
    cases = [("scenarios/cubic_nes_impulse.toml (RK4, 15 runs)",
              REPOSITORY / "scenarios/cubic_nes_impulse.toml"),
             ("smooth scene, 4 paths of 20 s (kick-drift-kick)", smooth)]
    env = _fresh_env(NUMBA_CACHE_DIR=str(directory / "numba-cache"))
    rows = []
    for name, path in cases:
        if not path.exists():
            continue
        times = []
        for _ in range(2):
            start = time.perf_counter()
            subprocess.run([sys.executable, "-m", "vines_stoch.cli", "run", str(path), "--quiet",
                            "--out", str(directory / "startup")], check=True, env=env)
            times.append(time.perf_counter() - start)
        rows.append((name, *times))
    return rows


def _frame_data(storeys: int, absorbers: list[dict], loads: list[dict], **more: Any) -> dict[str, Any]:
    """A shear frame of ``storeys`` equal storeys (1 kg, 4 n^2 N/m, 0.05 N s/m) with ``absorbers``
    and ``loads``, 5 s at dt = 1e-3, 16 realisations: a structure no earlier run had."""
    data = {"name": f"new-{storeys}", "primary": {"masses": [1.0] * storeys,
                                                  "stiffnesses": [4.0 * storeys**2] * storeys,
                                                  "dampings": [0.05] * storeys},
            "absorbers": absorbers, "loads": loads, "ensemble": {"realizations": 16},
            "simulation": {"duration": 5.0, "dt": 1e-3}}
    return scenes.changed(data, more)


#: Structures never run before (storeys, absorber laws, loads, declared outputs) whose first run
#: ``_new_structures`` times after ``vines-stoch compile --general``.
NEW_STRUCTURES = {
    "1 storey, no absorber, harmonic": (
        1, [], [{"type": "harmonic", "amplitude": 0.1, "frequency": 2.0}], {}),
    "2 storeys, bistable + geometric NES, Kanai-Tajimi ground motion": (
        2, [{"type": "bistable", "mass": 0.05, "stiffness": 1.0, "linear_stiffness": -0.05, "damping": 0.01},
            {"type": "geometric", "mass": 0.05, "stiffness": 1.0, "free_length": 1.0, "length": 1.0,
             "damping": 0.01, "floor": 1}],
        [{"type": "ground-motion", "model": "kanai-tajimi", "soil": "medium", "intensity": 0.1}], {}),
    "5 storeys, Hertz NES, white noise, history and limits": (
        5, [{"type": "hertz", "geometry": "double-sided", "mass": 0.05, "stiffness": 0.5, "damping": 0.01,
             "offset": 0.0, "gap": 0.05, "contact_left": {"k": 1e5}, "contact_right": {"k": 1e5}}],
        [{"type": "white-noise", "intensity": 0.2}],
        {"simulation.history": {"points": 50}, "limits": {"drift": {"metric": "x_max_1", "value": 0.2}}}),
    "9 storeys, cubic + impact NES, Clough-Penzien ground motion": (
        9, [{"type": "cubic", "mass": 0.05, "stiffness": 1.0, "damping": 0.01},
            {"type": "impact", "mass": 0.05, "clearance": 0.02, "restitution": 0.6, "floor": 8}],
        [{"type": "ground-motion", "model": "clough-penzien", "soil": "firm", "intensity": 0.1}], {}),
}


def _new_structures(directory: Path) -> tuple[float, list[tuple[str, float, int]]]:
    """Seconds of ``vines-stoch compile --general`` on an empty numba cache, then the wall time of
    the first ``vines-stoch run`` of each structure of ``NEW_STRUCTURES`` in a fresh process on
    the cache it wrote, and how many functions that run compiled (numba's own count of the
    entries it saved to the cache, ``NUMBA_DEBUG_CACHE``)."""
    env = _fresh_env(NUMBA_CACHE_DIR=str(directory / "general-cache"))
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "vines_stoch.cli", "compile", "--general"], check=True, env=env,
                   capture_output=True)
    compiled = time.perf_counter() - start
    rows = []
    for k, (name, (storeys, absorbers, loads, more)) in enumerate(NEW_STRUCTURES.items()):
        path = directory / f"new{k}.toml"
        path.write_text(scenes.text(_frame_data(storeys, absorbers, loads, **more)))
        start = time.perf_counter()
        done = subprocess.run([sys.executable, "-m", "vines_stoch.cli", "run", str(path), "--quiet",
                               "--out", str(directory / f"new{k}")], check=True, capture_output=True,
                              text=True, env={**env, "NUMBA_DEBUG_CACHE": "1"})
        rows.append((name, time.perf_counter() - start, (done.stdout + done.stderr).count("data saved to")))
    return compiled, rows


def _estimate_times(rounds: int = 3) -> list[tuple[str, int, str, float]]:
    """``vines_stoch.estimate`` of every shipped scenario whose points it can estimate (one
    ``exact-linear`` or ``statistical-linearization`` row at least), best of ``rounds``: rows
    ``(scenario, points, methods, seconds)``."""
    from ..rvt import estimate
    from ..scenario import ScenarioError, load_scenario

    rows = []
    for path in sorted((REPOSITORY / "scenarios").glob("*.toml")):
        try:
            study = load_scenario(path)
        except ScenarioError:  # (a record not shipped)
            continue
        seconds = []
        for _ in range(rounds):
            start = time.perf_counter()
            table = estimate(study)
            seconds.append(time.perf_counter() - start)
        counts = table["method"].value_counts()
        if set(counts.index) != {"not-applicable"}:
            methods = ", ".join(f"{n} {m}" for m, n in counts.items())
            rows.append((path.name, len(table), methods, min(seconds)))
    return rows


def main(out: Path = Path("reports/benchmarks.md"), n_paths: int = 200) -> str:
    """Run the benchmark and write the Markdown report; returns its text.  Its runs take the loops
    specialised to their structure whatever their work (``VINES_STOCH_GENERAL_WORK=0``: the loops
    a long run takes, which the throughput sections measure), the general loop where a row says
    so; the fresh processes of "Compile time and start-up" run as a user's do (``_fresh_env``)."""
    with _general_work("0"):
        return _measure(out, n_paths)


def _measure(out: Path, n_paths: int) -> str:
    """``main``'s measurements and report."""
    with tempfile.TemporaryDirectory() as tmp:
        _api_rate(4, 1, Path(tmp) / "warm")  # compile (or load from cache) outside the timing
        _api_rate(4, 1, Path(tmp) / "warm-impact", impacts=True)
        rates = _step_loop_rates(n_paths // 2)
        loop, loop_metrics, rec, rec_metrics, euler_loop, kernel, general_loop = rates.values()
        # three rounds of: the 1- and 2-thread runs, each between two short batches of both
        # rooflines, compared with their mean (the host's speed drifts between minutes); the
        # round with the better 1-thread ratio is reported
        rounds = []
        for k in range(3):
            before = _step_loop_rates(10, only=("roofline", "recurrence roofline"))
            api1, res1 = _api_rate(n_paths, 1, Path(tmp) / f"one{k}")
            api2, res2 = _api_rate(n_paths, 2, Path(tmp) / f"two{k}")
            after = _step_loop_rates(10, only=("roofline", "recurrence roofline"))
            near, near_rec = (0.5 * (before[name] + after[name]) for name in before)
            rounds.append((near, near_rec, api1, res1, api2, res2))
        near, near_rec, api1, res1, api2, res2 = max(rounds, key=lambda r: r[2] / r[0])
        impact1, res_impact = _api_rate(n_paths, 1, Path(tmp) / "impact", impacts=True)
        lanes = _lanes(Path(tmp))
        contact = _contact_rates(n_paths, Path(tmp))
        seismic = _seismic(Path(tmp))
        memory = {n: _peak_memory(n, Path(tmp) / f"history{n}") for n in (10_000, 100_000)}
        overhead = _distributed_overhead(Path(tmp))
        startup = _startup(Path(tmp))
        general = _new_structures(Path(tmp))
    short = _short_paths()
    outputs = _output_costs()
    floors = _floors()
    frames = _frames()
    estimates = _estimate_times()
    ssvi = _ssvi()
    same_path = {kind: precision.same_path_errors(kind, SAME_PATH_LEVELS, paths=20)
                 for kind in ("hertz", "impact")}
    out.parent.mkdir(parents=True, exist_ok=True)
    work_precision = precision.section(out.parent)
    stability_suite = stability.section()
    rare_events = bench_rare.section()
    cores = os.cpu_count()
    budget = lanes["budget"]  # (a lane-step with and without its normal; one at 8x the scalar loop)
    step_ns, quiet_ns, eight_ns = (1e9 / budget["lanes"], 1e9 / budget["lanes, no noise"],
                                   1e9 / (8 * budget["scalar"]))
    scipy_row = (f"| scipy DOP853 + events, rtol {ssvi['scipy_rtol']:.0e} | {ssvi['scipy_s'] * 1e3:.1f} | "
                 f"{ssvi['scipy_error']:.1e} | {ssvi['scipy_s'] / ssvi['ours_s']:.0f}x slower |"
                 if "scipy_s" in ssvi
                 else "| scipy DOP853 + events | - | no tolerance down to 1e-10 matched | - |")
    measured = dict(cores=cores, n_paths=n_paths, loop=loop, rec=rec, loop_metrics=loop_metrics,
                    rec_metrics=rec_metrics, euler_loop=euler_loop, kernel=kernel, general_loop=general_loop,
                    api1=api1, near=near,
                    near_rec=near_rec, res1=res1, api2=api2, res2=res2, lanes=lanes, budget=budget,
                    quiet_ns=quiet_ns, step_ns=step_ns, eight_ns=eight_ns, impact1=impact1,
                    res_impact=res_impact, short=short, outputs=outputs, contact=contact,
                    same_path=same_path, ssvi=ssvi, scipy_row=scipy_row, work_precision=work_precision,
                    stability_suite=stability_suite, rare_events=rare_events, estimates=estimates,
                    startup=startup, general=general, seismic=seismic, floors=floors, frames=frames,
                    overhead=overhead, memory=memory)
    text = "".join(section(measured) for section in SECTIONS)
    out.parent.mkdir(parents=True, exist_ok=True)
    gpu_section = section_of(out.read_text()) if out.exists() else None  # (make bench-gpu's: kept)
    out.write_text(text if gpu_section is None else replace_section(text, gpu_section))
    print(text)
    return text


def _smooth_section(m: dict[str, Any]) -> str:
    """The report's title and its section "Smooth scene" from the measurements ``m``."""
    (cores, n_paths, loop, rec, loop_metrics, rec_metrics, euler_loop, kernel, general, api1, near, near_rec,
     res1, api2, res2) = (
        m["cores"], m["n_paths"], m["loop"], m["rec"], m["loop_metrics"], m["rec_metrics"],
        m["euler_loop"], m["kernel"], m["general_loop"], m["api1"], m["near"], m["near_rec"], m["res1"],
        m["api2"], m["res2"])
    return f"""# Benchmarks

Machine: {cores} cores. All figures from one run of `make bench`; ratios are within that run.

## Smooth scene

LPO m = k = 1, cubic NES eps = 0.05, c = 0.01, k3 = 1; 0.1 cos t + white noise 0.05; T = 200,
dt = 1e-3, {n_paths} realisations, Euler-Maruyama (kick-drift-kick).

| runner | threads | M path-steps/s | ratio to the roofline | ratio to the recurrence roofline | \
max abs energy residual |
| --- | ---: | ---: | ---: | ---: | ---: |
| roofline: minimal numba loop of the same scheme (kick-drift-kick), `cos` a step, no metrics | 1 | \
{loop / 1e6:.1f} | 1.00 | {loop / rec:.2f} | - |
| the same loop with the same metrics (scalar code for this one scene) | 1 | {loop_metrics / 1e6:.1f} | \
{loop_metrics / loop:.2f} | {loop_metrics / rec:.2f} | - |
| recurrence roofline: the roofline with the load from a turned phasor, as the step loop | 1 | \
{rec / 1e6:.1f} | {rec / loop:.2f} | 1.00 | - |
| the recurrence roofline with the same metrics | 1 | {rec_metrics / 1e6:.1f} | {rec_metrics / loop:.2f} | \
{rec_metrics / rec:.2f} | - |
| minimal numba loop, semi-implicit Euler (one force evaluation a step) | 1 | {euler_loop / 1e6:.1f} | \
{euler_loop / loop:.2f} | {euler_loop / rec:.2f} | - |
| vines_stoch step loop (`simulate`, seeded as in an ensemble) | 1 | {kernel / 1e6:.1f} | \
{kernel / loop:.2f} | {kernel / rec:.2f} | - |
| the general loop of the scheme (the same path; one loop for every structure) | 1 | \
{general / 1e6:.1f} | {general / loop:.2f} | {general / rec:.2f} | - |
| `vines_stoch.run` | 1 | {api1 / 1e6:.1f} | {api1 / near:.2f} | {api1 / near_rec:.2f} | {res1:.1e} |
| `vines_stoch.run` | 2 | {api2 / 1e6:.1f} | {api2 / near:.2f} | {api2 / near_rec:.2f} | {res2:.1e} |

Against the rooflines with the same metrics: step loop {kernel / loop_metrics:.2f}x (`cos` a step) and
{kernel / rec_metrics:.2f}x (recurrence). Scaling 1 -> 2 threads: {api2 / api1:.2f}x. The API figures
include seeding, metric reduction, dask scheduling and Parquet output. The first seven rows run one
path of each in turn ({n_paths // 2} paths each), so they see the same machine. The step loop and
the `run` rows run the loops specialised to the scene's structure, as a run of 10^8 path-steps or
more does (`VINES_STOCH_GENERAL_WORK`); a shorter run takes the general loop, compiled once for
every structure: {general / kernel:.2f}x the specialised loop's speed here (the same numbers,
bitwise). This host's speed drifts by up to 1.5x between minutes, so the `run` rows' ratios are
to the mean of short roofline batches timed just before and just after them ({near / 1e6:.1f} and
{near_rec / 1e6:.1f} M path-steps/s; three rounds, the better 1-thread ratio kept).
"""


def _lanes_section(m: dict[str, Any]) -> str:
    """The report's section "Paths in SIMD lanes" from the measurements ``m``."""
    (lanes, budget, quiet_ns, step_ns, eight_ns) = (
        m["lanes"], m["budget"], m["quiet_ns"], m["step_ns"], m["eight_ns"])
    return f"""
## Paths in SIMD lanes

`vines_stoch.run` with T = 20 (20,000 steps) with its paths in SIMD lanes (`kernels/lanes.py`, the
default for these scenes, on Philox streams; {VECTOR_BITS}-bit vectors asked for) and as before lanes
(the scalar loop on PCG64 streams), in turn, the best of three rounds. The smooth scene as above;
the impact-rich scene below; the contact scene of "Contact under noise" (steel-on-steel DSVI and
a plastic impact NES); the parallel NES (cubic and impact) under filtered noise from its stationary
law (`scenarios/filtered_noise.toml`: each lane advances its own filter). A lane whose step
holds an impact, a contact onset or end, or sticking, or whose absorber is stuck or touches, is
finished by the scalar step. The contact scene's time
is in such steps: its plastic absorber is stuck on about half of them, and its events (impacts,
the contact's sub-steps, the root searches on the Brownian tree) fall on about 3.5 %, so its
lanes run at about the scalar loop's speed.

| scene | realisations | runner | threads | M path-steps/s | ratio to the scalar loop (1 thread) | \
mean `x1_rms` (standard error) |
| --- | ---: | --- | ---: | ---: | ---: | ---: |
{_lane_rows(lanes)}

A run into a folder writes each chunk's Parquet part and, at its end, the result tables, in the
calling thread beside the workers: with one worker that thread has the second core to itself,
with two it takes time from them. The in-memory rows (`run(study, None)`) write no files, so
their 1 -> 2 threads ratio is the lanes' own scaling.

Where a lane-step goes (the smooth scene, one chunk of 512 paths, no files; the best of three):
the lanes run {budget["lanes"] / 1e6:.1f} M path-steps/s ({budget["lanes"] / budget["scalar"]:.2f}x the
scalar loop's {budget["scalar"] / 1e6:.1f}); without the white noise (the same update, no normals drawn)
{1e3 / quiet_ns:.1f} M/s, {1e9 / quiet_ns / budget["scalar"]:.2f}x the scalar loop with noise.
A lane-step takes {step_ns:.2f} ns, its normal {step_ns - quiet_ns:.2f} ns of it
({1 - quiet_ns / step_ns:.0%}). 8x the scalar loop asks for a lane-step of {eight_ns:.2f} ns, which
leaves its normal {eight_ns - quiet_ns:.2f} ns.

The lanes' normals alone (a block of Philox4x32-10 and its two branch-free float32 Box-Muller
pairs every four draws, a batch of {LANES} lanes, drawn from compiled code as the lane loop draws
them; the best of three): {lanes["normals"] / 1e6:.0f} M normals/s, {1e9 / lanes["normals"]:.2f} ns a
normal; a normal drawn in the scalar loop costs {lanes["philox ns"]:.1f} ns from a Philox stream and
{lanes["pcg ns"]:.1f} ns from a PCG64 stream (the ziggurat).
The SRA and Runge-Kutta schemes do not run in lanes (the scalar loop: a ratio of 1).
"""


def _impact_section(m: dict[str, Any]) -> str:
    """The report's section "Impact-rich stochastic scene" from the measurements ``m``."""
    impact1, api1, res_impact = m["impact1"], m["api1"], m["res_impact"]
    return f"""
## Impact-rich stochastic scene

The smooth scene plus an impact NES (m = 0.05, clearance 0.2, r = 0.6): the parallel NES of
seed 000 under harmonic + white noise, impacts split on the Brownian tree of the step.

| runner | threads | M path-steps/s | ratio to the smooth scene (1 thread) | max abs energy residual |
| --- | ---: | ---: | ---: | ---: |
| `vines_stoch.run` | 1 | {impact1 / 1e6:.1f} | {impact1 / api1:.2f} | {res_impact:.1e} |
"""


def _short_section(m: dict[str, Any]) -> str:
    """The report's section "Short paths and worker scaling" from the measurements ``m``."""
    short = m["short"]
    return f"""
## Short paths and worker scaling

`vines_stoch.run` in memory on a linear oscillator under white noise (`scenes/linear.toml`,
dt = 0.01), one worker unless said, each figure the best of three runs in a fresh process (the
worker ratios: of two such processes each, one and two workers in turn): a
chunk of realisations runs in one compiled call with the GIL released (`kernels/chunk.py`),
its streams made inside it.

| paths | realisations | M path-steps/s (1 worker) | ratio to 100,000-step paths |
| --- | ---: | ---: | ---: |
{chr(10).join(f"| {name} | {SHORT_PATHS[name][1]:,} | {short[name] / 1e6:.1f} | "
              f"{short[name] / short['100,000-step paths']:.2f} |" for name in SHORT_PATHS)}

Fixed cost of a realisation (the 10-step paths' time per realisation less their steps at the
100,000-step paths' rate): {short["fixed cost (us)"]:.2f} us.

| paths | 2 workers / 1 worker | host: 2 processes side by side / 1 alone |
| --- | ---: | ---: |
{chr(10).join(f"| {name} | {short[name + ': 2 workers']:.2f} | {short[name + ': 2 processes']:.2f} |"
              for name in ("1,000-step paths", "100,000-step paths"))}

The host column is the machine's own scaling: two independent processes of one worker each
against one alone (shared caches, memory bandwidth and turbo clocks), the ceiling of the
program's.
"""


def _outputs_section(m: dict[str, Any]) -> str:
    """The report's section "Dynamics outputs: what asking costs" from the measurements ``m``."""
    outputs = m["outputs"]
    return f"""
## Dynamics outputs: what asking costs

`vines_stoch.run` in memory, one worker, the best of three runs after a warm-up: a linear
oscillator under white noise (200 realisations of 15,000 steps, kick-drift-kick) and a cubic NES
under a harmonic force (20 frequencies of 100,000 steps, rk4), each as asked for nothing and
with one output more (the last row declares the absorbers' energy share's mean and peak, folded
at every step end).

| run | time (s) | ratio to the same scene asking for nothing |
| --- | ---: | ---: |
{chr(10).join(f"| {name} | {sec:.3f} | {sec / outputs[name.split(':')[0] + ': nothing asked']:.2f} |"
              for name, sec in outputs.items())}
"""


def _contact_section(m: dict[str, Any]) -> str:
    """The report's section "Contact under noise" from the measurements ``m``."""
    n_paths, api1, contact, same_path = m["n_paths"], m["api1"], m["contact"], m["same_path"]
    return f"""
## Contact under noise

`vines_stoch.run` with one thread on the example scenarios (one sweep point, {n_paths} paths;
kick-drift-kick, contacts sub-stepped, every sub-step on the Brownian tree of its step), as
ratios to the smooth scene's 1-thread `run` above; and the step loops' ratio, each scene's
`simulate` against the smooth scene's, one path of each in turn (the smooth paths are 200,000
steps long, the SSVI's 30,000: a run's fixed costs, its folder and tables, weigh more on short
paths).

{CONTACT_HEADER}
{chr(10).join(f"| {name} | {rate / 1e6:.2f} | {rate / api1:.2f} | {loops:.2f} | {hits:.0f} | {res:.1e} |"
              for name, rate, res, hits, loops in contact)}

Work-precision on one Brownian path (`precision.same_path_errors`): LPO m = k = 1, c = 0.02 with
a double-sided Hertz absorber (K = 7e5 N/m^1.5) or an impact absorber (r = 0.9), white noise 0.1,
T = 0.5; mean over 20 paths of the error of x1(T) against dt = 2^-14 on the same path (every
run replays the same fine normals and tree seed); time per path of the kernel.

| dt | Hertz: error | Hertz: ms per path | impact: error | impact: ms per path |
| ---: | ---: | ---: | ---: | ---: |
{chr(10).join(f"| 2^-{lv} | {same_path['hertz'][0][i]:.2e} | {same_path['hertz'][1][i] * 1e3:.3f} | "
              f"{same_path['impact'][0][i]:.2e} | {same_path['impact'][1][i] * 1e3:.3f} |"
              for i, lv in enumerate(SAME_PATH_LEVELS))}

Measured strong order: Hertz contact {precision.strong_order(SAME_PATH_LEVELS, same_path['hertz'][0]):.2f},
impacts {precision.strong_order(SAME_PATH_LEVELS, same_path['impact'][0]):.2f} \
(docs/numerics.md, "Schemes": 1 and 1/2 expected).
"""


def _ssvi_section(m: dict[str, Any]) -> str:
    """The report's section "SSVI design SS-1(60) of seed 003" from the measurements ``m``."""
    (ssvi, scipy_row, work_precision, stability_suite, rare_events) = (
        m["ssvi"], m["scipy_row"], m["work_precision"], m["stability_suite"], m["rare_events"])
    return f"""
## SSVI design SS-1(60) of seed 003

12 s from rest (the first contacts), error of `e1_max` against DOP853 at rtol 1e-11 with
contact onsets and ends located as events.

| solver | time per run (ms) | relative `e1_max` error | ratio |
| --- | ---: | ---: | ---: |
| vines_stoch RK4, dt = 1e-3, contact sub-steps | {ssvi['ours_s'] * 1e3:.1f} | {ssvi['ours_error']:.1e} | 1 |
{scipy_row}

{work_precision}
{stability_suite}
{rare_events}"""


def _estimates_section(m: dict[str, Any]) -> str:
    """The report's section "Estimates without an ensemble" from the measurements ``m``."""
    estimates = m["estimates"]
    return f"""
## Estimates without an ensemble

`vines_stoch.estimate` of every shipped scenario it can estimate (MODEL.md section 6; the others
say why not in a few milliseconds), all sweep points, best of 3, in this process:

| scenario | points | methods | time (s) |
| --- | ---: | --- | ---: |
{chr(10).join(f"| {name} | {n} | {methods} | {sec:.2f} |" for name, n, methods, sec in estimates)}
"""


def _startup_section(m: dict[str, Any]) -> str:
    """The report's section "Compile time and start-up" from the measurements ``m``."""
    startup, (compiled, firsts) = m["startup"], m["general"]
    return f"""
## Compile time and start-up

`vines-stoch run FILE --quiet` in a fresh process: first on an empty numba cache (every kernel
the scene needs is compiled), then again with the cache written by the first run.

| scenario | first run, cold cache (s) | cached start-up and run (s) |
| --- | ---: | ---: |
{chr(10).join(f"| {name} | {cold:.1f} | {warm:.2f} |" for name, cold, warm in startup)}

`vines-stoch compile --general` on an empty cache took {compiled:.1f} s (the general loops of every
scheme and the pass loop, one process a core, and one run of every absorber law). After it, the first run of
structures no run had before (16 realisations of 5 s, `vines-stoch run --quiet` in a fresh
process; functions compiled: the entries numba saved to its cache, `NUMBA_DEBUG_CACHE`):

| structure | first run (s) | functions compiled |
| --- | ---: | ---: |
{chr(10).join(f"| {name} | {seconds:.2f} | {saved} |" for name, seconds, saved in firsts)}
"""


def _seismic_section(m: dict[str, Any]) -> str:
    """The report's section "Record-driven scene" from the measurements ``m``."""
    seismic = m["seismic"]
    return f"""
## Record-driven scene

1 Hz primary (1000 kg, 2 % damping) with a cubic NES (50 kg, k3 = 2e6, c = 20), 40 s at
dt = 2e-3, RK4, one path: under a synthetic accelerogram (Clough-Penzien medium soil, Jennings
envelope, 0.01 s samples, PGA 0.3 g; base excitation on both masses, sub-steps end at the
samples) and under a harmonic force of the same peak (`m1 * 0.3 g * cos 6t`).

| load | M path-steps/s | ratio to harmonic | energy residual | `e1_max` change dt -> dt/2 |
| --- | ---: | ---: | ---: | ---: |
| harmonic force | {seismic['harmonic'][0] / 1e6:.2f} | 1.00 | {seismic['harmonic'][1]:.1e} | \
{seismic['harmonic'][2]:.1e} |
| record (base excitation) | {seismic['record'][0] / 1e6:.2f} | \
{seismic['record'][0] / seismic['harmonic'][0]:.2f} | {seismic['record'][1]:.1e} | \
{seismic['record'][2]:.1e} |
"""


def _floors_section(m: dict[str, Any]) -> str:
    """The report's section "Floors" from the measurements ``m``."""
    floors = m["floors"]
    return f"""
## Floors

Cost against size (one thread, one path at a time; the first call includes compilation when
the kernel is not cached yet):

| scene | M path-steps/s | ns a step | first call (s) |
| --- | ---: | ---: | ---: |
{chr(10).join(f"| {name} | {rate:.2f} | {ns:.0f} | {first:.1f} |" for name, rate, ns, first in floors)}
"""


def _frames_section(m: dict[str, Any]) -> str:
    """The report's section "Frames in lanes: the pass loop" from the measurements ``m``."""
    rows = "\n".join(f"| {name} | {first:.2f} | {rate:.1f} | {special:.1f} | {rate / special:.2f} | "
                     f"{scalar:.1f} | {rate / scalar:.1f} | {special_first:.1f} |"
                     for name, first, rate, special, scalar, special_first in m["frames"])
    return f"""
## Frames in lanes: the pass loop

Every noisy kick-drift-kick structure of three bodies or more without impact or Hertz absorbers
runs the pass loop, compiled once for all of them (`kernels/passes.py`), and so does one of one
or two bodies in a short run (one storey below: a longer run takes the specialised lanes); the
lane loop specialised to the structure (the executor before it, compiled for each structure)
and the scalar loop in the same run. Frames with cubic NES on the roof under white noise and a
harmonic force, 20 s; the first call is the first chunk of a structure this process has not run
(the pass loop loaded or compiled before, on a bare four-storey frame).

| frame | first call (s) | pass loop (M path-steps/s) | specialised lanes | pass / specialised \
| scalar loop | pass / scalar | specialised first call (s) |
| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |
{rows}
"""


def _scale_section(m: dict[str, Any]) -> str:
    """The report's section "Scale" from the measurements ``m``."""
    overhead, cores, memory = m["overhead"], m["cores"], m["memory"]
    return f"""
## Scale

Scheduler overhead: 10^4 realisations of the smooth scene with T = 20 (2 x 10^8 path-steps).

| scheduler | workers | time (s) | ratio |
| --- | --- | ---: | ---: |
| embedded (threaded scheduler) | {cores} threads | {overhead[0]:.2f} | 1.00 |
| local `dask.distributed` cluster on loopback | {cores} processes x 1 thread | {overhead[1]:.2f} | \
{overhead[1] / overhead[0]:.2f} |

Realisations bitwise identical on both: {"yes" if overhead[2] else "NO"}.
Overhead of the distributed scheduler: {100 * (overhead[1] / overhead[0] - 1):+.1f} %.

Memory: 2-DOF scene (LPO + cubic NES, white noise, T = 10, dt = 0.01) with history statistics
of x1 and E1 on a 1001-point grid, mean, std and 3 quantiles, in a fresh process each.

| realisations | peak RSS (MiB) | time (s) |
| ---: | ---: | ---: |
{chr(10).join(f"| {n:,} | {rss:.0f} | {sec:.1f} |" for n, (rss, sec) in memory.items())}
"""


#: The report's sections, in order.
SECTIONS = (_smooth_section, _lanes_section, _impact_section, _short_section, _outputs_section,
            _contact_section, _ssvi_section, _estimates_section, _startup_section, _seismic_section,
            _floors_section, _frames_section, _scale_section)
