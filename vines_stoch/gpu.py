"""GPU ensembles (``backend = "cuda"``): the step loops of ``kernels/`` on an NVIDIA GPU through
numba-cuda, one thread per realisation.

The launcher (``kernels/launch.py``) is a small CUDA kernel around the step loop that the CPU runs for
the scene's structure (``kernels.kernel_for``): numba-cuda compiles that loop, and every
physics function it inlines, for the GPU from the same source, so both backends share their
schemes, impact and contact events, loads and metrics.  Each thread copies its realisation's
initial state to its stack, opens its Philox streams (``streams/rng.py``), draws its filters'
stationary start and runs the loop into its row of the metric table; the metric rows (and the
Poincare samples and history rows a scene asks for) are all that comes back.

Streams: realisation ``r`` of sweep point ``p`` draws from Philox streams keyed by (seed,
purpose) with the counter (draw, ``r`` [, ``p`` without common random numbers]), so its
numbers depend on nothing else: not on the launch configuration, the batch or the chunk.  They
are not the CPU's PCG64 streams (``streams/``): a scenario's GPU and CPU ensembles are two
independent samples of the same law, each reproducible on its own.

Without a GPU, numba-cuda's simulator (``NUMBA_ENABLE_CUDASIM=1``) runs the launcher as
Python, each thread calling the step loop compiled for the CPU (with the Philox streams):
slow, for tests of the launcher, its streams and its batching.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .kernels import DEFAULT_SIGNALS, general_run, kernel_for, simulate, spec_of
from .outputs import EVENT_COLUMNS, new_metrics
from .scene import Scene
from .signals import declare
from .streams import BRIDGE, FILTER, INCREMENTS, Streams
from .streams.rng import philox_stream, stream_key, stream_place

#: Threads of a block (one realisation each).
THREADS = 128
#: Share of the device's free memory one batch may take.
MEMORY_SHARE = 0.5
#: Realisations of a batch under the simulator (no device memory to size it by).
SIMULATED_BATCH = 64
#: The scene arrays a realisation may have of its own (uncertain parameters), in the order the
#: launcher takes them; the others are one for the whole ensemble.
PER_PATH = ("mass", "storey_k", "storey_c", "floor_c", "x0", "v0", "rows", "forces", "sigma", "limits",
            "phi", "chol", "envelope", "c_force", "c_ground", "p0")
SHARED = ("kind", "host", "wall", "series_t", "series_v", "series_ptr", "series_target", "reductions")
_FILTER_KEYS = ("phi", "chol", "envelope", "c_force", "c_ground", "p0")


class GPUUnavailable(RuntimeError):
    """The cuda backend cannot run here (no numba-cuda, driver or device)."""


def simulating() -> bool:
    """True when numba-cuda's simulator stands in for a GPU (``NUMBA_ENABLE_CUDASIM=1`` when
    numba was first imported)."""
    from numba.core import config

    return bool(getattr(config, "ENABLE_CUDASIM", False))


def unavailable() -> str | None:
    """Why the cuda backend cannot run here, or None when it can."""
    try:
        from numba import cuda
    except ImportError:
        return ("numba-cuda is not installed; install the cuda extra (pip install 'vines-stoch[cuda]', "
                "with a CUDA 12 driver)")
    if simulating():
        return None
    try:
        if not (cuda.is_available() and len(cuda.gpus) > 0):
            return "no CUDA GPU or driver found on this machine (numba.cuda.is_available() is False)"
    except Exception as exc:  # the driver's own errors are of many kinds
        return f"no usable CUDA device ({type(exc).__name__}: {exc})"
    from numba.cuda.cudadrv import nvvm

    if not nvvm.is_available():
        return ("NVVM, the CUDA compiler library, is not found; install the cuda extra "
                "(pip install 'vines-stoch[cuda]')")
    if not hasattr(np, "row_stack"):  # numba-cuda 0.30's GPU target names it when it loads
        return (f"numba-cuda 0.30 needs numpy < 2.5 (numpy {np.__version__} has no row_stack); "
                "pip install 'numpy<2.5', or the cuda extra, which asks for it")
    return None


def require() -> None:
    """Raise ``GPUUnavailable`` (with the reason) unless the cuda backend can run here."""
    reason = unavailable()
    if reason is not None:
        raise GPUUnavailable(f"--backend cuda: {reason}")


def device_name() -> str:
    """The GPU the backend runs on (``"simulator"`` under ``NUMBA_ENABLE_CUDASIM``)."""
    if simulating():
        return "numba-cuda simulator"
    from numba import cuda

    name = cuda.get_current_device().name
    return name.decode() if isinstance(name, bytes) else str(name)


@dataclass
class Batch:
    """What came back of a batch of realisations: raw metric rows ``(n, slots)``, Poincare
    samples ``(n, samples, 2 n_bodies + 2)`` (none: ``(n, 0, ...)``), history rows ``(n, grid,
    columns)`` (none: ``(n, 0, 2)``), event logs ``(n, capacity, len(EVENT_COLUMNS))`` (none:
    ``(n, 0, ...)``)."""

    raw: np.ndarray
    samples: np.ndarray
    history: np.ndarray
    events: np.ndarray


def _array(scene: Scene, name: str):
    """A launcher input of ``scene`` by name (the filter arrays from its ``filters``)."""
    return scene.filters[name] if name in _FILTER_KEYS else getattr(scene, name)


def _stack(scenes: list[Scene]) -> dict[str, np.ndarray]:
    """The launcher's per-path arrays, with a leading axis: one entry for one scene, one a
    realisation for several (uncertain parameters); the shared arrays must agree."""
    first = scenes[0]
    for name in (*SHARED, "dt", "n_steps", "i0", "period", "sample_from", "n_samples", "n_floors"):
        if any(not np.array_equal(getattr(s, name), getattr(first, name)) for s in scenes[1:]):
            raise ValueError(f"backend cuda: the uncertain parameters change the scene's {name}, which "
                             "every realisation of a GPU batch shares")
    stacked = {}
    for name in PER_PATH:
        try:
            stacked[name] = np.ascontiguousarray(np.stack([np.asarray(_array(s, name), dtype=float)
                                                           for s in scenes]))
        except ValueError:
            raise ValueError(f"backend cuda: the uncertain parameters change the shape of the scene's "
                             f"{name}, which every realisation of a GPU batch shares") from None
    return stacked


def _batch_size(per_path_bytes: int, wanted: int) -> int:
    """Realisations of one launch: what ``MEMORY_SHARE`` of the device's free memory holds."""
    if simulating():
        return min(wanted, SIMULATED_BATCH)
    from numba import cuda

    free, _ = cuda.current_context().get_memory_info()
    return max(1, min(wanted, int(MEMORY_SHARE * free) // max(per_path_bytes, 1)))


@dataclass
class Inputs:
    """A chunk's launcher inputs on the host: the per-path arrays (``PER_PATH``, a leading axis
    of one, or one a realisation), the shared ones (``SHARED``), the metric row every thread
    starts from, the streams' keys and place, and the sizes of the outputs."""

    scene: Scene
    per_path: bool
    stacked: dict[str, np.ndarray]
    shared: dict[str, np.ndarray]
    template: np.ndarray
    keys: np.ndarray
    place: np.uint64
    n_samples: int
    stride: int
    size: int
    signals: np.ndarray
    n_events: int

    @classmethod
    def of(cls, scenes: list[Scene], seed: int, point: int, common: bool, grid: tuple[int, int] | None,
           signals: tuple[str, ...], events: int = 0) -> Inputs:
        scene = scenes[0]
        stride, size = grid if grid is not None else (1, 0)
        return cls(scene, len(scenes) > 1, _stack(scenes),
                   {name: np.ascontiguousarray(getattr(scene, name)) for name in SHARED},
                   new_metrics(scene.n_floors, scene.limits.shape[0], scene.reductions.shape[0]),
                   np.array([stream_key(seed, p) for p in (INCREMENTS, BRIDGE, FILTER)], np.uint64),
                   np.uint64(stream_place(0, point, common)), scene.n_samples if scene.period > 0 else 0,
                   stride, size, declare(signals, scene.n_floors, scene.kind.shape[0]), events)

    @property
    def n_bodies(self) -> int:
        return self.scene.mass.shape[0]

    def outputs(self, m: int, empty) -> tuple:
        """``m`` realisations' output arrays from ``empty(shape)``: metric rows, Poincare
        samples, history rows, event logs, filter scratch (state, next state, normals)."""
        return (empty((m, self.template.shape[0])), empty((m, self.n_samples, 2 * self.n_bodies + 2)),
                empty((m, self.size, self.signals.shape[0])), empty((m, self.n_events, len(EVENT_COLUMNS))),
                empty((m, 3, self.stacked["phi"].shape[1])))

    def row_bytes(self) -> int:
        """Device bytes a realisation takes (its outputs, and its own scene's arrays)."""
        own = sum(a[0].nbytes for a in self.stacked.values()) if self.per_path else 0
        return own + sum(8 * int(np.prod(a[1:])) for a in (o.shape for o in self.outputs(1, np.empty)))

    def arguments(self, first: int, m: int, params: dict, shared: dict, normals, keys, template, signals,
                  outputs: tuple) -> tuple:
        """The launcher's arguments, in its order (``kernels.launch.launcher``)."""
        scene = self.scene
        return (first, m, self.per_path, self.place, keys, *(params[k] for k in PER_PATH),
                *(shared[k] for k in SHARED), normals, scene.dt, scene.n_steps, scene.i0, scene.period,
                scene.sample_from, self.stride, spec_of(scene).kinds, template, signals, *outputs)


def launch_types(scene: Scene, grid: tuple[int, int] | None = None,
                 signals: tuple[str, ...] = DEFAULT_SIGNALS, events: int = 0) -> tuple:
    """numba types of the launcher's arguments for ``scene`` (for ``numba.cuda.compile_ptx``,
    which needs no GPU)."""
    import numba

    inputs = Inputs.of([scene], 0, 0, True, grid, signals, events)
    args = inputs.arguments(0, 1, inputs.stacked, inputs.shared, np.zeros(0), inputs.keys, inputs.template,
                            inputs.signals, inputs.outputs(1, np.empty))
    return tuple(numba.typeof(a) for a in args)


def _compile_here(scene: Scene, seed: int, point: int, realization: int, common: bool) -> None:
    """Compile the step loop that the simulator's threads call in this thread, by running
    ``realization`` on the CPU with its Philox streams: the simulator's block manager polls its
    threads in a busy loop, and a loop compiled inside a simulated thread shares the GIL with
    that poller (the contact-noise scene's loop: 106 s there, 24 s here)."""
    simulate(scene, Streams(*(philox_stream(seed, p, realization, point, common)
                              for p in (INCREMENTS, BRIDGE, FILTER))))


def simulate_many(scenes: Scene | list[Scene], seed: int, point: int, start: int, stop: int,
                  common: bool = True, grid: tuple[int, int] | None = None,
                  signals: tuple[str, ...] = DEFAULT_SIGNALS, events: int = 0) -> Batch:
    """Realisations ``start .. stop - 1`` of sweep point ``point`` on the GPU, in batches that
    fit its memory.  ``scenes``: the scene (or one per realisation, with uncertain parameters);
    ``grid = (stride, size)``: history rows of the ``signals`` (``kernels.simulate``); ``events``:
    the rows of each realisation's event log (``outputs.EVENT_COLUMNS``; 0: none kept)."""
    require()
    from numba import cuda

    from .jit.cache import compile_once
    from .kernels import launcher

    scenes = [scenes] if isinstance(scenes, Scene) else list(scenes)
    n = stop - start
    if len(scenes) > 1 and len(scenes) != n:
        raise ValueError(f"simulate_many: {len(scenes)} scenes for {n} realisations")
    inputs = Inputs.of(scenes, seed, point, common, grid, signals, events)
    # (the simulator runs the CPU loop a path of the scene runs, ``kernels.start_path``: the same
    # arithmetic, its flags on the heap)
    simulated = simulating()
    general = simulated and general_run(inputs.scene.n_steps)
    loop = kernel_for(inputs.scene, gpu=not simulated, general=general)
    launch = launcher(loop, inputs.n_bodies, simulated)
    if simulating():
        _compile_here(scenes[0], seed, point, start, common)
    raw, samples, history, logs, _ = inputs.outputs(n, np.empty)
    shared = {k: cuda.to_device(a) for k, a in inputs.shared.items()}
    device = None if inputs.per_path else {k: cuda.to_device(a) for k, a in inputs.stacked.items()}
    normals, keys = cuda.to_device(np.zeros(0)), cuda.to_device(inputs.keys)
    template, columns = cuda.to_device(inputs.template), cuda.to_device(inputs.signals)
    done = 0
    while done < n:
        m = _batch_size(inputs.row_bytes(), n - done)
        params = device or {k: cuda.to_device(a[done:done + m]) for k, a in inputs.stacked.items()}
        outputs = inputs.outputs(m, cuda.device_array)
        args = inputs.arguments(start + done, m, params, shared, normals, keys, template, columns, outputs)
        if not simulating():  # (once a process: from the disk cache, or compiled with the faster front end)
            compile_once(launch, args, "numba.cuda.core")
        launch[math.ceil(m / THREADS), THREADS](*args)
        raw[done:done + m] = outputs[0].copy_to_host()
        if inputs.n_samples:
            samples[done:done + m] = outputs[1].copy_to_host()
        if inputs.size:
            history[done:done + m] = outputs[2].copy_to_host()
        if inputs.n_events:
            logs[done:done + m] = outputs[3].copy_to_host()
        done += m
    return Batch(raw, samples, history, logs)


#: The bundle fields of a path in the stretch launcher's order (``kernels.launch.stretcher``), by
#: bundle (``kernels.Path.args``: bodies, absorbers, loads, filters, noise; outputs after the grid).
_STRETCH_FIELDS = ((0, ("mass", "storey_k", "storey_c", "floor_c", "x", "v")),
                   (1, ("kind", "host", "rows", "wall")),
                   (2, ("forces", "series_t", "series_v", "series_ptr", "series_target")),
                   (3, ("phi", "chol", "envelope", "c_force", "c_ground", "z", "zn", "draws")),
                   (4, ("sigma", "normals")))
_STRETCH_OUTPUTS = ("out", "samples", "history", "signals", "limits", "carry", "events", "reductions",
                    "impulses")
#: What a stretch changes of a path (its state, outputs and streams), copied back after it.
_CHANGED = frozenset({"x", "v", "z", "zn", "draws", "out", "samples", "history", "carry", "events",
                      "impulses", "inc", "bri", "fil"})


def _stacked(arrays: list[np.ndarray], name: str) -> np.ndarray:
    try:
        return np.ascontiguousarray(np.stack(arrays))
    except ValueError:
        raise ValueError(f"gpu.advance_many: the paths' {name} differ in shape; a batch runs paths of one "
                         "structure") from None


def advance_many(paths: list, stops: list[int]) -> None:
    """Run each of ``paths`` (``kernels.Path``s of one structure, their streams counter-based:
    Philox streams or tapes, ``streams/rng.py``) from the step it has reached to its stop on the
    GPU, one path a thread, in place: what ``kernels.advance`` does for each, bitwise under the
    simulator (which runs the CPU loop), up to rounding on a GPU (see ``simulate_many``).  The
    rare-event estimates' paths on the cuda backend (``rare.py``)."""
    from .kernels import compile_first, stretch_to
    from .streams.kinds import PCG_KIND, kind_of

    todo = []
    for path, stop in zip(paths, stops):
        if not stretch_to(path, stop):
            continue
        if any(kind_of(g) in (None, PCG_KIND) for g in path.args[7:]):
            raise ValueError("gpu.advance_many: a path on a PCG64 stream or a numpy generator; the GPU draws "
                             "from counter-based streams (rng.philox_stream, rng.tape)")
        if path.args[5]._replace(n_steps=0, first=0) != paths[0].args[5]._replace(n_steps=0, first=0):
            raise ValueError("gpu.advance_many: the paths' time grids differ; a batch shares its grid")
        todo.append((path, stop))
    if not todo:
        return
    require()
    from numba import cuda

    from .kernels import stretcher

    first = todo[0][0]
    grid = first.args[5]
    if simulating():  # (the threads run the path's own loop, compiled here: see ``_compile_here``)
        compile_first(first.kernel, (*first.args[:5], grid, *first.args[6:]), first.args[7:])
        launch = stretcher(first.kernel, True)
    else:
        launch = stretcher(kernel_for(first.scene, gpu=True), False)
    done = 0
    while done < len(todo):
        m = _batch_size(sum(a.nbytes for a in _path_arrays(first).values()) + 64, len(todo) - done)
        batch = todo[done:done + m]
        own = [_path_arrays(p) for p, _ in batch]
        device = {name: cuda.to_device(_stacked([a[name] for a in own], name)) for name in own[0]}
        firsts = cuda.to_device(np.array([p.step for p, _ in batch], np.int64))
        ends = cuda.to_device(np.array([stop for _, stop in batch], np.int64))
        args = _stretch_arguments(first, m, device, firsts, ends)
        if not simulating():
            from .jit.cache import compile_once

            compile_once(launch, args, "numba.cuda.core")
        threads = min(m, THREADS)  # (a level's few branches: no idle threads to start)
        launch[math.ceil(m / threads), threads](*args)
        for name in _CHANGED:
            back = device[name].copy_to_host()
            for i, arrays in enumerate(own):
                if arrays[name].size:
                    arrays[name][...] = back[i]
        for p, stop in batch:
            p.step = stop
        done += m


def _stretch_arguments(first, m: int, arrays: dict, firsts, stops) -> tuple:
    """The stretch launcher's arguments, in its order (``kernels.launch.stretcher``): ``m``
    paths' ``arrays`` (by ``_path_arrays``' names, a leading axis), the grid of ``first``,
    their first steps and stops."""
    grid = first.args[5]
    return (m, *(arrays[name] for _, names in _STRETCH_FIELDS for name in names), first.args[4].refine,
            grid.dt, grid.i0, grid.period, grid.sample_from, grid.stride, grid.kinds, firsts, stops,
            *(arrays[name] for name in _STRETCH_OUTPUTS), arrays["inc"], arrays["bri"], arrays["fil"])


def stretch_types(path) -> tuple:
    """numba types of the stretch launcher's arguments for paths like ``path`` (for
    ``numba.cuda.compile_ptx``, which needs no GPU)."""
    import numba

    arrays = {name: a[None] for name, a in _path_arrays(path).items()}
    steps = np.zeros(1, np.int64)
    return tuple(numba.typeof(a) for a in _stretch_arguments(path, 1, arrays, steps, steps))


def _path_arrays(path) -> dict[str, np.ndarray]:
    """A path's arrays by the stretch launcher's names (``_STRETCH_FIELDS``, the outputs and the
    three streams ``inc``, ``bri``, ``fil``)."""
    arrays = {name: getattr(path.args[b], name) for b, names in _STRETCH_FIELDS for name in names}
    arrays.update({name: getattr(path.args[6], name) for name in _STRETCH_OUTPUTS})
    arrays.update(zip(("inc", "bri", "fil"), path.args[7:10]))
    return arrays


__all__ = ["Batch", "GPUUnavailable", "Inputs", "advance_many", "device_name", "launch_types", "require",
           "simulate_many", "stretch_types", "unavailable"]
