"""What runs where: an ensemble's chunks and their sizes, the backends, and the step loops
compiled (or loaded) before the first chunk starts."""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, replace
from functools import partial

from ..kernels import (
    DEFAULT_SIGNALS,
    LANES,
    chunk_runner,
    compiled_already,
    general_run,
    in_pass_loop,
    keeps_general,
    lane_scene,
    pass_loop,
    scalar_general,
    simulate_chunk,
)
from ..notices import LOG
from ..scenario import History, Study
from ..scene import Scene, build_scene
from .chunks import recorded_bytes

#: Target work of one chunk, in path-steps (about 0.1-0.3 s of compute).
CHUNK_STEPS = 5_000_000
#: Automatic chunks split a sweep point's ensemble into at least this many tasks ...
CHUNKS_PER_POINT = 32
#: ... each of at least this many path-steps (where the ensemble has them): a chunk's fixed
#: costs, its table and its Parquet part written and read back, are about 5-10 ms, the compute
#: of 0.2-0.5 M path-steps of contact under ground motion (200 paths of 30,000 steps: in
#: chunks of 7 paths, 7.0-9.0 M path-steps/s; of 34, 9.2-10.7).
MIN_CHUNK_STEPS = 1_000_000
#: Largest history paths buffer of one chunk, in bytes (caps the chunk size when history
#: statistics are asked for).
HISTORY_CHUNK_BYTES = 8_000_000
#: How many times cheaper a path-step of a scene in SIMD lanes counts in an automatic chunk's
#: work (``_auto_chunk``): lanes run about 3-4x faster than the scalar loop (``make bench``,
#: "Paths in SIMD lanes"), and a chunk's fixed costs (its table, its Parquet part) need about 3x
#: more compute beside them to stay small (measured on the smooth scene, 4,096 paths of 20,000
#: steps: 124, 158 and 151 M path-steps/s on one worker at 4, 16 and 64).  Not for a scene with
#: Hertz contact: the scalar step finishes its steps in contact and its events, and its lanes
#: run at about the scalar loop's speed (``make bench``: 1.03x on the contact-under-noise scene,
#: whose 256 paths made one chunk that a second worker could not share).
LANE_WORK = 16
#: How many times cheaper a path-step counts toward ``kernels.GENERAL_WORK`` (``plan``) in a
#: chunk that a short run gives to the pass loop and a long one to the lane loop specialised to
#: its structure (a smooth structure of one or two bodies: ``kernels.in_pass_loop`` with
#: ``general`` alone).  The threshold counts path-steps at the general scalar loop's cost, and
#: the pass loop runs such a chunk 8-9x faster (one storey with a cubic NES, 256 realisations of
#: 20 s: 125-129 against 14-16 M path-steps/s), so such a run compiles a loop of its own only
#: past 8e8 path-steps (6-7 s in the pass loop on one core; the specialised lanes, 266 M
#: path-steps/s there, first compile for 10-20 s).
PASS_WORK = 8
#: Realisations of an automatic chunk of the cuda backend (a launch fills a large GPU from
#: about 1e5 threads on; ``gpu.simulate_many`` splits a chunk into launches that fit its memory).
GPU_CHUNK = 1 << 20
#: Largest history paths and Poincare samples of one cuda chunk on the host, in bytes.
GPU_CHUNK_BYTES = 1 << 29
#: Where ensembles run: ``run_chunk`` on CPU threads or ``run_chunk_cuda`` on an NVIDIA GPU.
BACKENDS = ("cpu", "cuda")


@dataclass
class Plan:
    """Scenes of the sweep points and the chunks ``(point, start, stop)`` covering them, and
    whether the run is short enough for a loop compiled once for every structure, the general
    loop of its scheme or the pass loop (``kernels.general_run``: its path-steps, every point's
    together; ``kernels.in_pass_loop``; the CPU's choice, the same numbers either way)."""

    scenes: list[Scene]
    chunks: list[tuple[int, int, int]]
    general: bool = False
    #: The most realisations one compiled call runs (``prepare_loops``' ``batch``): a chunk's, or
    #: one where each realisation has parameters of its own (``run_chunk``).
    batch: int = 1


