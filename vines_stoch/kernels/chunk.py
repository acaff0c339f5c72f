"""A chunk of realisations in one compiled call: the loop over realisations runs inside compiled
code, with the GIL released, deriving each realisation's streams from (seed, purpose, point,
realisation) there and writing its metric row, Poincare samples, history rows and event log
into arrays made once a chunk.  The ground-motion paths the realisations saw are replayed from
their filter streams apart (``ground_paths``), for the scenes that ask for intensity measures.

A realisation's streams are those of ``streams.streams`` (``pcg.seed_stream``: numpy's
``SeedSequence`` and ``PCG64`` in compiled code), its state starts from the scene's initial
state and its filters from their stationary law (``loads.stationary_start``), as ``simulate``
starts them: a chunk's rows are bitwise those of ``simulate`` run realisation by realisation
(``tests/unit/kernels/test_chunk.py``), so the numbers depend on no chunk size or worker count.
A chunk pays no Python per realisation: its compiled loop costs about 0.15 us a realisation beyond
the steps (streams, state, the loop's entry), where a Python call a realisation cost about 60 us;
``make bench`` ("Short paths and worker scaling") times whole runs, tables and statistics included.
"""

from __future__ import annotations

from functools import cache, lru_cache
from typing import NamedTuple

import numpy as np
from numba.extending import overload

from ..jit import njit
from ..jit.cache import stable_cache
from ..jit.flags import INLINE, KERNEL
from ..outputs import EVENT_COLUMNS, new_metrics
from ..schemes import in_lanes
from ..streams import BRIDGE, FILTER, INCREMENTS, PARAMETERS, Streams, streams
from ..streams.kinds import KIND, PCG_KIND
from ..streams.pcg import POOL_SIZE, new_stream, pcg_normal, pcg_uniform, seed_pool, seed_stream
from ..streams.rng import STREAM_WORDS, open_stream, philox_stream, stream_key, stream_place
from .bundles import Outputs
from .lanes import lane_loop
from .loads import load_path, stationary_start
from .passes import pass_layout, pass_loop, pass_scene
from .paths import (
    _NO_CARRY,
    _NO_HISTORY,
    _NO_SIGNALS,
    _UNUSED,
    bundles,
    compile_first,
    filter_tuple,
    history_columns,
    kernel_for,
    loads_of,
    needed_streams,
    sample_buffer,
    spec_of,
)


def reseed(stream, keys, purpose, point, realization, common, pool, words) -> None:
    """Set ``stream`` to the start of realisation ``realization``'s stream of ``purpose``: a
    PCG64 stream (``keys``: ``seed_keys``) or a Philox stream (``keys``: ``philox_keys``);
    ``pool`` and ``words`` are scratch.  (Compiled code only: ``_reseed``.)"""
    raise NotImplementedError("reseed runs in compiled code")


@overload(reseed, jit_options=INLINE)
def _reseed(stream, keys, purpose, point, realization, common, pool, words):
    def by_kind(stream, keys, purpose, point, realization, common, pool, words):
        if stream[KIND] == PCG_KIND:
            seed_stream(stream, keys[:POOL_SIZE], keys[POOL_SIZE], purpose, point, realization, common, pool,
                        words)
        else:
            open_stream(stream, keys[purpose], stream_place(realization, point, common))
    return by_kind


@lru_cache(maxsize=64)
def seed_keys(seed: int) -> np.ndarray:
    """The keys of a seed's PCG64 streams (``reseed``): ``SeedSequence``'s pool of the seed and
    its running constant (``pcg.seed_pool``)."""
    pool, hash_const = seed_pool(seed)
    keys = np.append(pool, np.uint64(hash_const))
    keys.flags.writeable = False
    return keys


@lru_cache(maxsize=64)
def philox_keys(seed: int) -> np.ndarray:
    """The keys of a seed's Philox streams (``reseed``), one a purpose (``rng.stream_key``)."""
    keys = np.array([stream_key(seed, purpose) for purpose in range(4)], np.uint64)
    keys.flags.writeable = False
    return keys


