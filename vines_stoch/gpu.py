"""GPU ensembles (``backend = "cuda"``): the step loops of ``kernels/`` on an NVIDIA GPU through
numba-cuda, one thread per realisation.

The launcher (``kernels/launch.py``) is a small CUDA kernel around the step loop that the CPU runs for
the scene's structure (``kernels.kernel_for``): numba-cuda compiles that loop, and every
physics function it inlines, for the GPU from the same source, so both backends share their
schemes, impact and contact events, loads and metrics.  Each thread copies its realisation's
initial state to its stack, opens its Philox streams (``kernels/rng.py``), draws its filters'
stationary start and runs the loop into its row of the metric table; the metric rows (and the
Poincare samples and history rows a scene asks for) are all that comes back.

Streams: realisation ``r`` of sweep point ``p`` draws from Philox streams keyed by (seed,
purpose) with the counter (draw, ``r`` [, ``p`` without common random numbers]), so its
numbers depend on nothing else: not on the launch configuration, the batch or the chunk.  They
are not the CPU's PCG64 streams (``streams.py``): a scenario's GPU and CPU ensembles are two
independent samples of the same law, each reproducible on its own.

Without a GPU, numba-cuda's simulator (``NUMBA_ENABLE_CUDASIM=1``) runs the launcher as
Python, each thread calling the step loop compiled for the CPU (with the Philox streams):
slow, for tests of the launcher, its streams and its batching.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .kernels import kernel_for
from .kernels.common import POINCARE_SAMPLES, new_metrics
from .kernels.rng import stream_key, stream_place
from .scene import Scene
from .streams import BRIDGE, FILTER, INCREMENTS

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
SHARED = ("kind", "host", "series_t", "series_v", "series_ptr", "series_target")
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
        if cuda.is_available() and len(cuda.gpus) > 0:
            return None
    except Exception as exc:  # the driver's own errors are of many kinds
        return f"no usable CUDA device ({type(exc).__name__}: {exc})"
    return "no CUDA GPU or driver found on this machine (numba.cuda.is_available() is False)"


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
    columns)`` (none: ``(n, 0, 2)``)."""

    raw: np.ndarray
    samples: np.ndarray
    history: np.ndarray


def _filter_arrays(scene: Scene) -> dict[str, np.ndarray]:
    f = scene.filters
    return {k: np.ascontiguousarray(f[k], dtype=float) for k in _FILTER_KEYS}


def _stack(scenes: list[Scene]) -> dict[str, np.ndarray]:
    """The launcher's per-path arrays, with a leading axis: one entry for one scene, one a
    realisation for several (uncertain parameters); the shared arrays must agree."""
    first = scenes[0]
    for s in scenes[1:]:
        for name in SHARED:
            if not np.array_equal(getattr(s, name), getattr(first, name)):
                raise ValueError(f"backend cuda: the uncertain parameters change the scene's {name}, which "
                                 "every realisation of a GPU batch shares")
        for name in ("dt", "n_steps", "i0", "period", "sample_from", "n_floors"):
            if getattr(s, name) != getattr(first, name):
                raise ValueError(f"backend cuda: the uncertain parameters change the scene's {name}, which "
                                 "every realisation of a GPU batch shares")
    stacked = {}
    filters = [_filter_arrays(s) for s in scenes]
    for name in PER_PATH:
        arrays = [f[name] for f in filters] if name in _FILTER_KEYS else [getattr(s, name) for s in scenes]
        try:
            stacked[name] = np.ascontiguousarray(np.stack([np.asarray(a, dtype=float) for a in arrays]))
        except ValueError:
            raise ValueError(f"backend cuda: the uncertain parameters change the shape of the scene's "
                             f"{name}, "
                             "which every realisation of a GPU batch shares") from None
    return stacked


def _batch_size(per_path_bytes: int, wanted: int) -> int:
    """Realisations of one launch: what ``MEMORY_SHARE`` of the device's free memory holds."""
    if simulating():
        return min(wanted, SIMULATED_BATCH)
    from numba import cuda

    free, _ = cuda.current_context().get_memory_info()
    return max(1, min(wanted, int(MEMORY_SHARE * free) // max(per_path_bytes, 1)))


def simulate_many(scenes: Scene | list[Scene], seed: int, point: int, start: int, stop: int,
                  common: bool = True, grid: tuple[int, int] | None = None, n_history: int = 2) -> Batch:
    """Realisations ``start .. stop - 1`` of sweep point ``point`` on the GPU, in batches that
    fit its memory.  ``scenes``: the scene (or one per realisation, with uncertain parameters);
    ``grid = (stride, size)``: history rows of ``n_history`` columns (``kernels.simulate``)."""
    require()
    from numba import cuda

    scenes = [scenes] if isinstance(scenes, Scene) else list(scenes)
    n = stop - start
    per_path = len(scenes) > 1
    if per_path and len(scenes) != n:
        raise ValueError(f"simulate_many: {len(scenes)} scenes for {n} realisations")
    scene = scenes[0]
    stacked = _stack(scenes)
    shared = {name: np.ascontiguousarray(getattr(scene, name)) for name in SHARED}
    nb = scene.mass.shape[0]
    template = new_metrics(scene.n_floors, scene.limits.shape[0])
    n_samples = POINCARE_SAMPLES if scene.period > 0 else 0
    stride, size = grid if grid is not None else (1, 0)
    nz = stacked["phi"].shape[1]
    keys = np.array([stream_key(seed, purpose) for purpose in (INCREMENTS, BRIDGE, FILTER)], np.uint64)
    place = np.uint64(stream_place(0, point, common))
    from .kernels.launch import launcher

    launch = launcher(kernel_for(scene), nb, simulating())
    per_row = 8 * (template.shape[0] + n_samples * (2 * nb + 2) + size * n_history + 3 * nz)
    per_scene = sum(a[0].nbytes for a in stacked.values()) if per_path else 0
    raw = np.empty((n, template.shape[0]))
    samples = np.empty((n, n_samples, 2 * nb + 2))
    history = np.empty((n, size, n_history))
    device = {k: cuda.to_device(a) for k, a in stacked.items()} if not per_path else None
    shared_d = {k: cuda.to_device(a) for k, a in shared.items()}
    normals = cuda.to_device(np.zeros(0))
    template_d = cuda.to_device(template)
    done = 0
    while done < n:
        m = min(_batch_size(per_row + per_scene, n - done), n - done)
        params = device if device is not None else {
            k: cuda.to_device(a[done:done + m]) for k, a in stacked.items()}
        out_d = cuda.device_array((m, template.shape[0]))
        samples_d = cuda.device_array((m, n_samples, 2 * nb + 2))
        history_d = cuda.device_array((m, size, n_history))
        work_d = cuda.device_array((m, 3, nz))
        blocks = math.ceil(m / THREADS)
        launch[blocks, THREADS](start + done, m, per_path, place, cuda.to_device(keys),
                                *(params[k] for k in PER_PATH), *(shared_d[k] for k in SHARED), normals,
                                scene.dt, scene.n_steps, scene.i0, scene.period, scene.sample_from, stride,
                                template_d, out_d, samples_d, history_d, work_d)
        raw[done:done + m] = out_d.copy_to_host()
        if n_samples:
            samples[done:done + m] = samples_d.copy_to_host()
        if size:
            history[done:done + m] = history_d.copy_to_host()
        done += m
    return Batch(raw, samples, history)


__all__ = ["Batch", "GPUUnavailable", "device_name", "require", "simulate_many", "unavailable"]