def plan(study: Study, chunk: int | None = None, realizations: int | None = None,
         backend: str = "cpu", history: History | None = None,
         executor: str = "lanes") -> Plan:
    """Split every sweep point's realisations into chunks (``chunk`` 0 or None: automatic,
    from the scene's cost, the backend and the CPU's ``executor`` alone, so the plan is the same
    on any cluster or GPU).  With history statistics (or the time histories ``history``, where
    given, kept) a chunk holds at most ``HISTORY_CHUNK_BYTES`` of paths (cuda: ``GPU_CHUNK_BYTES``
    of paths and Poincare samples)."""
    scenes = [build_scene(s) for s in study.points]
    wanted = study.base.ensemble.realizations if realizations is None else realizations
    chunk = study.base.ensemble.chunk if chunk is None else chunk
    spec = history or study.base.simulation.history
    spectra = study.base.output.spectra
    random = bool(study.base.uncertain)
    counts = [wanted if scene.has_noise or random else 1 for scene in scenes]
    chunks = []
    for p, (scene, n) in enumerate(zip(scenes, counts)):
        if backend == "cuda":
            size = chunk or min(n, GPU_CHUNK)
            row_bytes = recorded_bytes(scene, spec, spectra)
            if scene.period > 0:
                row_bytes += 8 * scene.n_samples * (2 * scene.mass.shape[0] + 2)
            size = min(size, max(1, GPU_CHUNK_BYTES // max(row_bytes, 1)))
        else:
            size = chunk or _auto_chunk(scene, n, lane_scene(scene, executor))
        if (spec or spectra) and backend != "cuda":
            row_bytes = recorded_bytes(scene, spec, spectra)
            size = min(size, max(1, HISTORY_CHUNK_BYTES // row_bytes))
        chunks += [(p, s, min(s + size, n)) for s in range(0, n, size)]
    work = sum((stop - start) * scenes[p].n_steps / _cheaper(scenes[p], executor, stop - start, random)
               for p, start, stop in chunks)
    batch = 1 if random else max((stop - start for _, start, stop in chunks), default=1)
    return Plan(scenes, chunks, general=backend == "cpu" and general_run(work), batch=batch)


def _cheaper(scene: Scene, executor: str, realisations: int, random: bool) -> float:
    """How many times cheaper a chunk's path-steps count toward ``kernels.GENERAL_WORK``:
    ``PASS_WORK`` where a short run gives the chunk to the pass loop and a long one would not (not
    with uncertain parameters, ``random``: each realisation then runs alone)."""
    short = not random and in_pass_loop(scene, executor, realisations=realisations, general=True)
    return PASS_WORK if short and not in_pass_loop(scene, executor, realisations=realisations) else 1


def _auto_chunk(scene: Scene, n: int, lanes: bool) -> int:
    """Realisations of an automatic CPU chunk: ``CHUNK_STEPS`` of work at most, ``n /
    CHUNKS_PER_POINT`` where that leaves a chunk ``MIN_CHUNK_STEPS`` of work.  A chunk that runs
    in SIMD lanes (``lanes``: ``kernels.lane_scene``) counts its path-steps
    ``LANE_WORK`` times cheaper and takes at least a batch of lanes (``lanes.LANES`` paths, or
    ``n``), its chunks then evened out (200 paths: two of 100, not 128 and 72); one with Hertz
    contact counts its path-steps at their scalar cost."""
    steps = max(scene.n_steps, 1)
    work = LANE_WORK if lanes and not scene.has_hertz else 1
    by_cost = max(1, work * CHUNK_STEPS // steps)
    least = math.ceil(work * MIN_CHUNK_STEPS / steps)
    size = max(1, min(by_cost, n, max(math.ceil(n / CHUNKS_PER_POINT), least)))
    if lanes and n > 0:
        size = max(size, min(n, LANES))
        size = math.ceil(n / math.ceil(n / size))
    return size


def structure(scene: Scene) -> str:
    """The structure a step loop is compiled for, in words (its scheme, bodies, floors and what
    the loop carries)."""
    features = [name for name, present in (("impacts", scene.has_impact), ("Hertz contact", scene.has_hertz),
                                           ("white noise", scene.has_white_noise),
                                           ("filtered loads", scene.has_filters),
                                           ("ground motion", scene.has_ground),
                                           ("shaped springs", scene.has_shaped)) if present]
    return (f"{scene.scheme} loop, {scene.mass.shape[0]} bodies, {scene.n_floors} floor(s)"
            + "".join(f", {f}" for f in features))


def prepare_loops(scenes: list[Scene], seed: int, common: bool, grid: tuple[int, int] | None = None,
                  signals: tuple[str, ...] = DEFAULT_SIGNALS, show: bool = True,
                  executor: str = "lanes", general: bool = False, batch: int = LANES) -> None:
    """Compile (or load from numba's cache on disk) the step loop of each structure among
    ``scenes`` that this process has not run yet, before any chunk starts, with one line each
    (logged at INFO on the ``vines_stoch`` logger, and with ``show`` on standard error): which
    structure, and whether it was compiled (once: later runs load it) or loaded.  A chunk of no
    realisations runs each loop with the argument types of ``run_chunk`` under ``executor``
    (``general``: a loop compiled once for every structure, ``Plan.general``; ``batch``: the
    realisations of the run's chunks, which choose between the pass loop and the general loop,
    ``kernels.in_pass_loop``)."""
    seen = set()
    for point, scene in enumerate(scenes):
        run = chunk_runner(scene, executor, general, batch)  # (the lane loop or the scalar loop's chunk)
        if run in seen:
            continue
        seen.add(run)
        what = ("the pass loop (every smooth kick-drift-kick structure)"
                if run is pass_loop else f"the general {scene.scheme} loop (every structure)"
                if scalar_general(scene, executor, general) else structure(scene))
        # (a loop run before may lack this run's signature: the general loop of a scheme takes
        # PCG64 streams under the scalar executor, Philox ones under the lanes)
        known = len(run.overloads)
        if show and not known:
            print(f"step loop: {what}: compiling or loading ...", end="", file=sys.stderr, flush=True)
        hits, start = sum(run.stats.cache_hits.values()), time.monotonic()
        simulate_chunk(scene, seed, point, 0, 0, common, grid, signals, scene.event_rows, executor,
                       general=general, batch=batch)
        if len(run.overloads) == known:
            continue
        loaded = sum(run.stats.cache_hits.values()) > hits
        outcome = (f"{'loaded from the cache' if loaded else 'compiled (cached on disk for later runs)'} "
                   f"in {time.monotonic() - start:.1f} s")
        _announce(what, outcome, show, known)


def _announce(what: str, outcome: str, show: bool, known: bool = True) -> None:
    """A step loop's line: logged at INFO on the ``vines_stoch`` logger, and with ``show`` on
    standard error (where ``known`` is False, the end of the line ``prepare_loops`` began)."""
    LOG.info("step loop: %s: %s", what, outcome)
    if show:
        print(f"step loop: {what}: {outcome}" if known else f" {outcome}", file=sys.stderr, flush=True)


def specialised_loops(scenes: list[Scene], seed: int, common: bool, grid: tuple[int, int] | None = None,
                      signals: tuple[str, ...] = DEFAULT_SIGNALS, executor: str = "lanes",
                      batch: int = LANES, show: bool = True) -> bool:
    """Whether the loops specialised to the structures of ``scenes``, where each is not the loop a
    short run takes anyway (the pass loop), are compiled already, in this process or on disk (each
    then loaded, with ``prepare_loops``' line): what a short run takes then (``kernels.keeps_general``).
    Looking compiles no loop (``kernels.compiled_already``), and a loop missing is looked for once
    a process (``kernels.compile_first``).  The arguments are ``prepare_loops``'."""
    wanted = {}
    for point, scene in enumerate(scenes):
        run = chunk_runner(scene, executor, False, batch)
        if run is not chunk_runner(scene, executor, True, batch):
            wanted.setdefault(run, (point, scene))
    for run, (point, scene) in wanted.items():
        known, start = len(run.overloads), time.monotonic()
        if not compiled_already(partial(simulate_chunk, scene, seed, point, 0, 0, common, grid, signals,
                                        scene.event_rows, executor, batch=batch)):
            return False
        if len(run.overloads) > known:
            _announce(structure(scene), f"loaded from the cache in {time.monotonic() - start:.1f} s (a short "
                      "run takes the loop specialised to its structure where it is on disk)", show)
    return bool(wanted)


def on_hand(the_plan: Plan, seed: int, common: bool, grid: tuple[int, int] | None = None,
            signals: tuple[str, ...] = DEFAULT_SIGNALS, executor: str = "lanes", show: bool = True) -> Plan:
    """``the_plan`` with the loops a short run takes where those specialised to its structures are
    compiled already (``kernels.keeps_general``, ``specialised_loops``; the same numbers)."""
    return replace(the_plan, general=keeps_general(the_plan.general, lambda: specialised_loops(
        the_plan.scenes, seed, common, grid, signals, executor, the_plan.batch, show)))