@njit(**KERNEL)
def ground_loop(ex, fl, dt, n_steps, gen_filter, filtered, keys, point, start, common, p0, ground, force):
    """The ground acceleration paths realisations ``start ..`` saw (``load_path``), one a row of
    ``ground``: their filters started and driven again from the start of their filter streams."""
    pool, words = np.zeros(POOL_SIZE, np.uint64), np.zeros(8, np.uint64)
    for j in range(ground.shape[0]):
        if filtered:
            reseed(gen_filter, keys, FILTER, point, start + j, common, pool, words)
        if fl.z.shape[0] > 0:
            stationary_start(p0, gen_filter, fl.z, fl.draws)
        load_path(ex, fl, dt, n_steps, gen_filter, force, ground[j])


def ground_paths(scene, seed: int, point: int, start: int, stop: int, common: bool = True,
                 philox: bool = False) -> np.ndarray:
    """The ground acceleration paths of realisations ``start .. stop - 1`` (``(n, n_steps +
    1)``), from their filter streams: PCG64 (the CPU's) or Philox (``philox``: the cuda
    backend's, ``rng.philox_stream``)."""
    filtered = needed_streams(scene)[2]
    gen = (np.zeros(STREAM_WORDS, np.uint64) if philox else new_stream()) if filtered else _UNUSED
    ground = np.zeros((stop - start, scene.n_steps + 1))
    keys = philox_keys(seed) if philox else seed_keys(seed)
    force = np.zeros((scene.n_steps + 1, scene.n_floors))
    ground_loop(loads_of(scene), filter_tuple(scene, None), scene.dt, scene.n_steps, gen, filtered, keys,
                point, start, common, scene.filters["p0"], ground, force)
    return ground


@cache
def chunk_loop(kernel):
    """The compiled chunk of ``kernel`` (a step loop, ``kernel_for``): it runs realisations
    ``start .. start + raw.shape[0] - 1`` of a sweep point, realisation ``j`` of the chunk into
    ``raw[j]`` (preset to the metric vector's start), ``samples[j]``, ``history[j]`` and
    ``events[j]`` (preset to NaN), drawing from its streams of the purposes ``wanted`` (the
    others keep the unused stream they are given)."""

    @njit(**KERNEL)
    def run(bodies, absorbers, ex, fl, noise, grid, outputs, gen, gen_bridge, gen_filter, keys, point, start,
            common, wanted, x0, v0, p0, raw, samples, history, events):
        pool, words = np.zeros(POOL_SIZE, np.uint64), np.zeros(8, np.uint64)
        nb = x0.shape[0]
        for j in range(raw.shape[0]):
            r = start + j
            if wanted[0]:
                reseed(gen, keys, INCREMENTS, point, r, common, pool, words)
            if wanted[1]:
                reseed(gen_bridge, keys, BRIDGE, point, r, common, pool, words)
            if wanted[2]:
                reseed(gen_filter, keys, FILTER, point, r, common, pool, words)
            for b in range(nb):
                bodies.x[b] = x0[b]
                bodies.v[b] = v0[b]
            if fl.z.shape[0] > 0:
                stationary_start(p0, gen_filter, fl.z, fl.draws)
            out = Outputs(raw[j], samples[j], history[j], outputs.signals, outputs.limits, outputs.carry,
                          events[j], outputs.reductions, outputs.impulses)
            kernel(bodies, absorbers, ex, fl, noise, grid, out, gen, gen_bridge, gen_filter)

    stable_cache(run)  # (its closure holds the step loop: see ``jit.cache.stable_cache``)
    return run


class Chunk(NamedTuple):
    """What a chunk's realisations recorded, one a row: the raw metric vectors (``SLOTS``...),
    the Poincare samples, the history rows (``(n, points, signals)``) and the event logs."""

    raw: np.ndarray
    samples: np.ndarray
    history: np.ndarray
    events: np.ndarray


def simulate_chunk(scene, seed: int, point: int, start: int, stop: int, common: bool = True,
                   history: tuple[int, int] | None = None, signals: tuple[str, ...] | None = None,
                   event_rows: int = 0, executor: str = "lanes", specialised: bool = False,
                   general: bool = False, batch: int | None = None) -> Chunk:
    """Realisations ``start .. stop - 1`` of ``scene`` at sweep point ``point`` on the streams of
    ``seed`` (``realization_streams``; ``common``: common random numbers), in one compiled call
    of ``executor`` (``EXECUTORS``): what ``simulate`` gives for each, bitwise.  ``history =
    (stride, size)`` keeps ``size`` history rows of ``signals`` (``signals.declare``) every
    ``stride`` steps; ``event_rows`` rows of event log.  ``specialised``: the lane loop specialised
    to the structure even where the pass loop would run it (``passes.pass_scene``; the
    benchmark's comparison: the same numbers).  ``general``: a loop compiled once for every
    structure (``paths.GENERAL_WORK``): the pass loop where it takes the scene's lanes
    (``in_pass_loop``), else the scheme's general scalar loop, on the streams ``executor`` gives
    (a lane scene's Philox streams: the lanes' numbers, bitwise).  ``batch``: the realisations of
    the chunks this call stands for, where they are not its own (``ensemble.prepare_loops``'
    chunks of none)."""
    n = stop - start
    stride, size = history or (1, 0)
    template = _NO_HISTORY if size == 0 else np.zeros((1, len(signals)))
    columns = _NO_SIGNALS if size == 0 else history_columns(scene, template, signals)
    out0 = new_metrics(scene.n_floors, scene.limits.shape[0], scene.reductions.shape[0])
    raw = np.tile(out0, (n, 1))
    buffer = sample_buffer(scene)
    samples = np.full((n, *buffer.shape), np.nan)
    history_rows = np.full((n, size, columns.shape[0]), np.nan)
    events = np.full((n, event_rows, len(EVENT_COLUMNS)), np.nan)
    philox = lane_scene(scene, executor)  # (on the Philox streams)
    if lane_chunk(scene, executor, general, specialised, n if batch is None else batch):
        simulate_lanes(scene, seed, point, start, common, raw, history_rows, stride, columns, events,
                       specialised, general)
        return Chunk(raw, samples, history_rows, events)
    # (the bundles of one path: the state and filter buffers the loop reuses; the outputs'
    # buffers stand for their types, each realisation writing into its rows of the arrays above)
    wanted = np.array(needed_streams(scene), np.bool_)
    if philox:
        gens = tuple(np.zeros(STREAM_WORDS, np.uint64) for _ in wanted)
    else:  # (the general loop: a PCG64 stream in every place, one signature)
        gens = tuple(new_stream() if w or general else _UNUSED for w in wanted)
    args = bundles(scene, scene.x0.copy(), scene.v0.copy(), filter_tuple(scene, None), np.zeros(0), out0,
                   buffer, template, stride, gens, 1, _NO_CARRY, columns,
                   np.zeros((0, len(EVENT_COLUMNS))))
    general = scalar_general(scene, executor, general, specialised)
    run = chunk_loop(kernel_for(scene, general=general))
    keys = philox_keys(seed) if philox else seed_keys(seed)
    call = (*args, keys, point, start, common, wanted, scene.x0, scene.v0, scene.filters["p0"], raw, samples,
            history_rows, events)
    compile_first(run, call, gens)
    run(*call)
    return Chunk(raw, samples, history_rows, events)


#: The CPU executors of an ensemble's realisations: ``"lanes"`` (the scenes whose scheme runs in
#: SIMD lanes run there, ``lanes.lane_loop``, on Philox streams; the others in the scalar loop) and
#: ``"scalar"`` (every scene in the scalar loop, ``driver.step_loop``, on the PCG64 streams of
#: ``streams.streams``: the executor before SIMD lanes, the benchmark's reference).  The two draw
#: from different streams, so they give two independent samples of the same law.
EXECUTORS = ("lanes", "scalar")


def check_executor(executor: object) -> None:
    """Refuse an executor that is not one of ``EXECUTORS``, naming it and those allowed."""
    if not (isinstance(executor, str) and executor in EXECUTORS):
        raise ValueError(f"executor = {executor!r}: must be one of {', '.join(map(repr, EXECUTORS))}")


def lane_scene(scene, executor: str = "lanes") -> bool:
    """Whether ``scene``'s CPU realisations run in SIMD lanes under ``executor`` (``EXECUTORS``:
    the lanes executor, and a scheme the registry puts in lanes, ``schemes.in_lanes``), and so
    draw from the Philox streams of ``philox_keys``."""
    return executor == "lanes" and in_lanes(scene.scheme)


#: The fewest realisations of a chunk that runs in the pass loop (``in_pass_loop``; fewer run
#: in the general scalar loop, ``lane_chunk``): with fewer lanes its passes cost more than they
#: share (on a three-storey frame a lone lane ran at 1.3 M path-steps/s against the general
#: scalar loop's 12, 16 lanes at 10.7 against 7.8).
PASS_LANES = 16


def in_pass_loop(scene, executor: str = "lanes", specialised: bool = False,
                 realisations: int = PASS_LANES, general: bool = False) -> bool:
    """Whether a chunk of ``realisations`` of ``scene`` runs in the pass loop under ``executor``
    (``lane_scene`` and ``passes.pass_scene``, unless ``specialised``; at least ``PASS_LANES``
    realisations): a structure of three bodies or more however short or long the run, one of
    one or two bodies in a short run (``general``).  The pass loop is itself one loop for every
    structure it takes, compiled once (``ensemble.compile_general``), and runs them in SIMD
    lanes: 3-4x the general scalar loop's speed on a three-storey frame, 8-9x on one storey
    with a cubic NES (the same numbers, bitwise)."""
    return pass_structure(scene, executor, specialised, general) and realisations >= PASS_LANES


def pass_structure(scene, executor: str = "lanes", specialised: bool = False, general: bool = False) -> bool:
    """Whether ``scene``'s lane realisations run in the pass loop under ``executor`` in chunks of
    ``PASS_LANES`` or more (``in_pass_loop``), and in the general scalar loop in smaller ones."""
    return lane_scene(scene, executor) and pass_scene(scene, general) and not specialised


def lane_chunk(scene, executor: str, general: bool, specialised: bool, realisations: int) -> bool:
    """Whether a chunk of ``realisations`` of ``scene`` runs in SIMD lanes under ``executor``: a
    lane scene's (``lane_scene``) in the lane loop ``specialised`` to it, or in the pass loop
    where that takes it (``in_pass_loop``, whatever the run's length); a chunk of fewer than
    ``PASS_LANES`` realisations of a structure of the pass loop (a path, ``solve``, each
    realisation of a study with uncertain parameters), and a short run's (``general``) chunk of
    another lane scene, in the general scalar loop on the same Philox streams (``scalar_general``;
    the same numbers, bitwise)."""
    if pass_structure(scene, executor, specialised, general):
        return realisations >= PASS_LANES
    return lane_scene(scene, executor) and (specialised or not general)


def scalar_general(scene, executor: str, general: bool, specialised: bool = False) -> bool:
    """Whether a chunk of ``scene`` that runs in the scalar loop (``lane_chunk``) runs its
    scheme's general loop, compiled once for every structure: in a short run (``general``), and
    for a structure of the pass loop in any run (its chunks too small for the pass loop)."""
    return general or pass_structure(scene, executor, specialised)


def chunk_runner(scene, executor: str = "lanes", general: bool = False, batch: int = PASS_LANES):
    """The compiled loop a chunk of ``batch`` realisations of ``scene`` runs under ``executor``
    (``simulate_chunk``'s choice, ``lane_chunk``), whatever it records: the lane loop or the
    scalar loop's chunk (``general``: a loop compiled once for every structure, the pass loop or
    the scheme's general loop's; ``scalar_general``)."""
    if lane_chunk(scene, executor, general, False, batch):
        return lane_runner(scene, general=general)
    return chunk_loop(kernel_for(scene, general=scalar_general(scene, executor, general)))


def lane_runner(scene, specialised: bool = False, general: bool = False):
    """The compiled loop of ``scene``'s realisations in SIMD lanes: the pass loop, one for every
    structure it takes (``passes.pass_scene``, ``general`` in a short run; unless
    ``specialised``), or the lane loop specialised to ``scene``'s structure."""
    if pass_scene(scene, general) and not specialised:
        return pass_loop
    return lane_loop(spec_of(scene, lanes=True))


def realization_streams(scene, seed: int, point: int, realization: int, common: bool = True,
                        executor: str = "lanes") -> Streams:
    """The streams realisation ``realization`` of ``scene`` draws from in a CPU ensemble run by
    ``executor`` (``simulate_chunk``), each where the scene draws from it: Philox streams where
    the scene runs in lanes (``lane_scene``), the PCG64 generators of ``streams.streams`` elsewhere.
    ``simulate(scene, realization_streams(...))`` gives the realisation's row of the ensemble."""
    increments, bridge, filters = needed_streams(scene)
    if not lane_scene(scene, executor):
        return streams(seed, point, realization, increments=increments, bridge=bridge, filters=filters,
                       common=common)
    return Streams(*(philox_stream(seed, purpose, realization, point, common) if wanted else None
                     for purpose, wanted in ((INCREMENTS, increments), (BRIDGE, bridge), (FILTER, filters))))


def lane_call(scene, seed: int, point: int, start: int, common: bool, raw: np.ndarray,
              history: np.ndarray | None = None, stride: int = 1, signals: np.ndarray = _NO_SIGNALS,
              events: np.ndarray | None = None, specialised: bool = False, general: bool = False) -> tuple:
    """The arguments of ``scene``'s lane loop (``lanes.lane_loop``) for realisations ``start ..
    start + len(raw) - 1`` on the Philox streams of ``seed``, their metric vectors into ``raw``
    (the declared metrics among them) and, with ``history`` (``(n, rows, len(signals))``, preset
    to NaN), their history rows of the ``signals`` (``signals.declare``'s rows) every ``stride``
    steps; with ``events`` (``(n, rows, len(EVENT_COLUMNS))``, preset to NaN), their event logs;
    for the pass loop unless ``specialised`` (``lane_runner``, ``general`` in a short run)."""
    places = stream_place(np.arange(start, start + raw.shape[0], dtype=np.uint64), np.uint64(point), common)
    args = bundles(scene, scene.x0.copy(), scene.v0.copy(), filter_tuple(scene, None), np.zeros(0), raw[:0],
                   sample_buffer(scene), _NO_HISTORY, 1, (_UNUSED,) * 3)
    keys = philox_keys(seed)
    history = np.zeros((raw.shape[0], 0, 0)) if history is None else history
    events = np.zeros((raw.shape[0], 0, len(EVENT_COLUMNS))) if events is None else events
    call = (*args[:6], scene.limits, np.uint64(keys[INCREMENTS]), np.uint64(keys[BRIDGE]),
            np.uint64(keys[FILTER]), scene.filters["p0"], places, raw, history, stride, signals,
            scene.reductions, events)
    if pass_scene(scene, general) and not specialised:  # (the pass loop's sizes and kinds: run-time data)
        kinds = (scene.has_white_noise, scene.has_ground, scene.has_shaped)
        return (*call, pass_layout(scene.mass.shape[0], scene.n_floors), kinds)
    return call


def simulate_lanes(scene, seed: int, point: int, start: int, common: bool, raw: np.ndarray,
                   history: np.ndarray | None = None, stride: int = 1,
                   signals: np.ndarray = _NO_SIGNALS, events: np.ndarray | None = None,
                   specialised: bool = False, general: bool = False) -> None:
    """Realisations ``start .. start + len(raw) - 1`` in SIMD lanes (``lanes.lane_loop``), their
    metric vectors into ``raw`` (preset to the vector's start) and, with ``history`` and
    ``events``, their history rows and event logs (``lane_call``): what the scalar loop gives on
    their Philox streams (``specialised``, ``general``: ``lane_runner``'s)."""
    run = lane_runner(scene, specialised, general)
    call = lane_call(scene, seed, point, start, common, raw, history, stride, signals, events, specialised,
                     general)
    compile_first(run, call, ())
    run(*call)


@njit(**KERNEL)
def parameter_draws(keys, point: int, start: int, common: bool, normal, out) -> None:
    """The draws of uncertain parameters of realisations ``start ..`` (a row of ``out`` each):
    in each realisation's parameter stream (``streams.PARAMETERS``), one draw a parameter in
    file order, a standard normal where ``normal`` is set, else a uniform (the draws of
    ``scenario.distributions``)."""
    stream = np.zeros(STREAM_WORDS, np.uint64)
    pool, words = np.zeros(POOL_SIZE, np.uint64), np.zeros(8, np.uint64)
    for j in range(out.shape[0]):
        seed_stream(stream, keys[:POOL_SIZE], keys[POOL_SIZE], PARAMETERS, point, start + j, common, pool,
                    words)
        for k in range(out.shape[1]):
            out[j, k] = pcg_normal(stream) if normal[k] else pcg_uniform(stream)


__all__ = ["PASS_LANES", "Chunk", "chunk_loop", "chunk_runner", "ground_paths", "in_pass_loop", "lane_call",
           "lane_chunk", "lane_scene", "parameter_draws", "pass_structure", "philox_keys",
           "realization_streams", "reseed", "scalar_general", "seed_keys", "simulate_chunk", "simulate_lanes"]
